// Baseline identifiers for the benchmark: see baselines.hpp.
#include "baselines.hpp"

#include <algorithm>
#include <stdexcept>
#include <optional>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include <Eigen/Core>
#include <unsupported/Eigen/NonLinearOptimization>

#include "signals/filters.hpp"
#include "identify/identify.hpp"

namespace feedid::host {

const char* const kParamNames[9] = {"m", "sigma+", "Fc+", "Fs+", "vs+", "sigma-", "Fc-", "Fs-", "vs-"};

ParamVector param_vector(const DriveParams& p) {
  return {p.mass_kg,
          p.pos.viscous_Ns_m, p.pos.coulomb_N, p.pos.breakaway_N, p.pos.stribeck_velocity_m_s,
          p.neg.viscous_Ns_m, p.neg.coulomb_N, p.neg.breakaway_N, p.neg.stribeck_velocity_m_s};
}

double max_rel_error(const DriveParams& estimate, const DriveParams& truth, int* worst) {
  const ParamVector e = param_vector(estimate), t = param_vector(truth);
  double w = 0.0;
  int wi = 0;
  for (int i = 0; i < 9; ++i) {
    const double r = t[i] != 0.0 ? std::fabs(e[i] / t[i] - 1.0) : std::fabs(e[i]);
    const double rr = std::isfinite(r) ? r : std::numeric_limits<double>::infinity();
    if (rr > w || i == 0) { w = rr; wi = i; }
  }
  if (worst) *worst = wi;
  return w;
}

double friction_curve_r2(const DriveParams& estimate, const DriveParams& truth, double v_lo, double v_hi) {
  constexpr int n = 200;
  double r2_min = 1.0;
  for (int d = 0; d < 2; ++d) {
    const double sign = d == 0 ? 1.0 : -1.0;
    double mean = 0.0;
    std::vector<double> ft(n), fe(n);
    for (int i = 0; i < n; ++i) {
      const double v = sign * v_lo * std::pow(v_hi / v_lo, static_cast<double>(i) / (n - 1));
      ft[static_cast<std::size_t>(i)] = stribeck_friction(truth, v);
      fe[static_cast<std::size_t>(i)] = stribeck_friction(estimate, v);
      mean += ft[static_cast<std::size_t>(i)] / n;
    }
    double ss_res = 0.0, ss_tot = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      ss_res += (ft[i] - fe[i]) * (ft[i] - fe[i]);
      ss_tot += (ft[i] - mean) * (ft[i] - mean);
    }
    const double r2 = ss_tot > 0.0 ? 1.0 - ss_res / ss_tot : 0.0;
    r2_min = std::min(r2_min, std::isfinite(r2) ? r2 : -std::numeric_limits<double>::infinity());
  }
  return r2_min;
}

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// Signals and the core's velocity range for a trace (shared by all baselines).
struct Prepared {
  Signals s;
  double v_min = 0.0, v_max = 0.0, max_gap = 0.0, stribeck_lo = 0.0, stribeck_hi = 0.0;
};

Prepared prepare(const Trace& trace, const BaselineOptions& opt) {
  Prepared p;
  const IdentifyOptions io = bench_identify_options(trace, opt.stated_conventions);
  p.s = simulated_signals(trace, io);
  const feedid::Config<double> c = auto_config(p.s, io);
  p.v_min = opt.velocity_min_m_s > 0 ? opt.velocity_min_m_s : c.velocity_min_m_s;
  p.v_max = c.velocity_max_m_s;
  p.max_gap = c.max_gap_s;
  p.stribeck_lo = feedid::analysis::stribeck_lo(c);
  p.stribeck_hi = feedid::analysis::stribeck_hi(c);
  return p;
}

RegressionRows rows_from(const Prepared& p, const BaselineOptions& opt) {
  RegressionRows r;
  const Signals& s = p.s;
  const std::size_t n = s.t.size();
  r.velocity_min_m_s = p.v_min;
  r.velocity_max_m_s = p.v_max;
  r.stribeck_lo_m_s = p.stribeck_lo;
  r.stribeck_hi_m_s = p.stribeck_hi;
  r.sample_rate_hz = s.sample_rate_hz;
  std::vector<double> vf, uf;
  if (opt.filter_hz > 0 && n > 16) {
    r.filter_hz = applied_cutoff_hz(opt.filter_hz, s.sample_rate_hz);
    vf = filtfilt_butter4(s.v, r.filter_hz, s.sample_rate_hz);
    uf = filtfilt_butter4(s.u, r.filter_hz, s.sample_rate_hz);
  } else {
    vf = s.v;
    uf = s.u;
  }
  std::vector<double> nv, na, nu;  // negative rows, appended after the positive ones
  const feedid::ForcePairing<double> pairing = s.pairing();
  for (std::size_t k = 1; k < n; ++k) {
    const double dt = s.t[k] - s.t[k - 1];
    if (!(dt > 0.0) || dt > p.max_gap) continue;
    const double v0 = vf[k - 1], v1 = vf[k];
    const double vm = 0.5 * (v0 + v1);
    if (std::fabs(vm) < p.v_min || v0 * v1 <= 0.0) continue;
    const double a = (v1 - v0) / dt;
    const double u = paired_force(uf, pairing, k, s.stretch_start(k));
    if (vm > 0) { r.v.push_back(vm); r.a.push_back(a); r.u.push_back(u); }
    else { nv.push_back(vm); na.push_back(a); nu.push_back(u); }
  }
  r.n_pos = r.v.size();
  r.v.insert(r.v.end(), nv.begin(), nv.end());
  r.a.insert(r.a.end(), na.begin(), na.end());
  r.u.insert(r.u.end(), nu.begin(), nu.end());
  return r;
}

// ---------------------------------------------------------------------------
// The model on the rows. Internal parameter vector for the optimisers:
//   x = {m, Fc+, sigma+, Fs+, ln vs+, Fc-, sigma-, Fs-, ln vs-}
// (vs in logarithm: positive by construction, and the cost is closer to
// quadratic in ln vs than in vs).
// ---------------------------------------------------------------------------
using X = std::array<double, 9>;

X to_x(const DriveParams& p) {
  return {p.mass_kg, p.pos.coulomb_N, p.pos.viscous_Ns_m, p.pos.breakaway_N, std::log(p.pos.stribeck_velocity_m_s),
          p.neg.coulomb_N, p.neg.viscous_Ns_m, p.neg.breakaway_N, std::log(p.neg.stribeck_velocity_m_s)};
}
template <typename V> DriveParams from_x(const V& x) {
  DriveParams p;
  p.mass_kg = x[0];
  p.pos = DirectionFriction{x[2], x[1], x[3], std::exp(x[4])};
  p.neg = DirectionFriction{x[6], x[5], x[7], std::exp(x[8])};
  return p;
}

/// Sum of squared equation errors over all rows:
///   r = u - m a - s (Fc + Fs exp(-(v/vs)^2)) - sigma v,  s = sign(v).
/// Rows are split by direction so each loop is branch-free.
template <typename V> double cost(const RegressionRows& r, const V& x) {
  double sum = 0.0;
  const std::size_t n = r.v.size();
  for (int d = 0; d < 2; ++d) {
    const double s = d == 0 ? 1.0 : -1.0;
    const int o = d == 0 ? 1 : 5;
    const double fc = s * x[o], sigma = x[o + 1], fs = s * x[o + 2];
    const double inv_vs2 = std::exp(-2.0 * x[o + 3]);
    const double m = x[0];
    const std::size_t k0 = d == 0 ? 0 : r.n_pos, k1 = d == 0 ? r.n_pos : n;
    for (std::size_t k = k0; k < k1; ++k) {
      const double v = r.v[k];
      const double e = std::exp(-v * v * inv_vs2);
      const double res = r.u[k] - m * r.a[k] - fc - fs * e - sigma * v;
      sum += res * res;
    }
  }
  return sum;
}

/// Least squares by normal equations with Cholesky (small dense systems).
template <int N> bool solve_ls(std::array<std::array<double, N>, N> a, std::array<double, N> b, std::array<double, N>& x) {
  for (int i = 0; i < N; ++i) {
    const double energy = a[i][i];
    for (int k = 0; k < i; ++k) a[i][i] -= a[i][k] * a[i][k];
    // Numerically singular too: less than 1e-10 of the column's energy left
    // beside the earlier columns (a speed constant to rounding, one per direction).
    if (!(a[i][i] > 1e-10 * energy) || !(a[i][i] > 1e-300)) return false;
    a[i][i] = std::sqrt(a[i][i]);
    for (int j = i + 1; j < N; ++j) {
      for (int k = 0; k < i; ++k) a[j][i] -= a[j][k] * a[i][k];
      a[j][i] /= a[i][i];
    }
  }
  for (int i = 0; i < N; ++i) {
    for (int k = 0; k < i; ++k) b[i] -= a[i][k] * b[k];
    b[i] /= a[i][i];
  }
  for (int i = N - 1; i >= 0; --i) {
    for (int k = i + 1; k < N; ++k) b[i] -= a[k][i] * b[k];
    b[i] /= a[i][i];
  }
  x = b;
  return std::isfinite(x[0]);
}

}  // namespace

IdentifyOptions bench_identify_options(const Trace& trace, bool stated) {
  IdentifyOptions io;
  const std::size_t n = trace.samples.size();
  if (!stated || n < 2) return io;
  const double rate_hz = static_cast<double>(n - 1) / (trace.samples.back().t_s - trace.samples.front().t_s);
  io.velocity_filter_hz = 0.4 / std::sqrt(2.0) * rate_hz;
  io.alignment = "held-backward";
  return io;
}

Signals simulated_signals(const Trace& trace, const IdentifyOptions& io) {
  Signals s = prepare_signals(trace, io);
  if (!s.error.empty()) throw std::logic_error("bench: a simulated trace did not condition: " + s.error);
  return s;
}

RegressionRows regression_rows(const Trace& trace, const BaselineOptions& opt) {
  return rows_from(prepare(trace, opt), opt);
}

namespace {

/// Linear least squares without the Stribeck term:
///   u = m a + Fc+ s+ + sigma+ v s+ - Fc- s- + sigma- v s-,  s+- the direction indicators;
/// nullopt when the rows do not separate them (one speed per direction, or no acceleration).
std::optional<DriveParams> fit_without_stribeck(const RegressionRows& r) {
  constexpr int N = 5;
  std::array<std::array<double, N>, N> ata{};
  std::array<double, N> atb{}, th{};
  const std::size_t n = r.v.size();
  for (std::size_t k = 0; k < n; ++k) {
    const bool pos = k < r.n_pos;
    const double phi[N] = {r.a[k], pos ? 1.0 : 0.0, pos ? r.v[k] : 0.0, pos ? 0.0 : -1.0, pos ? 0.0 : r.v[k]};
    for (int i = 0; i < N; ++i) {
      atb[i] += phi[i] * r.u[k];
      for (int j = 0; j < N; ++j) ata[i][j] += phi[i] * phi[j];
    }
  }
  DriveParams p;
  if (!solve_ls<N>(ata, atb, th)) return std::nullopt;
  p.mass_kg = th[0];
  p.pos.coulomb_N = th[1];
  p.pos.viscous_Ns_m = th[2];
  p.neg.coulomb_N = th[3];
  p.neg.viscous_Ns_m = th[4];
  return p;
}

}  // namespace

DriveParams linear_start(const RegressionRows& r) {
  DriveParams p = fit_without_stribeck(r).value();  // rows_for() refused rows without a solution
  const std::size_t n = r.v.size();
  // Stribeck part from the low-speed residual, per direction: mean residual
  // in 16 log-spaced speed bands; Fs = its largest value above the
  // high-speed level, vs = speed where it falls to 1/e of that.
  constexpr int B = 16;
  const double lo = r.velocity_min_m_s, hi = std::max(r.velocity_max_m_s, 4.0 * lo);
  for (int d = 0; d < 2; ++d) {
    DirectionFriction& f = d == 0 ? p.pos : p.neg;
    const double s = d == 0 ? 1.0 : -1.0;
    double sum[B] = {}, cnt[B] = {}, spd[B] = {};
    const std::size_t k0 = d == 0 ? 0 : r.n_pos, k1 = d == 0 ? r.n_pos : n;
    for (std::size_t k = k0; k < k1; ++k) {
      const double v = std::fabs(r.v[k]);
      const int b = std::clamp(static_cast<int>(B * std::log(v / lo) / std::log(hi / lo)), 0, B - 1);
      sum[b] += s * (r.u[k] - p.mass_kg * r.a[k]) - f.coulomb_N - f.viscous_Ns_m * v;
      spd[b] += v;
      cnt[b] += 1.0;
    }
    std::vector<double> upper;
    for (int b = B / 2; b < B; ++b) if (cnt[b] > 0) upper.push_back(sum[b] / cnt[b]);
    double level = 0.0;
    if (!upper.empty()) {
      std::nth_element(upper.begin(), upper.begin() + static_cast<std::ptrdiff_t>(upper.size() / 2), upper.end());
      level = upper[upper.size() / 2];
    }
    // The Stribeck excess is a low-speed effect: look for its peak in the
    // lower half of the bands only (noise in the fast bands is not a dip).
    int peak = -1;
    double peak_val = 0.0;
    for (int b = 0; b < B / 2; ++b)
      if (cnt[b] >= 10 && (peak < 0 || sum[b] / cnt[b] - level > peak_val)) { peak = b; peak_val = sum[b] / cnt[b] - level; }
    f.coulomb_N += level;
    f.breakaway_N = std::max(peak_val, 0.1 * std::fabs(f.coulomb_N));
    double vs = lo * std::pow(hi / lo, 0.25);  // no clear dip: a quarter of the way up the (log) range
    for (int b = std::max(peak, 0); b < B && peak >= 0; ++b)
      if (cnt[b] >= 10 && sum[b] / cnt[b] - level < peak_val / M_E) { vs = spd[b] / cnt[b]; break; }
    f.stribeck_velocity_m_s = vs;
  }
  return p;
}

DriveParams naive_start(const RegressionRows& r) {
  DriveParams p = fit_without_stribeck(r).value();  // rows_for() refused rows without a solution
  std::vector<double> speed(r.v.size());
  for (std::size_t k = 0; k < r.v.size(); ++k) speed[k] = std::fabs(r.v[k]);
  double med = std::sqrt(r.velocity_min_m_s * r.velocity_max_m_s);
  if (!speed.empty()) {
    std::nth_element(speed.begin(), speed.begin() + static_cast<std::ptrdiff_t>(speed.size() / 2), speed.end());
    med = speed[speed.size() / 2];
  }
  for (DirectionFriction* f : {&p.pos, &p.neg}) {
    f->breakaway_N = 0.2 * std::fabs(f->coulomb_N);
    f->stribeck_velocity_m_s = med;
  }
  return p;
}

// ---------------------------------------------------------------------------
// batch_lm
// ---------------------------------------------------------------------------
namespace {

/// Eigen functor: residual f_k = m a_k + F(v_k) - u_k and, for the
/// row-by-row (MINPACK lmstr) variant, one Jacobian row at a time.
struct LmFunctor {
  using Scalar = double;
  using InputType = Eigen::VectorXd;
  using ValueType = Eigen::VectorXd;
  const RegressionRows& r;
  long evaluations = 0;
  int inputs() const { return 9; }
  int values() const { return static_cast<int>(r.v.size()); }

  int operator()(const Eigen::VectorXd& x, Eigen::VectorXd& f) {
    ++evaluations;
    const std::size_t n = r.v.size();
    for (int d = 0; d < 2; ++d) {
      const double s = d == 0 ? 1.0 : -1.0;
      const int o = d == 0 ? 1 : 5;
      const double fc = s * x[o], sigma = x[o + 1], fs = s * x[o + 2], inv_vs2 = std::exp(-2.0 * x[o + 3]);
      const std::size_t k0 = d == 0 ? 0 : r.n_pos, k1 = d == 0 ? r.n_pos : n;
      for (std::size_t k = k0; k < k1; ++k) {
        const double v = r.v[k];
        f[static_cast<Eigen::Index>(k)] = x[0] * r.a[k] + fc + fs * std::exp(-v * v * inv_vs2) + sigma * v - r.u[k];
      }
    }
    return 0;
  }

  /// Row rownb-2 of the Jacobian (MINPACK numbering starts at 2 here).
  int df(const Eigen::VectorXd& x, Eigen::VectorXd& row, Eigen::Index rownb) {
    const std::size_t k = static_cast<std::size_t>(rownb - 2);
    const bool pos = k < r.n_pos;
    const double s = pos ? 1.0 : -1.0;
    const int o = pos ? 1 : 5;
    const double v = r.v[k];
    const double q = v * v * std::exp(-2.0 * x[o + 3]);  // (v/vs)^2
    const double e = std::exp(-q);
    row.setZero();
    row[0] = r.a[k];
    row[o] = s;                        // d/dFc
    row[o + 1] = v;                    // d/dsigma
    row[o + 2] = s * e;                // d/dFs
    row[o + 3] = s * x[o + 2] * e * 2.0 * q;  // d/d(ln vs)
    return 0;
  }
};

const char* lm_status_text(Eigen::LevenbergMarquardtSpace::Status st) {
  using namespace Eigen::LevenbergMarquardtSpace;
  switch (st) {
    case ImproperInputParameters: return "improper input parameters";
    case RelativeReductionTooSmall: return "converged: relative reduction of the cost below ftol";
    case RelativeErrorTooSmall: return "converged: relative step below xtol";
    case RelativeErrorAndReductionTooSmall: return "converged: step and reduction below tolerance";
    case CosinusTooSmall: return "converged: gradient orthogonal to residual";
    case TooManyFunctionEvaluation: return "stopped: evaluation budget (maxfev) exhausted";
    case FtolTooSmall: return "stopped: ftol too small, no further reduction possible";
    case XtolTooSmall: return "stopped: xtol too small, no further improvement possible";
    case GtolTooSmall: return "stopped: gtol too small";
    case UserAsked: return "stopped by the functor";
    default: return "not started";
  }
}

/// The moving samples as regression rows; false (with out's status set)
/// when either direction has too few to identify anything.
bool rows_for(const Trace& trace, const BaselineOptions& opt, const char* method,
              Clock::time_point t0, BaselineResult& out, RegressionRows& r) {
  out.method = method;
  r = regression_rows(trace, opt);
  out.rows = r.v.size();
  if (out.rows < 20 || r.n_pos < 5 || out.rows - r.n_pos < 5) {
    out.status = "too few moving samples in one direction";
    out.seconds = since(t0);
    return false;
  }
  if (!fit_without_stribeck(r)) {  // it used to start from all-ones parameters instead
    out.status = "no start: the linear fit of m, Fc+-, sigma+- is singular on this trace";
    out.seconds = since(t0);
    return false;
  }
  return true;
}

}  // namespace

BaselineResult batch_lm(const Trace& trace, const BaselineOptions& opt) {
  const auto t0 = Clock::now();
  BaselineResult out;
  RegressionRows r;
  if (!rows_for(trace, opt, "batch_lm", t0, out, r)) return out;
  out.start = opt.lm_naive_start ? naive_start(r) : linear_start(r);
  const X x0 = to_x(out.start);
  Eigen::VectorXd x(9);
  for (int i = 0; i < 9; ++i) x[i] = x0[static_cast<std::size_t>(i)];
  LmFunctor f{r};
  Eigen::LevenbergMarquardt<LmFunctor> lm(f);
  lm.parameters.maxfev = opt.lm_max_evaluations;
  lm.parameters.ftol = opt.lm_tolerance;
  lm.parameters.xtol = opt.lm_tolerance;
  Eigen::LevenbergMarquardtSpace::Status st = lm.minimizeOptimumStorageInit(x);
  if (st != Eigen::LevenbergMarquardtSpace::ImproperInputParameters) {
    do {
      st = lm.minimizeOptimumStorageOneStep(x);
      ++out.iterations;
      if (opt.progress) opt.progress(std::min(0.99, static_cast<double>(lm.nfev) / opt.lm_max_evaluations));
    } while (st == Eigen::LevenbergMarquardtSpace::Running);
  }
  out.status = lm_status_text(st);
  out.converged = st == Eigen::LevenbergMarquardtSpace::RelativeReductionTooSmall ||
                  st == Eigen::LevenbergMarquardtSpace::RelativeErrorTooSmall ||
                  st == Eigen::LevenbergMarquardtSpace::RelativeErrorAndReductionTooSmall ||
                  st == Eigen::LevenbergMarquardtSpace::CosinusTooSmall ||
                  st == Eigen::LevenbergMarquardtSpace::XtolTooSmall ||
                  st == Eigen::LevenbergMarquardtSpace::FtolTooSmall;
  out.params = from_x(x);
  out.ok = std::isfinite(x.sum());
  // MINPACK's tests only say the cost stopped improving. A minimum with a
  // negative magnitude or a Stribeck velocity outside [v_min/10, v_max]
  // (the exponential then is 0 or 1 on every sample, Fs merges with Fc) is
  // a degenerate point, not a converged fit.
  if (out.converged) {
    const ParamVector pv = param_vector(out.params);
    bool physical = true;
    for (double v : pv) physical = physical && std::isfinite(v) && v > 0.0;
    for (double vs : {pv[4], pv[8]})
      physical = physical && vs >= 0.1 * r.velocity_min_m_s && vs <= r.velocity_max_m_s;
    if (!physical) {
      out.converged = false;
      out.status = std::string("degenerate minimum (") + out.status + ", but a magnitude <= 0 or vs outside [v_min/10, v_max])";
    }
  }
  out.evaluations = f.evaluations + lm.njev;  // residual passes + Jacobian passes
  out.rms_residual_N = std::sqrt(cost(r, x) / static_cast<double>(out.rows));
  // rows (v, a, u) + residual vector + 9x9 R and a few 9-vectors.
  out.working_bytes = out.rows * 4 * sizeof(double) + 9 * 16 * sizeof(double);
  out.seconds = since(t0);
  if (opt.progress) opt.progress(1.0);
  return out;
}

// ---------------------------------------------------------------------------
// ga: differential evolution, DE/rand/1/bin
// ---------------------------------------------------------------------------
BaselineResult genetic_algorithm(const Trace& trace, const BaselineOptions& opt) {
  const auto t0 = Clock::now();
  BaselineResult out;
  RegressionRows r;
  if (!rows_for(trace, opt, "ga", t0, out, r)) return out;
  // Search box around the linear start (a practitioner's "order of magnitude"
  // box): m, sigma in [0.5, 2] x start; Fc, Fs in [0, 2 |Fc start| + 1 N];
  // ln vs over the core's Stribeck search range (analysis::stribeck_lo/hi).
  out.start = linear_start(r);
  const X c = to_x(out.start);
  X lo{}, hi{};
  lo[0] = 0.5 * std::fabs(c[0]); hi[0] = 2.0 * std::fabs(c[0]) + 1e-3;
  const double vlo = std::log(r.stribeck_lo_m_s), vhi = std::log(r.stribeck_hi_m_s);
  for (int o : {1, 5}) {
    const double fc = std::fabs(c[static_cast<std::size_t>(o)]) ;
    lo[o] = 0.0; hi[o] = 2.0 * fc + 1.0;
    lo[o + 1] = 0.5 * std::fabs(c[o + 1]); hi[o + 1] = 2.0 * std::fabs(c[o + 1]) + 1e-3;
    lo[o + 2] = 0.0; hi[o + 2] = 2.0 * fc + 1.0;
    lo[o + 3] = vlo; hi[o + 3] = vhi;
  }
  const int np = std::max(opt.ga_population, 5);
  const int gens = std::max(opt.ga_generations, 0);
  std::mt19937_64 rng(opt.ga_seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::vector<X> pop(static_cast<std::size_t>(np));
  std::vector<double> fit(static_cast<std::size_t>(np));
  for (auto& ind : pop)
    for (int i = 0; i < 9; ++i) ind[i] = lo[i] + uni(rng) * (hi[i] - lo[i]);
  pop[0] = c;  // the start is one member, as a seeded GA would have it
  for (int i = 0; i < 9; ++i) pop[0][i] = std::clamp(pop[0][i], lo[i], hi[i]);
  for (int j = 0; j < np; ++j) fit[static_cast<std::size_t>(j)] = cost(r, pop[static_cast<std::size_t>(j)]);
  out.evaluations = np;
  constexpr double F = 0.6, CR = 0.9;
  std::uniform_int_distribution<int> pick(0, np - 1), dim(0, 8);
  for (int g = 0; g < gens; ++g) {
    for (int j = 0; j < np; ++j) {
      int a, b, cc;
      do a = pick(rng); while (a == j);
      do b = pick(rng); while (b == j || b == a);
      do cc = pick(rng); while (cc == j || cc == a || cc == b);
      const X& xa = pop[static_cast<std::size_t>(a)];
      const X& xb = pop[static_cast<std::size_t>(b)];
      const X& xc = pop[static_cast<std::size_t>(cc)];
      X trial = pop[static_cast<std::size_t>(j)];
      const int forced = dim(rng);
      for (int i = 0; i < 9; ++i) {
        if (i != forced && uni(rng) >= CR) continue;
        double y = xa[i] + F * (xb[i] - xc[i]);
        // Out of the box: a random point between the parent and the bound.
        if (y < lo[i]) y = lo[i] + uni(rng) * (pop[static_cast<std::size_t>(j)][i] - lo[i]);
        if (y > hi[i]) y = hi[i] - uni(rng) * (hi[i] - pop[static_cast<std::size_t>(j)][i]);
        trial[i] = y;
      }
      const double ft = cost(r, trial);
      ++out.evaluations;
      if (ft <= fit[static_cast<std::size_t>(j)]) { pop[static_cast<std::size_t>(j)] = trial; fit[static_cast<std::size_t>(j)] = ft; }
    }
    ++out.iterations;
    if (opt.progress) opt.progress(static_cast<double>(g + 1) / gens);
  }
  const auto best = static_cast<std::size_t>(std::min_element(fit.begin(), fit.end()) - fit.begin());
  const double worst = *std::max_element(fit.begin(), fit.end());
  out.params = from_x(pop[best]);
  out.ok = std::isfinite(fit[best]);
  out.rms_residual_N = std::sqrt(fit[best] / static_cast<double>(out.rows));
  // Converged: the whole population within 1e-6 of the best cost.
  out.converged = worst - fit[best] <= 1e-6 * fit[best];
  char buf[160];
  std::snprintf(buf, sizeof buf, "%s after %d generations x %d members (%ld cost evaluations); population cost spread %.2g",
                out.converged ? "converged" : "budget exhausted", gens, np, out.evaluations,
                fit[best] > 0 ? (worst - fit[best]) / fit[best] : 0.0);
  out.status = buf;
  out.working_bytes = out.rows * 3 * sizeof(double) + static_cast<std::size_t>(np) * (sizeof(X) + sizeof(double));
  out.seconds = since(t0);
  return out;
}

// ---------------------------------------------------------------------------
// rls: parallel RLS filters with forgetting, one per candidate vs.
// ---------------------------------------------------------------------------
namespace {

/// One RLS filter on theta = {m, Fc+, sigma+, Fs+, Fc-, sigma-, Fs-} with
/// the Stribeck velocity fixed at vs (both directions), regressor
///   phi+ = {a, 1, v, e(v)},  phi- = {a, -1, v, -e(v)} in the direction's slots.
/// Memory: theta (7) + P (7x7) + 2 error sums.
struct RlsFilter {
  static constexpr int N = 7;
  double theta[N] = {};
  double P[N][N] = {};
  double inv_vs2 = 0.0;
  double err[2] = {0.0, 0.0};  ///< forgotten sums of squared a-priori errors, per direction (N^2)

  void init(double vs, double p0) {
    inv_vs2 = 1.0 / (vs * vs);
    for (int i = 0; i < N; ++i) P[i][i] = p0;
  }

  // Update with one interval; lambda the forgetting factor. The regressor
  // has 4 non-zeros (a and the direction's three), so P phi costs 7x4.
  void update(double a, double v, double u, double lambda, bool count_error) {
    const int d = v > 0 ? 0 : 1;
    const int o = d == 0 ? 1 : 4;
    const double s = d == 0 ? 1.0 : -1.0;
    const double e = std::exp(-v * v * inv_vs2);
    const int idx[4] = {0, o, o + 1, o + 2};
    const double ph[4] = {a, s, v, s * e};
    // a-priori error
    double yhat = 0.0;
    for (int q = 0; q < 4; ++q) yhat += theta[idx[q]] * ph[q];
    const double eps = u - yhat;
    if (count_error) { err[d] += eps * eps; }
    // Pphi = P phi, denominator lambda + phi' P phi
    double pp[N];
    for (int i = 0; i < N; ++i) {
      double acc = 0.0;
      for (int q = 0; q < 4; ++q) acc += P[i][idx[q]] * ph[q];
      pp[i] = acc;
    }
    double den = lambda;
    for (int q = 0; q < 4; ++q) den += ph[q] * pp[idx[q]];
    const double inv = 1.0 / den;
    for (int i = 0; i < N; ++i) theta[i] += pp[i] * inv * eps;
    const double il = 1.0 / lambda;
    for (int i = 0; i < N; ++i)
      for (int j = i; j < N; ++j) {
        const double pij = (P[i][j] - pp[i] * pp[j] * inv) * il;
        P[i][j] = pij;
        P[j][i] = pij;
      }
  }
};

/// Every filter of the bank over the trace's sliding samples (one
/// direction's velocity, within the gap limit): forgotten a-priori errors
/// counted after a warm-up of the first 10 % of the samples, when every
/// filter has left its P0 transient. Returns the samples used.
std::size_t run_rls_bank(const Prepared& p, const BaselineOptions& opt, double lambda, std::vector<RlsFilter>& f) {
  const Signals& s = p.s;
  const std::size_t n = s.t.size(), warmup = n / 10;
  const feedid::ForcePairing<double> pairing = s.pairing();
  const std::size_t report_every = std::max<std::size_t>(n / 50, 1);
  std::size_t rows = 0;
  for (std::size_t k = 1; k < n; ++k) {
    const double dt = s.t[k] - s.t[k - 1];
    if (!(dt > 0.0) || dt > p.max_gap) continue;
    const double vm = 0.5 * (s.v[k - 1] + s.v[k]);
    if (std::fabs(vm) < p.v_min || s.v[k - 1] * s.v[k] <= 0.0) continue;
    const double a = (s.v[k] - s.v[k - 1]) / dt;
    const double u = paired_force(s.u, pairing, k, s.stretch_start(k));
    const bool count = k >= warmup;
    for (auto& filt : f) {
      if (count) { filt.err[0] *= lambda; filt.err[1] *= lambda; }
      filt.update(a, vm, u, lambda, count);
    }
    ++rows;
    if (opt.progress && k % report_every == 0) opt.progress(static_cast<double>(k) / static_cast<double>(n));
  }
  return rows;
}

/// Direction d's friction from the bank: the best filter by forgotten
/// a-priori error, refined by a parabola through it and its neighbours in
/// ln vs, the friction interpolated linearly between the two nearest
/// filters. at_edge: the best filter is at the end of the grid.
DirectionFriction rls_direction(const std::vector<RlsFilter>& f, int d, double l0, double lstep, bool& at_edge) {
  const int K = static_cast<int>(f.size());
  auto err = [&](int i) { return f[static_cast<std::size_t>(i)].err[d]; };
  int b = 0;
  for (int i = 1; i < K; ++i) if (err(i) < err(b)) b = i;
  double off = 0.0;
  if (b > 0 && b < K - 1) {
    const double cm = err(b - 1), c0 = err(b), cp = err(b + 1);
    const double den = cm - 2.0 * c0 + cp;
    if (den > 0) off = std::clamp(0.5 * (cm - cp) / den, -0.5, 0.5);
  } else {
    at_edge = true;
  }
  const int nb = off < 0 ? b - 1 : b + 1;
  const double w = std::fabs(off);
  const RlsFilter& A = f[static_cast<std::size_t>(b)];
  const RlsFilter& B = f[static_cast<std::size_t>(std::clamp(nb, 0, K - 1))];
  const int o = d == 0 ? 1 : 4;
  auto mix = [&](int i) { return (1.0 - w) * A.theta[i] + w * B.theta[i]; };
  DirectionFriction df;
  df.coulomb_N = mix(o);
  df.viscous_Ns_m = mix(o + 1);
  df.breakaway_N = mix(o + 2);
  df.stribeck_velocity_m_s = std::exp(l0 + lstep * (b + off));
  return df;
}

}  // namespace

BaselineResult recursive_least_squares(const Trace& trace, const BaselineOptions& opt) {
  const auto t0 = Clock::now();
  BaselineResult out;
  out.method = "rls";
  const Prepared p = prepare(trace, opt);
  const int K = std::max(opt.rls_filters, 3);
  std::vector<RlsFilter> f(static_cast<std::size_t>(K));
  const double l0 = std::log(p.stribeck_lo), l1 = std::log(p.stribeck_hi);
  const double lstep = (l1 - l0) / (K - 1);
  for (int i = 0; i < K; ++i) f[static_cast<std::size_t>(i)].init(std::exp(l0 + lstep * i), opt.rls_initial_covariance);
  const double dt_nom = p.s.period_s();
  const double lambda = std::clamp(1.0 - dt_nom / opt.rls_memory_s, 0.5, 1.0);
  out.rows = run_rls_bank(p, opt, lambda, f);
  out.iterations = static_cast<long>(out.rows);
  out.evaluations = 1;
  // The mass from the filter best over both directions.
  int best_total = 0;
  for (int i = 1; i < K; ++i)
    if (f[static_cast<std::size_t>(i)].err[0] + f[static_cast<std::size_t>(i)].err[1] <
        f[static_cast<std::size_t>(best_total)].err[0] + f[static_cast<std::size_t>(best_total)].err[1])
      best_total = i;
  bool at_edge = false;
  DriveParams est;
  est.pos = rls_direction(f, 0, l0, lstep, at_edge);
  est.neg = rls_direction(f, 1, l0, lstep, at_edge);
  est.mass_kg = f[static_cast<std::size_t>(best_total)].theta[0];
  out.params = est;
  out.ok = out.rows > 20 && std::isfinite(est.mass_kg);
  out.converged = !at_edge;
  char buf[200];
  std::snprintf(buf, sizeof buf, "%d filters over vs in [%.3g, %.3g] m/s, lambda = 1 - %.3g%s", K, p.stribeck_lo,
                p.stribeck_hi, 1.0 - lambda, at_edge ? "; best vs at the edge of the grid" : "");
  out.status = buf;
  out.state_bytes = static_cast<std::size_t>(K) * sizeof(RlsFilter);
  out.working_bytes = out.state_bytes;
  out.seconds = since(t0);
  if (opt.progress) opt.progress(1.0);
  return out;
}

}  // namespace feedid::host
