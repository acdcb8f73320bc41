#include "diagnose.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include "filters.hpp"

namespace feedid::host {
namespace {

using Mat = Eigen::MatrixXd;
using Vec = Eigen::VectorXd;

/// Per interval (sample k-1 -> k), in the core's pairing convention.
struct Intervals {
  std::vector<double> t, x, v, dt, u, dv;  // mid time, mean position, mean velocity, length, force, velocity change
  std::vector<double> since_reversal;      // distance since the last reversal (m)
  std::vector<double> since_start;         // distance since the last reversal or start from rest (m)
  std::vector<double> accel;               // smoothed acceleration at the interval (m/s^2)
  std::vector<double> force_lp;            // low-passed measured force at the interval end (N)
  std::vector<double> sample_t, sample_uf; // per sample: time and low-passed force (for shifts)
  /// Low-passed measured force at time t (linear interpolation, clamped).
  double force_at(double t) const {
    auto it = std::lower_bound(sample_t.begin(), sample_t.end(), t);
    if (it == sample_t.begin()) return sample_uf.front();
    if (it == sample_t.end()) return sample_uf.back();
    const std::size_t j = static_cast<std::size_t>(it - sample_t.begin());
    const double w = (t - sample_t[j - 1]) / (sample_t[j] - sample_t[j - 1]);
    return sample_uf[j - 1] + w * (sample_uf[j] - sample_uf[j - 1]);
  }
};

struct Block {
  std::size_t k0 = 0, k1 = 0;  // interval range [k0, k1)
  // An observation is a pair of adjacent blocks under a triangular weight
  // rising over [k0, kmid) and falling over [kmid, k1); see pair_blocks().
  std::size_t kmid = 0;
  double t_a = 0, t_mid = 0, t_b = 0, tau1 = 0, tau2 = 0;
  int dir = 0;                 // +1 / -1
  bool heldout = false;
  double tau = 0, y = 0;       // length (s); mean force (N)
  double t = 0, x = 0, v = 0;  // means
  double since_reversal = 0;   // at the block start (m)
  double accel_change = 0;     // |a_end - a_start| (m/s^2)
};

Intervals make_intervals(const Signals& s, double v_min) {
  Intervals iv;
  const std::size_t n = s.t.size();
  const double fs = s.sample_rate_hz;
  // Acceleration for the compliance term and low-passed force for the delay
  // term: zero-phase filters well above the motion's bandwidth.
  const double fc = std::min(0.2 * fs, 300.0);
  const std::vector<double> vf = filtfilt_butter4(s.v, fc, fs);
  const std::vector<double> af = central_difference(vf, s.t);
  const std::vector<double> uf = filtfilt_butter4(s.u, fc, fs);
  iv.sample_t = s.t;
  iv.sample_uf = uf;
  int last_dir = 0;
  double x_rev = s.x.empty() ? 0.0 : s.x[0], x_start = x_rev;
  bool resting = true;
  for (std::size_t k = 1; k < n; ++k) {
    const double vm = 0.5 * (s.v[k] + s.v[k - 1]);
    const double xm = 0.5 * (s.x[k] + s.x[k - 1]);
    const int d = vm >= v_min ? 1 : (vm <= -v_min ? -1 : 0);
    if (d != 0 && d != last_dir) {
      x_rev = xm;
      last_dir = d;
    }
    if (d != 0 && resting) x_start = xm;
    resting = d == 0;
    iv.t.push_back(0.5 * (s.t[k] + s.t[k - 1]));
    iv.x.push_back(xm);
    iv.v.push_back(vm);
    iv.dt.push_back(s.t[k] - s.t[k - 1]);
    iv.u.push_back(interval_force(s, k));
    iv.dv.push_back(s.v[k] - s.v[k - 1]);
    iv.since_reversal.push_back(std::fabs(xm - x_rev));
    iv.since_start.push_back(std::min(std::fabs(xm - x_rev), std::fabs(xm - x_start)));
    iv.accel.push_back(0.5 * (af[k] + af[k - 1]));
    iv.force_lp.push_back(uf[k]);
  }
  return iv;
}

/// Time folds, odd ones held out. Folds of fixed length alias with
/// periodic motion: 40 folds of 0.75 s over a 30 s ladder whose strokes
/// alternate every 0.75 s put every positive stroke in the identification
/// folds and every negative one in the held-out folds, and effect-free
/// traces came out `unexplained` with a held-out gap 20-57 times the noise
/// floor. So each fold spans at least two full motion cycles (both
/// directions in every fold), and its edges sit in a dwell where there is
/// one within half a fold, so no rest-to-rest section is cut.
struct Folds {
  std::vector<double> edges;  ///< interior edges, ascending (s)
  /// Fold index of time t (0-based).
  int of(double t) const {
    return static_cast<int>(std::upper_bound(edges.begin(), edges.end(), t) - edges.begin());
  }
  int count() const { return static_cast<int>(edges.size()) + 1; }
};

/// Median time between reversals of the motion (s); 0 if it never reverses.
double median_half_cycle(const Signals& s, double v_min) {
  std::vector<double> halves;
  int dir = 0;
  double since = s.t.front();
  for (std::size_t k = 0; k < s.t.size(); ++k) {
    const int d = s.v[k] >= v_min ? 1 : (s.v[k] <= -v_min ? -1 : 0);
    if (d == 0 || d == dir) continue;
    if (dir != 0) halves.push_back(s.t[k] - since);
    dir = d;
    since = s.t[k];
  }
  if (halves.empty()) return 0.0;
  std::nth_element(halves.begin(), halves.begin() + static_cast<long>(halves.size() / 2), halves.end());
  return halves[halves.size() / 2];
}

/// Middles of dwells: at least 20 ms slow with the position within a few
/// quanta (a slow stroke pauses between encoder counts; that is not a dwell).
std::vector<double> dwell_middles(const Signals& s, double v_min) {
  std::vector<double> rest;
  const double still = std::max(4.0 * s.position_quantum_m, 1e-9);
  for (std::size_t k = 0; s.has_position && k < s.t.size();) {
    if (std::fabs(s.v[k]) >= v_min) { ++k; continue; }
    const std::size_t a = k;
    while (k < s.t.size() && std::fabs(s.v[k]) < v_min && std::fabs(s.x[k] - s.x[a]) <= still) ++k;
    if (s.t[k - 1] - s.t[a] >= 0.02) rest.push_back(0.5 * (s.t[a] + s.t[k - 1]));
    k = std::max(k, a + 1);
  }
  return rest;
}

Folds make_folds(const Signals& s, int max_folds, double v_min) {
  const double t0 = s.t.front(), duration = s.t.back() - t0;
  const double cycle = 2.0 * median_half_cycle(s, v_min);
  int folds = max_folds;
  if (cycle > 0) folds = std::clamp(static_cast<int>(duration / (2.0 * cycle)), 4, max_folds);
  const double len = duration / folds;
  const std::vector<double> rest = dwell_middles(s, v_min);
  Folds f;
  for (int i = 1; i < folds; ++i) {
    const double nominal = t0 + i * len;
    double edge = nominal, best = 0.5 * len;
    const auto it = std::lower_bound(rest.begin(), rest.end(), nominal);
    if (it != rest.end() && *it - nominal < best) { best = *it - nominal; edge = *it; }
    if (it != rest.begin() && nominal - *(it - 1) < best) edge = *(it - 1);
    if (f.edges.empty() || edge > f.edges.back()) f.edges.push_back(edge);
  }
  return f;
}

/// Blocks of consecutive moving intervals of one direction inside one fold.
std::vector<Block> make_blocks(const Intervals& iv, double v_min, double block_s, const Folds& folds) {
  std::vector<Block> blocks;
  Block b;
  bool open = false;
  int fold_open = -1;
  auto close = [&](std::size_t k_end) {
    if (open && b.tau >= 0.5 * block_s) {
      b.k1 = k_end;
      const std::size_t n = b.k1 - b.k0;
      b.y /= b.tau;
      b.t /= b.tau;
      b.x /= b.tau;
      b.v /= b.tau;
      b.accel_change = std::fabs(iv.accel[b.k1 - 1] - iv.accel[b.k0]);
      (void)n;
      blocks.push_back(b);
    }
    open = false;
  };
  for (std::size_t k = 0; k < iv.t.size(); ++k) {
    const int d = iv.v[k] >= v_min ? 1 : (iv.v[k] <= -v_min ? -1 : 0);
    const int fold = folds.of(iv.t[k]);
    const bool gap = k > 0 && iv.dt[k] > 5.0 * iv.dt[k - 1] && iv.dt[k] > 1e-3;
    if (open && (d != b.dir || fold != fold_open || gap)) close(k);
    if (d == 0) continue;
    if (!open) {
      b = Block{};
      b.k0 = k;
      b.dir = d;
      b.heldout = fold % 2 == 1;
      b.since_reversal = iv.since_reversal[k];
      fold_open = fold;
      open = true;
    }
    const double dt = iv.dt[k];
    b.tau += dt;
    b.y += iv.u[k] * dt;
    b.t += iv.t[k] * dt;
    b.x += iv.x[k] * dt;
    b.v += iv.v[k] * dt;
    if (b.tau >= block_s) close(k + 1);
  }
  close(iv.t.size());
  return blocks;
}

/// Triangular weight of interval k in observation b.
inline double pair_weight(const Block& b, const Intervals& iv, std::size_t k) {
  return k < b.kmid ? (iv.t[k] - b.t_a) / b.tau1 : (b.t_b - iv.t[k]) / b.tau2;
}

/// Column of weighted means of g over each observation:
/// (1/A) sum w g dt with A = sum w dt (tau holds A).
template <typename G> Vec block_column(const std::vector<Block>& blocks, const Intervals& iv, G&& g) {
  Vec c(static_cast<Eigen::Index>(blocks.size()));
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    double s = 0.0;
    for (std::size_t k = blocks[i].k0; k < blocks[i].k1; ++k) s += pair_weight(blocks[i], iv, k) * g(k) * iv.dt[k];
    c(static_cast<Eigen::Index>(i)) = s / blocks[i].tau;
  }
  return c;
}

/// Observations from adjacent blocks of one motion stretch and one fold.
/// Under the triangle w, sum w dv telescopes to the difference of the two
/// blocks' mean velocities, i.e. of position differences: encoder
/// quantisation enters as q/tau^2 instead of the velocity quantum / tau of
/// a single block's end-point velocities (8x less at 5 ms and 2 kHz).
std::vector<Block> pair_blocks(const std::vector<Block>& blocks, const Intervals& iv) {
  std::vector<Block> obs;
  for (std::size_t i = 1; i < blocks.size(); ++i) {
    const Block& a = blocks[i - 1];
    const Block& b = blocks[i];
    if (b.k0 != a.k1 || b.dir != a.dir || b.heldout != a.heldout) continue;
    Block o;
    o.k0 = a.k0;
    o.kmid = a.k1;
    o.k1 = b.k1;
    o.dir = a.dir;
    o.heldout = a.heldout;
    o.tau1 = a.tau;
    o.tau2 = b.tau;
    o.t_a = iv.t[a.k0] - 0.5 * iv.dt[a.k0];
    o.t_mid = o.t_a + a.tau;
    o.t_b = o.t_mid + b.tau;
    double area = 0.0;
    for (std::size_t k = o.k0; k < o.k1; ++k) area += pair_weight(o, iv, k) * iv.dt[k];
    o.tau = area;
    o.t = o.t_mid;
    o.x = 0.5 * (a.x + b.x);
    o.v = 0.5 * (a.v + b.v);
    o.since_reversal = a.since_reversal;
    o.accel_change = std::fabs(iv.accel[o.k1 - 1] - iv.accel[o.k0]);
    obs.push_back(o);
  }
  return obs;
}

struct Fit {
  Vec theta;
  Vec residual;  // all blocks
  double ssr_id = 0.0;
  bool ok = false;
};

Fit fit_columns(const Mat& x, const Vec& y, const std::vector<char>& id_mask) {
  Fit f;
  const Eigen::Index n = x.rows(), p = x.cols();
  Eigen::Index m = 0;
  for (char c : id_mask) m += c;
  Mat xi(m, p);
  Vec yi(m);
  for (Eigen::Index i = 0, j = 0; i < n; ++i)
    if (id_mask[static_cast<std::size_t>(i)]) { xi.row(j) = x.row(i); yi(j) = y(i); ++j; }
  // Scale columns so the rank decision is unit-free.
  Vec scale(p);
  for (Eigen::Index c = 0; c < p; ++c) {
    const double nrm = xi.col(c).norm();
    scale(c) = nrm > 0 ? 1.0 / nrm : 1.0;
    xi.col(c) *= scale(c);
  }
  Eigen::ColPivHouseholderQR<Mat> qr(xi);
  qr.setThreshold(1e-9);
  f.theta = qr.solve(yi).cwiseProduct(scale);
  f.residual = y - x * f.theta;
  f.ssr_id = 0.0;
  for (Eigen::Index i = 0; i < n; ++i)
    if (id_mask[static_cast<std::size_t>(i)]) f.ssr_id += f.residual(i) * f.residual(i);
  f.ok = f.theta.allFinite();
  return f;
}

/// R^2 of a column regressed on the base columns (identification blocks):
/// near 1 means the effect's term is already a combination of the model's.
double collinearity(const Mat& base, const Vec& col, const std::vector<char>& id_mask) {
  const Fit f = fit_columns(base, col, id_mask);
  double ss = 0.0, sr = 0.0, mean = 0.0;
  std::size_t n = 0;
  for (Eigen::Index i = 0; i < col.size(); ++i)
    if (id_mask[static_cast<std::size_t>(i)]) { mean += col(i); ++n; }
  mean /= std::max<std::size_t>(n, 1);
  for (Eigen::Index i = 0; i < col.size(); ++i)
    if (id_mask[static_cast<std::size_t>(i)]) {
      ss += col(i) * col(i);  // uncentred: the base has no intercept of its own
      sr += f.residual(i) * f.residual(i);
    }
  (void)mean;
  return ss > 0 ? 1.0 - sr / ss : 1.0;
}

double rms_over(const Vec& r, const std::vector<Block>& blocks, bool heldout) {
  double s = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < blocks.size(); ++i)
    if (blocks[i].heldout == heldout) { s += r(static_cast<Eigen::Index>(i)) * r(static_cast<Eigen::Index>(i)); ++n; }
  return n ? std::sqrt(s / static_cast<double>(n)) : 0.0;
}

/// White noise floor of the block residual: consecutive held-out blocks of
/// one motion stretch differ by noise only (smooth structure cancels), so
/// sigma = 1.4826 * median|r_i - r_{i-1}| / sqrt(2).
double noise_floor(const Vec& r, const std::vector<Block>& blocks) {
  std::vector<double> d;
  // Observations i and i-2 are neighbours that share no block.
  for (std::size_t i = 2; i < blocks.size(); ++i)
    if (blocks[i].heldout && blocks[i - 2].heldout && blocks[i].k0 == blocks[i - 2].k1)
      d.push_back(std::fabs(r(static_cast<Eigen::Index>(i)) - r(static_cast<Eigen::Index>(i - 2))));
  if (d.size() < 10) return 0.0;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return 1.4826 * d[d.size() / 2] / std::sqrt(2.0);
}

/// t statistic of the held-out improvement sum(r_base^2 - r_aug^2), with
/// blocks grouped in runs of 20 so neighbouring blocks' correlation does not
/// inflate it.
double improvement_t(const Vec& rb, const Vec& ra, const std::vector<Block>& blocks) {
  std::vector<double> g;
  double acc = 0.0;
  int in_group = 0;
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    if (!blocks[i].heldout) continue;
    const auto j = static_cast<Eigen::Index>(i);
    acc += rb(j) * rb(j) - ra(j) * ra(j);
    if (++in_group == 20) { g.push_back(acc); acc = 0.0; in_group = 0; }
  }
  if (g.size() < 3) return 0.0;
  const double mean = std::accumulate(g.begin(), g.end(), 0.0) / static_cast<double>(g.size());
  double var = 0.0;
  for (double x : g) var += (x - mean) * (x - mean);
  var /= static_cast<double>(g.size() - 1);
  return var > 0 ? mean / std::sqrt(var / static_cast<double>(g.size())) : 0.0;
}

std::vector<double> log_grid(double lo, double hi, int n) {
  std::vector<double> g;
  for (int i = 0; i < n; ++i) g.push_back(lo * std::pow(hi / lo, static_cast<double>(i) / (n - 1)));
  return g;
}

/// A candidate effect: columns for a value of its nonlinear parameter, and
/// how to name the fitted numbers.
struct EffectModel {
  std::string kind;
  std::vector<double> grid;  // nonlinear parameter values (empty: none), log-spaced if continuous
  bool continuous = false;   // refine between grid points by golden-section search
  std::function<Mat(double)> columns;
  std::function<nlohmann::json(double, const Vec& coef)> parameters;
  /// Discrete refinement: more values to try around the best grid value.
  std::function<std::vector<double>(double)> refine = {};
  /// Physical plausibility of the fitted parameters ("" if plausible, else why not).
  std::function<std::string(const nlohmann::json&)> implausible = {};
};

/// Second-order low-pass response H(s) = w^2/(s^2 + 2 z w s + w^2) of the
/// load behind a spring to the motor acceleration, by exact discretisation
/// per step (the step is far below 1/w).
std::vector<double> second_order_response(const std::vector<double>& in, const std::vector<double>& dt, double w, double z) {
  std::vector<double> out(in.size());
  double y = in.empty() ? 0.0 : in[0], yd = 0.0;
  for (std::size_t k = 0; k < in.size(); ++k) {
    const double h = dt[k];
    const int sub = std::max(1, static_cast<int>(std::ceil(h * w / 0.2)));
    const double hs = h / sub;
    for (int i = 0; i < sub; ++i) {  // semi-implicit Euler, stable for hs*w <= 0.2
      yd += hs * (w * w * (in[k] - y) - 2.0 * z * w * yd);
      y += hs * yd;
    }
    out[k] = y;
  }
  return out;
}

std::string fmt(double v, const char* unit) {
  std::ostringstream o;
  o.precision(3);
  o << v << " " << unit;
  return o.str();
}

}  // namespace

DiagnoseResult diagnose(const Trace& trace, const DiagnoseOptions& opt) {
  DiagnoseResult out;
  if (trace.samples.size() < 1000) {
    out.error = trace.source + ": trace too short to diagnose: " + std::to_string(trace.samples.size()) +
                " samples (need at least 1000, moving in both directions)";
    return out;
  }
  if (opt.folds < 2) throw std::invalid_argument("folds must be >= 2");
  IdentifyOptions timing_opt = opt.identify;
  timing_opt.lag_within_conventions = true;  // a delay beyond them is an effect (docs/diagnosis.md)
  const Signals sig = prepare_signals(trace, timing_opt);
  out.force_lag_s = sig.force_lag_s;
  out.lag_beyond_conventions_s = sig.lag_beyond_conventions / sig.sample_rate_hz;
  const double t0 = sig.t.front(), t1 = sig.t.back();
  const Folds folds = make_folds(sig, opt.folds, auto_config(sig, opt.identify).velocity_min_m_s);
  out.folds = folds.count();

  // 1. Base model from the identification folds (even ones), by the core.
  Trace id_trace;
  id_trace.source = trace.source + " (identification folds)";
  id_trace.has_velocity = true;
  id_trace.has_position = trace.has_position;
  for (std::size_t k = 0; k < sig.t.size(); ++k) {
    if (folds.of(sig.t[k]) % 2 == 0) id_trace.samples.push_back({sig.t[k], sig.x[k], sig.v[k], sig.u[k]});
  }
  IdentifyOptions idopt = opt.identify;
  // The folds are already aligned (velocity delayed if the lag was positive):
  // what is left of the lag goes to the core as stated.
  idopt.force_lag_s = sig.force_lag_samples / sig.sample_rate_hz;
  idopt.velocity_lag_s = sig.velocity_is_difference ? 0.5 / sig.sample_rate_hz : sig.velocity_lag_s;
  out.base = identify(id_trace, idopt);
  if (!out.base.error.empty()) {
    out.error = out.base.error;
    return out;
  }
  if (opt.progress) opt.progress(0.2);
  const auto& est = out.base.estimate;
  const double v_min = out.base.config.velocity_min_m_s;

  // 2. Blocks over the whole trace, with the base model's regressors.
  const Intervals iv = make_intervals(sig, v_min);
  const std::vector<Block> blocks = pair_blocks(make_blocks(iv, v_min, opt.block_s, folds), iv);
  std::vector<char> id_mask(blocks.size());
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    id_mask[i] = blocks[i].heldout ? 0 : 1;
    out.blocks_identification += id_mask[i];
  }
  out.blocks_heldout = blocks.size() - out.blocks_identification;
  if (out.blocks_identification < 50 || out.blocks_heldout < 50) {
    out.error = trace.source + ": too little motion to diagnose: " + std::to_string(blocks.size()) +
                " blocks of motion (need 50 for identification and 50 held out)";
    return out;
  }
  const Vec y = block_column(blocks, iv, [&](std::size_t k) { return iv.u[k]; });

  // Base columns: m, Fc+, Fc-, sigma+, sigma-, and where the core found a
  // Stribeck dip, Fs+/- with the linearised vs correction dE/dvs. Negative-
  // direction columns carry the model's signs so coefficients are magnitudes.
  // Stribeck columns wherever the direction's friction was identified: the
  // least-squares fit sets Fs near 0 if there is no dip.
  const bool stribeck_pos = est.pos.friction_identified() && est.pos.breakaway_N > 0,
             stribeck_neg = est.neg.friction_identified() && est.neg.breakaway_N > 0;
  std::vector<Vec> fixed_cols;
  {
    fixed_cols.push_back(block_column(blocks, iv, [&](std::size_t k) { return iv.dv[k] / iv.dt[k]; }));
  }
  fixed_cols.push_back(block_column(blocks, iv, [&](std::size_t k) { return iv.v[k] > 0 ? 1.0 : 0.0; }));
  fixed_cols.push_back(block_column(blocks, iv, [&](std::size_t k) { return iv.v[k] < 0 ? -1.0 : 0.0; }));
  fixed_cols.push_back(block_column(blocks, iv, [&](std::size_t k) { return iv.v[k] > 0 ? iv.v[k] : 0.0; }));
  fixed_cols.push_back(block_column(blocks, iv, [&](std::size_t k) { return iv.v[k] < 0 ? iv.v[k] : 0.0; }));
  // exp(-(v/vs)^2) and its vs-derivative exp(..) 2 v^2 / vs^3, per direction.
  auto stribeck_cols = [&](int dir, double vs, Vec& e, Vec& de) {
    e = block_column(blocks, iv, [&](std::size_t k) {
      const double q = iv.v[k] / vs;
      return (dir > 0 ? iv.v[k] > 0 : iv.v[k] < 0) ? dir * std::exp(-q * q) : 0.0;
    });
    de = block_column(blocks, iv, [&](std::size_t k) {
      const double q = iv.v[k] / vs;
      return (dir > 0 ? iv.v[k] > 0 : iv.v[k] < 0) ? dir * std::exp(-q * q) * 2.0 * q * q / vs : 0.0;
    });
  };
  auto base_matrix = [&](double vp, double vn) {
    std::vector<Vec> cols = fixed_cols;
    Vec e, de;
    if (stribeck_pos) { stribeck_cols(1, vp, e, de); cols.push_back(e); cols.push_back(de); }
    if (stribeck_neg) { stribeck_cols(-1, vn, e, de); cols.push_back(e); cols.push_back(de); }
    Mat m(static_cast<Eigen::Index>(blocks.size()), static_cast<Eigen::Index>(cols.size()));
    for (std::size_t c = 0; c < cols.size(); ++c) m.col(static_cast<Eigen::Index>(c)) = cols[c];
    return m;
  };
  // The core's vs search range and grid; Stribeck columns precomputed on it.
  const std::vector<double> vs_grid = log_grid(0.5 * v_min, 0.25 * out.base.config.velocity_max_m_s, 24);
  std::vector<Vec> grid_e[2], grid_de[2];
  for (int d = 0; d < 2; ++d)
    if (d == 0 ? stribeck_pos : stribeck_neg)
      for (double vs : vs_grid) {
        Vec e, de;
        stribeck_cols(d == 0 ? 1 : -1, vs, e, de);
        grid_e[d].push_back(e);
        grid_de[d].push_back(de);
      }
  auto grid_matrix = [&](int gp, int gn, const Mat& extra) {
    std::vector<const Vec*> cols;
    for (const auto& c : fixed_cols) cols.push_back(&c);
    if (stribeck_pos) { cols.push_back(&grid_e[0][gp]); cols.push_back(&grid_de[0][gp]); }
    if (stribeck_neg) { cols.push_back(&grid_e[1][gn]); cols.push_back(&grid_de[1][gn]); }
    Mat m(static_cast<Eigen::Index>(blocks.size()), static_cast<Eigen::Index>(cols.size()) + extra.cols());
    for (std::size_t c = 0; c < cols.size(); ++c) m.col(static_cast<Eigen::Index>(c)) = *cols[c];
    if (extra.cols() > 0) m.rightCols(extra.cols()) = extra;
    return m;
  };
  auto nearest = [&](double vs) {
    std::size_t best = 0;
    for (std::size_t g = 0; g < vs_grid.size(); ++g)
      if (std::fabs(std::log(vs_grid[g] / vs)) < std::fabs(std::log(vs_grid[best] / vs))) best = g;
    return static_cast<int>(best);
  };
  // Joint fit of the base terms and extra columns with vs+/- free: an
  // unmodelled effect biases the core's vs (quadratic damping pulled it from
  // 2 to 17 mm/s), so each fit picks vs on the grid by coordinate search,
  // then Gauss-Newton steps through the dE/dvs columns.
  double vs_base_pos = est.pos.stribeck_velocity_m_s, vs_base_neg = est.neg.stribeck_velocity_m_s;
  auto fit_joint = [&](const Mat& extra, double& vp, double& vn, int steps) {
    int gp = nearest(vp), gn = nearest(vn);
    double best_ssr = fit_columns(grid_matrix(gp, gn, extra), y, id_mask).ssr_id;
    for (int round = 0; round < 2; ++round)
      for (int d = 0; d < 2; ++d) {
        if (!(d == 0 ? stribeck_pos : stribeck_neg)) continue;
        for (int g = 0; g < static_cast<int>(vs_grid.size()); ++g) {
          const int tp = d == 0 ? g : gp, tn = d == 1 ? g : gn;
          const Fit f = fit_columns(grid_matrix(tp, tn, extra), y, id_mask);
          if (f.ok && f.ssr_id < best_ssr) { best_ssr = f.ssr_id; gp = tp; gn = tn; }
        }
      }
    vp = vs_grid[gp];
    vn = vs_grid[gn];
    Fit f;
    for (int it = 0; it <= steps; ++it) {
      const Mat b = base_matrix(vp, vn);
      Mat x(b.rows(), b.cols() + extra.cols());
      if (extra.cols() > 0) x << b, extra; else x = b;
      f = fit_columns(x, y, id_mask);
      if (!f.ok || it == steps) break;
      Eigen::Index c = static_cast<Eigen::Index>(fixed_cols.size());
      auto step = [&](double& vs) {
        const double fs_coef = f.theta(c), d_coef = f.theta(c + 1);
        if (fs_coef > 0) vs = std::clamp(vs + d_coef / fs_coef, 0.7 * vs, 1.4 * vs);
        c += 2;
      };
      if (stribeck_pos) step(vp);
      if (stribeck_neg) step(vn);
    }
    return f;
  };
  const Mat no_extra(static_cast<Eigen::Index>(blocks.size()), 0);
  const Fit base_fit = fit_joint(no_extra, vs_base_pos, vs_base_neg, 6);
  const Mat base = base_matrix(vs_base_pos, vs_base_neg);
  out.rms_base_N = rms_over(base_fit.residual, blocks, true);
  out.noise_floor_N = noise_floor(base_fit.residual, blocks);

  // 3. Candidate effects, each fitted jointly with the base terms on the
  //    identification blocks (nonlinear parameter by grid search there too),
  //    then judged on the held-out blocks only.
  const double x_lo = *std::min_element(iv.x.begin(), iv.x.end());
  const double x_hi = *std::max_element(iv.x.begin(), iv.x.end());
  const double travel = std::max(x_hi - x_lo, 1e-6);
  const double duration = t1 - t0;
  const double fs = sig.sample_rate_hz;
  auto one_col = [&](Vec c) { Mat m(c.size(), 1); m.col(0) = c; return m; };
  std::vector<EffectModel> models;
  models.push_back({"offset", {}, false, [&](double) { return one_col(block_column(blocks, iv, [](std::size_t) { return 1.0; })); },
                    [](double, const Vec& c) { return nlohmann::json{{"force_N", c(0)}}; }});
  models.push_back({"position_ripple", log_grid(std::max(4e-4, 1e-3 * travel), travel / 3.0, 160), true,
                    [&](double p) {
                      Mat m(static_cast<Eigen::Index>(blocks.size()), 2);
                      m.col(0) = block_column(blocks, iv, [&](std::size_t k) { return std::sin(2 * M_PI * iv.x[k] / p); });
                      m.col(1) = block_column(blocks, iv, [&](std::size_t k) { return std::cos(2 * M_PI * iv.x[k] / p); });
                      return m;
                    },
                    [](double p, const Vec& c) {
                      return nlohmann::json{{"period_m", p}, {"amplitude_N", std::hypot(c(0), c(1))},
                                            {"phase_rad", std::atan2(c(1), c(0))}};
                    }});
  {
    // Position friction: a contiguous range of the travel, on 200 cells:
    // coarse ranges of 10 cells, then each edge moved cell by cell.
    constexpr int cells = 200, coarse = 10;
    std::vector<double> grid;
    for (int a = 0; a < cells; a += coarse)
      for (int b = a + coarse; b <= cells; b += coarse)
        if (!(a == 0 && b == cells)) grid.push_back(a * 1000 + b);
    EffectModel pf{"position_friction", grid, false,
                   [&, cells](double code) {
                     const int a = static_cast<int>(code) / 1000, b = static_cast<int>(code) % 1000;
                     const double xa = x_lo + travel * a / cells, xb = x_lo + travel * b / cells;
                     return one_col(block_column(blocks, iv, [&](std::size_t k) {
                       return (iv.x[k] >= xa && iv.x[k] < xb) ? (iv.v[k] > 0 ? 1.0 : -1.0) : 0.0;
                     }));
                   },
                   [&, cells](double code, const Vec& c) {
                     const int a = static_cast<int>(code) / 1000, b = static_cast<int>(code) % 1000;
                     return nlohmann::json{{"x_min_m", x_lo + travel * a / cells},
                                           {"x_max_m", x_lo + travel * b / cells}, {"delta_N", c(0)}};
                   }};
    pf.refine = [cells, coarse](double code) {
      const int a = static_cast<int>(code) / 1000, b = static_cast<int>(code) % 1000;
      std::vector<double> out;
      for (int d = -coarse; d <= coarse; ++d) {
        if (a + d >= 0 && a + d < b) out.push_back((a + d) * 1000 + b);
        if (b + d > a && b + d <= cells) out.push_back(a * 1000 + b + d);
      }
      return out;
    };
    models.push_back(pf);
  }
  models.push_back({"thermal_drift", log_grid(std::max(1.0, 0.02 * duration), 5.0 * duration, 40), true,
                    [&](double tc) {
                      Mat m(static_cast<Eigen::Index>(blocks.size()), 2);
                      m.col(0) = block_column(blocks, iv, [&](std::size_t k) { return iv.v[k] * std::exp(-(iv.t[k] - t0) / tc); });
                      m.col(1) = block_column(blocks, iv, [&](std::size_t k) {
                        return (iv.v[k] > 0 ? 1.0 : -1.0) * std::exp(-(iv.t[k] - t0) / tc);
                      });
                      return m;
                    },
                    [](double tc, const Vec& c) {
                      return nlohmann::json{{"time_constant_s", tc}, {"viscous_change_Ns_m", c(0)}, {"coulomb_change_N", c(1)}};
                    }});
  models.push_back({"quadratic_viscous", {}, false,
                    [&](double) { return one_col(block_column(blocks, iv, [&](std::size_t k) { return iv.v[k] * std::fabs(iv.v[k]); })); },
                    [](double, const Vec& c) { return nlohmann::json{{"c2", c(0)}, {"c2_unit", "N s^2/m^2"}}; }});
  {
    // Bristle friction builds up over a distance d after a reversal. Whether
    // a stop also resets it depends on how the drive settles (a slip back
    // below one encoder quantum during the stop is a reversal no measurement
    // shows), so both readings of "distance" are tried: p > 0 counts from the
    // last reversal, p < 0 from the last reversal or start from rest.
    std::vector<double> grid = log_grid(1e-6, std::min(2e-3, travel / 4), 40);
    const std::size_t n = grid.size();
    for (std::size_t i = 0; i < n; ++i) grid.push_back(-grid[i]);
    EffectModel ph{"presliding_hysteresis", grid, false,
                   [&](double p) {
                     const double d = std::fabs(p);
                     const std::vector<double>& dist = p > 0 ? iv.since_reversal : iv.since_start;
                     return one_col(block_column(blocks, iv, [&](std::size_t k) {
                       return -(iv.v[k] > 0 ? 1.0 : -1.0) * std::exp(-dist[k] / d);
                     }));
                   },
                   [](double p, const Vec& c) {
                     return nlohmann::json{{"distance_m", std::fabs(p)}, {"force_N", 0.5 * c(0)},
                                           {"resets", p > 0 ? "at reversals" : "at reversals and starts from rest"}};
                   }};
    ph.refine = [](double p) {  // finer steps in d around the best, same reading
      std::vector<double> out;
      for (int i = -4; i <= 4; ++i) out.push_back(p * std::pow(1.05, i));
      return out;
    };
    models.push_back(ph);
  }
  {
    // Compliance: the load behind a spring follows the motor through
    // H(s) = w^2/(s^2 + 2 z w s + w^2); the base model misses m2 (a2 - a1).
    std::vector<double> grid = log_grid(3.0, std::min(0.25 * fs, 400.0), 50);
    models.push_back({"compliance", grid, true,
                      [&](double f) {
                        const std::vector<double> a2 = second_order_response(iv.accel, iv.dt, 2 * M_PI * f, 0.05);
                        return one_col(block_column(blocks, iv, [&](std::size_t k) { return a2[k] - iv.accel[k]; }));
                      },
                      [&](double f, const Vec& c) {
                        // c = load mass m2; free resonance sqrt(k (m1+m2)/(m1 m2)) with k = m2 w^2.
                        const double m2 = c(0), m_total = base_fit.theta(0);
                        const double m1 = m_total - m2;
                        const double fr = m1 > 0 && m2 > 0 ? f * std::sqrt(1.0 + m2 / m1) : f;
                        return nlohmann::json{{"frequency_hz", fr}, {"load_frequency_hz", f}, {"load_mass_kg", m2}};
                      }});
  }
  // Delay: the recorded force lags, u_rec(t) = u(t - d), so
  // u_rec(t) = model(t) - [u_rec(t + d) - u_rec(t)]: regressor
  // u_f(t + d) - u_f(t) (coefficient near -1), d by grid search. Exact for
  // any d, unlike the first-order u - d du/dt.
  models.push_back({"delay", log_grid(0.2 / fs, 25.0 / fs, 40), true,
                    [&](double d) {
                      return one_col(block_column(blocks, iv, [&](std::size_t k) {
                        const double te = iv.t[k] + 0.5 * iv.dt[k];
                        return iv.force_at(te + d) - iv.force_lp[k];
                      }));
                    },
                    // For a force smooth on the scale of d only the product
                    // c*d is identified (c*d*du/dt); -c*d is the delay.
                    [](double d, const Vec& c) { return nlohmann::json{{"delay_s", -c(0) * d}, {"shift_s", d}, {"coefficient", c(0)}}; }});

  // Fits that no physical effect of that kind can produce are never named:
  // e.g. a "compliance" with a negative load mass at the top of its
  // frequency grid is a delay in disguise (both look like jerk there).
  const double f_top = std::min(0.25 * fs, 400.0);
  for (auto& em : models) {
    if (em.kind == "compliance")
      em.implausible = [&, f_top](const nlohmann::json& p) {
        const double m2 = p.value("load_mass_kg", 0.0), m = base_fit.theta(0);
        if (!(m2 > 0.0) || !(m2 < m)) return std::string("load mass outside (0, m)");
        if (p.value("load_frequency_hz", 0.0) > 0.97 * f_top) return std::string("frequency at the top of the search range");
        return std::string();
      };
    if (em.kind == "delay")
      em.implausible = [](const nlohmann::json& p) {
        return p.value("delay_s", 0.0) > 0.0 ? std::string() : std::string("recorded force would lead the motion");
      };
    if (em.kind == "presliding_hysteresis")
      em.implausible = [](const nlohmann::json& p) {
        return p.value("force_N", 0.0) > 0.0 ? std::string() : std::string("friction would rise after a reversal");
      };
  }
  for (std::size_t mi = 0; mi < models.size(); ++mi) {
    const EffectModel& em = models[mi];
    const std::vector<double> grid = em.grid.empty() ? std::vector<double>{0.0} : em.grid;
    double best_ssr = 1e300, best_p = grid[0];
    Fit best;
    Mat best_cols;
    auto try_p = [&](double p) {
      const Mat cols = em.columns(p);
      Mat x(base.rows(), base.cols() + cols.cols());
      x << base, cols;
      const Fit f = fit_columns(x, y, id_mask);
      if (f.ok && f.ssr_id < best_ssr) { best_ssr = f.ssr_id; best_p = p; best = f; best_cols = cols; }
      return f.ok ? f.ssr_id : 1e300;
    };
    std::size_t best_i = 0;
    for (std::size_t i = 0; i < grid.size(); ++i) {
      const double before = best_ssr;
      try_p(grid[i]);
      if (best_ssr < before) best_i = i;
    }
    if (em.refine) {
      for (int round = 0; round < 2; ++round)
        for (double p : em.refine(best_p)) try_p(p);
    }
    if (em.continuous && grid.size() >= 3) {
      // Golden-section search in log p over the best grid cell's neighbours.
      double a = std::log(grid[best_i > 0 ? best_i - 1 : 0]);
      double b = std::log(grid[std::min(best_i + 1, grid.size() - 1)]);
      const double g = 0.6180339887498949;
      double x1 = b - g * (b - a), x2 = a + g * (b - a);
      double f1 = try_p(std::exp(x1)), f2 = try_p(std::exp(x2));
      for (int it = 0; it < 25; ++it) {
        if (f1 < f2) { b = x2; x2 = x1; f2 = f1; x1 = b - g * (b - a); f1 = try_p(std::exp(x1)); }
        else { a = x1; x1 = x2; f1 = f2; x2 = a + g * (b - a); f2 = try_p(std::exp(x2)); }
      }
    }
    Candidate c;
    c.kind = em.kind;
    if (best.ok) {  // the chosen effect refitted with vs free as for the base
      double vp = vs_base_pos, vn = vs_base_neg;
      const Fit refit = fit_joint(best_cols, vp, vn, 6);
      if (refit.ok) best = refit;
    }
    if (!best.ok) { c.note = "fit failed"; out.candidates.push_back(c); continue; }
    const Vec coef = best.theta.tail(best_cols.cols());
    c.parameters = em.parameters(best_p, coef);
    c.heldout_rms_N = rms_over(best.residual, blocks, true);
    c.t_statistic = improvement_t(base_fit.residual, best.residual, blocks);
    const double excess = out.rms_base_N - out.noise_floor_N;
    c.closed_fraction = excess > 0 ? std::clamp((out.rms_base_N - c.heldout_rms_N) / excess, -1.0, 1.0) : 0.0;
    double r2 = 0.0;
    for (Eigen::Index j = 0; j < best_cols.cols(); ++j) r2 = std::max(r2, collinearity(base, best_cols.col(j), id_mask));
    c.indistinguishable = r2 > 0.995;
    if (c.indistinguishable) {
      c.note = "its term is a combination of the base model's terms on this data (R^2 " + std::to_string(r2) + ")";
      if (em.kind == "offset") {
        const double fcp = base_fit.theta(1), fcn = base_fit.theta(2);
        c.note = "while the axis moves, a constant offset is indistinguishable from Coulomb friction that differs by "
                 "direction: the fit's Fc+ - Fc- = " + fmt(fcp - fcn, "N") + " equals an offset of " + fmt(0.5 * (fcp - fcn), "N");
        c.parameters = {{"force_N", 0.5 * (fcp - fcn)}};
      }
    }
    const std::string why_not = em.implausible ? em.implausible(c.parameters) : std::string();
    if (!why_not.empty()) c.note = "not physical: " + why_not;
    c.significant = !c.indistinguishable && why_not.empty() && c.t_statistic >= opt.significance_t &&
                    c.heldout_rms_N < out.rms_base_N;
    out.candidates.push_back(c);
    if (opt.progress) opt.progress(0.2 + 0.7 * static_cast<double>(mi + 1) / static_cast<double>(models.size()));
    // Keep the residual of the best candidate so far for the report.
    (void)best_cols;
  }
  std::stable_sort(out.candidates.begin(), out.candidates.end(), [](const Candidate& a, const Candidate& b) {
    if (a.significant != b.significant) return a.significant;
    return a.heldout_rms_N < b.heldout_rms_N;
  });

  // 4. Verdict.
  const Candidate& top = out.candidates.front();
  const double ratio = out.noise_floor_N > 0 ? out.rms_base_N / out.noise_floor_N : 0.0;
  if (top.significant && top.closed_fraction >= opt.min_closed_fraction && ratio >= opt.unexplained_ratio) {
    out.effect = top.kind;
    out.effect_parameters = top.parameters;
    out.rms_augmented_N = top.heldout_rms_N;
    out.closed_fraction = top.closed_fraction;
  } else {
    out.effect = ratio >= opt.unexplained_ratio ? "unexplained" : "none";
    out.rms_augmented_N = out.rms_base_N;
    out.closed_fraction = 0.0;
    // An offset is absorbed by the base model as Coulomb friction that
    // differs by direction, so it leaves no gap. With no gap left, a large
    // asymmetry is named as an offset: healthy feed drives differ by a few
    // percent between directions, gravity, cable drag or a sensor offset by
    // more. It stays marked indistinguishable: the data alone cannot decide.
    const double fcp = base_fit.theta(1), fcn = base_fit.theta(2);
    const double asym = 0.5 * (fcp - fcn), mean_fc = 0.5 * (fcp + fcn);
    if (out.effect == "none" && mean_fc > 0 && std::fabs(asym) > opt.offset_asymmetry_ratio * mean_fc) {
      out.effect = "offset";
      out.effect_parameters = {{"force_N", asym},
                               {"indistinguishable_from", "Coulomb friction that differs by direction"},
                               {"basis", "Coulomb asymmetry above the offset_asymmetry_ratio prior"}};
      out.rms_augmented_N = out.rms_base_N;
    }
  }

  // Residual series for the report; refit the chosen effect to keep its residual.
  Vec r_aug = base_fit.residual;
  if (out.effect != "none" && out.effect != "unexplained") {
    Mat best_cols;
    for (const auto& em : models)
      if (em.kind == out.effect) {
        const std::vector<double> grid = em.grid.empty() ? std::vector<double>{0.0} : em.grid;
        double best_ssr = 1e300;
        for (double p : grid) {
          const Mat cols = em.columns(p);
          Mat x(base.rows(), base.cols() + cols.cols());
          x << base, cols;
          const Fit f = fit_columns(x, y, id_mask);
          if (f.ok && f.ssr_id < best_ssr) { best_ssr = f.ssr_id; best_cols = cols; }
        }
        double vp = vs_base_pos, vn = vs_base_neg;
        const Fit f = fit_joint(best_cols, vp, vn, 6);
        if (f.ok) {
          r_aug = f.residual;
          // theta: m, Fc+, Fc-, sigma+, sigma-, then (Fs, dE) per direction with a dip.
          DriveParams& a = out.augmented_model;
          a.mass_kg = f.theta(0);
          a.pos = {f.theta(3), f.theta(1), 0.0, vp};
          a.neg = {f.theta(4), f.theta(2), 0.0, vn};
          Eigen::Index c = 5;
          if (stribeck_pos) { a.pos.breakaway_N = f.theta(c); c += 2; }
          if (stribeck_neg) { a.neg.breakaway_N = f.theta(c); }
          out.has_augmented_model = true;
        }
      }
  }
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    out.block_t.push_back(blocks[i].t);
    out.block_x.push_back(blocks[i].x);
    out.block_v.push_back(blocks[i].v);
    out.block_r_base.push_back(base_fit.residual(static_cast<Eigen::Index>(i)));
    out.block_r_aug.push_back(r_aug(static_cast<Eigen::Index>(i)));
    out.block_heldout.push_back(blocks[i].heldout);
  }

  // 5. Where the held-out residual energy lies, by domain.
  double e_total = 0.0, t_total = 0.0;
  for (std::size_t i = 0; i < blocks.size(); ++i)
    if (blocks[i].heldout) {
      const double r = base_fit.residual(static_cast<Eigen::Index>(i));
      e_total += r * r * blocks[i].tau;
      t_total += blocks[i].tau;
    }
  auto where_bins = [&](const std::string& domain, const std::vector<double>& edges, auto value, const char* unit) {
    WhereEntry best;
    double best_lift = -1.0;
    for (std::size_t b = 0; b + 1 < edges.size(); ++b) {
      double e = 0.0, tt = 0.0;
      for (std::size_t i = 0; i < blocks.size(); ++i) {
        if (!blocks[i].heldout) continue;
        const double q = value(blocks[i]);
        if (q < edges[b] || q >= edges[b + 1]) continue;
        const double r = base_fit.residual(static_cast<Eigen::Index>(i));
        e += r * r * blocks[i].tau;
        tt += blocks[i].tau;
      }
      if (tt < 0.02 * t_total || e_total <= 0) continue;
      const double share = e / e_total, tshare = tt / t_total;
      if (share - tshare > best_lift) {
        best_lift = share - tshare;
        best = {domain, fmt(edges[b], unit) + " .. " + fmt(edges[b + 1], unit), edges[b], edges[b + 1], share, tshare};
      }
    }
    if (best_lift > -1.0) out.where.push_back(best);
  };
  {
    const double vmax = out.base.config.velocity_max_m_s;
    std::vector<double> ve;
    for (int i = 8; i >= 0; --i) ve.push_back(-vmax * std::pow(v_min / vmax, i / 8.0));
    ve.front() = -1e9;
    std::vector<double> vp;
    for (int i = 0; i <= 8; ++i) vp.push_back(vmax * std::pow(v_min / vmax, 1.0 - i / 8.0));
    vp.back() = 1e9;
    std::vector<double> edges = ve;
    edges.insert(edges.end(), vp.begin(), vp.end());
    where_bins("velocity", edges, [](const Block& b) { return b.v; }, "m/s");
    std::vector<double> xe;
    for (int i = 0; i <= 10; ++i) xe.push_back(x_lo + travel * i / 10.0);
    xe.back() += 1e-12;
    where_bins("position", xe, [](const Block& b) { return b.x; }, "m");
    std::vector<double> te;
    for (int i = 0; i <= 5; ++i) te.push_back(t0 + duration * i / 5.0);
    te.back() += 1e-9;
    where_bins("time", te, [](const Block& b) { return b.t; }, "s");
    where_bins("after_reversal", {0.0, 1e-5, 1e-4, 1e-3, 1e9}, [](const Block& b) { return b.since_reversal; }, "m");
    std::vector<double> ac;
    for (const auto& b : blocks) ac.push_back(b.accel_change);
    std::vector<double> sorted = ac;
    std::sort(sorted.begin(), sorted.end());
    const double p90 = sorted[sorted.size() * 9 / 10];
    where_bins("acceleration_change", {0.0, p90, 1e12}, [](const Block& b) { return b.accel_change; }, "m/s^2");
  }
  {
    // Frequency: periodogram of the held-out block residual over runs of
    // contiguous blocks; the peak and its share of the energy.
    const double fb = 1.0 / opt.block_s;
    std::vector<double> freqs = log_grid(0.5, 0.45 * fb, 120);
    std::vector<double> power(freqs.size(), 0.0);
    std::size_t i = 0;
    double total = 0.0;
    while (i < blocks.size()) {
      std::size_t j = i + 1;
      while (j < blocks.size() && blocks[j].heldout && blocks[i].heldout && blocks[j].k0 == blocks[j - 1].kmid) ++j;
      if (blocks[i].heldout && j - i >= 32) {
        for (std::size_t fi = 0; fi < freqs.size(); ++fi) {
          double re = 0.0, im = 0.0;
          for (std::size_t b = i; b < j; ++b) {
            const double r = base_fit.residual(static_cast<Eigen::Index>(b));
            re += r * std::cos(2 * M_PI * freqs[fi] * blocks[b].t);
            im += r * std::sin(2 * M_PI * freqs[fi] * blocks[b].t);
          }
          power[fi] += (re * re + im * im) / static_cast<double>(j - i);
        }
      }
      i = j;
    }
    for (double p : power) total += p;
    if (total > 0) {
      const auto pk = static_cast<std::size_t>(std::max_element(power.begin(), power.end()) - power.begin());
      double near = 0.0;
      for (std::size_t fi = 0; fi < freqs.size(); ++fi)
        if (std::fabs(std::log(freqs[fi] / freqs[pk])) < 0.1) near += power[fi];
      double tshare = 0.0;
      for (std::size_t fi = 0; fi < freqs.size(); ++fi)
        if (std::fabs(std::log(freqs[fi] / freqs[pk])) < 0.1) tshare += 1.0;
      out.where.push_back({"frequency", fmt(freqs[pk], "Hz"), freqs[pk] * 0.9, freqs[pk] * 1.1, near / total,
                           tshare / static_cast<double>(freqs.size())});
    }
  }
  std::stable_sort(out.where.begin(), out.where.end(), [](const WhereEntry& a, const WhereEntry& b) {
    return a.share - a.time_share > b.share - b.time_share;
  });
  if (opt.progress) opt.progress(1.0);
  return out;
}

nlohmann::json to_json(const DiagnoseResult& r) {
  nlohmann::json j;
  if (!r.error.empty()) {
    j["error"] = r.error;
    return j;
  }
  j["effect"] = {{"kind", r.effect}, {"parameters", r.effect_parameters.is_null() ? nlohmann::json::object() : r.effect_parameters}};
  for (auto it = r.effect_parameters.begin(); r.effect_parameters.is_object() && it != r.effect_parameters.end(); ++it)
    j["effect"][it.key()] = it.value();
  j["heldout"] = {{"rms_base_N", r.rms_base_N}, {"rms_augmented_N", r.rms_augmented_N},
                  {"closed_fraction", r.closed_fraction},
                  {"gap_ratio", r.noise_floor_N > 0 ? r.rms_base_N / r.noise_floor_N : 0.0},
                  {"blocks", r.blocks_heldout}};
  j["noise_floor_N"] = r.noise_floor_N;
  nlohmann::json w = nlohmann::json::array();
  for (const auto& e : r.where)
    w.push_back({{"domain", e.domain}, {"range", e.range}, {"lo", e.lo}, {"hi", e.hi}, {"share", e.share}, {"time_share", e.time_share}});
  j["where"] = w;
  nlohmann::json c = nlohmann::json::array();
  for (const auto& x : r.candidates)
    c.push_back({{"kind", x.kind}, {"parameters", x.parameters}, {"heldout_rms_N", x.heldout_rms_N},
                 {"closed_fraction", x.closed_fraction}, {"t_statistic", x.t_statistic},
                 {"significant", x.significant}, {"indistinguishable", x.indistinguishable}, {"note", x.note}});
  j["candidates"] = c;
  nlohmann::json ind = nlohmann::json::array();
  for (const auto& x : r.candidates)
    if (x.indistinguishable) ind.push_back({{"kind", x.kind}, {"note", x.note}, {"parameters", x.parameters}});
  j["indistinguishable"] = ind;
  j["base_model"] = to_json(r.base);
  j["timing"] = {{"force_lag_s", r.force_lag_s},
                 {"lag_beyond_conventions_s", r.lag_beyond_conventions_s},
                 {"convention_force_delay_limit_periods", convention_force_delay_limit()},
                 {"rule", "the base model takes the force lag only as far as logging conventions explain it (force delay "
                          "within +-convention_force_delay_limit_periods); the rest is left to the delay candidate"}};
  j["split"] = {{"method", "time folds of two motion cycles or more, edges in dwells; odd folds held out"},
                {"folds", r.folds}, {"blocks_identification", r.blocks_identification},
                {"blocks_heldout", r.blocks_heldout}};
  return j;
}

std::string summary(const DiagnoseResult& r) {
  std::ostringstream o;
  if (!r.error.empty()) return "error: " + r.error + "\n";
  char buf[300];
  std::snprintf(buf, sizeof buf, "held-out gap: RMS %.3g N (noise floor %.3g N, ratio %.2f) over %zu blocks\n",
                r.rms_base_N, r.noise_floor_N, r.noise_floor_N > 0 ? r.rms_base_N / r.noise_floor_N : 0.0, r.blocks_heldout);
  o << buf;
  o << "effect: " << r.effect;
  if (r.effect_parameters.is_object() && !r.effect_parameters.empty()) o << " " << r.effect_parameters.dump();
  o << "\n";
  if (r.effect != "none" && r.effect != "unexplained") {
    std::snprintf(buf, sizeof buf, "  adding it: held-out RMS %.3g -> %.3g N, closes %.0f %% of the excess over the noise floor\n",
                  r.rms_base_N, r.rms_augmented_N, 100.0 * r.closed_fraction);
    o << buf;
  }
  o << "where the residual lies (share of held-out residual energy vs share of time):\n";
  for (std::size_t i = 0; i < r.where.size() && i < 4; ++i) {
    std::snprintf(buf, sizeof buf, "  %-20s %-28s %5.1f %% of energy in %5.1f %% of time\n", r.where[i].domain.c_str(),
                  r.where[i].range.c_str(), 100 * r.where[i].share, 100 * r.where[i].time_share);
    o << buf;
  }
  o << "candidates (held-out RMS, t statistic, share of excess closed):\n";
  for (const auto& c : r.candidates) {
    std::snprintf(buf, sizeof buf, "  %-22s %8.3g N  t %7.1f  closes %6.1f %%%s%s\n", c.kind.c_str(), c.heldout_rms_N,
                  c.t_statistic, 100 * c.closed_fraction, c.significant ? "  significant" : "",
                  c.indistinguishable ? "  indistinguishable from base" : "");
    o << buf;
  }
  for (const auto& c : r.candidates)
    if (c.indistinguishable && !c.note.empty()) o << "  note (" << c.kind << "): " << c.note << "\n";
  return o.str();
}

}  // namespace feedid::host
