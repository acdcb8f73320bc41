// solve(): statistics -> parameters. Bounded work (bands x grid x iterations),
// no allocation, every output defined on every path.
// Context: task only (tens of thousands of flops), never in the servo ISR.
#pragma once

#include "feedid/small_matrix.hpp"
#include "feedid/statistics.hpp"
#include "feedid/thresholds.hpp"

namespace feedid {
namespace detail {

/// One direction's friction curve as band points: target Y_j = U_j - m*dv_j
/// (force integral with the residual inertia removed) against time, speed
/// and second moment of the band. What does not depend on vs is formed
/// once here, not in each of the ~100 fits of a search: the band's squared
/// mean speed and speed variance (the Stribeck integral's moments), and the
/// (Fc, sigma) block of the normal equations with its right-hand side.
template <typename T, int Bands> struct FrictionPoints {
  T time[Bands] = {}, speed[Bands] = {}, speed2[Bands] = {}, target[Bands] = {};
  T mean2[Bands] = {}, var[Bands] = {};  ///< (speed/time)^2, max(0, speed2/time - mean2)
  SymMatrix<T, 3> a_cv{};  ///< sum w phi_r phi_c for r, c in {Fc, sigma}; w = 1/time
  Vector<T, 3> b_cv{};     ///< sum w phi_r target for r in {Fc, sigma}
  int count = 0;
  T total_time = T(0);
  BorderedFactor<T, 3> cv{};  ///< a_cv's (Fc, sigma) block factorised, for `factored_count` points
  int factored_count = -1;
};

/// The fit tolerance of the normal equations' pivots in T.
template <typename T> constexpr T fit_pivot_tolerance() { return T(sizeof(T) == 4 ? 1e-5 : 1e-10); }

/// Factorises the points' (Fc, sigma) block once for all fits of a search.
template <typename T, int Bands> void factor_friction_points(FrictionPoints<T, Bands>& p) {
  p.cv = bordered_factor(p.a_cv, p.b_cv, fit_pivot_tolerance<T>());
  p.factored_count = p.count;
}

/// The rules that turn a standard error into "not identifiable"; the host
/// applies the same ones after it widens a standard error (jackknife).
template <typename T> uint32_t stribeck_uncertainty_flags(const DirectionEstimate<T>& e) {
  constexpr T q = T(thresholds::kFrictionRelativeSe);
  const bool uncertain = !(e.breakaway_N > T(0)) || e.breakaway_se > q * e.breakaway_N ||
                         e.stribeck_velocity_se > q * e.stribeck_velocity_m_s;
  return uncertain ? static_cast<uint32_t>(flag_stribeck_uncertain) : 0u;
}
/// A friction term is resolved when its standard error is within a quarter
/// of it (thresholds::kFrictionRelativeSe); a NaN is not.
template <typename T> bool friction_term_uncertain(T value, T se) {
  return !(se <= T(thresholds::kFrictionRelativeSe) * port::abs(value));
}
template <typename T> uint32_t coulomb_uncertainty_flags(const DirectionEstimate<T>& e) {
  return friction_term_uncertain(e.coulomb_N, e.coulomb_se) ? static_cast<uint32_t>(flag_coulomb_uncertain) : 0u;
}
template <typename T> uint32_t viscous_uncertainty_flags(const DirectionEstimate<T>& e) {
  return friction_term_uncertain(e.viscous_Ns_m, e.viscous_se) ? static_cast<uint32_t>(flag_viscous_uncertain) : 0u;
}
template <typename T> uint32_t mass_uncertainty_flags(T mass, T mass_se) {
  return mass_se > T(thresholds::kMassRelativeSe) * port::abs(mass) ? static_cast<uint32_t>(flag_no_acceleration) : 0u;
}

/// Bands with less time than this (s) carry too few samples to count as a point.
template <typename T> constexpr T min_band_time_s() { return T(thresholds::kMinBandTime_s); }

/// Appends one band point (its time, integrals of speed and speed^2, and
/// the friction impulse it must explain) with the moments every fit reuses.
/// False when the points are full.
template <typename T, int Bands>
bool add_friction_point(FrictionPoints<T, Bands>& p, T t, T speed, T speed2, T target) {
  if (p.count >= Bands) return false;
  const int k = p.count++;
  p.time[k] = t;
  p.speed[k] = speed;
  p.speed2[k] = speed2;
  p.target[k] = target;
  p.total_time += t;
  // The operations of exp_integral_moments(), so that a fit gives the same
  // integrals to the bit.
  const T mean = speed / t;
  p.mean2[k] = mean * mean;
  p.var[k] = port::max(T(0), speed2 / t - mean * mean);
  const T phi[2] = {t, speed};
  const T w = T(1) / t;
  for (int r = 0; r < 2; ++r) {
    p.b_cv.v[r] += w * phi[r] * target;
    for (int c = 0; c < 2; ++c) p.a_cv.a[r][c] += w * phi[r] * phi[c];
  }
  return true;
}

template <typename T, int Bands, int C>
FrictionPoints<T, Bands> friction_points(const Statistics<T, Bands, C>& s, int d, T mass) {
  FrictionPoints<T, Bands> p;
  for (int j = 0; j < Bands; ++j) {
    const BandSums<T>& b = s.band[d][j];
    const T t = b.time_s.get();
    if (!(t >= min_band_time_s<T>())) continue;
    (void)add_friction_point(p, t, b.speed.get(), b.speed2.get(), b.force.get() - mass * b.dvel.get());
  }
  factor_friction_points(p);
  return p;
}

/// Weighted residual (N^2 s) of the band points against theta = {Fc, sigma,
/// Fs}, e[k] the band's integral of the Stribeck shape.
template <typename T, int Bands>
T friction_ssr(const FrictionPoints<T, Bands>& p, const Vector<T, 3>& theta, const T* e) {
  T ssr = T(0);
  for (int k = 0; k < p.count; ++k) {
    const T r = p.target[k] - theta.v[0] * p.time[k] - theta.v[1] * p.speed[k] - theta.v[2] * e[k];
    ssr += r * r / p.time[k];
  }
  return ssr;
}

/// The (Fc, sigma) corner of the friction normal equations a, b solved
/// alone: theta = {Fc, sigma, 0}. False if singular.
template <typename T>
bool solve_coulomb_viscous(const SymMatrix<T, 3>& a, const Vector<T, 3>& b, T tol, Vector<T, 3>& theta,
                           Vector<T, 3>* inv_diag) {
  SymMatrix<T, 2> a2;
  Vector<T, 2> b2, x2, d2;
  for (int r = 0; r < 2; ++r) {
    b2.v[r] = b.v[r];
    for (int c = 0; c < 2; ++c) a2.a[r][c] = a.a[r][c];
  }
  if (!solve_normal_equations(a2, b2, tol, x2, inv_diag ? &d2 : nullptr)) return false;
  theta.v[0] = x2.v[0];
  theta.v[1] = x2.v[1];
  theta.v[2] = T(0);
  if (inv_diag) { inv_diag->v[0] = d2.v[0]; inv_diag->v[1] = d2.v[1]; inv_diag->v[2] = T(0); }
  return true;
}

/// Weighted least squares of  Y_j = Fc T_j + sigma V_j + Fs E_j(vs)  with
/// weights 1/T_j (the noise of a band integral grows with its time).
/// theta = {Fc, sigma, Fs}. Fs is fitted only where the data can carry it:
/// the exponential must reach at least two bands (otherwise it just fits one
/// band's point exactly) and Fs must come out >= 0 (a negative break-away is
/// not physical); else Fs = 0 and the curve is fitted with Fc and sigma
/// (active set). Returns false if even that is singular.
template <typename T, int Bands>
bool fit_friction_at(const FrictionPoints<T, Bands>& p, T vs, Vector<T, 3>& theta, T& ssr,
                     Vector<T, 3>* inv_diag = nullptr, bool* stribeck_active = nullptr) {
  // Only the Stribeck column depends on vs: the (Fc, sigma) block is p's.
  SymMatrix<T, 3> a = p.a_cv;
  Vector<T, 3> b = p.b_cv;
  T e[Bands];
  T sum_e = T(0), sum_e2 = T(0);
  const T inv_vs2 = T(1) / (vs * vs);
  for (int k = 0; k < p.count; ++k) {
    e[k] = exp_integral_mean_var(p.time[k], p.mean2[k], p.var[k], inv_vs2);
    const T share = e[k] / p.time[k];  // mean of exp(-(v/vs)^2) in the band, 0..1
    sum_e += share;
    sum_e2 += share * share;
    const T w = T(1) / p.time[k];
    const T we = w * e[k];
    a.a[0][2] += we * p.time[k];
    a.a[1][2] += we * p.speed[k];
    a.a[2][2] += we * e[k];
    b.v[2] += we * p.target[k];
  }
  a.a[2][0] = a.a[0][2];
  a.a[2][1] = a.a[1][2];
  const T tol = fit_pivot_tolerance<T>();
  // Effective number of bands the exponential reaches: (sum s)^2 / sum s^2.
  const bool spread = sum_e2 > T(0) && sum_e * sum_e >= T(2) * sum_e2;
  bool active;
  if (inv_diag || p.factored_count != p.count) {
    active = spread && solve_normal_equations(a, b, tol, theta, inv_diag) && theta.v[2] >= T(0);
    if (!active && !solve_coulomb_viscous(a, b, tol, theta, inv_diag)) return false;
  } else {  // a search's fit: the (Fc, sigma) block's factor is the points' (bordered_solve)
    active = spread && bordered_solve(p.cv, a, b, tol, theta) && theta.v[2] >= T(0);
    if (!active) {
      if (!p.cv.ok) return false;
      theta = p.cv.x_lead;
    }
  }
  if (stribeck_active) *stribeck_active = active;
  ssr = friction_ssr(p, theta, e);
  return port::is_finite(ssr);
}

/// Coulomb + viscous alone (no Stribeck dip): the alternative a model
/// selection weighs the Stribeck law against. Same weights as fit_friction_at.
template <typename T, int Bands>
bool fit_coulomb_viscous_at(const FrictionPoints<T, Bands>& p, Vector<T, 3>& theta, T& ssr,
                            Vector<T, 3>* inv_diag = nullptr) {
  T e[Bands];
  for (int k = 0; k < p.count; ++k) e[k] = T(0);
  if (!solve_coulomb_viscous(p.a_cv, p.b_cv, fit_pivot_tolerance<T>(), theta, inv_diag)) return false;
  ssr = friction_ssr(p, theta, e);
  return port::is_finite(ssr);
}

/// Coulomb + viscous with sigma kept to its physical range. A fit with a
/// positive level and a negative slope says friction falls across every
/// speed logged: the data end inside a Stribeck fall, and the slope is that
/// fall, not a viscous rise. sigma is then held at its bound 0 (the bounded
/// least-squares optimum: Fc the time-weighted mean friction) and the
/// direction flagged flag_friction_still_falling: neither sigma nor the
/// level the fall settles to is in the data. A negative level (a force of
/// the wrong sign) is left as fitted, for the not-physical rule to name.
/// Returns the flag bits it sets; theta and ssr become the bounded fit's.
template <typename T, int Bands>
uint32_t hold_falling_friction(const FrictionPoints<T, Bands>& p, Vector<T, 3>& theta, T& ssr) {
  if (!(theta.v[0] > T(0) && theta.v[1] < T(0)) || !(p.total_time > T(0))) return 0u;
  T force = T(0);
  for (int k = 0; k < p.count; ++k) force += p.target[k];
  theta.v[0] = force / p.total_time;
  theta.v[1] = T(0);
  theta.v[2] = T(0);
  T e[Bands];
  for (int k = 0; k < p.count; ++k) e[k] = T(0);
  ssr = friction_ssr(p, theta, e);
  return static_cast<uint32_t>(flag_friction_still_falling);
}

constexpr int kStribeckGridPoints = thresholds::kStribeckGridPoints;
/// The width in log(vs) at which the bracketing stops and a parabola finishes.
template <typename T> constexpr T stribeck_bracket_tolerance() { return T(2e-3); }

/// The band fit's residual at log(vs) = l (1e30 if the fit fails).
template <typename T, int Bands> T stribeck_cost(const FrictionPoints<T, Bands>& p, T l) {
  Vector<T, 3> th;
  T ssr;
  return fit_friction_at(p, port::exp(l), th, ssr) ? ssr : T(1e30);
}

/// The minimum of the residual in the bracket [a, b] of log(vs): golden
/// section down to stribeck_bracket_tolerance() (at most max_iter steps),
/// then the vertex of a parabola through the bracket: unlike the last golden
/// comparisons (between nearly equal costs, decided by rounding), the vertex
/// moves continuously with the data.
template <typename T, int Bands>
void stribeck_in_bracket(const FrictionPoints<T, Bands>& p, T a, T b, int max_iter, T& log_vs, T& best_ssr) {
  auto eval = [&](T l) { return stribeck_cost(p, l); };
  constexpr T golden = T(0.6180339887498949);
  T x1 = b - golden * (b - a), x2 = a + golden * (b - a);
  T f1 = eval(x1), f2 = eval(x2);
  for (int i = 0; i < max_iter && (b - a) > stribeck_bracket_tolerance<T>(); ++i) {
    if (f1 < f2) { b = x2; x2 = x1; f2 = f1; x1 = b - golden * (b - a); f1 = eval(x1); }
    else { a = x1; x1 = x2; f1 = f2; x2 = a + golden * (b - a); f2 = eval(x2); }
  }
  const T h = T(0.5) * (b - a), mid = T(0.5) * (a + b);
  const T fa = eval(a), fm = eval(mid), fb = eval(b);
  const T curv = fa - T(2) * fm + fb;
  log_vs = curv > T(0) ? port::clamp(mid - T(0.5) * h * (fb - fa) / curv, a, b) : mid;
  best_ssr = eval(log_vs);
}

/// Stribeck velocity search on log(vs): a coarse grid (robust to the local
/// minima of a flat cost) then golden-section refinement in the best grid
/// cell, at most max_iter steps. Returns the best log(vs) and its cost.
/// With `coarse`, the grid alone: the vertex of the parabola through the
/// best grid point and its neighbours, a start for refine_stribeck().
template <typename T, int Bands>
bool search_stribeck(const FrictionPoints<T, Bands>& p, T vs_lo, T vs_hi, int max_iter,
                     T& log_vs, T& best_ssr, bool& at_bound, bool coarse = false) {
  constexpr int grid = kStribeckGridPoints;
  const T l0 = port::log(vs_lo), l1 = port::log(vs_hi);
  const T step = (l1 - l0) / T(grid - 1);
  Vector<T, 3> th;
  T cost[grid];
  int best = -1;
  for (int g = 0; g < grid; ++g) {
    T ssr;
    cost[g] = fit_friction_at(p, port::exp(l0 + step * T(g)), th, ssr) ? ssr : T(-1);
    if (cost[g] >= T(0) && (best < 0 || cost[g] < cost[best])) best = g;
  }
  if (best < 0) return false;
  const T a = l0 + step * T(best > 0 ? best - 1 : 0);
  const T b = l0 + step * T(best < grid - 1 ? best + 1 : grid - 1);
  if (coarse) {
    log_vs = l0 + step * T(best);
    best_ssr = cost[best];
    if (best > 0 && best < grid - 1 && cost[best - 1] >= T(0) && cost[best + 1] >= T(0)) {
      const T curv = cost[best - 1] - T(2) * cost[best] + cost[best + 1];
      if (curv > T(0)) log_vs = port::clamp(log_vs - T(0.5) * step * (cost[best + 1] - cost[best - 1]) / curv, a, b);
    }
  } else {
    stribeck_in_bracket(p, a, b, max_iter, log_vs, best_ssr);
  }
  if (cost[best] < best_ssr) { log_vs = l0 + step * T(best); best_ssr = cost[best]; }
  const T margin = T(0.02) * step;
  at_bound = (log_vs - l0) < margin + step * T(0.5) && best == 0 ? true
           : (l1 - log_vs) < margin + step * T(0.5) && best == grid - 1;
  return true;
}

/// Stribeck velocity near a previous optimum log_vs, after a change of the
/// band targets (the next round of the mass/friction alternation): from
/// log_vs -+ h (h at most half a grid step), either step downhill by h (the centre
/// is not the lowest) or move to the vertex of the parabola through the
/// three costs and shrink h 8x; at h of half the final bracket width the
/// vertex is the result, as search_stribeck() finishes. About 3 fits per
/// level instead of a grid and a golden section. False when the walk leaves
/// the range less half a grid step at either end (search_stribeck() would
/// flag such an optimum) or takes more than kStribeckRefineMoves moves (from
/// half a grid step down to the final width takes 4 shrinks; the rest allows
/// a few steps downhill): the caller then searches on the grid. The bound
/// keeps the worst case of solve() near that of a full search every round.
constexpr int kStribeckRefineMoves = 8;
template <typename T, int Bands>
bool refine_stribeck(const FrictionPoints<T, Bands>& p, T vs_lo, T vs_hi, T h, T& log_vs, T& best_ssr) {
  const T l0 = port::log(vs_lo), l1 = port::log(vs_hi);
  const T step = (l1 - l0) / T(kStribeckGridPoints - 1);
  const T final_h = T(0.5) * stribeck_bracket_tolerance<T>();
  auto inside = [&](T l) { return l - l0 >= T(0.5) * step && l1 - l >= T(0.5) * step; };
  T x = log_vs;
  h = port::clamp(h, final_h, T(0.5) * step);
  T fm = stribeck_cost(p, x);
  for (int i = 0; i < kStribeckRefineMoves; ++i) {
    if (!inside(x - h) || !inside(x + h)) return false;
    const T fa = stribeck_cost(p, x - h), fb = stribeck_cost(p, x + h);
    if (!(fm < T(1e30))) return false;
    if (fa < fm || fb < fm) { x += fa < fb ? -h : h; fm = port::min(fa, fb); continue; }
    const T curv = fa - T(2) * fm + fb;
    const T vertex = curv > T(0) ? port::clamp(x - T(0.5) * h * (fb - fa) / curv, x - h, x + h) : x;
    if (h > final_h) { x = vertex; fm = stribeck_cost(p, x); h = port::max(final_h, h / T(8)); continue; }
    log_vs = vertex;
    best_ssr = stribeck_cost(p, vertex);
    if (fm < best_ssr) { log_vs = x; best_ssr = fm; }
    return true;
  }
  return false;
}

/// Whether the data shows the Stribeck bend at all: some time below vs, and
/// bands within a factor 3 of vs on both sides of it. Data only far below
/// (creep at stroke ends) and far above (cruise) fits some vs with a small
/// Jacobian standard error and still says nothing about the curve between.
template <typename T, int Bands, int C>
uint32_t stribeck_coverage_flags(const Statistics<T, Bands, C>& s, int d, T vs) {
  T slow_time = T(0);
  int slow_bands = 0, below = 0, above = 0;
  for (int j = 0; j < Bands; ++j) {
    const T t = s.band[d][j].time_s.get();
    if (!(t >= min_band_time_s<T>())) continue;
    const T mean = s.band[d][j].speed.get() / t;
    if (mean < vs) { slow_time += t; ++slow_bands; }
    if (mean >= vs / T(3) && mean < vs) ++below;
    if (mean >= vs && mean <= T(3) * vs) ++above;
  }
  const bool covered = slow_bands >= thresholds::kStribeckSlowBands && slow_time >= T(thresholds::kStribeckSlowTime_s) && below >= 1 && above >= 1 && below + above >= 3;
  return covered ? 0u : static_cast<uint32_t>(flag_no_low_speed_data);
}

/// What the data can and cannot say about a direction's friction fit with
/// Stribeck velocity vs, by either method: below the speed the data resolves,
/// uncertain, not covered by bands near vs, or not physical.
template <typename T, int Bands, int C>
uint32_t friction_evidence_flags(const Statistics<T, Bands, C>& s, const Config<T>& cfg, int d,
                                 const DirectionEstimate<T>& e, T vs) {
  uint32_t f = 0;
  const T floor_v = port::max(T(thresholds::kStribeckFloorResolutions) * cfg.velocity_resolution_m_s,
                              T(thresholds::kStribeckFloorOfVelocityMin) * cfg.velocity_min_m_s);
  if (vs < floor_v) f |= flag_stribeck_below_resolution;
  f |= stribeck_uncertainty_flags(e);
  f |= coulomb_uncertainty_flags(e);
  f |= viscous_uncertainty_flags(e);
  f |= stribeck_coverage_flags(s, d, vs);
  if (e.coulomb_N < T(0) || e.viscous_Ns_m < T(0)) f |= flag_not_physical;
  return f;
}

/// The mass's flags from its value and standard error (either method).
template <typename T> uint32_t mass_evidence_flags(T mass, T mass_se) {
  return mass_uncertainty_flags(mass, mass_se) | (mass > T(0) ? 0u : static_cast<uint32_t>(flag_not_physical));
}

/// Force noise (N) from the second differences of the interval forces: the
/// variance of a second difference of white noise is 6 sigma^2.
template <typename T, int Bands, int C> T force_noise_variance(const Statistics<T, Bands, C>& s) {
  return s.noise_count > 0 ? s.noise_d2.get() / (T(6) * T(s.noise_count)) : T(0);
}

template <typename T> struct DirectionFit {
  DirectionEstimate<T> est{};
  T ssr = T(0);      ///< weighted residual (N^2 s)
  int dof = 0;
  bool usable = false;  ///< friction known well enough to enter the mass equation
  bool at_bound = false;  ///< the Stribeck search ended at its range's end
  T log_vs = T(0);      ///< where the search ended (usable only)
  T next_h = T(1e30);   ///< half-width for the next round's refine_stribeck(): twice this round's move
};

/// Friction of one direction at a given mass: search vs (near the previous
/// round's optimum `near` when there is one inside the range; else the grid
/// alone in a round whose fit only feeds the mass equation (!with_errors),
/// and fully in the published one), fit, then, if `with_errors`,
/// standard errors from the Gauss-Newton Jacobian
/// (T, V, E, Fs dE/dvs) at the optimum, R^2 and the evidence flags.
template <typename T, int Bands, int C>
DirectionFit<T> fit_direction(const Statistics<T, Bands, C>& s, const Config<T>& cfg, int d,
                              T mass, T vs_lo, T vs_hi, const DirectionFit<T>* near = nullptr,
                              bool with_errors = true) {
  DirectionFit<T> out;
  DirectionEstimate<T>& e = out.est;
  const FrictionPoints<T, Bands> p = friction_points(s, d, mass);
  e.bands_used = static_cast<uint32_t>(p.count);
  e.time_in_bands_s = p.total_time;
  e.sections = s.dir[d].sections;
  if (p.count < 5) { e.flags |= flag_no_data; return out; }

  T log_vs = near && near->usable && !near->at_bound ? near->log_vs : T(0), ssr = T(0);
  bool at_bound = false;
  const bool refined = near && near->usable && !near->at_bound && refine_stribeck(p, vs_lo, vs_hi, near->next_h, log_vs, ssr);
  const bool coarse = !with_errors;
  if (!refined && !search_stribeck(p, vs_lo, vs_hi, cfg.max_vs_iterations, log_vs, ssr, at_bound, coarse)) {
    e.flags |= flag_fit_failed;
    return out;
  }
  out.at_bound = at_bound;
  out.log_vs = log_vs;
  // After the grid alone the optimum is known to a grid step; after a
  // refinement the next round's move is of the order of this one's.
  if (refined) out.next_h = T(2) * port::abs(log_vs - near->log_vs);
  const T vs = port::exp(log_vs);
  Vector<T, 3> th;
  bool stribeck_active = false;
  if (!fit_friction_at(p, vs, th, ssr, static_cast<Vector<T, 3>*>(nullptr), &stribeck_active)) { e.flags |= flag_fit_failed; return out; }
  e.coulomb_N = th.v[0];
  e.viscous_Ns_m = th.v[1];
  e.breakaway_N = th.v[2];
  e.stribeck_velocity_m_s = vs;
  out.ssr = ssr;
  out.dof = p.count - 4;
  out.usable = true;
  if (!with_errors) return out;

  // Jacobian w.r.t. (Fc, sigma, Fs, vs); dE/dvs by a central difference in vs.
  const T h = T(sizeof(T) == 4 ? 1e-2 : 1e-4);
  SymMatrix<T, 4> jtj;
  T r2_num = T(0), mean_f = T(0);
  for (int k = 0; k < p.count; ++k) mean_f += p.target[k];
  mean_f /= p.total_time;
  T r2_den = T(0);
  for (int k = 0; k < p.count; ++k) {
    const T ep = exp_integral_moments(p.time[k], p.speed[k], p.speed2[k], vs * (T(1) + h));
    const T em = exp_integral_moments(p.time[k], p.speed[k], p.speed2[k], vs * (T(1) - h));
    const T e0 = exp_integral_moments(p.time[k], p.speed[k], p.speed2[k], vs);
    const T j[4] = {p.time[k], p.speed[k], e0, e.breakaway_N * (ep - em) / (T(2) * h * vs)};
    const T w = T(1) / p.time[k];
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) jtj.a[r][c] += w * j[r] * j[c];
    // Band-mean friction against the model, time weighted (the paper's R^2).
    const T fit = (th.v[0] * p.time[k] + th.v[1] * p.speed[k] + th.v[2] * e0) / p.time[k];
    const T meas = p.target[k] / p.time[k];
    r2_num += p.time[k] * (meas - fit) * (meas - fit);
    r2_den += p.time[k] * (meas - mean_f) * (meas - mean_f);
  }
  e.friction_rms_N = port::sqrt(r2_num / p.total_time);
  e.friction_r2 = r2_den > T(0) ? T(1) - r2_num / r2_den : T(0);

  const T s2 = out.dof > 0 ? ssr / T(out.dof) : T(0);
  SymMatrix<T, 4> fac = jtj;
  Vector<T, 4> zero, dummy, inv_diag;
  if (stribeck_active &&
      solve_normal_equations(fac, zero, T(sizeof(T) == 4 ? 1e-7 : 1e-14), dummy, &inv_diag)) {
    e.coulomb_se = port::sqrt(s2 * inv_diag.v[0]);
    e.viscous_se = port::sqrt(s2 * inv_diag.v[1]);
    e.breakaway_se = port::sqrt(s2 * inv_diag.v[2]);
    e.stribeck_velocity_se = port::sqrt(s2 * inv_diag.v[3]);
  } else {
    // vs has no effect on the fit (Fs ~ 0 or no data near vs): unknowable.
    // Standard errors of what was fitted; Fs and vs get no confident figure.
    Vector<T, 3> th3, inv3;
    T ssr3;
    if (fit_friction_at(p, vs, th3, ssr3, &inv3)) {
      e.coulomb_se = port::sqrt(s2 * inv3.v[0]);
      e.viscous_se = port::sqrt(s2 * inv3.v[1]);
      // This fit's own decision on the Stribeck column decides too: the
      // search's bordered solve and this full one can round apart where
      // multiply-adds are fused (the M4), and a column this one dropped has
      // no variance (0 would read as certain).
      e.breakaway_se = stribeck_active && inv3.v[2] > T(0) ? port::sqrt(s2 * inv3.v[2])
                                                           : port::max(e.coulomb_se, T(0)) * T(1e3);
    }
    e.stribeck_velocity_se = vs * T(1e3);
  }

  if (at_bound) e.flags |= flag_stribeck_at_search_bound;
  e.flags |= friction_evidence_flags(s, cfg, d, e, vs);
  return out;
}

/// Differentiation-free mass: over each window w,
///   integral_w u' dt = m dv'_w + integral_w F dt,
/// projected on dv'_w and summed over windows and directions:
///   m = [sum_w dv'_w U_w - sum_w dv'_w F_w] / sum_w dv'_w^2,
/// where sum_w dv'_w F_w comes from the dv'-weighted band moments.
template <typename T, int Bands, int C>
bool mass_equation(const Statistics<T, Bands, C>& s, const BandLayout<T, Bands>& layout,
                   const DirectionFit<T> fit[2], T& mass, T& numerator_out, T& dv2_out,
                   T& tau_dv2_out) {
  T num = T(0), den = T(0), tau_dv2 = T(0);
  for (int d = 0; d < 2; ++d) {
    if (!fit[d].usable) continue;
    const DirectionEstimate<T>& e = fit[d].est;
    T friction_proj = T(0);
    for (int j = 0; j < Bands; ++j) {
      const BandSums<T>& b = s.band[d][j];
      const T pt = b.proj_time.get(), pv = b.proj_speed.get(), pw = b.proj_speed2.get();
      friction_proj += e.coulomb_N * pt + e.viscous_Ns_m * pv;
      if (e.breakaway_N != T(0))
        friction_proj += e.breakaway_N * exp_integral_about(layout.center(j), pt, pv, pw, e.stribeck_velocity_m_s);
    }
    num += s.dir[d].win_dv_force.get() - friction_proj;
    den += s.dir[d].win_dv2.get();
    tau_dv2 += s.dir[d].win_tau_dv2.get();
  }
  numerator_out = num;
  dv2_out = den;
  tau_dv2_out = tau_dv2;
  if (!(den > T(0))) return false;
  mass = num / den;
  return port::is_finite(mass);
}

template <typename T> T stribeck_lo(const Config<T>& c) {
  return c.stribeck_min_m_s > T(0) ? c.stribeck_min_m_s : T(thresholds::kStribeckLowOfVelocityMin) * c.velocity_min_m_s;
}
template <typename T> T stribeck_hi(const Config<T>& c) {
  return c.stribeck_max_m_s > T(0) ? c.stribeck_max_m_s : T(thresholds::kStribeckHighOfVelocityMax) * c.velocity_max_m_s;
}
/// Candidate i of `count` Stribeck velocities, log-spaced over the search range.
template <typename T> T stribeck_candidate(const Config<T>& c, int i, int count) {
  const T lo = stribeck_lo(c), hi = stribeck_hi(c);
  return lo * port::exp(port::log(hi / lo) * T(i) / T(count - 1));
}

/// A first friction for the first mass: Coulomb and viscous alone, at m = 0
/// (two fits of the (Fc, sigma) block, no vs search). A Stribeck search at
/// m = 0 placed vs far from where the next round found it (the residual
/// inertia is in every band's target), so its grid was thrown away.
template <typename T, int Bands, int C>
DirectionFit<T> fit_first_friction(const Statistics<T, Bands, C>& s, int d) {
  DirectionFit<T> out;
  const FrictionPoints<T, Bands> p = friction_points(s, d, T(0));
  Vector<T, 3> th;
  T ssr;
  if (p.count < 5 || !fit_coulomb_viscous_at(p, th, ssr)) return out;
  out.est.coulomb_N = th.v[0];
  out.est.viscous_Ns_m = th.v[1];
  out.usable = true;
  return out;
}

template <typename T, int Bands, int C>
Status solve_bands(const Statistics<T, Bands, C>& s, const BandLayout<T, Bands>& layout,
                   const Config<T>& cfg, Estimate<T>& out) {
  const T lo = stribeck_lo(cfg), hi = stribeck_hi(cfg);
  DirectionFit<T> fit[2];
  T mass = T(0), num = T(0), dv2 = T(0), tau_dv2 = T(0);
  // Friction needs m only for the small residual-inertia correction, and m
  // needs friction; alternate. The coupling is weak (sum of dv per band is
  // near zero), so a few rounds converge to working precision. The first
  // mass comes from Coulomb and viscous friction alone; the first search
  // round puts vs on the grid at that mass, later rounds refine near the
  // previous optimum, and only the last one (the published fit) computes
  // standard errors and flags.
  for (int d = 0; d < 2; ++d) fit[d] = fit_first_friction(s, d);
  T m_new;
  bool mass_ok = mass_equation(s, layout, fit, m_new, num, dv2, tau_dv2);
  if (mass_ok) mass = m_new;
  constexpr int rounds = 3;
  for (int it = 0; it < rounds; ++it) {
    const T m_fit = mass_ok ? mass : T(0);
    const bool last = it == rounds - 1;
    for (int d = 0; d < 2; ++d) fit[d] = fit_direction(s, cfg, d, m_fit, lo, hi, it > 0 ? &fit[d] : nullptr, last);
    mass_ok = mass_equation(s, layout, fit, m_new, num, dv2, tau_dv2);
    if (!mass_ok) {  // no further round: this one's fit is published
      if (!last) for (int d = 0; d < 2; ++d) fit[d] = fit_direction(s, cfg, d, m_fit, lo, hi, &fit[d], true);
      break;
    }
    mass = m_new;
  }
  out.pos = fit[0].est;
  out.neg = fit[1].est;
  out.mass_kg = mass_ok ? mass : T(0);
  out.mass_flags = 0;

  // Residual variance per unit time (N^2 s): the larger of the band-fit
  // residual and the white force noise, so the standard error is never
  // optimistic when the model misfits.
  T ssr = T(0);
  int dof = 0;
  for (int d = 0; d < 2; ++d) if (fit[d].usable) { ssr += fit[d].ssr; dof += fit[d].dof; }
  const T mean_dt = s.interval_count > 0 ? s.total_interval_time.get() / T(s.interval_count) : T(0);
  const T noise_var = force_noise_variance(s);
  out.force_noise_N = port::sqrt(noise_var);
  const T var_time = port::max(dof > 0 ? ssr / T(dof) : T(0), noise_var * mean_dt);
  if (!mass_ok) {
    out.mass_flags |= flag_no_acceleration;
  } else {
    out.mass_se_kg = port::sqrt(var_time * tau_dv2) / dv2;
    // Inertia visible only if the velocity change explains far more than noise.
    out.mass_flags |= mass_evidence_flags(mass, out.mass_se_kg);
  }
  if (!fit[0].usable && !fit[1].usable) return Status::insufficient_data;
  return Status::ok;
}

/// The seed paper's regression, literally: per complete section s,
///   mass:     Y_s = integral u a dt = m X_s,  X_s = integral a^2 dt  (line through origin)
///   friction: U_s = Fc T_s + sigma V_s + Fs E_s(vs)  (least squares over sections)
/// with vs picked from the fixed candidate bank and refined by a parabola
/// through the best candidate and its neighbours.
template <typename T, int Bands, int C>
Status solve_paper(const Statistics<T, Bands, C>& s, const Config<T>& cfg, Estimate<T>& out) {
  T xy = T(0), xx = T(0), yy = T(0);
  uint32_t nsec = 0;
  for (int d = 0; d < 2; ++d) {
    xy += s.dir[d].sec_xy.get();
    xx += s.dir[d].sec_xx.get();
    yy += s.dir[d].sec_yy.get();
    nsec += s.dir[d].sections;
  }
  out.mass_flags = 0;
  if (xx > T(0) && nsec >= 2) {
    out.mass_kg = xy / xx;
    const T res = port::max(T(0), yy - out.mass_kg * xy);
    out.mass_se_kg = port::sqrt(res / T(nsec - 1) / xx);
    out.mass_flags |= mass_evidence_flags(out.mass_kg, out.mass_se_kg);
  } else {
    out.mass_flags |= flag_no_acceleration;
  }

  for (int d = 0; d < 2; ++d) {
    const DirectionSums<T, C>& ds = s.dir[d];
    DirectionEstimate<T>& e = d == 0 ? out.pos : out.neg;
    e = DirectionEstimate<T>{};
    e.sections = ds.sections;
    for (int j = 0; j < Bands; ++j) e.time_in_bands_s += s.band[d][j].time_s.get();
    if (ds.sections < 4) { e.flags |= flag_no_data; continue; }
    // Normal equations at candidate i (sums interpolated between candidates
    // when t is fractional).
    auto normal = [&](int i, T frac, SymMatrix<T, 3>& a, Vector<T, 3>& b) {
      const int i1 = i + 1 < C ? i + 1 : i;
      auto lerp = [&](const Sum<T>* arr) { return arr[i].get() + frac * (arr[i1].get() - arr[i].get()); };
      a.a[0][0] = ds.sec_tt.get(); a.a[0][1] = a.a[1][0] = ds.sec_tv.get(); a.a[1][1] = ds.sec_vv.get();
      a.a[0][2] = a.a[2][0] = lerp(ds.cand_et);
      a.a[1][2] = a.a[2][1] = lerp(ds.cand_ev);
      a.a[2][2] = lerp(ds.cand_ee);
      b.v[0] = ds.sec_tu.get(); b.v[1] = ds.sec_vu.get(); b.v[2] = lerp(ds.cand_eu);
    };
    auto cost = [&](int i, T frac, Vector<T, 3>& th, Vector<T, 3>* inv) {
      SymMatrix<T, 3> a; Vector<T, 3> b;
      normal(i, frac, a, b);
      if (!solve_normal_equations(a, b, T(sizeof(T) == 4 ? 1e-6 : 1e-12), th, inv)) return T(-1);
      return port::max(T(0), ds.sec_uu.get() - (th.v[0] * b.v[0] + th.v[1] * b.v[1] + th.v[2] * b.v[2]));
    };
    T c[C];
    int best = -1;
    Vector<T, 3> th;
    for (int i = 0; i < C; ++i) {
      c[i] = cost(i, T(0), th, nullptr);
      if (c[i] >= T(0) && (best < 0 || c[i] < c[best])) best = i;
    }
    if (best < 0) { e.flags |= flag_fit_failed; continue; }
    // Parabola through (best-1, best, best+1) in log vs: one bounded update.
    const T lstep = port::log(s.vs_candidate[C > 1 ? 1 : 0] / s.vs_candidate[0]);
    T offset = T(0), curvature = T(0);
    if (best > 0 && best < C - 1 && c[best - 1] >= T(0) && c[best + 1] >= T(0)) {
      const T den = c[best - 1] - T(2) * c[best] + c[best + 1];
      if (den > T(0)) {
        offset = port::clamp(T(0.5) * (c[best - 1] - c[best + 1]) / den, T(-0.5), T(0.5));
        curvature = den / (lstep * lstep);
      }
    } else {
      e.flags |= flag_stribeck_at_search_bound;
    }
    const int base = offset < T(0) ? best - 1 : best;
    const T frac = offset < T(0) ? T(1) + offset : offset;
    Vector<T, 3> inv;
    T ssr = cost(base, frac, th, &inv);
    if (ssr < T(0)) {  // the interpolated sums are singular: stay on the best candidate
      offset = T(0);
      curvature = T(0);
      ssr = cost(best, T(0), th, &inv);
    }
    if (ssr < T(0)) { e.flags |= flag_fit_failed; continue; }  // never standard errors of 0 from a failed solve
    const T vs = s.vs_candidate[best] * port::exp(offset * lstep);
    e.coulomb_N = th.v[0];
    e.viscous_Ns_m = th.v[1];
    e.breakaway_N = th.v[2];
    e.stribeck_velocity_m_s = vs;
    const T s2 = ssr / T(ds.sections - 3);
    e.coulomb_se = port::sqrt(s2 * inv.v[0]);
    e.viscous_se = port::sqrt(s2 * inv.v[1]);
    e.breakaway_se = port::sqrt(s2 * inv.v[2]);
    e.stribeck_velocity_se = curvature > T(0) ? vs * port::sqrt(T(2) * s2 / curvature) : vs * T(1e3);
    e.flags |= friction_evidence_flags(s, cfg, d, e, vs);
    // R^2 of section means: 1 - SSR / total sum of squares about the mean force.
    e.friction_r2 = ds.sec_uu.get() > T(0) ? T(1) - ssr / ds.sec_uu.get() : T(0);
  }
  out.force_noise_N = port::sqrt(force_noise_variance(s));
  if (out.pos.flags & flag_no_data && out.neg.flags & flag_no_data) return Status::insufficient_data;
  return Status::ok;
}

}  // namespace detail
}  // namespace feedid
