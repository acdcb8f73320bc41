#include "filters.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace feedid::host {
namespace {

struct Biquad {
  double b0, b1, b2, a1, a2;  // a0 normalised to 1
  double z1 = 0, z2 = 0;      // transposed direct form II state
  double step(double x) {
    const double y = b0 * x + z1;
    z1 = b1 * x - a1 * y + z2;
    z2 = b2 * x - a2 * y;
    return y;
  }
  // State for a constant input x0 (DC gain 1): output equals input.
  void settle(double x0) {
    const double y = x0;
    z2 = b2 * x0 - a2 * y;
    z1 = b1 * x0 - a1 * y + z2;
  }
};

// Low-pass biquad with bilinear transform and pre-warped cut-off (RBJ form).
Biquad lowpass(double cutoff_hz, double rate_hz, double q) {
  const double w0 = 2.0 * M_PI * cutoff_hz / rate_hz;
  const double alpha = std::sin(w0) / (2.0 * q);
  const double c = std::cos(w0);
  const double a0 = 1.0 + alpha;
  Biquad b{};
  b.b0 = (1.0 - c) / 2.0 / a0;
  b.b1 = (1.0 - c) / a0;
  b.b2 = b.b0;
  b.a1 = -2.0 * c / a0;
  b.a2 = (1.0 - alpha) / a0;
  return b;
}

/// The filter over y in place, first to last, or last to first (the same
/// arithmetic as reversing y, filtering and reversing back, without the
/// two passes that reverse it).
void run(std::vector<double>& y, double cutoff_hz, double rate_hz, bool backwards = false) {
  // Butterworth order 4 = two sections with Q = 1/(2 cos(pi/8)), 1/(2 cos(3pi/8)).
  Biquad s1 = lowpass(cutoff_hz, rate_hz, 1.0 / (2.0 * std::cos(M_PI / 8.0)));
  Biquad s2 = lowpass(cutoff_hz, rate_hz, 1.0 / (2.0 * std::cos(3.0 * M_PI / 8.0)));
  const double start = backwards ? y.back() : y.front();
  s1.settle(start);
  s2.settle(start);
  if (backwards)
    for (auto v = y.rbegin(); v != y.rend(); ++v) *v = s2.step(s1.step(*v));
  else
    for (double& v : y) v = s2.step(s1.step(v));
}

}  // namespace

std::vector<double> filtfilt_butter4(const std::vector<double>& x, double cutoff_hz, double rate_hz) {
  if (!(cutoff_hz > 0.0) || !(rate_hz > 2.0 * cutoff_hz))
    throw std::invalid_argument("filter cut-off must be > 0 Hz and below half the sample rate");
  const std::size_t n = x.size();
  if (n < 3) return x;
  const std::size_t pad = std::min<std::size_t>(n - 1, static_cast<std::size_t>(3.0 * rate_hz / cutoff_hz) + 12);
  std::vector<double> y;
  y.reserve(n + 2 * pad);
  for (std::size_t i = pad; i >= 1; --i) y.push_back(2.0 * x.front() - x[i]);
  y.insert(y.end(), x.begin(), x.end());
  for (std::size_t i = 1; i <= pad; ++i) y.push_back(2.0 * x.back() - x[n - 1 - i]);
  run(y, cutoff_hz, rate_hz);
  run(y, cutoff_hz, rate_hz, true);
  y.erase(y.begin() + static_cast<std::ptrdiff_t>(pad + n), y.end());
  y.erase(y.begin(), y.begin() + static_cast<std::ptrdiff_t>(pad));  // in place: no second buffer
  return y;
}

std::vector<double> central_difference(const std::vector<double>& y, const std::vector<double>& t) {
  const std::size_t n = y.size();
  std::vector<double> d(n, 0.0);
  if (n < 2) return d;
  d[0] = (y[1] - y[0]) / (t[1] - t[0]);
  d[n - 1] = (y[n - 1] - y[n - 2]) / (t[n - 1] - t[n - 2]);
  for (std::size_t k = 1; k + 1 < n; ++k) d[k] = (y[k + 1] - y[k - 1]) / (t[k + 1] - t[k - 1]);
  return d;
}

namespace {
/// A position that does not change for `span` samples either side is at
/// rest: its velocity is 0, not the filter's ringing from a start or stop
/// nearby, whose sign would put +-Fc of friction on a standing axis.
void hold_rest(const std::vector<double>& x, std::size_t span, std::vector<double>& v) {
  const std::size_t n = x.size();
  std::size_t run_start = 0;  // first index of the current run of equal positions
  for (std::size_t k = 1; k <= n; ++k) {
    if (k < n && x[k] == x[run_start]) continue;
    // [run_start, k) hold one position; its inner part, span from each end, is at rest.
    for (std::size_t j = run_start + span; j + span < k; ++j) v[j] = 0.0;
    run_start = k;
  }
}
/// One stretch without gaps, on the uniform grid it is filtered on
/// (uniform_grid), then read back at its own times.
std::vector<double> stretch_velocity(const std::vector<double>& x, const std::vector<double>& t, double cutoff_hz,
                                     double rate_hz) {
  const std::vector<double> tg = uniform_grid(t, rate_hz);
  if (tg.empty()) return central_difference(filtfilt_butter4(x, cutoff_hz, rate_hz), t);
  const std::vector<double> vg = central_difference(filtfilt_butter4(resample(t, x, tg), cutoff_hz, rate_hz), tg);
  return resample(tg, vg, t);
}
}  // namespace

std::vector<double> zero_phase_velocity(const std::vector<double>& x, const std::vector<double>& t, double cutoff_hz,
                                        double rate_hz, double max_step_s) {
  std::vector<double> v(x.size(), 0.0);
  for (std::size_t a = 0; a < x.size();) {
    std::size_t b = a + 1;
    while (b < x.size() && t[b] - t[b - 1] <= max_step_s) ++b;
    if (a == 0 && b == x.size()) {  // one stretch: no copies of it
      v = stretch_velocity(x, t, cutoff_hz, rate_hz);
      break;
    }
    const std::vector<double> xs(x.begin() + static_cast<std::ptrdiff_t>(a), x.begin() + static_cast<std::ptrdiff_t>(b));
    const std::vector<double> ts(t.begin() + static_cast<std::ptrdiff_t>(a), t.begin() + static_cast<std::ptrdiff_t>(b));
    const std::vector<double> vs = stretch_velocity(xs, ts, cutoff_hz, rate_hz);
    std::copy(vs.begin(), vs.end(), v.begin() + static_cast<std::ptrdiff_t>(a));
    a = b;
  }
  hold_rest(x, static_cast<std::size_t>(std::ceil(rate_hz / cutoff_hz)), v);
  return v;
}

double interpolate(const std::vector<double>& t, const std::vector<double>& y, double q) {
  const auto hi = std::upper_bound(t.begin(), t.end(), q);
  if (hi == t.begin()) return y.front();
  if (hi == t.end()) return y.back();
  const auto k = static_cast<std::size_t>(hi - t.begin());
  const double w = (q - t[k - 1]) / (t[k] - t[k - 1]);
  return y[k - 1] + w * (y[k] - y[k - 1]);
}

std::vector<double> resample(const std::vector<double>& t, const std::vector<double>& y, const std::vector<double>& q) {
  std::vector<double> out(q.size());
  for (std::size_t k = 0; k < q.size(); ++k) out[k] = interpolate(t, y, q[k]);
  return out;
}

bool evenly_stamped(const std::vector<double>& t, double rate_hz) {
  if (t.size() < 3) return true;
  for (std::size_t k = 1; k < t.size(); ++k)
    if (!(std::fabs((t[k] - t[k - 1]) * rate_hz - 1.0) < 0.01)) return false;
  return true;
}

std::vector<double> clock_grid(const std::vector<double>& t, double rate_hz) {
  if (evenly_stamped(t, rate_hz)) return {};
  const double span = t.back() - t.front();
  const double slots = std::max(1.0, std::round(span * rate_hz));
  const double h = span / slots;
  std::vector<double> tg(static_cast<std::size_t>(slots) + 1);
  for (std::size_t k = 0; k < tg.size(); ++k) tg[k] = t.front() + static_cast<double>(k) * h;
  tg.back() = t.back();
  return tg;
}

std::vector<double> uniform_grid(const std::vector<double>& t, double rate_hz) {
  if (evenly_stamped(t, rate_hz)) return {};
  const double h = 1.0 / rate_hz;
  const auto n = static_cast<std::size_t>(std::floor((t.back() - t.front()) / h)) + 1;
  std::vector<double> tg(n);
  for (std::size_t k = 0; k < n; ++k) tg[k] = t.front() + static_cast<double>(k) * h;
  return tg;
}

double median_step(const std::vector<double>& t) {
  std::vector<double> d;
  d.reserve(t.size());
  for (std::size_t k = 1; k < t.size(); ++k) d.push_back(t[k] - t[k - 1]);
  if (d.empty()) return 0.0;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

std::vector<double> integrate_velocity(const std::vector<double>& v, const std::vector<double>& t, double max_step_s) {
  std::vector<double> x(v.size(), 0.0);
  for (std::size_t k = 1; k < v.size(); ++k) {
    const double h = t[k] - t[k - 1];
    x[k] = x[k - 1] + (h > 0 && h <= max_step_s ? v[k] * h : 0.0);
  }
  return x;
}

}  // namespace feedid::host
