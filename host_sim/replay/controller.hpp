// The drive's own position/velocity loop as a controller file describes it
// (docs/reference.md, "replay"), and the gains a logged command reveals.
//
//   qf(k)   = sum_i fir[i] q(k-i)                   position FIR
//   dq(k)   = (qf(k) - qf(k-1)) / dt                 velocity estimate
//   ev(k)   = kp (r(k) - q(k)) - dq(k)               velocity error
//   c(k)    = kv ev(k)              (law "pd")
//           = kv ev(k) + ki I(k),  I(k) = sum_{j<k} ev(j) dt  (law "p_pi"; the
//             integral stops growing while c is beyond the limit and ev pushes further)
//   applied(k) = sat(c(k - delay)) + extra(k),  force = drive_gain * applied
//
// Host only.
#pragma once
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/outcome.hpp"

namespace feedid::host {

enum class ControlLaw { pd, p_pi };

struct Controller {
  ControlLaw law = ControlLaw::pd;
  /// Gains in command units: kp (1/s), kv (command per m/s), ki (command
  /// per m). Absent: identified from the logged command (fit_gains).
  std::optional<double> kp, kv, ki;
  double drive_gain = 0.0;               ///< force per command unit (N/V for EMPS)
  double saturation = 0.0;               ///< command limit, symmetric (V for EMPS)
  std::vector<double> position_fir{1.0}; ///< taps on q(k), q(k-1), ... before the velocity difference
  int delay_samples = 0;                 ///< computation delay between command and plant (samples)
  std::string reference;                 ///< column of the position reference
  std::string extra_command;             ///< column added after the saturation (command units); "" for none
  std::vector<std::string> warnings;     ///< unknown keys, one message each
  std::string source;                    ///< file name, for messages
  /// Why the file holds no usable controller, naming the file and the key;
  /// empty when it does (the host's one error form, io/outcome.hpp).
  std::string error;
};

/// Reads a controller from parsed JSON; `source` names it in messages.
/// Required: drive_gain (> 0), saturation (> 0), position_fir (a non-empty
/// array of numbers), delay_samples (integer >= 0), reference (a column
/// name). Optional: law ("pd", the default, or "p_pi"), kp, kv, ki,
/// extra_command, comment. A file that cannot be used sets `error`, naming the key.
Controller controller_from_json(const nlohmann::json& j, const std::string& source);
/// The same from a file (read_json_file's errors for a missing or broken file).
Controller read_controller_file(const std::string& path);

const char* law_name(ControlLaw law);

/// The loop's gains, each given or identified.
struct Gains {
  double kp = 0.0, kv = 0.0, ki = 0.0;
};

/// The gains a logged command reveals (fit_gains).
struct GainFit {
  bool done = false;
  Gains value, se;       ///< estimates and standard errors (ki 0 for "pd")
  int lag_samples = 0;   ///< whether the log holds the command as computed (0) or as applied (delay)
  double rms_residual = 0.0;  ///< of the logged command (command units)
  double rms_command = 0.0;   ///< of the logged command over the same samples
  std::size_t samples = 0;    ///< unsaturated samples fitted
  /// How much of the logged extra command the logged command holds (1 when
  /// it is added as logged; NaN without one), with its standard error.
  double extra_gain = std::nan(""), extra_gain_se = std::nan("");
  /// Why no gains could be fitted (too few unsaturated samples, degenerate
  /// regressors); empty when they were.
  std::string error;
};

/// Ordinary least squares of the logged command, u / drive_gain, on the
/// loop's regressors from the measured position: kv kp (r - q) and -kv dq
/// (and, for "p_pi", ki kp and -ki times their running integrals, with a
/// constant for the integral's unknown start), and the extra command with a
/// gain of its own (a pulse scaled on its way in would otherwise bias kv),
/// over samples whose command less the extra is below 95 % of the
/// saturation. The log may hold the command as
/// computed or as applied (delay_samples later): both are fitted and the
/// smaller residual kept. Standard errors by a delete-one-block jackknife
/// (20 contiguous blocks), which holds for correlated residuals. `error`
/// says why when too few samples remain or the regressors are degenerate.
GainFit fit_gains(const Controller& c, const std::vector<double>& t, const std::vector<double>& x,
                  const std::vector<double>& u, const std::vector<double>& reference,
                  const std::vector<double>& extra);

/// The given gains, with the fitted ones where the file has none; the fit's
/// error, or why fitted gains are no position loop's. A fitted ki below 0
/// within two standard errors is taken as 0, said in notes.
Outcome<Gains> resolve_gains(const Controller& c, const GainFit& fit, std::vector<std::string>& notes);

/// Whether some gain the law uses is missing from the file.
bool needs_fit(const Controller& c);

/// The position FIR and velocity difference: dq(k) from q(k) and the
/// FIR's history, the history started at rest at the first position.
class VelocityEstimate {
 public:
  VelocityEstimate(const std::vector<double>& fir, double dt_s) : fir_(fir), q_(fir.size(), 0.0), dt_(dt_s) {}
  double next(double q);

 private:
  std::vector<double> fir_, q_;  ///< taps, and q(k), q(k-1), ... newest first
  double dt_;
  double qf_prev_ = 0.0;
  bool started_ = false;
};

}  // namespace feedid::host
