// Logging conventions (drive_log.hpp). Host only.
#include "drive_log.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace feedid::host {

const char* force_log_name(ForceLog f) {
  switch (f) {
    case ForceLog::held: return "held";
    case ForceLog::instant: return "instant";
    case ForceLog::averaged: return "averaged";
  }
  return "?";
}
const char* velocity_log_name(VelocityLog v) {
  switch (v) {
    case VelocityLog::backward_difference: return "backward";
    case VelocityLog::moving_average: return "average";
    case VelocityLog::low_pass: return "lowpass";
  }
  return "?";
}
Outcome<ForceLog> parse_force_log(const std::string& s) {
  for (ForceLog f : {ForceLog::held, ForceLog::instant, ForceLog::averaged})
    if (s == force_log_name(f)) return {f, ""};
  return refused<ForceLog>("--force-log must be held, instant or averaged, not '" + s + "'");
}
Outcome<VelocityLog> parse_velocity_log(const std::string& s) {
  for (VelocityLog v : {VelocityLog::backward_difference, VelocityLog::moving_average, VelocityLog::low_pass})
    if (s == velocity_log_name(v)) return {v, ""};
  return refused<VelocityLog>("--velocity-log must be backward, average or lowpass, not '" + s + "'");
}

LoggedVelocity::LoggedVelocity(const LoggingParams& p, double dt_s)
    : kind_(p.velocity), alpha_(1.0 - std::exp(-dt_s / p.velocity_time_constant_s)),
      window_(static_cast<std::size_t>(std::max(1, p.velocity_average_samples)), 0.0) {}

double LoggedVelocity::next(double v_backward) {
  switch (kind_) {
    case VelocityLog::backward_difference: return v_backward;
    case VelocityLog::moving_average: {
      sum_ += v_backward - window_[next_];
      window_[next_] = v_backward;
      next_ = (next_ + 1) % window_.size();
      return sum_ / static_cast<double>(window_.size());
    }
    case VelocityLog::low_pass: return low_pass_ += alpha_ * (v_backward - low_pass_);
  }
  return v_backward;
}

double quantise(double x, double q) { return q > 0.0 ? std::round(x / q) * q : x; }

}  // namespace feedid::host
