// From an identified model to friction compensation a drive can load: a
// speed -> friction table per direction with its breakpoints where the
// curve bends, and the Coulomb + viscous parameter form. Host only.
#pragma once
#include <array>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/units.hpp"
#include "model/drive_model.hpp"

namespace feedid::host {

/// The most breakpoints per direction a table may have (drives take about 20).
constexpr int kMaxTablePoints = 256;

struct CompensateOptions {
  int points = 20;             ///< breakpoints per direction (>= 2), speed 0 included
  double max_speed_m_s = 0.0;  ///< top of the table (m/s); 0: the model JSON's config.velocity_max_m_s
  double force_scale = 1.0;    ///< N per drive unit (as identify's --force-scale); the table is divided by it
  std::string force_unit;      ///< the drive unit's label (A, %); empty: N
};

struct TablePoint {
  double speed_m_s = 0.0;
  double force_N = 0.0;  ///< friction magnitude (positive)
};

struct CompensationTable {
  std::array<std::vector<TablePoint>, 2> dir;  ///< [pos, neg]
  double max_interpolation_error_N = 0.0;      ///< largest |table - model| on [0, max speed], both directions
  double max_speed_m_s = 0.0;
  DriveParams model;
  std::string error;  ///< why there is no table (io/outcome.hpp); empty when there is
};

/// Friction magnitude of the model in one direction (0: pos, 1: neg) at a
/// speed >= 0: the core's friction_magnitude (core/feedid/feedforward.hpp).
double model_friction(const DriveParams& m, int dir, double speed_m_s);

/// The table whose largest linear-interpolation error against the model is
/// smallest for `points` breakpoints per direction (minimax: the least
/// error for which segments of greatest reach cover [0, max speed] in
/// points - 1 steps, found by bisection). `error` for points outside
/// 2..kMaxTablePoints or a max speed that is not positive.
CompensationTable make_compensation_table(const DriveParams& model, double max_speed_m_s, int points);

/// Largest |table - model| over n evenly spaced speeds in [0, max speed].
double table_error(const CompensationTable& t, int dir, int n = 20000);

nlohmann::json to_json(const CompensationTable& t, const CompensateOptions& opt);
std::string to_csv(const CompensationTable& t, const CompensateOptions& opt, const Units& units = Units{});
/// Why a model JSON cannot be compensated with: identify's status is not
/// ok, the model reader (model/model_file.hpp) refuses it (a key missing,
/// a parameter breaking the sign rule); empty when it can.
std::string unusable_model(const nlohmann::json& model);

/// A model JSON's compensation: the table and its JSON (with the model's
/// units as units), and whether the model was identified with the
/// logged force negated (input.force_sign -1: the drive's feedforward is
/// then minus the table).
struct ModelCompensation {
  CompensationTable table;
  nlohmann::json json;
  bool force_negated = false;
  std::vector<std::string> warnings;  ///< the model reader's (an unknown key, a parameter identify flagged) and the table's range
  Units units;                        ///< the model's (its units: m and N unless it states others)
  std::string error;                  ///< why there is no table, naming the source; empty when there is
};

/// The table for a model JSON (identify's): up to opt.max_speed_m_s, or
/// its config.velocity_max_m_s when that is 0. `error` names `source` when
/// the model cannot be compensated with (unusable_model), has no top
/// speed, or opt cannot be applied.
ModelCompensation compensate_model(const nlohmann::json& model, CompensateOptions opt, const std::string& source);


}  // namespace feedid::host
