#include "force_outliers.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "signals/condition.hpp"
#include "signals/filters.hpp"

namespace feedid::host {

double force_outlier_limit(const std::vector<double>& x, const std::vector<double>& u) {
  std::vector<double> moving, all;
  moving.reserve(u.size());
  all.reserve(u.size());
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

std::string ForceSaturation::describe(const std::string& force_unit) const {
  char buf[320];
  std::string levels;
  if (found_hi) { std::snprintf(buf, sizeof buf, "%+.6g", level_hi); levels += buf; }
  if (found_lo) { std::snprintf(buf, sizeof buf, "%s%+.6g", found_hi ? " and " : "", level_lo); levels += buf; }
  std::snprintf(buf, sizeof buf,
                "clipped at %s %s: %zu rows sit on the level (a drive's limit or the log's range), left out with the rows "
                "around them (%zu in all), so that no integral spans a force that did not move the axis",
                levels.c_str(), force_unit.c_str(), rows, rows_left_out);
  return buf;
}

nlohmann::json ForceSaturation::to_json() const {
  if (!found()) return nullptr;
  return {{"level_hi", found_hi ? nlohmann::json(level_hi) : nlohmann::json()},
          {"level_lo", found_lo ? nlohmann::json(level_lo) : nlohmann::json()},
          {"rows", rows}, {"rows_left_out", rows_left_out}};
}

namespace {
/// Whether `level` is a clip level of u on the side `sign` (the rules of
/// ForceSaturation), the rows beyond it left aside as spikes.
bool clip_at(const std::vector<double>& u, double sign, double level) {
  if (!(sign * level > 0.0) || !std::isfinite(level)) return false;
  // The force's step at the level: the distance to the nearest value below it.
  std::size_t on = 0;
  double step = std::numeric_limits<double>::infinity();
  for (double x : u) {
    if (x == level) ++on;
    else if (sign * (level - x) > 0.0) step = std::min(step, sign * (level - x));
  }
  // A force that never leaves the level (a constant) has nothing clipped.
  if (on < kSaturationMinRows || !std::isfinite(step)) return false;
  const double band = std::max(kSaturationBand * std::fabs(level), std::isfinite(step) ? 3.0 * step : 0.0);
  std::size_t near = 0;
  for (double x : u)
    if (x != level && sign * (level - x) > 0.0 && sign * (level - x) <= band) ++near;
  return static_cast<double>(on) > kSaturationPileUp * static_cast<double>(near);
}

/// Whether the largest value of `u` (sign +1) or the smallest (-1) is a
/// clip level (ForceSaturation), and which. A few rows beyond it
/// (kSaturationSpikes: outliers, bridged later) do not hide it: one row of
/// 1e5 N above a clip at 116 N left EMPS-like data 12 % light, unnamed.
bool clip_level(const std::vector<double>& u, double sign, double& level) {
  if (u.empty()) return false;
  // The kSaturationSpikes + 1 extreme distinct values, the most extreme first.
  std::vector<double> extremes;
  for (double x : u) {
    // Full, the list takes only a value beyond its least extreme: the
    // common sample is turned away by one comparison, not a search and a sort.
    if (extremes.size() > kSaturationSpikes && !(sign * x > sign * extremes.back())) continue;
    if (!std::isfinite(x) || std::find(extremes.begin(), extremes.end(), x) != extremes.end()) continue;
    extremes.push_back(x);
    std::sort(extremes.begin(), extremes.end(), [sign](double a, double b) { return sign * a > sign * b; });
    if (extremes.size() > kSaturationSpikes + 1) extremes.pop_back();
  }
  std::size_t beyond = 0;
  for (double candidate : extremes) {
    if (beyond > kSaturationSpikes) break;
    if (clip_at(u, sign, candidate)) {
      level = candidate;
      return true;
    }
    beyond += static_cast<std::size_t>(std::count(u.begin(), u.end(), candidate));
  }
  level = extremes.empty() ? 0.0 : extremes.front();
  return false;
}
}  // namespace

Trace leave_out_force_saturation(Trace logged, ForceSaturation& found, const ForceSaturation& known,
                                 double min_level) {
  found = ForceSaturation{};
  std::vector<double> u, t;
  u.reserve(logged.samples.size());
  t.reserve(logged.samples.size());
  for (const TraceSample& s : logged.samples) {
    u.push_back(s.u_N);
    t.push_back(s.t_s);
  }
  found.found_hi = clip_level(u, 1.0, found.level_hi) && found.level_hi >= min_level;
  found.found_lo = clip_level(u, -1.0, found.level_lo) && -found.level_lo >= min_level;
  if (!found.found_hi && known.found_hi) found.found_hi = true, found.level_hi = known.level_hi;
  if (!found.found_lo && known.found_lo) found.found_lo = true, found.level_lo = known.level_lo;
  if (!found.found()) return logged;
  const std::size_t n = u.size();
  std::vector<bool> out(n, false);
  for (std::size_t k = 0; k < n; ++k)
    out[k] = (found.found_hi && u[k] == found.level_hi) || (found.found_lo && u[k] == found.level_lo);
  found.rows = static_cast<std::size_t>(std::count(out.begin(), out.end(), true));
  // Widen each clipped stretch until the kept rows either side are a gap apart.
  const double gap_s = max_step_s(median_step(t));
  for (std::size_t a = 0; a < n;) {
    if (!out[a]) { ++a; continue; }
    std::size_t b = a;
    while (b + 1 < n && out[b + 1]) ++b;
    std::size_t lo = a, hi = b;  // [lo, hi] left out; at either end of the trace nothing is spanned
    auto is_gap = [&] { return lo == 0 || hi + 1 >= n || t[hi + 1] - t[lo - 1] > gap_s; };
    while (!is_gap()) { --lo; ++hi; }
    for (std::size_t k = lo; k <= hi; ++k) out[k] = true;
    a = hi + 1;
  }
  const std::vector<TraceSample> all = std::move(logged.samples);  // logged is this call's own
  Trace kept = std::move(logged);
  kept.samples.clear();
  kept.samples.reserve(n);
  for (TraceRun& run : kept.runs) {
    const std::size_t first = run.first, last = run.first + run.samples;
    run.first = kept.samples.size();
    for (std::size_t k = first; k < last; ++k)
      if (!out[k]) kept.samples.push_back(all[k]);
    run.samples = kept.samples.size() - run.first;
  }
  if (kept.runs.empty())
    for (std::size_t k = 0; k < n; ++k)
      if (!out[k]) kept.samples.push_back(all[k]);
  found.rows_left_out = n - kept.samples.size();
  return kept;
}

std::string PositionSpikes::describe(const std::string& position_unit) const {
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "%zu position row%s jumped more than %.4g %s (%g times the %g quantile of the position's steps) and "
                "back, bridged by the straight line between its neighbours; first: %s",
                rows, rows == 1 ? "" : "s", limit_m, position_unit.c_str(), kForceOutlierFactor, kForceScaleQuantile,
                first.empty() ? "" : first.front().c_str());
  return buf;
}

Trace bridge_position_spikes(Trace logged, PositionSpikes& found) {
  found = PositionSpikes{};
  const std::size_t n = logged.samples.size();
  if (!logged.has_position || n < 3) return logged;
  std::vector<double> t, steps;
  t.reserve(n);
  steps.reserve(n - 1);
  for (const TraceSample& s : logged.samples) t.push_back(s.t_s);
  const double gap_s = max_step_s(median_step(t));
  for (std::size_t k = 1; k < n; ++k)
    if (!(t[k] - t[k - 1] > gap_s)) steps.push_back(logged.samples[k].x_m - logged.samples[k - 1].x_m);
  const double scale = quantile_abs(steps, kForceScaleQuantile);
  if (!(scale > 0.0)) return logged;
  found.limit_m = kForceOutlierFactor * scale;
  // In place: sample k reads its bridged predecessor and its own and its
  // successor's values as logged (neither is bridged yet).
  std::vector<TraceSample>& out = logged.samples;
  for (std::size_t k = 1; k + 1 < n; ++k) {
    if (t[k] - t[k - 1] > gap_s || t[k + 1] - t[k] > gap_s) continue;  // a run's end: no neighbour to judge by
    const double before = out[k - 1].x_m, here = out[k].x_m, after = out[k + 1].x_m;
    if (!(std::fabs(here - before) > found.limit_m && std::fabs(after - here) > found.limit_m &&
          std::fabs(after - before) <= found.limit_m))
      continue;
    ++found.rows;
    char value[96];
    std::snprintf(value, sizeof value, ": position %.9g", here);
    if (found.first.size() < kNamedOutliers) found.first.push_back(where(logged, k) + value);
    out[k].x_m = before + (after - before) * (t[k] - t[k - 1]) / (t[k + 1] - t[k - 1]);
  }
  return logged;
}

Trace bridge_force_outliers(const Trace& spiky, const std::string& force_unit, ForceOutliers& found) {
  PositionSpikes spikes;
  ForceSaturation saturation;
  Trace out = leave_out_force_saturation(bridge_position_spikes(spiky, spikes), saturation);  // the one copy
  std::vector<double> u, t;
  u.reserve(out.samples.size());
  t.reserve(out.samples.size());
  for (const TraceSample& s : out.samples) {
    u.push_back(s.u_N);
    t.push_back(s.t_s);
  }
  found = ForceOutliers{};
  found.saturation = saturation;
  found.position_spikes = spikes;
  found.limit = force_outlier_limit(travel_of(out), u);
  const double gap_s = t.size() > 1 ? max_step_s(median_step(t)) : 0.0;
  auto good = [&](std::size_t k) { return !(std::fabs(u[k]) > found.limit); };
  for (std::size_t k = 0; k < u.size(); ++k) {
    if (good(k)) continue;
    ++found.rows;
    char value[160];
    std::snprintf(value, sizeof value, ": force %.6g %s is beyond the outlier limit +-%.4g %s", u[k], force_unit.c_str(),
                  found.limit, force_unit.c_str());
    if (found.first.size() < kNamedOutliers) found.first.push_back(where(out, k) + value);  // times and runs as logged
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
