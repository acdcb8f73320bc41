// Cross-validation of an identified model on another trace: predict the
// force from velocity and acceleration obtained as the EMPS reference
// protocol does, and report 100 ||u - u_hat|| / ||u||. Host only.
#pragma once
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sim/drive_sim.hpp"
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
};

struct ValidateResult {
  double relative_error_pct = 0.0;       ///< on the decimated samples (protocol-comparable)
  double relative_error_full_pct = 0.0;  ///< on every sample, no decimation
  double rms_error_N = 0.0;              ///< on the decimated samples
  double error_norm_N = 0.0;             ///< ||u - u_hat|| on the decimated samples
  std::size_t samples_used = 0;
  std::vector<double> t, u, u_hat, v;    ///< the decimated series (for plots)
  std::string velocity_origin;
  /// What the logged force was multiplied by before the comparison (found
  /// from its work on the motion, as identify finds it).
  ForceSign force_sign;
  ForceOutliers force_outliers;  ///< forces beyond the data's limit, bridged as identify bridges them
  PositionWrap position_wrap;  ///< jumps of a wrapped position taken out, as identify takes them out
  Units units;  ///< ValidateOptions::units
};

/// Velocity and acceleration as the EMPS protocol obtains them: the position
/// low-passed by a zero-phase 4th-order Butterworth, then central differences
/// (twice for acceleration). If the trace has no position, the velocity
/// column is filtered and differentiated once.
void protocol_derivatives(const Trace& trace, double filter_hz, std::vector<double>& v, std::vector<double>& a);

ValidateResult validate(const DriveParams& model, const Trace& trace, const ValidateOptions& opt);

nlohmann::json to_json(const ValidateResult& r, const DriveParams& model, const ValidateOptions& opt);

}  // namespace feedid::host
