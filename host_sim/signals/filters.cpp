#include "filters.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
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

namespace {
/// Samples of reflected padding either end of a filtfilt over n samples.
std::size_t filtfilt_pad(std::size_t n, double cutoff_hz, double rate_hz) {
  return std::min<std::size_t>(n - 1, static_cast<std::size_t>(3.0 * rate_hz / cutoff_hz) + 12);
}

/// x[0, n) reflected about its ends, filtered forwards and backwards, into
/// y[0, n + 2 pad): the filtered samples are y[pad, pad + n). y's storage
/// is reused from call to call (the cut-off scan filters the whole log
/// at every candidate; fresh buffers cost more than the filter).
void filtfilt_padded(const double* x, std::size_t n, std::size_t pad, double cutoff_hz, double rate_hz,
                     std::vector<double>& y) {
  if (y.capacity() < n + 2 * pad) y.clear();  // nothing in it to keep: growing copies nothing
  y.resize(n + 2 * pad);
  for (std::size_t i = pad, j = 0; i >= 1; --i, ++j) y[j] = 2.0 * x[0] - x[i];
  std::copy(x, x + n, y.begin() + static_cast<std::ptrdiff_t>(pad));
  for (std::size_t i = 1; i <= pad; ++i) y[pad + n - 1 + i] = 2.0 * x[n - 1] - x[n - 1 - i];
  run(y, cutoff_hz, rate_hz);
  run(y, cutoff_hz, rate_hz, true);
}

void check_cutoff(double cutoff_hz, double rate_hz) {
  if (!(cutoff_hz > 0.0) || !(rate_hz > 2.0 * cutoff_hz))
    throw std::invalid_argument("filter cut-off must be > 0 Hz and below half the sample rate");
}

/// d[k] = dy/dt at t[k] by central differences (one-sided at the ends),
/// y and t n >= 2 samples long. d may be y itself shifted down (d <= y):
/// the ends are read first, and each write lies below every later read.
void central_difference_into(const double* y, const double* t, std::size_t n, double* d) {
  const double first = (y[1] - y[0]) / (t[1] - t[0]);
  const double last = (y[n - 1] - y[n - 2]) / (t[n - 1] - t[n - 2]);
  d[0] = first;
  for (std::size_t k = 1; k + 1 < n; ++k) d[k] = (y[k + 1] - y[k - 1]) / (t[k + 1] - t[k - 1]);
  d[n - 1] = last;
}
}  // namespace

std::vector<double> filtfilt_butter4(const std::vector<double>& x, double cutoff_hz, double rate_hz) {
  check_cutoff(cutoff_hz, rate_hz);
  const std::size_t n = x.size();
  if (n < 3) return x;
  const std::size_t pad = filtfilt_pad(n, cutoff_hz, rate_hz);
  std::vector<double> y;
  filtfilt_padded(x.data(), n, pad, cutoff_hz, rate_hz, y);
  return std::vector<double>(y.begin() + static_cast<std::ptrdiff_t>(pad), y.begin() + static_cast<std::ptrdiff_t>(pad + n));
}

std::vector<double> central_difference(const std::vector<double>& y, const std::vector<double>& t) {
  const std::size_t n = y.size();
  std::vector<double> d(n, 0.0);
  if (n >= 2) central_difference_into(y.data(), t.data(), n, d.data());
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
/// The velocity of one stretch without gaps, x[0, n) at t[0, n), into
/// v[0, n). An evenly stamped stretch is filtered in `scratch`; an uneven
/// one on its uniform_grid, and read back at its own times.
void stretch_velocity(const double* x, const double* t, std::size_t n, double cutoff_hz, double rate_hz, double* v,
                      std::vector<double>& scratch) {
  check_cutoff(cutoff_hz, rate_hz);
  if (!evenly_stamped(t, n, rate_hz)) {
    const std::vector<double> ts(t, t + n);
    const std::vector<double> tg = uniform_grid(ts, rate_hz);
    const std::vector<double> vg =
        central_difference(filtfilt_butter4(resample(ts, std::vector<double>(x, x + n), tg), cutoff_hz, rate_hz), tg);
    const std::vector<double> vs = resample(tg, vg, ts);
    std::copy(vs.begin(), vs.end(), v);
    return;
  }
  if (n < 3) {  // too short to filter: the differences of the samples themselves
    if (n >= 2) central_difference_into(x, t, n, v);
    else if (n == 1) v[0] = 0.0;
    return;
  }
  const std::size_t pad = filtfilt_pad(n, cutoff_hz, rate_hz);
  filtfilt_padded(x, n, pad, cutoff_hz, rate_hz, scratch);
  central_difference_into(scratch.data() + pad, t, n, v);
}
}  // namespace

std::vector<double> zero_phase_velocity(const std::vector<double>& x, const std::vector<double>& t, double cutoff_hz,
                                        double rate_hz, double max_step_s) {
  std::vector<double> v;
  zero_phase_velocity(x, t, cutoff_hz, rate_hz, max_step_s, v);
  return v;
}

namespace {
bool one_stretch(const std::vector<double>& t, double max_step_s) {
  for (std::size_t k = 1; k < t.size(); ++k)
    if (!(t[k] - t[k - 1] <= max_step_s)) return false;
  return true;
}
}  // namespace

void zero_phase_velocity(const std::vector<double>& x, const std::vector<double>& t, double cutoff_hz, double rate_hz,
                         double max_step_s, std::vector<double>& v) {
  const std::size_t n = x.size();
  if (n >= 3 && one_stretch(t, max_step_s) && evenly_stamped(t, rate_hz)) {
    // The commonest log: filtered in v itself and differenced in place.
    check_cutoff(cutoff_hz, rate_hz);
    const std::size_t pad = filtfilt_pad(n, cutoff_hz, rate_hz);
    filtfilt_padded(x.data(), n, pad, cutoff_hz, rate_hz, v);
    central_difference_into(v.data() + pad, t.data(), n, v.data());
    v.resize(n);
  } else {
    v.resize(n);
    std::vector<double> scratch;
    for (std::size_t a = 0; a < n;) {
      std::size_t b = a + 1;
      while (b < n && t[b] - t[b - 1] <= max_step_s) ++b;
      stretch_velocity(x.data() + a, t.data() + a, b - a, cutoff_hz, rate_hz, v.data() + a, scratch);
      a = b;
    }
  }
  hold_rest(x, static_cast<std::size_t>(std::ceil(rate_hz / cutoff_hz)), v);
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

bool evenly_stamped(const double* t, std::size_t n, double rate_hz) {
  if (n < 3) return true;
  for (std::size_t k = 1; k < n; ++k)
    if (!(std::fabs((t[k] - t[k - 1]) * rate_hz - 1.0) < 0.01)) return false;
  return true;
}

bool evenly_stamped(const std::vector<double>& t, double rate_hz) { return evenly_stamped(t.data(), t.size(), rate_hz); }

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

std::string cutoff_note(double requested_hz, double applied_hz, const char* filtered) {
  if (!(applied_hz > 0.0) || !(requested_hz > applied_hz * (1.0 + 1e-6))) return "";
  char buf[200];
  std::snprintf(buf, sizeof buf, "--filter %.4g Hz is beyond 0.4 of the log's rate: %s filtered at %.4g Hz",
                requested_hz, filtered, applied_hz);
  return buf;
}

}  // namespace feedid::host
