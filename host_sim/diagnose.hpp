// Sim-to-real gap diagnosis: fit the base model on part of a trace, measure
// the force residual on the held-out rest, say where it lies, which
// unmodelled effect explains it, and how far adding that effect shrinks the
// held-out gap. docs/diagnosis.md gives the method. Host only.
#pragma once
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "identify.hpp"
#include "trace.hpp"

namespace feedid::host {

/// The catalogue (NOTES.md), plus the two verdicts.
inline const std::vector<std::string>& effect_kinds() {
  static const std::vector<std::string> k = {"offset", "position_ripple", "position_friction", "thermal_drift",
                                             "quadratic_viscous", "presliding_hysteresis", "compliance", "delay"};
  return k;
}

struct DiagnoseOptions {
  IdentifyOptions identify;       ///< how the base model is identified (columns, filters)
  double block_s = 0.005;         ///< residual block length (s): force residual is averaged per block
  int folds = 40;                 ///< at most this many time folds (each spans two motion cycles); odd ones are held out
  double significance_t = 3.0;    ///< t statistic a candidate's held-out improvement must exceed
  double min_closed_fraction = 0.5;  ///< share of the excess gap a named effect must close
  double unexplained_ratio = 1.4;    ///< held-out RMS / noise floor above which a gap is real
  /// With no gap left, a Coulomb asymmetry |Fc+ - Fc-|/2 above this share of
  /// the mean Coulomb force is named an offset (indistinguishable while moving).
  double offset_asymmetry_ratio = 0.1;
  std::function<void(double)> progress;
};

struct Candidate {
  std::string kind;
  nlohmann::json parameters;      ///< fitted on the identification part, SI names
  double heldout_rms_N = 0.0;     ///< held-out RMS with this effect added
  double closed_fraction = 0.0;   ///< of the excess gap over the noise floor
  double t_statistic = 0.0;       ///< of the held-out improvement (grouped blocks)
  bool significant = false;
  bool indistinguishable = false; ///< its term is (almost) a combination of the base model's terms here
  std::string note;
};

struct WhereEntry {
  std::string domain;   ///< velocity, position, time, after_reversal, acceleration_change, frequency
  std::string range;    ///< human-readable range with units
  double lo = 0.0, hi = 0.0;  ///< numeric range in the domain's SI unit
  double share = 0.0;         ///< share of held-out residual energy in this range
  double time_share = 0.0;    ///< share of held-out time in this range
};

struct DiagnoseResult {
  std::string error;
  IdentifyResult base;            ///< the core's identification on the identification part
  std::string effect;             ///< none, unexplained, or one of effect_kinds()
  nlohmann::json effect_parameters;
  double rms_base_N = 0.0;        ///< held-out RMS force residual of the base model
  double rms_augmented_N = 0.0;   ///< held-out RMS with the chosen effect (= base when none)
  double noise_floor_N = 0.0;     ///< RMS a perfect model would leave (white block noise)
  double closed_fraction = 0.0;
  std::vector<WhereEntry> where;
  std::vector<Candidate> candidates;  ///< ranked, best first
  /// The base model refitted jointly with the chosen effect on the
  /// identification folds (valid when has_augmented_model).
  DriveParams augmented_model{};
  bool has_augmented_model = false;
  std::size_t blocks_identification = 0, blocks_heldout = 0;
  double force_lag_s = 0.0;               ///< lag the base model pairs force with (s)
  double lag_beyond_conventions_s = 0.0;  ///< estimated lag beyond the conventions, left to `delay` (s)
  int folds = 0;  ///< time folds used (at most DiagnoseOptions::folds; each spans two motion cycles)
  // Series for the report (held-out blocks): centre time, position, velocity, residual before/after.
  std::vector<double> block_t, block_x, block_v, block_r_base, block_r_aug;
  std::vector<bool> block_heldout;
};

DiagnoseResult diagnose(const Trace& trace, const DiagnoseOptions& opt);
nlohmann::json to_json(const DiagnoseResult& r);
std::string summary(const DiagnoseResult& r);

}  // namespace feedid::host
