#include "position_wrap.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace feedid::host {
namespace {

constexpr double kTwoPi = 6.283185307179586;

/// One wrap: where it is, and the jump less the motion around it.
struct Jump {
  std::size_t k = 0;         ///< the sample after the jump
  double excess = 0.0;       ///< x[k] - x[k-1] less the neighbouring steps' mean
};

/// Step k (x[k] - x[k-1]) if within one continuous stretch, else NaN.
double step(const std::vector<double>& t, const std::vector<double>& x, std::size_t k, double max_step_s) {
  if (k == 0 || k >= x.size() || t[k] - t[k - 1] > max_step_s) return NAN;
  return x[k] - x[k - 1];
}

std::vector<Jump> candidate_jumps(const std::vector<double>& t, const std::vector<double>& x, double max_step_s,
                                  double span) {
  std::vector<Jump> jumps;
  for (std::size_t k = 1; k < x.size(); ++k) {
    const double d = step(t, x, k, max_step_s);
    if (!(std::fabs(d) > 0.5 * span)) continue;
    const double before = step(t, x, k - 1, max_step_s), after = step(t, x, k + 1, max_step_s);
    double sum = 0.0, largest = 0.0;
    int n = 0;
    for (double s : {before, after})
      if (std::isfinite(s)) {
        sum += s;
        largest = std::max(largest, std::fabs(s));
        ++n;
      }
    // A lone sample between two gaps has no motion to compare with.
    if (n == 0 || std::fabs(d) <= kWrapOverStep * largest) continue;
    jumps.push_back({k, d - sum / n});
  }
  return jumps;
}

double median_magnitude(const std::vector<Jump>& jumps) {
  std::vector<double> m;
  for (const Jump& j : jumps) m.push_back(std::fabs(j.excess));
  std::nth_element(m.begin(), m.begin() + m.size() / 2, m.end());
  return m[m.size() / 2];
}

/// The period the jumps agree on (their mean magnitude: least squares), or
/// 0 when one strays or the span exceeds it.
double agreed_period(const std::vector<Jump>& jumps, double span) {
  const double median = median_magnitude(jumps);
  double sum = 0.0;
  for (const Jump& j : jumps) {
    if (std::fabs(std::fabs(j.excess) - median) > kWrapAgreement * median) return 0.0;
    sum += std::fabs(j.excess);
  }
  const double period = sum / static_cast<double>(jumps.size());
  if (span > (1.0 + kWrapAgreement) * period) return 0.0;
  return std::fabs(period / kTwoPi - 1.0) < kWrapTwoPiTolerance ? kTwoPi : period;
}

struct Wraps {
  PositionWrap wrap;
  std::vector<Jump> jumps;
};

Wraps find_wraps(const std::vector<double>& t, const std::vector<double>& x, double max_step_s) {
  Wraps w;
  if (x.size() < 3 || t.size() != x.size()) return w;
  const auto [lo, hi] = std::minmax_element(x.begin(), x.end());
  const double span = *hi - *lo;
  if (!(span > 0)) return w;
  w.jumps = candidate_jumps(t, x, max_step_s, span);
  if (w.jumps.empty()) return w;
  w.wrap.period = agreed_period(w.jumps, span);
  w.wrap.wraps = w.wrap.period > 0 ? w.jumps.size() : 0;
  return w;
}

}  // namespace

std::string PositionWrap::describe() const {
  char buf[160];
  std::snprintf(buf, sizeof buf, "wrapped (jumps of %.6g, e.g. a single-turn angle or a counter overflow): unwrapped at %zu place%s",
                period, wraps, wraps == 1 ? "" : "s");
  return buf;
}

PositionWrap find_position_wrap(const std::vector<double>& t, const std::vector<double>& x, double max_step_s) {
  return find_wraps(t, x, max_step_s).wrap;
}

PositionWrap unwrap_position(const std::vector<double>& t, std::vector<double>& x, double max_step_s) {
  const Wraps found = find_wraps(t, x, max_step_s);
  if (!found.wrap.found()) return found.wrap;
  double offset = 0.0;
  std::size_t next = 0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    if (next < found.jumps.size() && found.jumps[next].k == k)
      offset -= std::copysign(found.wrap.period, found.jumps[next++].excess);
    x[k] += offset;
  }
  return found.wrap;
}

}  // namespace feedid::host
