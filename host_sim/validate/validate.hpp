// Cross-validation of an identified model on another trace: predict the
// force from velocity and acceleration obtained as the EMPS reference
// protocol does, and report 100 ||u - u_hat|| / ||u||. Host only.
#pragma once
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "model/drive_model.hpp"
#include "io/trace.hpp"
#include "io/units.hpp"
#include "signals/force_outliers.hpp"
#include "signals/force_sign.hpp"
#include "signals/position_wrap.hpp"

namespace feedid::host {

struct ValidateOptions {
  double filter_hz = 100.0;   ///< zero-phase Butterworth cut-off on position (Hz)
  int decimate = 10;          ///< keep every n-th sample after anti-alias filtering (1 = none)
  int drop_first = 49;        ///< samples dropped at the start (filter edge), as in the protocol
  Units units;                ///< labels only (units.hpp)
  /// The model's load (ModelFile::load), added to every prediction:
  /// u = m a + F(v) + load(x).
  ModelLoad load;
};

struct ValidateResult {
  /// Why there is no relative error (an option out of range, a trace too
  /// short or without a rate, a load the trace cannot place, no measured
  /// force to be relative to), naming the trace; empty when the figures
  /// below hold (io/outcome.hpp).
  std::string error;
  double relative_error_pct = 0.0;       ///< on the decimated samples (protocol-comparable)
  double relative_error_full_pct = 0.0;  ///< on every sample, no decimation
  double rms_error_N = 0.0;              ///< on the decimated samples
  double error_norm_N = 0.0;             ///< ||u - u_hat|| on the decimated samples
  std::size_t samples_used = 0;
  /// Stretches between time gaps (pooled runs, cuts, logger pauses); those
  /// long enough to score; and those logged unevenly (dropped rows, jittered
  /// stamps), scored on a uniform grid read from their samples.
  std::size_t stretches = 0, stretches_scored = 0, stretches_resampled = 0;
  /// Stretches whose jittered stamps were taken to the log's clock (Signals::stretches_on_clock_slots).
  std::size_t stretches_on_clock_slots = 0;
  std::vector<double> t, u, u_hat, v;    ///< the decimated series (for plots)
  std::string velocity_origin;
  double time_origin_s = 0.0;  ///< what t counts from (Trace::time_origin_s)
  /// What the logged force was multiplied by before the comparison (found
  /// from its work on the motion, as identify finds it).
  ForceSign force_sign;
  ForceOutliers force_outliers;  ///< forces beyond the data's limit, bridged as identify bridges them
  PositionWrap position_wrap;  ///< jumps of a wrapped position taken out, as identify takes them out
  Units units;  ///< ValidateOptions::units
  /// The position filter's cut-off as applied (Hz; applied_cutoff_hz: at
  /// most 0.4 of the rate, the least over the scored stretches); below
  /// ValidateOptions::filter_hz where that was out of the rate's reach.
  double filter_applied_hz = 0.0;
  double filter_requested_hz = 0.0;  ///< ValidateOptions::filter_hz (Hz)
  /// Why the filter was applied below the request, or empty (cutoff_note).
  std::string filter_note() const;
};

/// The EMPS protocol (docs/emps.md) on each stretch between time gaps of
/// the conditioned trace (condition.hpp: the time base, gaps, wrap and force
/// sign identify uses), at the stretch's own rate; no filter or difference
/// spans a gap, drop_first samples are left out at the start of every
/// stretch, and the error sums run over all of them.
ValidateResult validate(const DriveParams& model, const Trace& trace, const ValidateOptions& opt);

nlohmann::json to_json(const ValidateResult& r, const DriveParams& model, const ValidateOptions& opt);

}  // namespace feedid::host
