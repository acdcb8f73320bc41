// The drive model u = m a + F(v) with direction-dependent Stribeck
// friction (NOTES.md): its parameters, F(v), and their JSON form, in one
// place for every stage - the simulator drives with it, identify fills it,
// validate, diagnose, compensate and the reports read it. Host only.
#pragma once
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "feedid/types.hpp"
#include "io/outcome.hpp"
#include "io/units.hpp"

namespace feedid::host {

/// Friction of one direction, positive magnitudes (NOTES.md model).
struct DirectionFriction {
  double viscous_Ns_m = 700.0;            ///< sigma (N s/m)
  double coulomb_N = 25.0;                ///< Fc (N)
  double breakaway_N = 8.0;               ///< Fs (N): static friction is Fc + Fs
  double stribeck_velocity_m_s = 2.0e-3;  ///< vs (m/s)
};

struct DriveParams {
  double mass_kg = 100.0;
  DirectionFriction pos{};
  DirectionFriction neg{720.0, 26.0, 7.5, 1.8e-3};
};

/// F(v) of NOTES.md for v != 0 (sign included); 0 at v == 0.
double stribeck_friction(const DriveParams& p, double v_m_s);
/// One direction's law continued analytically through any v while sliding
/// in `direction` s (+1 or -1):
///   s = +1: F+(v) = +(Fc+ + Fs+ exp(-(v/vs+)^2)) + sigma+ v
///   s = -1: F-(v) = -(Fc- + Fs- exp(-(v/vs-)^2)) + sigma- v
/// The simulator's integrator uses it for stages that cross zero within a
/// step; the crossing itself is resolved separately.
double sliding_friction(const DirectionFriction& f, double direction, double v_m_s);

/// The identified model as simulator parameters (same equations, one place).
DriveParams to_drive_params(const feedid::Estimate<double>& e);

/// The parameters as a core estimate (no standard errors or flags), for the
/// core's model functions (friction_magnitude, feedforward).
feedid::Estimate<double> to_estimate(const DriveParams& p);

/// The parameters that break the model's sign rule, the core's
/// flag_not_physical (m > 0, Fc >= 0 and sigma >= 0 in both directions), as
/// "m = -95.2 kg, Fc+ = -20.1 N"; empty for a physical model. Such a model
/// pushes with the motion, and a friction feedforward from it would too.
std::string non_physical_parameters(const DriveParams& p, const Units& units = {});

/// Warnings for a mass, a top speed (where known; NaN: not) or a Coulomb
/// force no feed drive has, in `units` (SI linear or rotary; none for other
/// units): a position in counts or a force in amps left unscaled. The one
/// rule for identify's result and a model file (a hand-written m of 1e-9
/// kg replayed to an acceleration error of 8e13 % without a word).
std::vector<std::string> implausible_parameters(const DriveParams& p, const Units& units,
                                                double top_speed = std::numeric_limits<double>::quiet_NaN());

/// A load that does not reverse with the motion, beside m a + F(v): a
/// constant force F0 (an inclined axis, cable drag, a sensor offset; the
/// EMPS reference model's "offset") and, on a rotary arm, its weight
/// G cos(q - q0) (identify --gravity). The one rule for the load, used by
/// the simulator's plant, validate, replay and diagnose.
struct ModelLoad {
  double offset_N = 0.0;            ///< F0 (N, or the log's force unit)
  double gravity_N = 0.0;           ///< G of G cos(q - q0) (N m, or the log's force unit); 0: none
  double gravity_angle0_rad = 0.0;  ///< q0 (rad): the angle where the arm's weight pulls hardest
  /// The load at position x (rad where gravity_N != 0).
  double at(double x) const;
  /// Whether the load needs the position (a log without one cannot carry it).
  bool depends_on_position() const { return gravity_N != 0.0; }
  /// Why `source`, a log with or without a position column, cannot carry
  /// this load; empty when it can.
  std::string refusal(const std::string& source, bool has_position) const;
  bool any() const { return offset_N != 0.0 || gravity_N != 0.0; }
};

/// Writes the load into a model's JSON as the model file reads it:
/// "offset_N" always, "gravity" {"G", "angle0_rad"} when there is one.
void put_load(nlohmann::json& model, const ModelLoad& load);

/// Force the model predicts for velocity v and acceleration a (N).
double predict_force(const DriveParams& p, double v_m_s, double a_m_s2);

/// Names of the set bits of a flag word, e.g. ["stribeck_uncertain"].
std::vector<std::string> flag_names(uint32_t flags);

/// The model part alone: {"m":..,"pos":{..},"neg":{..}} (also the truth format).
nlohmann::json model_json(const DriveParams& p, const Units& units = {});

/// A JSON file (a model, a truth file); the error names the file when it
/// cannot be opened or parsed.
Outcome<nlohmann::json> read_json_file(const std::string& path);

/// A file read as a T (a model file, a controller file): `from_json(j,
/// path)` on its JSON, or a T whose `source` is the path and whose `error`
/// says why the file could not be read.
template <typename T, typename FromJson>
T read_json_file_as(const std::string& path, FromJson from_json) {
  const Outcome<nlohmann::json> j = read_json_file(path);
  if (j.ok()) return from_json(j.value, path);
  T out;
  out.source = path;
  out.error = j.error;
  return out;
}

}  // namespace feedid::host
