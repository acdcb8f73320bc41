// Closed-loop replay: a model simulated inside the drive's own loop
// (controller.hpp), sampled like the drive at the log's period, driven by
// the logged position reference and extra command, and compared with the
// logged run as the EMPS reference package compares its simulation
// (EMPS_Description.pdf §3.5; ../shared/data/emps/README.md):
//
//   measured   position filtered zero-phase by a 4th-order Butterworth at
//              filter_hz, velocity and acceleration by central differences;
//   simulated  position, velocity and acceleration from the plant's state at
//              each sample; force = drive_gain * (sat(delayed command) + extra);
//   both       the first drop_first samples left out; for each signal y,
//              100 ||y - y_sim|| / ||y||.
//
// The plant is the simulator's (sim/plant.hpp): RK4 substeps with the
// command held, Karnopp stick/slip at rest. Host only.
#pragma once
#include <limits>
#include <future>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "controller.hpp"
#include "io/csv_trace.hpp"
#include "io/units.hpp"
#include "model/model_file.hpp"
#include "sim/drive_sim.hpp"
#include "sim/named_effects.hpp"

namespace feedid::host {

/// One continuous logged run with the columns a replay reads (SI units,
/// equal lengths; extra empty when the controller names none).
struct LoggedRun {
  std::string source;
  std::vector<double> t, x, u, reference, extra;
  std::vector<std::string> notes;  ///< e.g. an extra command the log does not have
  /// Why the run cannot be replayed (a column missing or unreadable, rows
  /// that differ between reads); empty when it can (io/outcome.hpp).
  std::string error;
};

/// Reads the run of `path` (CSV or .mat) with the trace columns of `cols`
/// (time, measured position, force) and the controller's reference (scaled
/// like the position) and extra command (as logged, command units)
/// columns. An extra command the log lacks is none (a run without pulses
/// replays with the controller of one with them), said in notes.
/// `error` names a missing reference column, or says where the rows the
/// reads keep differ. `beside`: the reference and extra command's pass may
/// run on a thread of its own beside the trace's (start_reference_and_extra).
LoggedRun read_logged_run(const std::string& path, const CsvColumns& cols, const Controller& c, bool beside = true);
/// The reference and the extra command into `run` (whose t the file's
/// trace gave) in one pass over the file: the reference through the
/// position slot (scaled like the position), the extra command through the
/// force slot (as logged). False, with run untouched, where the controller
/// names no extra command, or that read fails or keeps other rows than the
/// trace: read_logged_run then reads the columns one by one, and those
/// reads say why.
bool read_reference_and_extra(const std::string& path, const CsvColumns& cols, const Controller& c, LoggedRun& run);
/// That one pass's read alone (the file with the reference in the position
/// slot and the extra command in the force slot; not ok where the
/// controller names no extra command), started beside the caller's read of
/// the trace: on a thread of its own where `beside` allows
/// (io/beside.hpp), so that the file's two passes take the time of one.
std::future<CsvResult> start_reference_and_extra(const std::string& path, const CsvColumns& cols, const Controller& c,
                                                 bool beside);
/// The same as read_logged_run, with `main`, the file as
/// read_trace_file(path, cols) reads it, and `both`, the pass
/// start_reference_and_extra made (a caller that has read them already
/// need not read them again).
LoggedRun read_logged_run(const std::string& path, const CsvColumns& cols, const Controller& c, const CsvResult& main,
                          const CsvResult& both);

struct ReplayOptions {
  /// Plant integration steps per sample; 0: the fewest that resolve the
  /// plant's shortest time scale kStepsPerTimeScale times (plant.hpp,
  /// shortest_time_scale_s), at most kMaxAutomaticSubsteps.
  int substeps = 0;
  double filter_hz = 100;  ///< cut-off of the zero-phase Butterworth on the measured position (Hz)
  int drop_first = 49;     ///< samples left out at the start (the filter's edge), as in the protocol
  Units units;             ///< labels only (units.hpp)
  /// Unmodelled effects added to the model's plant (diagnose's named
  /// effects, sim/drive_sim.hpp); offset_N adds to the model's own load.
  /// None given (here and in extra_force): the model file's own effects
  /// (ModelFile::effects) are the plant's.
  Effects effects;
  /// A further force against the motion, f(t, x, v) (N), for an effect the
  /// plant's fixed shapes do not draw (a drift per direction); none when empty.
  ExtraForce extra_force;
  ExtraForceScales extra_scales;  ///< how fast extra_force changes (the automatic substeps resolve it)
};

/// opt with the plant's effects, extra force and its scales from `pe`
/// (the named effects as the plant takes them), in place of opt's.
ReplayOptions with_plant_effects(ReplayOptions opt, const PlantEffects& pe);

/// Plant steps per shortest time scale when the substeps are automatic:
/// RK4 at h = tau / 5 (omega h = 0.2 on a resonance) errs by about
/// (omega h)^5 / 120 = 3e-6 of the state per step, far below what moves a
/// figure by 1 % when the step is halved (tests/replay/replay_test.cpp).
constexpr double kStepsPerTimeScale = 5.0;
/// The automatic substeps' ceiling (ten times the fixed 10 of earlier
/// versions): a time scale below dt / 20, a resonance above 3 kHz at 1 kHz
/// (a model far off), is not resolved; the replay says so in a note.
constexpr int kMaxAutomaticSubsteps = 100;

/// Relative errors (%), 100 ||y - y_sim|| / ||y||, of the four signals.
struct ReplayFigures {
  double position = 0.0, velocity = 0.0, acceleration = 0.0, force = 0.0;
};

struct ReplayResult {
  /// Why there is no replay: the model's, the controller's or the run's own
  /// error, an option out of range, a gap in the run, gains fitted that are
  /// no position loop's, a simulation that left the finite numbers. Empty
  /// when the figures below hold.
  std::string error;
  /// The published comparison: measured processed, simulated from the plant's state.
  ReplayFigures error_pct;
  /// The simulated position processed exactly as the measured one (both sides alike).
  ReplayFigures same_processing_pct;
  /// The gap the processing alone makes: simulated state against the same
  /// simulation processed, relative to the measured signal's norm.
  ReplayFigures processing_pct;
  Gains gains;       ///< the gains replayed
  GainFit gain_fit;  ///< done when the file lacked a gain, or always when asked
  double dt_s = 0.0; ///< sample period of the log (median step)
  int substeps = 0;  ///< plant steps per sample, as given or chosen (ReplayOptions::substeps)
  /// The plant's shortest time scale at the run's top speed (s; infinite
  /// when nothing sets one): what the automatic substeps resolve.
  double shortest_time_scale_s = std::numeric_limits<double>::infinity();
  std::size_t samples = 0, samples_compared = 0;
  std::size_t saturated_samples = 0;  ///< simulated commands at the limit
  std::size_t stuck_samples = 0;      ///< samples at which the simulated axis was at rest
  std::vector<std::string> notes;     ///< the run's (LoggedRun::notes), and a filter beyond the rate's reach
  Units units;                        ///< ReplayOptions::units
  double filter_applied_hz = 0.0;     ///< the comparison's cut-off as applied (applied_cutoff_hz)
  /// The compared series (every sample after drop_first), for plots.
  std::vector<double> t, x, v, a, u, x_sim, v_sim, a_sim, u_sim;
  /// The simulated position processed as the measured one, and its velocity and acceleration.
  std::vector<double> x_sim_processed, v_sim_processed, a_sim_processed;
};

/// The four figures over the compared samples k (index into ReplayResult::t)
/// where keep[k] is non-zero: simulated from the plant's state, or
/// processed as the measured signals when `same_processing`.
ReplayFigures figures_where(const ReplayResult& r, const std::vector<char>& keep, bool same_processing);
/// The processing's own share over the same samples: the simulated state
/// against the same simulation processed, relative to the measured signal.
ReplayFigures processing_where(const ReplayResult& r, const std::vector<char>& keep);

/// Replays the model in the loop of `c` over `run`. `fit_always`: fit the
/// gains from the log even when the file gives them all (a check of the
/// file against the log). Throws std::invalid_argument for a run with a
/// gap, too short a run, or a simulation that leaves finite numbers.
ReplayResult replay(const ModelFile& model, const Controller& c, const LoggedRun& run, const ReplayOptions& opt,
                    bool fit_always = false);

nlohmann::json to_json(const ReplayResult& r, const ModelFile& model, const Controller& c, const ReplayOptions& opt);

}  // namespace feedid::host
