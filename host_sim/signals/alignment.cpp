#include "alignment.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace feedid::host {

/// v and x of `from` delayed by `delay` whole samples into `to`, which has
/// the other columns of `from` (`to` may be `from`). The first samples repeat
/// the first value; a source across a time gap (another recording,
/// Trace::runs) is not taken: the few samples after a gap keep their own.
void delay_motion(const Signals& from, int delay, Signals& to) {
  const auto d = static_cast<std::size_t>(std::max(delay, 0));
  const double span_max = from.sample_rate_hz > 0 ? 5.0 * static_cast<double>(d) / from.sample_rate_hz : 0.0;
  // Newest first, so in place every sample reads its source before it is overwritten.
  for (std::size_t k = from.v.size(); k-- > 0;) {
    std::size_t src = k >= d ? k - d : 0;
    if (d > 0 && span_max > 0 && from.t[k] - from.t[src] > span_max) src = k;
    to.v[k] = from.v[src];
    to.x[k] = from.x[src];
  }
  to.velocity_delay_samples = delay;
}

int whole_delay_for(double lag_samples) { return lag_samples > 0.0 ? static_cast<int>(std::ceil(lag_samples)) : 0; }

double estimate_velocity_lag(const Signals& s) {
  const std::size_t n = s.t.size();
  if (!s.has_position || s.x.size() != n || n < 64) return std::numeric_limits<double>::quiet_NaN();
  // The logged velocity integrated, X, is the position seen through the
  // velocity's filter: x(t) - X(t) = D v(t), D the filter's mean delay
  // beyond the backward difference (0 for the difference itself, (k-1)/2
  // for a k-sample mean, (1-a)/a for y += a (v - y)). D is the regression
  // of x - X on v within windows of 0.1 s, each with its own offset, so a
  // slow drift of X (a bias in v) does not enter. A least-squares shift of
  // v against the position difference measures the delay of the count
  // edges instead, the median of a low-pass's response rather than its
  // mean: 1.2 instead of 1.55 periods on a slow, coarse trace.
  const double rate = s.sample_rate_hz > 0 ? s.sample_rate_hz : 1.0;
  const std::size_t window = std::max<std::size_t>(16, static_cast<std::size_t>(0.1 * rate));
  double integral = s.x[0], sxy = 0.0, sxx = 0.0;
  std::vector<double> gap, vel;
  gap.reserve(window);
  vel.reserve(window);
  auto flush = [&]() {
    if (gap.size() >= 8) {
      double mg = 0.0, mv = 0.0;
      for (std::size_t i = 0; i < gap.size(); ++i) { mg += gap[i]; mv += vel[i]; }
      mg /= static_cast<double>(gap.size());
      mv /= static_cast<double>(gap.size());
      for (std::size_t i = 0; i < gap.size(); ++i) {
        sxy += (gap[i] - mg) * (vel[i] - mv);
        sxx += (vel[i] - mv) * (vel[i] - mv);
      }
    }
    gap.clear();
    vel.clear();
  };
  for (std::size_t k = 1; k < n; ++k) {
    const double dt = s.t[k] - s.t[k - 1];
    if (!(dt > 0) || dt > 5.0 / rate) {  // a gap: start the integral again
      flush();
      integral = s.x[k];
      continue;
    }
    integral += s.v[k] * dt;
    gap.push_back((s.x[k] - integral) / dt);  // in periods times velocity
    vel.push_back(s.v[k]);
    if (gap.size() == window) flush();
  }
  flush();
  if (!(sxx > 0)) return std::numeric_limits<double>::quiet_NaN();
  return 0.5 + sxy / sxx;
}

double velocity_column_gain(const Signals& s) {
  const std::size_t n = s.t.size();
  if (!s.has_position || s.x.size() != n || s.v.size() != n || n < 64) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t window = std::max<std::size_t>(64, static_cast<std::size_t>(s.sample_rate_hz));
  double sxy = 0.0, sxx = 0.0, integral = 0.0;
  std::vector<double> X, x;
  auto flush = [&]() {
    if (X.size() >= 8) {
      double mX = 0.0, mx = 0.0;
      for (std::size_t i = 0; i < X.size(); ++i) { mX += X[i]; mx += x[i]; }
      mX /= static_cast<double>(X.size());
      mx /= static_cast<double>(X.size());
      for (std::size_t i = 0; i < X.size(); ++i) {
        sxy += (X[i] - mX) * (x[i] - mx);
        sxx += (x[i] - mx) * (x[i] - mx);
      }
    }
    X.clear();
    x.clear();
  };
  for (std::size_t k = 1; k < n; ++k) {
    if (s.gap_before(k)) {  // another run: the integral starts again
      flush();
      continue;
    }
    integral += s.v[k] * (s.t[k] - s.t[k - 1]);
    X.push_back(integral);
    x.push_back(s.x[k]);
    if (X.size() == window) flush();
  }
  flush();
  return sxx > 0 ? sxy / sxx : std::numeric_limits<double>::quiet_NaN();
}

bool velocity_column_agrees(double gain) {
  return !std::isfinite(gain) || (gain >= 1.0 / kVelocityColumnGainTolerance && gain <= kVelocityColumnGainTolerance);
}

void apply_force_lag(Signals& s, double lag_samples) {
  const int delay = whole_delay_for(lag_samples);
  delay_motion(s, delay, s);
  s.force_lag_samples = lag_samples - delay;
}

std::string nearest_force_convention(double force_lag_samples, double velocity_lag_samples) {
  // Delay of the force itself: its lag behind velocity plus the velocity's own delay.
  const double force_delay = force_lag_samples + velocity_lag_samples;
  const std::pair<double, const char*> named[] = {{-0.5, "held"}, {0.0, "instant"}, {0.5, "averaged"}};
  const char* name = "none";
  double best = 0.25;
  for (const auto& [delay, n] : named)
    if (std::fabs(force_delay - delay) <= best) { best = std::fabs(force_delay - delay); name = n; }
  return name;
}

}  // namespace feedid::host
