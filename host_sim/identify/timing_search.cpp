#include "timing_search.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

namespace feedid::host {
namespace {

/// Sum of squared block residuals of the model identified at one lag.
struct LagCost {
  double ssr = std::numeric_limits<double>::infinity();
  std::size_t blocks = 0;
  std::array<double, kJackknifeChunks> chunk_ssr{};
};

/// The model the core identifies on `work` as it is paired
/// (work.force_lag_samples); not ok where nothing identifies.
using HeldModel = HeldFriction;

HeldModel identify_model(const Signals& work, const feedid::Config<double>& cfg) {
  feedid::Config<double> c = cfg;
  c.force_lag_samples = work.force_lag_samples;
  const SolvedCore<BandsCore> run = solve_core<BandsCore>(work, c, feedid::Method::bands);
  HeldModel out;
  if (run.status != feedid::Status::ok) return out;
  out.ok = true;
  out.params = to_drive_params(run.estimate);
  return out;
}

/// The block residual of blocks observed with friction `model`, the force
/// paired by `pairing`, with the mass refitted on the same blocks, as
/// identify() does: the core's window mass takes raw velocity samples, and
/// with a coarse quantum its jumps from lag to lag made the cost rough (the
/// lag off by 0.3-1 period at 8 kHz and 100 nm, and m by 3 of its standard
/// errors with it).
LagCost block_cost(const std::vector<PairedBlock>& blocks, const DriveParams& model) {
  LagCost out;
  const BlockMass refit = block_mass(blocks);
  const BlockResidual b = block_residual(blocks, refit.ok ? refit.mass_kg : model.mass_kg);
  if (b.blocks == 0) return out;
  out.ssr = b.sum_squares;
  out.blocks = b.blocks;
  out.chunk_ssr = b.chunk_sum_squares;
  return out;
}

/// The same on `work` as it is paired (one pairing: paired_blocks); cfg's
/// band edges hold it to one set of blocks.
LagCost block_cost(const Signals& work, const DriveParams& model, const feedid::Config<double>& cfg) {
  return block_cost(paired_blocks(work, model, cfg.velocity_min_m_s, block_length_s(work)), model);
}

/// The block residual of the model the core identifies on `work` as paired.
LagCost fit_cost(const Signals& work, const feedid::Config<double>& cfg) {
  const HeldModel model = identify_model(work, cfg);
  return model.ok ? block_cost(work, model.params, cfg) : LagCost{};
}

/// Pairs `work` (v and x of `original`) at `lag`.
void pair_at(const Signals& original, Signals& work, double lag) {
  const int delay = whole_delay_for(lag);
  if (delay != work.velocity_delay_samples) delay_motion(original, delay, work);
  work.force_lag_samples = lag - delay;
}

/// Vertex of the parabola through (l - h, lo), (l, mid), (l + h, hi), kept
/// within h of l; NaN where the three do not curve upwards.
double vertex(double l, double h, double lo, double mid, double hi) {
  const double curv = (lo - 2.0 * mid + hi) / (2.0 * h * h);
  if (!(curv > 0.0) || !std::isfinite(curv)) return std::numeric_limits<double>::quiet_NaN();
  return l + std::clamp((lo - hi) / (4.0 * h * curv), -h, h);
}

/// Delete-one-chunk jackknife of the vertex: the lag's scatter over
/// stretches of the trace. The curvature's figure assumes independent block
/// residuals; at 8 kHz with a 100 nm encoder the residual curve is rough
/// and the lag was 0.3-0.5 periods off while that figure said 0.05.
double jackknife_vertex_se(double l, double h, const LagCost& lo, const LagCost& mid, const LagCost& hi) {
  std::vector<double> v;
  for (int c = 0; c < kJackknifeChunks; ++c) {
    const auto i = static_cast<std::size_t>(c);
    const double x = vertex(l, h, lo.ssr - lo.chunk_ssr[i], mid.ssr - mid.chunk_ssr[i], hi.ssr - hi.chunk_ssr[i]);
    if (std::isfinite(x)) v.push_back(x);
  }
  return jackknife_se(v);
}

/// Curvature a of SSR = a (lag - l0)^2 + c through three points h apart.
double curvature(double h, const LagCost& lo, const LagCost& mid, const LagCost& hi) {
  return (lo.ssr - 2.0 * mid.ssr + hi.ssr) / (2.0 * h * h);
}

/// Standard error of the vertex of the parabola through (l - h, lo),
/// (l, mid), (l + h, hi): from its curvature and the residual variance per
/// block (nine model parameters and the lag fitted), or the chunks'
/// scatter where that is larger; h where the three do not curve upwards.
double vertex_se(double l, double h, const LagCost& lo, const LagCost& mid, const LagCost& hi) {
  const double curv = curvature(h, lo, mid, hi);
  if (!(curv > 0.0) || !std::isfinite(curv)) return h;
  const double dof = static_cast<double>(mid.blocks) - 10.0;
  const double s2 = dof > 0 ? mid.ssr / dof : mid.ssr;
  const double jack = jackknife_vertex_se(l, h, lo, mid, hi);
  return std::isfinite(jack) ? std::max(std::sqrt(s2 / curv), jack) : std::sqrt(s2 / curv);
}

/// A lag, the model the core identifies with the force paired there, and
/// that model's block residual.
struct RefitPoint {
  double lag = 0.0;
  LagCost c;
  HeldModel model;
};

RefitPoint refit_at(const Signals& s, Signals& work, const feedid::Config<double>& cfg, double lag, int& evaluations) {
  pair_at(s, work, lag);
  ++evaluations;
  RefitPoint p{lag, LagCost{}, identify_model(work, cfg)};
  if (p.model.ok) p.c = block_cost(work, p.model.params, cfg);
  return p;
}

/// Three refits half a period apart, the middle one the least (or at an
/// end of the searched range), and whether the walk left its start.
struct RefitWalk {
  RefitPoint lo, mid, hi;
  bool walked = false;
};

/// Held friction finds the lag it was identified at whenever the motion
/// lets friction and mass absorb a shift of the force. On a single tone
/// u(t - d) = (m - d sigma) a + (sigma + d m w^2) v + the Coulomb steps,
/// so the held search returned its starting lag whatever the true one
/// (m 5 to 22 standard errors off, status ok): only the reversals tell the
/// lag there, and only a refit of the friction lets them. So the core
/// identifies again half a period either side of the held search's lag
/// (`start`, identified there); where a side fits better, the walk goes
/// that way by half periods until the fit worsens. On motion that
/// separates the lag the sides fit worse and the walk stays: two
/// identifications.
RefitWalk walk_by_refits(const Signals& s, Signals& work, const feedid::Config<double>& cfg, RefitPoint start,
                         int& evaluations) {
  const double h = 0.5;
  const double l = start.lag;
  RefitWalk w{refit_at(s, work, cfg, l - h, evaluations), std::move(start), refit_at(s, work, cfg, l + h, evaluations)};
  for (;;) {
    const bool down = w.lo.c.ssr < w.mid.c.ssr && w.lo.c.ssr <= w.hi.c.ssr && w.lo.lag - h >= kForceLagMin - 1e-9;
    const bool up = !down && w.hi.c.ssr < w.mid.c.ssr && w.hi.lag + h <= kForceLagMax + 1e-9;
    if (!down && !up) return w;
    w.walked = true;
    if (down) {
      w.hi = std::move(w.mid);
      w.mid = std::move(w.lo);
      w.lo = refit_at(s, work, cfg, w.mid.lag - h, evaluations);
    } else {
      w.lo = std::move(w.mid);
      w.mid = std::move(w.hi);
      w.hi = refit_at(s, work, cfg, w.mid.lag + h, evaluations);
    }
  }
}

}  // namespace

LagEstimate estimate_force_lag(const Signals& s, const feedid::Config<double>& cfg, HeldFriction* shared) {
  LagEstimate e;
  Signals work = s;
  work.velocity_delay_samples = 0;
  // Friction is a function of velocity: a shift of the force moves a
  // band's mean force by the shift times the change of force across the
  // band, but misses every block's inertia identity integral(u - F) = m dv
  // by the shift times the change of force (m jerk dt). So the lags are
  // scored with one identification's friction held and the mass, which
  // the lag trades against, refitted on the blocks at each. Held from a
  // period away, the friction put the vertex 0.02 period (3 standard
  // errors) off, so the core identifies again at the grid's best point
  // until that is where it identified: the parabola's points then sit at
  // and half a period either side of it. The blocks' integrals of each
  // force tap, kForceLead ahead to the oldest, serve every lag (the rule is
  // linear in its taps, and a positive lag's delay of the motion is a lead
  // of the force): one pass over the blocks per identification.
  struct Point { double lag; LagCost c; };
  std::vector<Point> pts;
  HeldModel model;
  const bool own_friction = !(shared && shared->ok);  // this search identifies the friction it holds
  std::vector<BlockPair> pairs;
  bool each_identified = false;  // the fallback below: the core identifies at every lag
  auto eval = [&](double lag) {
    for (const Point& p : pts)
      if (std::fabs(p.lag - lag) < 1e-9) return p.c;
    const int lead = whole_delay_for(lag);
    feedid::ForcePairing<double> pairing;
    (void)pairing.init(lag - lead);  // in [-5, 0] for every lag searched
    if (each_identified) {
      pair_at(s, work, lag);
      ++e.evaluations;
      pts.push_back({lag, fit_cost(work, cfg)});
    } else {
      pts.push_back({lag, block_cost(at_pairing(pairs, pairing, lead), model.params)});
    }
    return pts.back().c;
  };
  auto best_point = [&]() {
    return *std::min_element(pts.begin(), pts.end(), [](const Point& a, const Point& b) { return a.c.ssr < b.c.ssr; });
  };
  auto scan_grid = [&]() {  // whole periods, then the half periods around the best
    pts.clear();
    for (double lag = kForceLagMin; lag <= kForceLagMax + 1e-9; lag += 1.0) eval(lag);
    const double coarse = best_point().lag;
    for (double d : {-0.5, 0.5})
      if (coarse + d >= kForceLagMin && coarse + d <= kForceLagMax) eval(coarse + d);
  };
  // First identified at a held command's lag, the commonest log (align_force's assumption).
  const double held = -0.5 - (std::isfinite(s.core_velocity_lag) ? s.core_velocity_lag : 0.0);
  double identified_at = std::clamp(std::round(2.0 * held) / 2.0, kForceLagMin, kForceLagMax);
  bool settled = false;
  auto observe_and_scan = [&]() {
    pair_at(s, work, 0.0);  // the motion as logged; a positive lag leads the force instead
    pairs = block_pairs(work, model.params, cfg.velocity_min_m_s, block_length_s(work));
    scan_grid();
  };
  if (shared && shared->ok) {
    // The friction another search settled on, on the same motion: F(v) is
    // the axis's, whichever velocity estimate observes it, and the lag
    // trades against the mass, which is refitted at every lag.
    model = *shared;
    observe_and_scan();
    settled = true;
    identified_at = best_point().lag;
  }
  for (int round = 0; round < 3 && !settled; ++round) {
    pair_at(s, work, identified_at);
    model = identify_model(work, cfg);
    ++e.evaluations;
    if (!model.ok) break;
    observe_and_scan();
    settled = std::fabs(best_point().lag - identified_at) < 1e-9;
    identified_at = best_point().lag;
  }
  // Where the held friction does not settle, or settles at an end of the
  // range, the model fits the log too poorly to be held (pooled 200 Hz
  // SysId logs went from +2 to -6 periods, and m to a twentieth): every lag
  // is identified on its own, as the search's measure asks.
  if (!settled || identified_at <= kForceLagMin + 1e-9 || identified_at >= kForceLagMax - 1e-9) {
    each_identified = true;
    scan_grid();
  }
  const double h = 0.5;
  // The lag and its error from the points scanned: the best where it lies
  // at an end of the range (the lag is at least that far out; the edge is
  // still a better pairing than a held command's, and the diagnosis names
  // what lies beyond the conventions a delay), else the vertex of the
  // parabola through it and its neighbours half a period away.
  auto from_points = [&]() {
    const Point best = best_point();
    if (!std::isfinite(best.c.ssr)) return;
    e.lag_samples = best.lag;
    if (best.lag - h < kForceLagMin - 1e-9 || best.lag + h > kForceLagMax + 1e-9) {
      e.se_samples = h;
      e.ok = true;
      return;
    }
    const LagCost lo = eval(best.lag - h), hi = eval(best.lag + h);
    const double at = vertex(best.lag, h, lo.ssr, best.c.ssr, hi.ssr);
    e.se_samples = vertex_se(best.lag, h, lo, best.c, hi);
    if (!std::isfinite(at)) return;
    e.lag_samples = at;
    e.ok = true;
  };
  from_points();
  if (each_identified || !std::isfinite(best_point().c.ssr)) return e;
  if (!own_friction) {
    e.absorbed_by_refit = shared->absorbed_by_refit;
    e.se_samples = std::max(e.se_samples, shared->refit_se_samples);
    return e;
  }
  // Whether the held friction chose its own lag (walk_by_refits). Where the
  // walk stays, the held parabola's vertex stands and its error is at least
  // the refits' (flatter where friction and mass absorb part of a shift);
  // where it moves, the refits give both. A walk that stops at an end of
  // the range still falling gives that end with error h, as above.
  const Point best = best_point();
  const LagCost lo = eval(best.lag - h), hi = eval(best.lag + h);  // the held parabola's, kept in pts
  const RefitWalk w = walk_by_refits(s, work, cfg, RefitPoint{best.lag, best.c, model}, e.evaluations);
  const double held_curv = curvature(h, lo, best.c, hi), refit_curv = curvature(h, w.lo.c, w.mid.c, w.hi.c);
  if (held_curv > 0.0 && std::isfinite(held_curv) && std::isfinite(refit_curv))
    e.absorbed_by_refit = std::clamp(1.0 - std::max(refit_curv, 0.0) / held_curv, 0.0, 1.0);
  if (e.absorbed_by_refit >= kLagRefitEveryLag) {
    // Friction absorbs so much of a shift that the held lag, and a walk
    // from it, can be a local least of the refits (a 1 Hz tone with the
    // force 4 periods behind: -0.27 periods, m 40 standard errors off):
    // every lag is identified on its own, as where the held friction does
    // not settle, and the friction handed on is identified at the lag found.
    each_identified = true;
    scan_grid();
    from_points();
    if (e.ok && shared && !shared->ok) {
      pair_at(s, work, std::round(2.0 * e.lag_samples) / 2.0);
      ++e.evaluations;
      model = identify_model(work, cfg);
      if (model.ok) {
        *shared = model;
        shared->absorbed_by_refit = e.absorbed_by_refit;
        shared->refit_se_samples = e.se_samples;
      }
    }
    return e;
  }
  const RefitPoint& least = w.lo.c.ssr < w.mid.c.ssr ? w.lo : w.hi.c.ssr < w.mid.c.ssr ? w.hi : w.mid;
  const bool at_end = &least != &w.mid;
  const double refit_se = at_end ? h : vertex_se(w.mid.lag, h, w.lo.c, w.mid.c, w.hi.c);
  double at = e.ok ? e.lag_samples : std::numeric_limits<double>::quiet_NaN();
  if (w.walked || at_end) {
    at = at_end ? least.lag : vertex(w.mid.lag, h, w.lo.c.ssr, w.mid.c.ssr, w.hi.c.ssr);
    e.se_samples = refit_se;
    model = least.model;
  } else {
    e.se_samples = std::max(e.se_samples, refit_se);
  }
  if (shared && !shared->ok && model.ok && std::isfinite(at)) {
    *shared = model;
    shared->absorbed_by_refit = e.absorbed_by_refit;
    shared->refit_se_samples = refit_se;
  }
  e.ok = std::isfinite(at);
  if (e.ok) e.lag_samples = at;
  return e;
}

double lowest_velocity_filter_hz(const Signals& s) {
  // Two octaves below the top cut-off of a slow log, or of the rate the
  // position really comes at: a position held for four rows is sampled at a
  // quarter of the log rate, and a cut-off smooth enough for that rate
  // would otherwise never be tried.
  return std::min(kLowestVelocityFilter_hz, 0.1 * s.position_update_rate_hz());
}

namespace {
/// Whether candidate c's block residual is within one standard error of
/// the best's: the difference's delete-one-chunk jackknife.
bool within_one_se(const LagCost& c, const LagCost& best) {
  const double d = c.ssr - best.ssr;
  std::vector<double> leave_out;
  for (std::size_t i = 0; i < c.chunk_ssr.size(); ++i)
    leave_out.push_back(d - (c.chunk_ssr[i] - best.chunk_ssr[i]));
  const double se = jackknife_se(leave_out);
  return std::isfinite(d) && std::isfinite(se) && d <= se;
}

/// The least block residual of the cut-offs tried (not empty).
const LagCost& least_of(const std::vector<std::pair<double, LagCost>>& tried) {
  return std::min_element(tried.begin(), tried.end(), [](const auto& a, const auto& b) {
           return a.second.ssr < b.second.ssr;
         })->second;
}
}  // namespace

FilterChoice choose_velocity_filter(Signals work, const feedid::Config<double>& cfg, bool keep_velocities) {
  FilterChoice best;
  best.cutoff_hz = work.velocity_filter_hz;
  // Octave halves from lowest_velocity_filter_hz to 0.4 of the rate (where the filter all but
  // passes the position difference through), lowest first.
  // Past the least residual, each half octave passes more of the count
  // noise into the bands, so the residual only grows: the scan stops when
  // two cut-offs in a row have risen, each beyond a standard error of the
  // least so far (neither can be chosen or a rival, nor can any above them).
  const double top = 0.4 * work.sample_rate_hz;
  std::vector<std::pair<double, LagCost>> tried;
  std::vector<std::vector<double>> held;  // each tried cut-off's velocity while it can still be chosen or a rival
  int risen = 0;
  for (double fc = lowest_velocity_filter_hz(work); fc <= top * (1.0 + 1e-9) && risen < 2; fc *= std::sqrt(2.0)) {
    derive_velocity(work, fc);
    const LagCost cost = fit_cost(work, cfg);
    const bool rose = !tried.empty() && cost.ssr > tried.back().second.ssr && !within_one_se(cost, least_of(tried));
    risen = rose ? risen + 1 : 0;
    tried.emplace_back(fc, cost);
    ++best.candidates;
    if (!keep_velocities) continue;
    held.push_back(work.v);
    const LagCost& least = least_of(tried);
    for (std::size_t i = 0; i < tried.size(); ++i)
      if (!held[i].empty() && !within_one_se(tried[i].second, least)) std::vector<double>().swap(held[i]);
  }
  if (tried.empty()) return best;
  const LagCost least = least_of(tried);
  if (!std::isfinite(least.ssr)) return best;  // nothing identifies: keep the cut-off as it is
  best.least_block_ssr = least.ssr;
  // The one-standard-error rule (Breiman et al.; Hastie et al., ESL 7.10):
  // of the cut-offs whose residual is within a standard error of the
  // least, the smoothest. The others stay as rivals for the standard errors.
  bool chosen = false;
  for (std::size_t i = 0; i < tried.size(); ++i) {
    const auto& [fc, cost] = tried[i];
    if (!within_one_se(cost, least)) continue;
    if (keep_velocities) best.velocities.push_back(std::move(held[i]));
    if (chosen) { best.rivals_hz.push_back(fc); continue; }
    best.cutoff_hz = fc;
    best.block_ssr = cost.ssr;
    chosen = true;
  }
  return best;
}

double block_fit_ssr(const Signals& s, const feedid::Config<double>& cfg) { return fit_cost(s, cfg).ssr; }

std::vector<char> scan_selection(const Signals& s) {
  const std::size_t n = s.t.size();
  if (n <= kScanSamplesMax) return std::vector<char>(n, 1);
  std::vector<char> keep(n, 0);
  // At most half the log, so that the holes between stretches are as long
  // as the stretches: gaps no filter or integral spans (select_samples).
  const std::size_t pieces = kJackknifeChunks, piece = std::min(kScanSamplesMax, n / 2) / pieces;
  for (std::size_t p = 0; p < pieces; ++p) {
    const std::size_t first = (n - piece) * p / (pieces - 1);  // the first at the start, the last at the end
    std::fill(keep.begin() + static_cast<std::ptrdiff_t>(first), keep.begin() + static_cast<std::ptrdiff_t>(first + piece), 1);
  }
  return keep;
}

}  // namespace feedid::host
