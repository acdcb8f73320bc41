// `feedid blind-bench`: the diagnosis checked on data whose effect it is not
// told. Many traces are simulated with a randomly chosen effect (or none, or
// a disturbance outside the catalogue) on a random drive, motion and sensor;
// diagnose() sees only each trace (t, x, v, u); the labels and true effect
// parameters stay in the scorer, which then builds the confusion matrix of true
// against named effect, the error of the fitted effect parameters and the
// share of the held-out gap closed. Host only; plain functions so the library
// does not depend on the CLI parser.
#pragma once
#include <cstdint>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "io/outcome.hpp"
#include "sim/drive_sim.hpp"

namespace feedid::host {

/// The switched-on effects as JSON, keyed by catalogue name (diagnose's
/// effect_kinds(); "disturbance" and "wander" for the two outside it), with the
/// parameter names diagnose reports: offset {force_N}, position_ripple
/// {period_m, amplitude_N, phase_rad}, position_friction {x_min_m, x_max_m,
/// delta_N}, thermal_drift {time_constant_s, fraction, viscous_change_Ns_m,
/// coulomb_change_N}, quadratic_viscous {c2}, presliding_hysteresis
/// {distance_m, force_N}, compliance {frequency_hz, load_frequency_hz,
/// load_mass_kg, mass_fraction, damping_ratio}, delay {delay_s}. The drive
/// gives the changes in its units (mean of the two directions). An empty
/// object when no effect is on. For `simulate --truth` and the blind benchmark.
nlohmann::json effects_json(const Effects& e, const DriveParams& drive);

struct BlindOptions {
  int cases = 60;          ///< traces to generate and diagnose
  std::uint64_t seed = 1;  ///< one seed gives one set of cases (any thread count)
  std::string json_path;      ///< write every case and the scores as JSON here (empty: no)
  std::string markdown_path;  ///< write the report tables as Markdown here (empty: no)
  std::function<void(double)> progress;  ///< fraction of cases done, optional
  int threads = 0;  ///< worker threads; 0: the machine's hardware threads (at most 8)
  bool quiet = false;  ///< no per-case lines on stdout (the summary tables are still printed)
  std::string labels;     ///< comma-separated subset of the labels to deal (empty: all), e.g. "none" to calibrate
  std::string plants = "closed,open";               ///< plants a case draws from (drive_sim.hpp PlantKind names)
  std::string programs = "ladder,sine,production";  ///< motion programs a case draws from (motion_path.hpp)
  int write_case = 0;     ///< > 0: only write this case's trace (1-based) to case_path, and its truth beside it
  std::string case_path;  ///< CSV path for write_case
};

/// Generates, diagnoses and scores. Prints the per-case lines and the summary
/// tables on stdout. RunEnd::bar_missed when it ran but the bar is
/// missed (right effect named in >= 90 % of cases; median held-out gap
/// closed >= 80 % of its excess over the noise floor on the cases with a
/// catalogued effect); the options it refused and the outputs it could not
/// write are in the RunEnd too (io/outcome.hpp).
RunEnd run_blind_bench(const BlindOptions& opt);

}  // namespace feedid::host
