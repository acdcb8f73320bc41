// How a drive writes its log (NOTES.md, "Logging conventions"), shared by the
// closed-loop simulator and the open-loop plant: the force convention, the
// drive's velocity filter and the encoder quantum. Host only.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

#include "io/outcome.hpp"

namespace feedid::host {

/// How the drive writes its log (NOTES.md, "Logging conventions"). The plant
/// and the controller do not change; only the recorded force and velocity do.
/// The controller itself always uses the backward difference of position.
enum class ForceLog {
  held,      ///< u_k: the command held over [t_k, t_k+1] (a setpoint log)
  instant,   ///< the force at t_k itself: (u_{k-1} + u_k)/2 for a held command
  averaged,  ///< the mean over [t_{k-1}, t_k]: u_{k-1} (a filtered current)
};
enum class VelocityLog {
  backward_difference,  ///< (x_k - x_{k-1})/dt: half a period late
  moving_average,       ///< mean of the last `velocity_average_samples` backward differences
  low_pass,             ///< first-order low-pass (time constant below) of the backward difference
};
struct LoggingParams {
  ForceLog force = ForceLog::held;
  VelocityLog velocity = VelocityLog::backward_difference;
  int velocity_average_samples = 4;           ///< k of the moving average (>= 1)
  double velocity_time_constant_s = 1.0e-3;   ///< tau of the low-pass (s, > 0)
};
const char* force_log_name(ForceLog f);
const char* velocity_log_name(VelocityLog v);
/// Parses the names above ("held", "instant", "averaged"; "backward",
/// "average", "lowpass"); throws std::invalid_argument naming the option.
Outcome<ForceLog> parse_force_log(const std::string& s);
Outcome<VelocityLog> parse_velocity_log(const std::string& s);

/// The drive's velocity filter applied to the backward difference of the
/// encoder position, one sample at a time (VelocityLog above).
class LoggedVelocity {
 public:
  LoggedVelocity(const LoggingParams& p, double dt_s);
  double next(double v_backward_m_s);

 private:
  VelocityLog kind_;
  double alpha_;  ///< low-pass gain per sample, 1 - exp(-dt/tau)
  std::vector<double> window_;
  std::size_t next_ = 0;
  double sum_ = 0.0, low_pass_ = 0.0;
};

/// Position rounded to the encoder quantum q (m); q <= 0: unquantised.
double quantise(double x_m, double q_m);

}  // namespace feedid::host
