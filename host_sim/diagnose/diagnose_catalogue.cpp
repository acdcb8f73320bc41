#include "diagnose_catalogue.hpp"

#include "model/effects.hpp"
#include "phasor.hpp"

#include <algorithm>
#include <cmath>
#include <array>
#include <complex>
#include <cstdio>
#include <functional>
#include <memory>
#include <limits>
#include <utility>

namespace feedid::host::diag {

std::size_t run_of(const std::vector<double>& run_starts, double t) {
  const auto it = std::upper_bound(run_starts.begin(), run_starts.end(), t);
  return it == run_starts.begin() ? 0 : static_cast<std::size_t>(it - run_starts.begin()) - 1;
}

EdgeSet::EdgeSet(const std::function<std::pair<int, int>(double)>& edges_of, const std::vector<double>& ps) {
  for (const double p : ps) {
    const auto [a, b] = edges_of(p);
    edges.push_back(a);
    edges.push_back(b);
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
}

Eigen::Index EdgeSet::index(int edge) const {
  return static_cast<Eigen::Index>(std::lower_bound(edges.begin(), edges.end(), edge) - edges.begin());
}

namespace {

/// exp(x) for x <= 0, with what underflows to exactly 0 not sent to exp's
/// slow underflow path (a decay read far past its time constant: 4 % of
/// diagnose on a 25 s log).
double decay_exp(double x) { return x < -746.0 ? 0.0 : std::exp(x); }

/// Distance beyond which a decay is taken as over: exp(-40) = 4e-18 of
/// its start, below any force a log resolves. Most of presliding's
/// segments lie there, and their exps were a tenth of diagnose's time.
constexpr double kDecayOver = 40.0;

/// Mean of exp(-s/d) while s runs linearly from s0 to s1 (s >= 0).
double mean_decay(double s0, double s1, double d) {
  if (std::min(s0, s1) > kDecayOver * d) return 0.0;
  if (std::fabs(s1 - s0) < 1e-3 * d) return decay_exp(-0.5 * (s0 + s1) / d);
  return d * (decay_exp(-s0 / d) - decay_exp(-s1 / d)) / (s1 - s0);
}

double sign_of(const Segment& sg) { return sg.v > 0 ? 1.0 : -1.0; }

/// Columns of n parameter values drawn in one pass, q each, split back
/// into one matrix per value (EffectModel::columns_at_many).
std::vector<Mat> split_columns(const Mat& all, std::size_t n, Eigen::Index q) {
  std::vector<Mat> out;
  for (std::size_t j = 0; j < n; ++j) out.push_back(all.middleCols(static_cast<Eigen::Index>(j) * q, q));
  return out;
}

/// m's columns drawn several parameter values to a pass by `at`, and one
/// value as the one-element case of the same pass.
void draw_together(EffectModel& m, std::function<std::vector<Mat>(const std::vector<double>&, int, Observations::Draw)> at) {
  m.columns = [at](double p, int size, Observations::Draw r) { return at({p}, size, r).front(); };
  m.columns_at_many = std::move(at);
}

EffectModel offset_model(const Observations& obs) {
  EffectModel m;
  m.kind = effect_name(Effect::offset);
  m.keep_columns = EffectModel::Keep::from_first_draw;  // one column, the same at every step
  m.columns = [&obs](double, int, Observations::Draw r) {
    return obs.segment_columns(1, false, r, [](std::size_t, const Segment&, double* out) { out[0] = 1.0; });
  };
  m.parameters = [](double, int, const Vec& c, double) { return nlohmann::json{{"force_N", c(0)}}; };
  return m;
}

/// Means of sin(h k x) and cos(h k x), h = 1 .. harmonics, while x runs
/// linearly across a segment, for each of several k (a grid's periods):
/// mean e^{i h phi} = (e^{i h phi1} - e^{i h phi0}) / (i h (phi1 - phi0)),
/// the harmonics' phasors as powers of the fundamental's. Segments join,
/// so each end's phasors serve twice; the periods' phasors at one end are
/// taken side by side (unit_phasors).
class HarmonicMeans {
 public:
  HarmonicMeans(std::vector<double> ks, int harmonics)
      : k_(std::move(ks)), harmonics_(harmonics), re0_(k_.size()), im0_(k_.size()), re1_(k_.size()), im1_(k_.size()) {}
  /// out: per k, per harmonic, the sin and the cos mean.
  void operator()(const Segment& sg, double* out) {
    const std::size_t n = k_.size();
    if (sg.x0 != x_prev_) unit_phasors(k_.data(), sg.x0, n, re0_.data(), im0_.data());
    unit_phasors(k_.data(), sg.x1, n, re1_.data(), im1_.data());
    if (harmonics_ == 1) fundamentals(sg, out);
    else with_harmonics(sg, out);
    x_prev_ = sg.x1;
    re0_.swap(re1_);
    im0_.swap(im1_);
  }

 private:
  /// The fundamentals alone (a grid's search): with_harmonics' first
  /// harmonic, the same operations on each k, without the powers' complex
  /// products it would take and drop.
  void fundamentals(const Segment& sg, double* out) const {
    const double dx = sg.x1 - sg.x0;
    for (std::size_t j = 0; j < k_.size(); ++j) {
      const double dphi = k_[j] * dx, inv = 1.0 / dphi;
      const bool moved = std::fabs(dphi) > 1e-4;
      out[2 * j] = moved ? -(re1_[j] - re0_[j]) * inv : 0.5 * (im0_[j] + im1_[j]);
      out[2 * j + 1] = moved ? (im1_[j] - im0_[j]) * inv : 0.5 * (re0_[j] + re1_[j]);
    }
  }

  /// Every harmonic of every k: its phasors as powers of the fundamental's.
  void with_harmonics(const Segment& sg, double* out) const {
    for (std::size_t j = 0; j < k_.size(); ++j) {
      const std::complex<double> z0(re0_[j], im0_[j]), z1(re1_[j], im1_[j]);
      const double dphi = k_[j] * (sg.x1 - sg.x0);
      double* o = out + 2 * static_cast<std::ptrdiff_t>(j) * harmonics_;
      std::complex<double> p0 = z0, p1 = z1;
      for (int h = 1; h <= harmonics_; ++h, p0 *= z0, p1 *= z1) {
        // (p1 - p0) / (i h dphi), written out: one division, not the
        // complex division's library call or its two.
        const std::complex<double> rise = p1 - p0;
        const double inv = 1.0 / (h * dphi);
        const std::complex<double> mean = std::fabs(h * dphi) > 1e-4 ? std::complex<double>(rise.imag() * inv, -rise.real() * inv)
                                                                      : 0.5 * (p0 + p1);
        o[2 * (h - 1)] = mean.imag();
        o[2 * (h - 1) + 1] = mean.real();
      }
    }
  }

  std::vector<double> k_;
  int harmonics_;
  double x_prev_ = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> re0_, im0_, re1_, im1_;  ///< phasors at the segment's start and end, per k
};

/// Load force periodic in position, sum over h of A_h sin(2 pi h x / P +
/// phi_h): sin and cos columns per harmonic (size: harmonics). A cogging or
/// screw ripple is rarely one pure sine; the period is searched on the
/// fundamental alone (with harmonics, P and 2P would fit alike), then the
/// harmonics are chosen by their size-penalised error.
EffectModel ripple_model(const Observations& obs, const TraceExtent& e) {
  EffectModel m;
  m.kind = effect_name(Effect::position_ripple);
  // Fine up to a third of the travel, where three periods or more are seen
  // and a period's basin is narrow; coarser from there to three travels,
  // where it is wider than a grid step (14.7 %). A grid that stopped at a
  // third left a ripple of half the travel `unexplained` at a gap of 9
  // times the noise floor, and one of 0.7 of it named as compliance and
  // position friction. Beyond the travel a period is seen in part, and a
  // load that changes smoothly with position (a spring, a cable, a
  // counterweight) is drawn by it too: a spring's 60 N/m was `unexplained`,
  // and is closed to the noise at three travels.
  // (On a travel under 1.2 mm a third of it is below the shortest period,
  // 0.4 mm, and the grid is left as it was: nothing ascends past it.)
  const double shortest = std::max(4e-4, 1e-3 * e.travel);
  m.grid = log_grid(shortest, e.travel / 3.0, 160);
  if (e.travel / 3.0 > shortest) {
    const std::vector<double> long_periods = log_grid(e.travel / 3.0, 3.0 * e.travel, 17);
    m.grid.insert(m.grid.end(), long_periods.begin() + 1, long_periods.end());
  }
  m.continuous = true;
  m.sizes = {1, 2, 3};
  m.columns_per_size = 2;  // HarmonicMeans: harmonic h's pair the same for any count
  m.search_again_at_size = EffectModel::SearchAgain::no;  // at two harmonics 2P fits as P does: found with pooled runs in one order, not the other
  m.keep_columns = EffectModel::Keep::from_first_draw;
  // Several periods in one pass over the segments (the grid's), each its
  // own phasors.
  auto columns_at = [&obs](const std::vector<double>& ps, int harmonics, Observations::Draw r) {
    std::vector<double> ks;
    for (const double p : ps) ks.push_back(2.0 * M_PI / p);
    HarmonicMeans means(std::move(ks), harmonics);
    const int q = 2 * harmonics;
    const Mat all = obs.segment_columns(q * static_cast<int>(ps.size()), false, r,
                                        [&means](std::size_t, const Segment& sg, double* out) { means(sg, out); });
    return split_columns(all, ps.size(), q);
  };
  draw_together(m, columns_at);
  m.parameters = [travel = e.travel](double p, int harmonics, const Vec& c, double) {
    nlohmann::json j{{"period_m", p}, {"amplitude_N", std::hypot(c(0), c(1))}, {"phase_rad", std::atan2(c(1), c(0))}};
    if (harmonics > 1) {
      nlohmann::json amp = nlohmann::json::array(), phase = nlohmann::json::array();
      for (int h = 0; h < harmonics; ++h) {
        amp.push_back(std::hypot(c(2 * h), c(2 * h + 1)));
        phase.push_back(std::atan2(c(2 * h + 1), c(2 * h)));  // A_h sin(2 pi h x / P + phase_h): the replay draws them
      }
      j["harmonics"] = harmonics;
      j["harmonic_amplitudes_N"] = amp;
      j["harmonic_phases_rad"] = phase;
    }
    // Seen over less than one period, the period is less certain, and a
    // load that changes smoothly with position fits as such a ripple: the
    // report says so, and where the period is the search's end.
    if (p > 0.97 * 3.0 * travel)  // the grid's top (a travel under 1.2 mm has none: its grid ends below the travel)
      j["period_note"] = "at the top of the search range (three travels): a load that changes smoothly with position "
                         "over the travel (a spring, a cable, a counterweight), not a period the data resolve";
    else if (p > travel)
      j["period_note"] = "longer than the travel: seen over less than one period, so the period is less certain; a load "
                         "that changes smoothly with position (a spring, a cable, a counterweight) fits the same way";
    return j;
  };
  return m;
}

/// Uniform cubic B-splines over [x_lo, x_lo + travel] in `spans` spans:
/// spans + 3 functions, of which the four from `first` are non-zero at x.
struct SplineBasis {
  int first = 0;
  double w[4] = {0, 0, 0, 0};
  SplineBasis(double x, double x_lo, double travel, int spans) {
    const double u = std::clamp((x - x_lo) / travel * spans, 0.0, spans - 1e-9);
    first = static_cast<int>(u);
    const double t = u - first, t2 = t * t, t3 = t2 * t;
    w[0] = (1 - t) * (1 - t) * (1 - t) / 6.0;
    w[1] = (3 * t3 - 6 * t2 + 4) / 6.0;
    w[2] = (-3 * t3 + 3 * t2 + 3 * t + 1) / 6.0;
    w[3] = t3 / 6.0;
  }
};

/// Friction against the motion as a smooth function of position, one
/// profile per direction (a worn stretch of a guide, a tight nut, a wiper
/// that drags one way more than the other): each direction's B-spline
/// coefficients are its profile. Their sum is the direction's Coulomb
/// column, so the profile's level is the base model's; reported are the
/// profiles less their median, and the range where their mean departs by
/// more than half its extreme (x_min_m, x_max_m, delta_N).
nlohmann::json friction_profile(const Vec& c, int spans, double x_lo, double travel) {
  constexpr int points = 41;
  std::vector<double> x, f[2];
  for (int i = 0; i < points; ++i) {
    x.push_back(x_lo + travel * i / (points - 1));
    const SplineBasis b(x.back(), x_lo, travel, spans);
    for (int d = 0; d < 2; ++d) {
      double v = 0.0;
      for (int k = 0; k < 4; ++k) v += b.w[k] * c(d * (spans + 3) + b.first + k);
      f[d].push_back(v);
    }
  }
  auto less_median = [](std::vector<double>& v) {
    std::vector<double> sorted = v;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
    const double med = sorted[sorted.size() / 2];
    for (double& q : v) q -= med;
    return med;
  };
  // The medians are each direction's Coulomb change: the base model's own
  // when it is fitted, but a given model's (diagnose --model) keeps its
  // Coulomb force, and a replay of the profile needs them.
  const double level[2] = {less_median(f[0]), less_median(f[1])};
  std::vector<double> mean(points);
  std::size_t peak = 0;
  for (int i = 0; i < points; ++i) {
    mean[static_cast<std::size_t>(i)] = 0.5 * (f[0][static_cast<std::size_t>(i)] + f[1][static_cast<std::size_t>(i)]);
    if (std::fabs(mean[static_cast<std::size_t>(i)]) > std::fabs(mean[peak])) peak = static_cast<std::size_t>(i);
  }
  std::size_t a = peak, b = peak;
  while (a > 0 && std::fabs(mean[a - 1]) > 0.5 * std::fabs(mean[peak])) --a;
  while (b + 1 < mean.size() && std::fabs(mean[b + 1]) > 0.5 * std::fabs(mean[peak])) ++b;
  return {{"x_min_m", x[a]}, {"x_max_m", x[b]}, {"delta_N", mean[peak]}, {"shape", "spline"}, {"spans", spans},
          {"level_N", {{"positive", level[0]}, {"negative", level[1]}}},
          {"profile", {{"x_m", x}, {"positive_N", f[0]}, {"negative_N", f[1]}}}};
}

/// Extra friction against the motion that depends on position. Size 0: one
/// step on a contiguous range of the travel (200 cells, coarse ranges of 10
/// cells, then each edge moved cell by cell), the sharpest shape; sizes
/// above 0: a smooth profile per direction in that many spline spans
/// (friction_profile), for shapes a range cannot draw.
EffectModel position_friction_model(const Observations& obs, const TraceExtent& e) {
  constexpr int cells = 200, coarse = 10;
  EffectModel m;
  m.kind = effect_name(Effect::position_friction);
  m.sizes = {0, 4, 8, 16};
  for (int a = 0; a < cells; a += coarse)
    for (int b = a + coarse; b <= cells; b += coarse)
      if (!(a == 0 && b == cells)) m.grid.push_back(a * 1000 + b);
  // A range's code: its lower cell edge times 1000 plus its upper one.
  const auto edges_of = [](double code) { return std::pair<int, int>{static_cast<int>(code) / 1000, static_cast<int>(code) % 1000}; };
  auto range = [e, edges_of](double code) {
    const auto [a, b] = edges_of(code);
    return std::pair<double, double>{e.x_lo + e.travel * a / cells, e.x_lo + e.travel * b / cells};
  };
  // Size 0: the share of each segment inside a range, signed as the
  // motion: the share below its upper edge less that below its lower one
  // (a point on the lower edge is inside, one on the upper is not). A
  // search scores the 209 ranges from 21 edges (EffectModel::edges_of).
  auto edge_columns = [&obs, x_lo = e.x_lo, travel = e.travel](const std::vector<int>& edges, Observations::Draw r) {
    std::vector<double> at;
    for (const int k : edges) at.push_back(x_lo + travel * k / cells);
    return obs.segment_columns(static_cast<int>(at.size()), false, r, [&at](std::size_t, const Segment& sg, double* out) {
      const double lo = std::min(sg.x0, sg.x1), hi = std::max(sg.x0, sg.x1);
      for (std::size_t j = 0; j < at.size(); ++j) {
        const double below = hi - lo < 1e-12 ? (lo < at[j] ? 1.0 : 0.0) : std::clamp((at[j] - lo) / (hi - lo), 0.0, 1.0);
        out[j] = below * sign_of(sg);
      }
    });
  };
  m.edges_of = edges_of;
  m.edge_columns = edge_columns;
  auto ranges = [edge_columns, edges_of](const std::vector<double>& codes, Observations::Draw r) {
    const EdgeSet set(edges_of, codes);
    const Mat below = edge_columns(set.edges, r);
    std::vector<Mat> out;
    for (const double code : codes) {
      const auto [a, b] = edges_of(code);
      out.push_back(below.col(set.index(b)) - below.col(set.index(a)));
    }
    return out;
  };
  m.columns = [&obs, ranges, x_lo = e.x_lo, travel = e.travel](double code, int spans, Observations::Draw r) {
    if (spans > 0)
      return obs.segment_columns(2 * (spans + 3), false, r, [=](std::size_t, const Segment& sg, double* out) {
        const SplineBasis b(0.5 * (sg.x0 + sg.x1), x_lo, travel, spans);
        const int at = (sg.v > 0 ? 0 : spans + 3) + b.first;
        for (int k = 0; k < 4; ++k) out[at + k] = b.w[k] * sign_of(sg);
        return Observations::Band{at, at + 4};  // a spline is non-zero on four spans
      });
    return ranges(std::vector<double>{code}, r).front();
  };
  // The grid's ranges, several in one pass over the segments.
  m.columns_at_many = [ranges, columns = m.columns](const std::vector<double>& codes, int spans, Observations::Draw r) {
    if (spans == 0) return ranges(codes, r);
    std::vector<Mat> out;
    for (const double code : codes) out.push_back(columns(code, spans, r));
    return out;
  };
  m.parameters = [range, x_lo = e.x_lo, travel = e.travel](double code, int spans, const Vec& c, double) {
    if (spans > 0) return friction_profile(c, spans, x_lo, travel);
    const auto [xa, xb] = range(code);
    return nlohmann::json{{"x_min_m", xa}, {"x_max_m", xb}, {"delta_N", c(0)}, {"shape", "range"}};
  };
  m.refine = [edges_of](double code) {
    const auto [a, b] = edges_of(code);
    std::vector<double> out;
    for (int d = -coarse; d <= coarse; ++d) {
      if (a + d >= 0 && a + d < b) out.push_back((a + d) * 1000 + b);
      if (b + d > a && b + d <= cells) out.push_back(a * 1000 + b + d);
    }
    return out;
  };
  return m;
}

/// The warm-up's decay exp(-(t - t_run)/tc) on a segment: time counts from
/// the start of the segment's own run, the only clock a recording carries.
double drift_decay(const Segment& sg, const std::vector<double>& run_starts, double tc) {
  return decay_exp(-(sg.t - run_starts[run_of(run_starts, sg.t)]) / tc);
}

/// The decay's means over the moving segments of one run and direction
/// (dt-weighted, for the Coulomb term; v^2 dt-weighted, for the viscous
/// term: each the weight its term's least squares gives it).
struct DecayStats {
  double w = 0.0, w_vv = 0.0, sum = 0.0, sum_vv = 0.0;
  double mean() const { return w > 0 ? sum / w : 0.0; }
  double mean_vv() const { return w_vv > 0 ? sum_vv / w_vv : 0.0; }
};

/// Index of a segment's run and direction in decay_stats.
std::size_t run_direction(const Segment& sg, const std::vector<double>& run_starts) {
  return 2 * run_of(run_starts, sg.t) + (sg.v > 0 ? 0 : 1);
}

std::vector<DecayStats> decay_stats(const Observations& obs, Observations::Resolution r,
                                    const std::vector<double>& run_starts, double tc) {
  std::vector<DecayStats> st(2 * run_starts.size());
  for (const Segment& sg : obs.segments(r)) {
    if (sg.block == Segment::kNoBlock) continue;
    const double d = drift_decay(sg, run_starts, tc), vv = sg.v * sg.v;
    DecayStats& s = st[run_direction(sg, run_starts)];
    s.w += sg.dt, s.sum += d * sg.dt;
    s.w_vv += vv * sg.dt, s.sum_vv += d * vv * sg.dt;
  }
  return st;
}

/// Friction cannot push the axis along: with the drift's change added to
/// the level the trace measures (the base model's friction, fitted without
/// any effect: the run's mean), the friction force against the motion must
/// stay positive on every moving segment of every run, at that segment's
/// speed and time (where the measured friction is not positive itself, a
/// Coulomb estimate just below zero, the drift must not lower it further).
/// Anchoring at the measured level, not at the joint fit's warm asymptote,
/// matters: a time constant far beyond the run makes the decay nearly
/// constant, and the joint fit then trades a huge asymptote against a huge
/// change (-38 V "drift" against a 0.09 V Coulomb force on pooled SysId
/// files). A change larger than the friction itself fails this test; a
/// warm-up of the friction that is there never does.
/// Changes per direction (index 0 positive motion, 1 negative).
struct DriftChange {
  double viscous[2] = {0, 0}, coulomb[2] = {0, 0};
};

std::string drift_turns_friction_negative(const Observations& obs, const std::vector<double>& run_starts, double tc,
                                          const MeasuredFriction& f, const DriftChange& change) {
  const std::vector<DecayStats> st = decay_stats(obs, Observations::Resolution::fine, run_starts, tc);
  for (const Segment& sg : obs.segments(Observations::Resolution::fine)) {
    if (sg.block == Segment::kNoBlock) continue;
    const std::size_t k = run_direction(sg, run_starts);
    const double d = drift_decay(sg, run_starts, tc), speed = std::fabs(sg.v);
    const double measured = f.coulomb_N[k] + f.viscous_Ns_m[k] * speed;
    const std::size_t dir = k % 2;
    const double with_drift =
        measured + change.coulomb[dir] * (d - st[k].mean()) + change.viscous[dir] * (d - st[k].mean_vv()) * speed;
    if (with_drift < std::min(0.0, measured))
      return std::string("the friction change exceeds the friction the trace measures: friction against ") +
             (sg.v > 0 ? "positive" : "negative") + " motion would turn negative in run " + std::to_string(k / 2 + 1) +
             " at " + std::to_string(sg.t - run_starts[k / 2]) + " s";
  }
  return std::string();
}

/// Viscous and Coulomb friction decaying with time constant tc as the drive
/// warms, from the start of each run. Pooled runs (docs/diagnosis.md,
/// "Pooled runs"): the time between recordings is made up, so no drift
/// spans a run boundary; each run starts the decay afresh, with one
/// amplitude for all (the same warm-up each time the machine is started).
/// Each run's own friction level is in the base model (add_run_levels in
/// diagnose.cpp), so only the change within a run is read as drift.
/// Size 1: one change for both directions; size 2: a change per direction
/// (a seal or a preloaded nut warms differently each way).
EffectModel thermal_drift_model(const Observations& obs, const TraceExtent& e, const MeasuredFriction& friction) {
  EffectModel m;
  m.kind = effect_name(Effect::thermal_drift);
  m.friction_with_speed_or_time = true;
  m.grid = log_grid(std::max(1.0, 0.02 * e.longest_run_s), 5.0 * e.longest_run_s, 40);
  m.continuous = true;
  m.sizes = {1, 2};
  const bool pooled = e.run_starts.size() > 1;
  m.columns = [&obs, starts = e.run_starts](double tc, int per_direction, Observations::Draw r) {
    return obs.segment_columns(2 * per_direction, false, r, [&](std::size_t, const Segment& sg, double* out) {
      const double decay = drift_decay(sg, starts, tc);
      const int at = per_direction == 2 && sg.v < 0 ? 2 : 0;
      out[at] = sg.v * decay;
      out[at + 1] = sign_of(sg) * decay;
    });
  };
  m.parameters = [pooled](double tc, int per_direction, const Vec& c, double) {
    const int n = per_direction == 2 ? 2 : 0;  // offset of the negative direction's pair
    nlohmann::json p{{"time_constant_s", tc},
                     {"viscous_change_Ns_m", 0.5 * (c(0) + c(n))},
                     {"coulomb_change_N", 0.5 * (c(1) + c(n + 1))},
                     {"positive", {{"viscous_change_Ns_m", c(0)}, {"coulomb_change_N", c(1)}}},
                     {"negative", {{"viscous_change_Ns_m", c(n)}, {"coulomb_change_N", c(n + 1)}}}};
    if (pooled) p["time_origin"] = "the start of each run";
    return p;
  };
  m.implausible = [&obs, starts = e.run_starts, friction](const nlohmann::json& p, double) {
    DriftChange change;
    for (int d = 0; d < 2; ++d) {
      const nlohmann::json& side = p.at(d == 0 ? "positive" : "negative");
      change.viscous[d] = side.value("viscous_change_Ns_m", 0.0);
      change.coulomb[d] = side.value("coulomb_change_N", 0.0);
    }
    return drift_turns_friction_negative(obs, starts, p.value("time_constant_s", 1.0), friction, change);
  };
  return m;
}

/// Friction does not fall with speed above the Stribeck dip: with c2 added,
/// the slope of the friction against the motion, the measured viscous
/// coefficient plus 2 c2 |v|, must stay positive at every moving segment's
/// speed. A negative c2 that turns it is a stand-in for something else (on
/// EMPS PULSES, c2 = -1448 N s^2/m^2 took 58 N off at 0.2 m/s, where the
/// viscous friction is 41 N): named, it would tell the user to model a
/// drive whose friction falls as it speeds up.
std::string quadratic_turns_friction_downward(const Observations& obs, const std::vector<double>& run_starts, double c2,
                                              const MeasuredFriction& f) {
  if (!(c2 < 0.0)) return std::string();
  for (const Segment& sg : obs.segments(Observations::Resolution::fine)) {
    if (sg.block == Segment::kNoBlock) continue;
    const std::size_t k = run_direction(sg, run_starts);
    const double speed = std::fabs(sg.v), slope = f.viscous_Ns_m[k] + 2.0 * c2 * speed;
    if (slope < 0.0) {
      char buf[200];
      std::snprintf(buf, sizeof buf,
                    "friction would fall with speed against %s motion: the viscous slope %.3g N s/m plus 2 c2 v is "
                    "%.3g N s/m at %.3g m/s",
                    sg.v > 0 ? "positive" : "negative", f.viscous_Ns_m[k], slope, speed);
      return buf;
    }
  }
  return std::string();
}

/// c2 v|v|, at every interval (no grid, one pass).
EffectModel quadratic_viscous_model(const Observations& obs, const TraceExtent& e, const MeasuredFriction& friction) {
  EffectModel m;
  m.kind = effect_name(Effect::quadratic_viscous);
  m.friction_with_speed_or_time = true;
  m.keep_columns = EffectModel::Keep::from_first_draw;  // one column, the same at every step
  m.columns = [&obs](double, int, Observations::Draw r) {
    const Vec c = obs.sample_column([&obs](std::size_t j) {
      const double v = obs.interval_v(j);
      return v * std::fabs(v);
    }, r.rows);
    return Mat(c);
  };
  m.parameters = [](double, int, const Vec& c, double) { return nlohmann::json{{"c2", c(0)}, {"c2_unit", "N s^2/m^2"}}; };
  m.implausible = [&obs, starts = e.run_starts, friction](const nlohmann::json& p, double) {
    return quadratic_turns_friction_downward(obs, starts, p.value("c2", 0.0), friction);
  };
  return m;
}

/// Distances of presliding's elements, in units of the searched distance d
/// (size: how many): a Maxwell-slip ladder whose elements span a decade
/// and a half around d, as the asperities of a real contact do.
constexpr double kPreslidingElements[3] = {1.0, 4.0, 0.25};

/// Bristle friction that builds up over a distance d after a reversal.
/// Whether a stop also resets it depends on how the drive settles (a slip
/// back below one encoder quantum is a reversal no measurement shows), so
/// both readings are tried: p > 0 counts from the last reversal, p < 0 from
/// the last reversal or start from rest. Size: elements (kPreslidingElements),
/// each its own force; d is searched with one.
EffectModel presliding_model(const Observations& obs, const TraceExtent& e) {
  EffectModel m;
  m.kind = effect_name(Effect::presliding_hysteresis);
  m.fine_grid = true;  // it builds up within a few ms of a reversal: a whole block is too coarse
  m.keep_columns = EffectModel::Keep::from_first_draw;
  m.grid = log_grid(1e-6, std::min(2e-3, e.travel / 4), 40);
  m.sizes = {1, 2, 3};
  m.columns_per_size = 1;  // each element's decay its own
  const std::size_t n = m.grid.size();
  for (std::size_t i = 0; i < n; ++i) m.grid.push_back(-m.grid[i]);
  // Several distances in one pass over the segments (the grid's): a
  // segment far from its reversal adds nothing to any of them, and its
  // visit was most of a single distance's pass.
  auto columns_at = [&obs](const std::vector<double>& ps, int elements, Observations::Draw r) {
    const auto q = static_cast<std::size_t>(elements);
    return split_columns(
        obs.segment_columns(static_cast<int>(ps.size() * q), false, r,
                            [&ps, q](std::size_t, const Segment& sg, double* out) {
                              for (std::size_t j = 0; j < ps.size(); ++j)
                                for (std::size_t k = 0; k < q; ++k) {
                                  const double dk = std::fabs(ps[j]) * kPreslidingElements[k];
                                  const double decay = ps[j] > 0 ? mean_decay(sg.rev0, sg.rev1, dk)
                                                                 : mean_decay(sg.start0, sg.start1, dk);
                                  out[j * q + k] = -sign_of(sg) * decay;
                                }
                            }),
        ps.size(), elements);
  };
  draw_together(m, columns_at);
  m.parameters = [](double p, int elements, const Vec& c, double) {
    nlohmann::json j{{"distance_m", std::fabs(p)}, {"force_N", 0.5 * c(0)},
                     {"resets", p > 0 ? "at reversals" : "at reversals and starts from rest"}};
    if (elements > 1) {
      nlohmann::json list = nlohmann::json::array();
      double total = 0.0;
      for (int k = 0; k < elements; ++k) {
        list.push_back({{"distance_m", std::fabs(p) * kPreslidingElements[k]}, {"force_N", 0.5 * c(k)}});
        total += 0.5 * c(k);
      }
      j["elements"] = list;
      j["force_total_N"] = total;
    }
    return j;
  };
  m.refine = [](double p) {  // finer steps in d around the best, same reading
    std::vector<double> out;
    for (int i = -4; i <= 4; ++i) out.push_back(p * std::pow(1.05, i));
    return out;
  };
  m.implausible = [](const nlohmann::json& p, double) {
    return p.value("force_total_N", p.value("force_N", 0.0)) > 0.0 ? std::string()
                                                                     : std::string("friction would rise after a reversal");
  };
  return m;
}

/// Load acceleration a2 behind a spring and a damper to the motor,
/// m2 x2'' = k (x1 - x2) + c (x1' - x2'), so H(s) = (2 z w s + w^2)/(s^2 +
/// 2 z w s + w^2) of the motor's: discretised exactly for an acceleration
/// held over each segment (the state relaxes to y = a by Phi), whose step
/// at a segment's start the damper passes straight on as a step of the
/// load's jerk, 2 z w times it. Without that zero (a damper to ground) a
/// compliance at the family's own damping 0.05 left 3.2 times the noise
/// floor unexplained after its fit. Several resonances are stepped side by
/// side: independent recurrences the processor overlaps, where one after
/// the other each waited on its own latency.
class LoadFilters {
 public:
  struct Resonance {
    double w, z;  ///< rad/s, damping ratio
  };
  LoadFilters(const Observations& obs, Observations::Resolution r, const std::vector<Resonance>& res)
      : n_(res.size()), y_(res.size(), 0.0), yd_(res.size(), 0.0), jerk_gain_(res.size()) {
    // Phi once per distinct segment length (Observations::segment_lengths),
    // not an exp and a sincos per segment; a length's filters side by side.
    const std::vector<double>& lengths = obs.segment_lengths(r);
    phi_.resize(lengths.size() * n_);
    for (std::size_t k = 0; k < n_; ++k) {
      const double w = res[k].w, z = res[k].z;
      jerk_gain_[k] = 2.0 * z * w;
      const double wd = w * std::sqrt(1.0 - z * z);
      for (std::size_t l = 0; l < lengths.size(); ++l) {
        const double h = lengths[l], decay = std::exp(-z * w * h), c = std::cos(wd * h), s = std::sin(wd * h);
        phi_[l * n_ + k] = {decay * (c + z * w / wd * s), decay * s / wd, -decay * w * w / wd * s, decay * (c - z * w / wd * s)};
      }
    }
  }
  /// out[k]: filter k's mean load acceleration over the next segment less
  /// the motor's. Every segment of the resolution, in time order
  /// (Observations::segment_columns, stateful).
  void next(const Segment& sg, double* __restrict out) {
    const double a = sg.accel, step = started_ ? a - accel_before_ : 0.0;
    if (!started_) std::fill(y_.begin(), y_.end(), a);
    // Unaliased locals, so that the states stay in registers across the
    // filters (through `out` the compiler had to reload them).
    double* __restrict y = y_.data();
    double* __restrict yd = yd_.data();
    const double* __restrict gain = jerk_gain_.data();
    const Phi* __restrict phi = phi_.data() + sg.length * n_;
    for (std::size_t k = 0; k < n_; ++k) {
      const double e = y[k] - a, y0 = y[k], v = yd[k] + gain[k] * step;
      y[k] = a + phi[k].p11 * e + phi[k].p12 * v;
      yd[k] = phi[k].p21 * e + phi[k].p22 * v;
      out[k] = 0.5 * (y0 + y[k]) - a;
    }
    started_ = true;
    accel_before_ = a;
  }

 private:
  struct Phi {
    double p11, p12, p21, p22;
  };
  std::size_t n_;
  std::vector<Phi> phi_;  ///< per segment length, the n_ filters' transitions
  std::vector<double> y_, yd_, jerk_gain_;
  double accel_before_ = 0.0;
  bool started_ = false;
};

/// Damping ratios of the compliance's columns (size: how many). A mix of
/// responses at one frequency with a lighter and a heavier damping draws
/// the responses between them, so the damping is free while the fit stays
/// linear: 0.05 alone, then a lighter one (a bare steel structure rings at
/// 0.01 - 0.03). Not heavier: a heavily damped resonance above the motion's
/// frequencies is H(a) - a = -(2 zeta / w) da/dt, the jerk term of a delay,
/// with a plausible load mass (m2 = m d w / (2 zeta)); with a column at
/// zeta 0.5 a 2.5-period force delay was named as delay plus a 368 Hz
/// "compliance" that took half the delay.
constexpr double kComplianceDamping[2] = {0.05, 0.015};

/// Compliance: the base model misses m2 (a2 - a1). Size 1: damping ratio
/// 0.05; sizes 2, 3: a mix of kComplianceDamping (free damping). The
/// stiffness is free: the frequency is searched.
EffectModel compliance_model(const Observations& obs, const TraceExtent& e) {
  EffectModel m;
  m.kind = effect_name(Effect::compliance);
  const double f_top = std::min(0.25 * e.sample_rate_hz, 400.0);
  m.grid = log_grid(3.0, f_top, 50);
  m.continuous = true;
  m.fine_grid = true;
  m.keep_columns = EffectModel::Keep::from_first_draw;
  m.sizes = {1, 2};
  m.columns_per_size = 1;  // each damping's filter its own (LoadFilters)
  m.search_again_at_size = EffectModel::SearchAgain::near_first;  // the second damping shapes the same resonance
  // Each frequency's dampings, frequency by frequency: the columns of
  // several frequencies filtered in one pass.
  auto columns_at = [&obs](const std::vector<double>& fs, int dampings, Observations::Draw r) {
    std::vector<LoadFilters::Resonance> res;
    for (const double f : fs)
      for (int k = 0; k < dampings; ++k) res.push_back({2 * M_PI * f, kComplianceDamping[k]});
    LoadFilters filters(obs, r.resolution, res);
    const Mat all = obs.segment_columns(static_cast<int>(res.size()), true, r,
                                        [&filters](std::size_t, const Segment& sg, double* out) { filters.next(sg, out); });
    return split_columns(all, fs.size(), dampings);
  };
  draw_together(m, columns_at);
  // c = load mass m2 (summed over the dampings); free resonance
  // sqrt(k (m1 + m2) / (m1 m2)) with k = m2 w^2; the damping the mix
  // draws, as its coefficient-weighted ratio.
  m.parameters = [](double f, int dampings, const Vec& c, double mass_kg) {
    double m2 = 0.0, weighted = 0.0;
    for (int k = 0; k < dampings; ++k) m2 += c(k), weighted += c(k) * kComplianceDamping[k];
    const double m1 = mass_kg - m2;
    const double free = m1 > 0 && m2 > 0 ? f * std::sqrt(1.0 + m2 / m1) : f;
    nlohmann::json j{{"frequency_hz", free}, {"load_frequency_hz", f}, {"load_mass_kg", m2}};
    if (dampings > 1 && m2 != 0.0) j["damping_ratio"] = std::clamp(weighted / m2, kComplianceDamping[1], kComplianceDamping[0]);
    return j;
  };
  // A "compliance" with a negative load mass at the top of its frequency
  // grid is a delay in disguise: both look like jerk there.
  m.implausible = [f_top](const nlohmann::json& p, double mass_kg) {
    const double m2 = p.value("load_mass_kg", 0.0);
    if (!(m2 > 0.0) || !(m2 < mass_kg)) return std::string("load mass outside (0, m)");
    if (p.value("load_frequency_hz", 0.0) > 0.97 * f_top) return std::string("frequency at the top of the search range");
    return std::string();
  };
  return m;
}

/// The recorded force lags, u_rec(t) = u(t - d), so u_rec(t) = model(t) -
/// [u_rec(t + d) - u_rec(t)]: regressor u_f(t + d) - u_f(t) (coefficient
/// near -1), d by grid search. Exact for any d, unlike u - d du/dt.
EffectModel delay_model(const Observations& obs, const TraceExtent& e, double lag_beyond_conventions_s) {
  EffectModel m;
  m.kind = effect_name(Effect::delay);
  m.grid = log_grid(0.2 / e.sample_rate_hz, 25.0 / e.sample_rate_hz, 40);
  m.continuous = true;
  // Mean over the segment's interval ends (a half period after their middles).
  const double h = 0.5 / e.sample_rate_hz;
  // The unshifted mean does not depend on d: taken once per segment and
  // resolution, not at every delay tried (the walks to it were a twelfth of
  // diagnose on 10 minutes at 8 kHz). Taken here, so that columns() only
  // reads it: several threads may draw this family's columns at once.
  auto unshifted = std::make_shared<std::array<std::vector<double>, 2>>();
  for (const auto r : {Observations::Resolution::fine, Observations::Resolution::coarse}) {
    std::vector<double>& at = (*unshifted)[r == Observations::Resolution::fine ? 0 : 1];
    for (const Segment& sg : obs.segments(r)) at.push_back(obs.lowpass_force_mean(sg.t_start + h, sg.t_start + sg.dt + h, sg.j0));
  }
  // Several shifts in one pass over the segments (the grid's).
  auto columns_at = [&obs, h, unshifted = std::shared_ptr<const std::array<std::vector<double>, 2>>(unshifted)](
                        const std::vector<double>& ds, int, Observations::Draw r) {
    const std::vector<double>& at = (*unshifted)[r.resolution == Observations::Resolution::fine ? 0 : 1];
    return split_columns(obs.segment_columns(static_cast<int>(ds.size()), false, r,
                                             [&obs, &at, &ds, h](std::size_t i, const Segment& sg, double* out) {
                                               const double a = sg.t_start + h, b = sg.t_start + sg.dt + h;
                                               for (std::size_t j = 0; j < ds.size(); ++j)
                                                 out[j] = obs.lowpass_force_mean(a + ds[j], b + ds[j], sg.j0) - at[i];
                                             }),
                         ds.size(), 1);
  };
  draw_together(m, columns_at);
  // For a force smooth on the scale of d only c*d is identified (c d du/dt): -c*d is the delay.
  m.parameters = [](double d, int, const Vec& c, double) {
    return nlohmann::json{{"delay_s", -c(0) * d}, {"shift_s", d}, {"coefficient", c(0)}};
  };
  // The timing search keeps the base model's lag within what logging
  // conventions explain; only a lag it found beyond them is a delay. A
  // smaller one is the lag estimate's own error, not a physical effect.
  m.implausible = [lag_beyond_conventions_s](const nlohmann::json& p, double) {
    if (!(lag_beyond_conventions_s > 0.0)) return std::string("the force lag is within what logging conventions explain");
    return p.value("delay_s", 0.0) > 0.0 ? std::string() : std::string("recorded force would lead the motion");
  };
  return m;
}

}  // namespace

TraceExtent trace_extent(const Observations& obs, const std::vector<double>& run_starts) {
  const Signals& s = obs.signals();
  TraceExtent e;
  const auto [lo, hi] = std::minmax_element(s.x.begin(), s.x.end());
  e.x_lo = *lo;
  e.travel = std::max(*hi - *lo, 1e-6);
  e.t0 = s.t.front();
  e.duration = s.t.back() - s.t.front();
  e.sample_rate_hz = s.sample_rate_hz;
  e.run_starts = {e.t0};
  for (double t : run_starts)
    if (t > e.run_starts.back()) e.run_starts.push_back(t);
  e.longest_run_s = 0.0;
  for (std::size_t r = 0; r < e.run_starts.size(); ++r) {
    // A run ends at its last sample: the next run's start less the made-up gap.
    const double end = r + 1 < e.run_starts.size()
                           ? *(std::lower_bound(s.t.begin(), s.t.end(), e.run_starts[r + 1]) - 1)
                           : s.t.back();
    e.longest_run_s = std::max(e.longest_run_s, end - e.run_starts[r]);
  }
  return e;
}

std::vector<EffectModel> effect_catalogue(const Observations& obs, const TraceExtent& e, double lag_beyond_conventions_s,
                                          const MeasuredFriction& friction) {
  return {offset_model(obs),          ripple_model(obs, e),    position_friction_model(obs, e),
          thermal_drift_model(obs, e, friction), quadratic_viscous_model(obs, e, friction), presliding_model(obs, e),
          compliance_model(obs, e),    delay_model(obs, e, lag_beyond_conventions_s)};
}

}  // namespace feedid::host::diag
