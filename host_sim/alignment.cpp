#include "alignment.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

namespace feedid::host {
namespace {

/// v and x of `from` delayed by `delay` whole samples (the first ones repeat
/// the first value), into `to`, which has the other columns of `from`.
void delay_motion(const Signals& from, int delay, Signals& to) {
  const std::size_t n = from.v.size();
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t j = k >= static_cast<std::size_t>(delay) ? k - static_cast<std::size_t>(delay) : 0;
    to.v[k] = from.v[j];
    to.x[k] = from.x[j];
  }
  to.velocity_delay_samples = delay;
}

int whole_delay_for(double lag_samples) { return lag_samples > 0.0 ? static_cast<int>(std::ceil(lag_samples)) : 0; }

/// Sum of squared block residuals of the model identified at one lag.
struct LagCost {
  double ssr = std::numeric_limits<double>::infinity();
  std::size_t blocks = 0;
};

LagCost cost_at(const Signals& original, Signals& work, const feedid::Config<double>& cfg, double lag) {
  const int delay = whole_delay_for(lag);
  if (delay != work.velocity_delay_samples) delay_motion(original, delay, work);
  work.force_lag_samples = lag - delay;
  feedid::Config<double> c = cfg;
  c.force_lag_samples = work.force_lag_samples;
  IdentifyOptions quiet;
  const CoreRun run = run_core(work, c, quiet);
  LagCost out;
  if (run.status != feedid::Status::ok) return out;
  const BlockResidual b = block_residual(work, to_drive_params(run.estimate), cfg.velocity_min_m_s, 0.01);
  if (b.blocks == 0) return out;
  out.ssr = b.sum_squares;
  out.blocks = b.blocks;
  return out;
}

}  // namespace

LagEstimate estimate_force_lag(const Signals& s, const feedid::Config<double>& cfg) {
  LagEstimate e;
  Signals work = s;
  work.velocity_delay_samples = 0;
  // Coarse grid on whole periods, then the half periods around the best.
  struct Point { double lag; LagCost c; };
  std::vector<Point> pts;
  auto eval = [&](double lag) {
    for (const Point& p : pts)
      if (std::fabs(p.lag - lag) < 1e-9) return p.c;
    pts.push_back({lag, cost_at(s, work, cfg, lag)});
    ++e.evaluations;
    return pts.back().c;
  };
  auto best_point = [&]() {
    return *std::min_element(pts.begin(), pts.end(), [](const Point& a, const Point& b) { return a.c.ssr < b.c.ssr; });
  };
  for (double lag = kForceLagMin; lag <= kForceLagMax + 1e-9; lag += 1.0) eval(lag);
  const double coarse = best_point().lag;
  for (double d : {-0.5, 0.5})
    if (coarse + d >= kForceLagMin && coarse + d <= kForceLagMax) eval(coarse + d);
  const Point best = best_point();
  if (!std::isfinite(best.c.ssr)) return e;
  e.lag_samples = best.lag;
  // Parabola through the best point and its neighbours half a period away.
  const double h = 0.5;
  if (best.lag - h < kForceLagMin - 1e-9 || best.lag + h > kForceLagMax + 1e-9) return e;
  const LagCost lo = eval(best.lag - h), hi = eval(best.lag + h);
  const double curv = (lo.ssr - 2.0 * best.c.ssr + hi.ssr) / (2.0 * h * h);  // SSR = a (lag - l0)^2 + c
  if (!(curv > 0.0) || !std::isfinite(curv)) return e;
  e.lag_samples = best.lag + std::clamp((lo.ssr - hi.ssr) / (4.0 * h * curv), -h, h);
  // Residual variance per block, nine model parameters and the lag fitted.
  const double dof = static_cast<double>(best.c.blocks) - 10.0;
  const double s2 = dof > 0 ? best.c.ssr / dof : best.c.ssr;
  e.se_samples = std::sqrt(s2 / curv);
  e.ok = true;
  return e;
}

double estimate_velocity_lag(const Signals& s) {
  const std::size_t n = s.t.size();
  if (!s.has_position || s.x.size() != n || n < 64) return std::numeric_limits<double>::quiet_NaN();
  // Backward difference of position: late by half a period.
  std::vector<double> vb(n, 0.0);
  for (std::size_t k = 1; k < n; ++k) {
    const double dt = s.t[k] - s.t[k - 1];
    vb[k] = dt > 0 ? (s.x[k] - s.x[k - 1]) / dt : vb[k - 1];
  }
  // Least squares of the logged v against vb shifted by a lag (linear
  // between samples), on a grid of quarter periods, then a parabola.
  const std::size_t first = 16, stride = std::max<std::size_t>(1, n / 400000);
  auto cost = [&](double lag) {
    const double shift = lag - 0.5;  // vb is already half a period late
    const int whole = static_cast<int>(std::floor(shift));
    const double f = shift - whole;
    double sum = 0.0;
    for (std::size_t k = first; k < n; k += stride) {
      const long j = static_cast<long>(k) - whole;
      if (j - 1 < 1 || j >= static_cast<long>(n)) continue;
      const double pred = (1.0 - f) * vb[static_cast<std::size_t>(j)] + f * vb[static_cast<std::size_t>(j - 1)];
      const double r = s.v[k] - pred;
      sum += r * r;
    }
    return sum;
  };
  double best_lag = 0.0, best = std::numeric_limits<double>::infinity();
  constexpr double step = 0.25;
  for (double lag = -1.0; lag <= 12.0 + 1e-9; lag += step) {
    const double c = cost(lag);
    if (c < best) { best = c; best_lag = lag; }
  }
  const double lo = cost(best_lag - step), hi = cost(best_lag + step);
  const double den = lo - 2.0 * best + hi;
  if (den > 0) best_lag += std::clamp(0.5 * step * (lo - hi) / den, -step, step);
  return best_lag;
}

void apply_force_lag(Signals& s, double lag_samples) {
  const int delay = whole_delay_for(lag_samples);
  // Newest first, so every sample reads its source before it is overwritten.
  const auto d = static_cast<std::size_t>(delay);
  for (std::size_t k = s.v.size(); delay > 0 && k-- > 0;) {
    s.v[k] = s.v[k >= d ? k - d : 0];
    s.x[k] = s.x[k >= d ? k - d : 0];
  }
  s.velocity_delay_samples = delay;
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
