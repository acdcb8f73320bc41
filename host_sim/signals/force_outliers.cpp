#include "force_outliers.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "signals/filters.hpp"

namespace feedid::host {

double force_outlier_limit(const std::vector<double>& x, const std::vector<double>& u) {
  std::vector<double> moving, all;
  for (std::size_t k = 0; k < u.size(); ++k) {
    if (!std::isfinite(u[k])) continue;
    all.push_back(std::fabs(u[k]));
    if (k > 0 && k < x.size() && x[k] != x[k - 1]) moving.push_back(std::fabs(u[k]));
  }
  std::vector<double>& v = moving.empty() ? all : moving;
  if (v.empty()) return std::numeric_limits<double>::max();
  const auto q = static_cast<std::ptrdiff_t>(kForceScaleQuantile * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + q, v.end());
  const double scale = v[static_cast<std::size_t>(q)];
  return scale > 0.0 ? kForceOutlierFactor * scale : std::numeric_limits<double>::max();
}

std::string ForceOutliers::describe(const std::string& force_unit) const {
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "%zu force row%s beyond +-%.4g %s (%g times the %g quantile of |force| while moving) bridged by the "
                "straight line between the good forces either side", rows, rows == 1 ? "" : "s", limit,
                force_unit.c_str(), kForceOutlierFactor, kForceScaleQuantile);
  return buf;
}

namespace {
/// Where sample k of a trace came from: its file (of a pooled run) and its time there.
std::string where(const Trace& t, std::size_t k) {
  for (const TraceRun& run : t.runs)
    if (k >= run.first && k < run.first + run.samples) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "t = %.9g s", t.samples[k].t_s - run.time_shift_s);
      return run.source + ": " + buf;
    }
  char buf[64];
  std::snprintf(buf, sizeof buf, "t = %.9g s", t.samples[k].t_s);
  return t.source + ": " + buf;
}

/// x along the motion: the position, or the running sum of the velocity
/// (which changes where the axis moves, as the position would).
std::vector<double> travel_of(const Trace& t) {
  std::vector<double> x;
  double sum = 0.0;
  for (const TraceSample& s : t.samples) x.push_back(t.has_position ? s.x_m : (sum += s.v_m_s));
  return x;
}
}  // namespace

Trace bridge_force_outliers(const Trace& logged, const std::string& force_unit, ForceOutliers& found) {
  std::vector<double> u, t;
  for (const TraceSample& s : logged.samples) {
    u.push_back(s.u_N);
    t.push_back(s.t_s);
  }
  found = ForceOutliers{};
  found.limit = force_outlier_limit(travel_of(logged), u);
  Trace out = logged;
  const double gap_s = t.size() > 1 ? max_step_s(median_step(t)) : 0.0;
  auto good = [&](std::size_t k) { return !(std::fabs(u[k]) > found.limit); };
  for (std::size_t k = 0; k < u.size(); ++k) {
    if (good(k)) continue;
    ++found.rows;
    char value[160];
    std::snprintf(value, sizeof value, ": force %.6g %s is beyond the outlier limit +-%.4g %s", u[k], force_unit.c_str(),
                  found.limit, force_unit.c_str());
    if (found.first.size() < kNamedOutliers) found.first.push_back(where(logged, k) + value);
    // The nearest good forces on either side within the same stretch of samples.
    std::size_t a = k, b = k;
    while (a > 0 && !(t[a] - t[a - 1] > gap_s) && !good(--a)) {}
    while (b + 1 < u.size() && !(t[b + 1] - t[b] > gap_s) && !good(++b)) {}
    const bool before = a < k && good(a), after = b > k && good(b);
    if (before && after)
      out.samples[k].u_N = u[a] + (u[b] - u[a]) * (t[k] - t[a]) / (t[b] - t[a]);
    else if (before || after)
      out.samples[k].u_N = u[before ? a : b];
    else
      ++found.unbridged;  // left for the core to reject (max_force_N)
  }
  return out;
}

}  // namespace feedid::host
