#include "batch_reference.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <cstddef>
#include <stdexcept>
#include <string>

namespace feedid::host {
namespace {

constexpr int kBands = feedid::Estimator<double>::bands;
constexpr int kCandidates = feedid::Estimator<double>::candidates;
using LD = long double;

/// A long double total and the total of the magnitudes of its terms.
struct Acc {
  LD value = 0.0L;
  LD magnitude = 0.0L;
  void add(LD x) { value += x; magnitude += std::fabs(x); }
  /// A product term a*b of two sums, with |a|*|b| as its magnitude.
  void add_product(const Acc& a, const Acc& b) {
    value += a.value * b.value;
    magnitude += a.magnitude * b.magnitude;
  }
  void add_product(LD a, LD b) { add_product(Acc{a, std::fabs(a)}, Acc{b, std::fabs(b)}); }
};

void store(const Acc& a, Sum<double>& value, Sum<double>& magnitude) {
  value.value = static_cast<double>(a.value);
  value.carry = 0.0;
  magnitude.value = static_cast<double>(a.magnitude);
  magnitude.carry = 0.0;
}

// ---------------------------------------------------------------- pass 1 --
/// An accepted sample.
struct Point {
  double v = 0.0, u = 0.0;
  double dt = 0.0;         ///< interval length ending here (with skipped time); 0 at a chain start
  bool chain_start = false;    ///< first sample with a velocity after a (re)start: no interval ends here
  bool position_only = false;  ///< from_position: first sample after a (re)start, gives x_prev only
};

/// An interval between two consecutive accepted samples of one chain.
struct Interval {
  std::size_t end = 0;      ///< index into points of the sample ending it
  double dt = 0.0;          ///< s
  double u = 0.0;           ///< interval force per ForceAlignment (N)
  double v = 0.0;           ///< mean velocity (m/s)
  double dv = 0.0;          ///< velocity change (m/s)
  double v_start = 0.0, v_end = 0.0;
  double speed = 0.0;
  bool moving = false;      ///< speed >= velocity_min: enters bands/windows
  int dir = 0;              ///< 0 positive, 1 negative (only if moving)
  int band = 0;
  bool steady = false;      ///< quasi-steady: enters the friction bands
  bool chain_first = false; ///< first interval after a chain start
};

bool finite(double x) { return std::isfinite(x); }

/// Validation and per-sample state. Sequential by nature (a sample is judged
/// against the last accepted one), but holds nothing but the previous
/// accepted sample and the skipped time.
///
/// With velocity from position, the first accepted sample after a (re)start
/// (stream start or a gap) gives only a position; the next accepted one is the
/// chain's start sample, v = (x - x_prev) / (its dt + skipped time), with no
/// interval and no velocity-jump test (there is no previous velocity). A gap
/// sample's velocity is not formed (no velocity across the gap): it only
/// restarts from its position.
std::vector<Point> validate(const std::vector<Sample<double>>& in, const Config<double>& c, Diagnostics& dg) {
  std::vector<Point> pts;
  pts.reserve(in.size());
  const bool from_x = c.velocity_source == VelocitySource::from_position;
  enum class Known { nothing, position, velocity };
  Known known = Known::nothing;  // what the last accepted sample provides
  double v_last = 0.0, x_last = 0.0, skipped = 0.0;
  for (const Sample<double>& s : in) {
    const bool have = known != Known::nothing;
    const double span = s.dt_s + skipped;
    // A gap (or the very first sample) restarts: nothing before it pairs with it.
    const bool restart = !have || span > c.max_gap_s;
    Status why = Status::ok;
    double v = 0.0;
    if (!finite(s.dt_s) || !finite(s.force_N) || !(from_x ? finite(s.position_m) : finite(s.velocity_m_s))) {
      why = Status::rejected_not_finite;
    } else if (have && !(s.dt_s > 0.0)) {
      why = Status::rejected_time_not_increasing;
    } else {
      if (!from_x) v = s.velocity_m_s;
      else if (!restart) v = (s.position_m - x_last) / span;
      if (!finite(v)) {
        why = Status::rejected_not_finite;
      } else if (std::fabs(v) > c.max_speed_m_s || std::fabs(s.force_N) > c.max_force_N) {
        why = Status::rejected_out_of_range;
      } else if (known == Known::velocity && !restart) {
        const double allowed = c.max_acceleration_m_s2 * span + 4.0 * c.velocity_resolution_m_s;
        if (std::fabs(v - v_last) > allowed) why = Status::rejected_velocity_jump;
      }
    }
    if (why != Status::ok) {
      ++dg.samples_rejected;
      switch (why) {
        case Status::rejected_not_finite: ++dg.rejected_not_finite; break;
        case Status::rejected_time_not_increasing: ++dg.rejected_time_not_increasing; break;
        case Status::rejected_out_of_range: ++dg.rejected_out_of_range; break;
        default: ++dg.rejected_velocity_jump; break;
      }
      if (have && finite(s.dt_s) && s.dt_s > 0.0) skipped += s.dt_s;
      continue;
    }
    ++dg.samples_accepted;
    skipped = 0.0;
    if (have && span > c.max_gap_s) ++dg.continuity_breaks;
    Point p;
    p.v = v;
    p.u = s.force_N;
    if (restart && from_x) {
      p.position_only = true;
      known = Known::position;
    } else if (restart || known == Known::position) {
      p.chain_start = true;
      known = Known::velocity;
    } else {
      p.dt = span;
    }
    v_last = v;
    x_last = s.position_m;
    pts.push_back(p);
  }
  return pts;
}

int band_of(const BatchLayout& layout, double speed) {
  // edge[j] <= speed < edge[j+1]; the top band also takes faster speeds.
  const double* first = layout.edge;
  const double* last = layout.edge + kBands + 1;
  const auto j = static_cast<int>(std::upper_bound(first, last, speed) - first) - 1;
  return std::clamp(j, 0, kBands - 1);
}

std::vector<Interval> intervals_of(const std::vector<Point>& pts, const Config<double>& c,
                                   const BatchLayout& layout) {
  std::vector<Interval> out;
  out.reserve(pts.size());
  std::size_t chain_begin = 0;
  ForcePairing<double> pairing;
  (void)pairing.init(c.force_lag_samples);
  for (std::size_t k = 0; k < pts.size(); ++k) {
    if (pts[k].position_only) continue;
    if (pts[k].chain_start) { chain_begin = k; continue; }
    Interval iv;
    iv.end = k;
    iv.dt = pts[k].dt;
    const std::size_t in_chain = k - chain_begin;  // >= 1
    iv.u = pairing.interval_force_in_chain([&](int age) { return pts[k - static_cast<std::size_t>(age)].u; },
                                           static_cast<int>(std::min<std::size_t>(in_chain, ForcePairing<double>::history)));
    iv.v_start = pts[k - 1].v;
    iv.v_end = pts[k].v;
    iv.v = 0.5 * (iv.v_start + iv.v_end);
    iv.dv = iv.v_end - iv.v_start;
    iv.speed = std::fabs(iv.v);
    iv.moving = iv.speed >= c.velocity_min_m_s;
    iv.dir = iv.v > 0.0 ? 0 : 1;
    iv.band = iv.moving ? band_of(layout, iv.speed) : 0;
    iv.steady = iv.moving && std::fabs(iv.dv) <= std::max(c.max_step_speed_ratio * iv.speed, 2.0 * c.velocity_resolution_m_s);
    iv.chain_first = in_chain == 1;
    out.push_back(iv);
  }
  return out;
}

// ---------------------------------------------------------------- pass 2 --
enum class SectionEnd { rest, reversal, gap, end_of_data };

struct Section {
  int dir = 0;
  std::size_t first = 0, last = 0;  ///< interval indices, inclusive
  SectionEnd end = SectionEnd::end_of_data;
  double duration = 0.0;            ///< running double sum of its intervals' dt
  bool at_reversal = false;         ///< opened at a reversal of the section before it
  bool from_rest = false;           ///< starts at rest (pass 2b)
  bool split = false;               ///< folded while open by max_fold_s (pass 5)
};

/// Hysteresis over each chain's velocity array, one decision per sample that
/// ends an interval (the first sample of a chain opens nothing). The interval
/// ending at a sample belongs to the section open once that sample's opening
/// and reversal rules have run; the rest rule runs after it, so the interval
/// whose end sample completes rest_samples is still in the section, while the
/// interval that reverses already belongs to the new section.
std::vector<Section> label_sections(const std::vector<Point>& pts, const std::vector<Interval>& ivs,
                                    const Config<double>& c, std::vector<int>& section_of) {
  std::vector<Section> secs;
  section_of.assign(ivs.size(), -1);
  const double enter = c.section_enter_m_s;
  int open = -1;  // index into secs
  unsigned below = 0;
  auto sign = [](int dir) { return dir == 0 ? 1.0 : -1.0; };
  for (std::size_t i = 0; i < ivs.size(); ++i) {
    if (ivs[i].chain_first && open >= 0) {  // the chain before ended at a gap
      secs[open].end = SectionEnd::gap;
      open = -1;
    }
    const double v = pts[ivs[i].end].v;
    if (open >= 0) {
      if (sign(secs[open].dir) * v <= -enter) {
        secs[open].end = SectionEnd::reversal;  // last stays at i-1
        open = -1;
        secs.push_back(Section{v > 0.0 ? 0 : 1, i, i});
        secs.back().at_reversal = true;
        open = static_cast<int>(secs.size()) - 1;
        below = 0;
      }
    } else if (std::fabs(v) >= enter) {
      secs.push_back(Section{v > 0.0 ? 0 : 1, i, i});
      open = static_cast<int>(secs.size()) - 1;
      below = 0;
    }
    if (open < 0) continue;
    Section& s = secs[open];
    s.last = i;
    s.duration += ivs[i].dt;
    section_of[i] = open;
    if (sign(s.dir) * v < c.velocity_min_m_s) {
      if (++below >= c.rest_samples) { s.end = SectionEnd::rest; open = -1; }
    } else {
      below = 0;
    }
  }
  // A section still open at the end stays end_of_data (solve() splits it).
  return secs;
}

/// Pass 2b: which sections start at rest. Within a chain, rest is seen at its
/// start sample if |v| < velocity_min there, at a later sample with
/// |v| < velocity_min when no section is open at that sample (tested before
/// the sample may open one), and after a section closes at rest; once seen it
/// holds until the chain ends. A section opened at a reversal starts at rest
/// (the velocity passed through zero); any other starts at rest iff rest was
/// seen in its chain up to its opening sample.
void mark_from_rest(const std::vector<Point>& pts, const std::vector<Interval>& ivs, const Config<double>& c,
                    const std::vector<int>& section_of, std::vector<Section>& secs) {
  const std::size_t n = ivs.size();
  // Section closed at rest by the sample ending interval i.
  std::vector<char> rest_close(n, 0);
  for (const Section& s : secs)
    if (s.end == SectionEnd::rest) rest_close[s.last] = 1;
  // seen[i]: rest seen in i's chain up to and including the rest test of the
  // sample ending i (which precedes that sample's opening test).
  std::vector<char> seen(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const Interval& iv = ivs[i];
    const bool open_before = !iv.chain_first && section_of[i - 1] >= 0 && !rest_close[i - 1];
    const bool rest_here = !open_before && std::fabs(pts[iv.end].v) < c.velocity_min_m_s;
    const bool before = iv.chain_first ? std::fabs(pts[iv.end - 1].v) < c.velocity_min_m_s  // start sample
                                       : (seen[i - 1] || rest_close[i - 1]);
    seen[i] = before || rest_here;
  }
  for (Section& s : secs) s.from_rest = s.at_reversal || seen[s.first];
}

// ---------------------------------------------------------------- pass 3 --
struct Window {
  int dir = 0;
  std::size_t first = 0, last = 0;  ///< interval indices, inclusive
};

std::vector<Window> cut_windows(const std::vector<Interval>& ivs, const Config<double>& c, uint32_t& counted) {
  std::vector<Window> out;
  bool active = false;
  Window w;
  double tau = 0.0;
  auto close = [&]() {
    if (active && w.last > w.first) out.push_back(w);  // at least two intervals
    active = false;
  };
  for (std::size_t i = 0; i < ivs.size(); ++i) {
    const Interval& iv = ivs[i];
    if (iv.chain_first) close();
    if (!iv.moving) { close(); continue; }
    if (active && w.dir != iv.dir) close();
    if (!active) { active = true; w = Window{iv.dir, i, i}; tau = 0.0; }
    w.last = i;
    tau += iv.dt;
    if (tau >= c.mass_window_s) close();
  }
  close();
  counted = static_cast<uint32_t>(out.size());
  return out;
}

// ---------------------------------------------------------------- pass 4 --
struct BandAcc {
  Acc time, speed, speed2, force, dvel;
};

void add_to_band(BandAcc& b, const Interval& iv) {
  const LD sgn = iv.dir == 0 ? 1.0L : -1.0L;
  const LD dt = iv.dt, sp = iv.speed;
  b.time.add(dt);
  b.speed.add(sp * dt);
  b.speed2.add(sp * sp * dt);
  b.force.add(sgn * iv.u * dt);
  b.dvel.add(sgn * iv.dv);
}

/// The result with the configuration as the core completes it (its own
/// check and defaults), the band layout and the Stribeck candidates.
BatchResult batch_setup(const Config<double>& cfg_in) {
  auto probe = std::make_unique<Estimator<double, kBands, kCandidates>>();
  if (probe->init(cfg_in) != Status::ok)
    throw std::invalid_argument(std::string("batch_compute: invalid config: ") + probe->config_error());
  BatchResult r;
  r.config = probe->config();
  r.layout.init(r.config.velocity_min_m_s, r.config.velocity_max_m_s);
  for (int i = 0; i < kCandidates; ++i)
    r.stats.vs_candidate[i] = r.magnitude.vs_candidate[i] = analysis::stribeck_candidate(r.config, i, kCandidates);
  return r;
}

/// Pass 4a: friction bands over every quasi-steady moving interval.
void store_bands(const std::vector<Interval>& ivs, BatchResult& r) {
  BandAcc bands[2][kBands];
  for (const Interval& iv : ivs)
    if (iv.steady) add_to_band(bands[iv.dir][iv.band], iv);
  for (int d = 0; d < 2; ++d)
    for (int j = 0; j < kBands; ++j) {
      BandSums<double>& bv = r.stats.band[d][j];
      BandSums<double>& bm = r.magnitude.band[d][j];
      store(bands[d][j].time, bv.time_s, bm.time_s);
      store(bands[d][j].speed, bv.speed, bm.speed);
      store(bands[d][j].speed2, bv.speed2, bm.speed2);
      store(bands[d][j].force, bv.force, bm.force);
      store(bands[d][j].dvel, bv.dvel, bm.dvel);
    }
}

/// Pass 4b: each window's velocity change projected on its bands' time,
/// speed and speed^2, and the mass sums.
void store_window_projections(const std::vector<Interval>& ivs, const std::vector<Window>& wins, BatchResult& r) {
  Acc proj[2][kBands][3];
  Acc dv_force[2], dv2[2], tau_dv2[2];
  for (const Window& w : wins) {
    const double sgn = w.dir == 0 ? 1.0 : -1.0;
    const double dvw = sgn * ivs[w.last].v_end - sgn * ivs[w.first].v_start;
    Acc t[kBands], s1[kBands], s2[kBands], force, tau;
    for (std::size_t i = w.first; i <= w.last; ++i) {
      const Interval& iv = ivs[i];
      const LD dt = iv.dt, sp = iv.speed;
      t[iv.band].add(dt);
      s1[iv.band].add(sp * dt);
      s2[iv.band].add(sp * sp * dt);
      force.add(LD(sgn) * iv.u * dt);
      tau.add(dt);
    }
    const Acc dvw_acc{dvw, std::fabs(dvw)};
    for (int j = 0; j < kBands; ++j) {
      if (t[j].magnitude == 0.0L) continue;
      proj[w.dir][j][0].add_product(dvw_acc, t[j]);
      proj[w.dir][j][1].add_product(dvw_acc, s1[j]);
      proj[w.dir][j][2].add_product(dvw_acc, s2[j]);
    }
    dv_force[w.dir].add_product(dvw_acc, force);
    dv2[w.dir].add_product(dvw_acc, dvw_acc);
    const LD dvw2 = LD(dvw) * dvw;
    tau_dv2[w.dir].add_product(tau, Acc{dvw2, dvw2});
  }
  for (int d = 0; d < 2; ++d) {
    for (int j = 0; j < kBands; ++j) {
      store(proj[d][j][0], r.stats.band[d][j].proj_time, r.magnitude.band[d][j].proj_time);
      store(proj[d][j][1], r.stats.band[d][j].proj_speed, r.magnitude.band[d][j].proj_speed);
      store(proj[d][j][2], r.stats.band[d][j].proj_speed2, r.magnitude.band[d][j].proj_speed2);
    }
    store(dv_force[d], r.stats.dir[d].win_dv_force, r.magnitude.dir[d].win_dv_force);
    store(dv2[d], r.stats.dir[d].win_dv2, r.magnitude.dir[d].win_dv2);
    store(tau_dv2[d], r.stats.dir[d].win_tau_dv2, r.magnitude.dir[d].win_tau_dv2);
  }
}

/// Pass 4c: interval totals and the force second differences (within a chain).
void store_totals_and_noise(const std::vector<Point>& pts, const std::vector<Interval>& ivs, BatchResult& r) {
  Acc time, d2sum;
  uint64_t d2n = 0;
  for (const Interval& iv : ivs) time.add(iv.dt);
  std::size_t chain_begin = 0;
  for (std::size_t k = 0; k < pts.size(); ++k) {
    if (pts[k].position_only) continue;  // not part of any chain (its next accepted sample starts one)
    if (pts[k].chain_start) chain_begin = k;
    if (k - chain_begin < 2) continue;
    const double d2 = pts[k].u - 2.0 * pts[k - 1].u + pts[k - 2].u;
    d2sum.add(LD(d2) * d2);
    ++d2n;
  }
  store(time, r.stats.total_interval_time, r.magnitude.total_interval_time);
  r.stats.interval_count = r.magnitude.interval_count = ivs.size();
  store(d2sum, r.stats.noise_d2, r.magnitude.noise_d2);
  r.stats.noise_count = r.magnitude.noise_count = d2n;
}

/// Pass 5: fold periods per direction, splits, and the paper points.
///
/// Events around interval i, in the order they happen: a gap folds both
/// directions before the next chain's first interval; a section opening
/// with interval i starts a fold period of its direction (before i is
/// summed); a quasi-steady interval adds to its direction's period, which
/// is folded as soon as it reaches max_fold_s (splitting the section open
/// during i if it has that direction); then a section ended by rest
/// closes (its rest test ran on the sample ending i); a section ended by
/// a reversal closes after i (its reversal test runs before the next
/// interval). A section open at a gap or at the end of data is split.
class SectionFolds {
 public:
  SectionFolds(const std::vector<Interval>& ivs, std::vector<Section>& secs, const std::vector<int>& section_of,
               BatchResult& r)
      : ivs_(ivs), secs_(secs), section_of_(section_of), r_(r), c_(r.config), dg_(r.diagnostics) {}

  void run() {
    std::vector<int> closes_after(ivs_.size(), -1), opens_at(ivs_.size(), -1);
    for (std::size_t s = 0; s < secs_.size(); ++s) {
      if (secs_[s].end == SectionEnd::rest || secs_[s].end == SectionEnd::reversal)
        closes_after[secs_[s].last] = static_cast<int>(s);
      opens_at[secs_[s].first] = static_cast<int>(s);
    }
    for (std::size_t i = 0; i < ivs_.size(); ++i) {
      const Interval& iv = ivs_[i];
      if (iv.chain_first && i > 0) {  // a gap: the chain before ended (its open section is split)
        fold(0, false);  // counted below: two folds per continuity break
        fold(1, false);
      }
      if (opens_at[i] >= 0) fold(secs_[opens_at[i]].dir);
      if (iv.steady) add_steady(i);
      if (closes_after[i] >= 0 && secs_[closes_after[i]].end == SectionEnd::rest)
        close_section(static_cast<std::size_t>(closes_after[i]));
      if (closes_after[i] >= 0 && secs_[closes_after[i]].end == SectionEnd::reversal)
        close_section(static_cast<std::size_t>(closes_after[i]));
    }
    count_splits_and_folds();
    store_sums();
  }

 private:
  void fold(int d, bool count = true) {
    duration_[d] = 0.0;
    if (count) ++dg_.folds;
  }

  void add_steady(std::size_t i) {
    const Interval& iv = ivs_[i];
    duration_[iv.dir] += iv.dt;
    if (duration_[iv.dir] < c_.max_fold_s) return;
    const int open = section_of_[i];  // open during interval i, even if it closes at rest after it
    if (open >= 0 && secs_[open].dir == iv.dir) secs_[open].split = true;
    fold(iv.dir);
  }

  void close_section(std::size_t sidx) {
    const Section& s = secs_[sidx];
    if (s.duration < c_.min_section_s) ++dg_.sections_short;
    else if (s.from_rest && !s.split) paper_point(s);
    fold(s.dir);
  }

  /// The paper's section point: integral u dt = Fc T + sigma V + Fs E over
  /// the section's own moving intervals of its direction (quasi-steady or
  /// not), and its mass equation terms sum u dv, sum dv^2/dt over the same.
  void paper_point(const Section& s) {
    const int d = s.dir;
    const LD sgn = d == 0 ? 1.0L : -1.0L;
    Acc t[kBands], v1[kBands], v2[kBands];
    Acc ts, vs, us, ua, aa;
    for (std::size_t i = s.first; i <= s.last; ++i) {
      const Interval& iv = ivs_[i];
      if (!iv.moving || iv.dir != d) continue;
      const LD dt = iv.dt, sp = iv.speed, um = sgn * iv.u, dvm = sgn * iv.dv;
      t[iv.band].add(dt);
      v1[iv.band].add(sp * dt);
      v2[iv.band].add(sp * sp * dt);
      ts.add(dt);
      vs.add(sp * dt);
      us.add(um * dt);
      ua.add(um * dvm);
      aa.add(dvm * dvm / dt);
    }
    if (!(ts.value > 0.0L)) return;
    for (int i = 0; i < kCandidates; ++i) {
      LD e = 0.0L;
      for (int j = 0; j < kBands; ++j)
        if (t[j].value > 0.0L)
          e += exp_integral_moments<double>(double(t[j].value), double(v1[j].value), double(v2[j].value),
                                            r_.stats.vs_candidate[i]);
      const Acc ea{e, std::fabs(e)};
      cand_[d][0][i].add_product(ea, ts);
      cand_[d][1][i].add_product(ea, vs);
      cand_[d][2][i].add_product(ea, us);
      cand_[d][3][i].add_product(ea, ea);
    }
    const Acc* pair[9][2] = {{&ts, &ts}, {&ts, &vs}, {&vs, &vs}, {&ts, &us}, {&vs, &us},
                             {&us, &us}, {&aa, &ua}, {&aa, &aa}, {&ua, &ua}};
    for (int k = 0; k < 9; ++k) sec_sums_[d][k].add_product(*pair[k][0], *pair[k][1]);
    ++r_.stats.dir[d].sections;
    ++dg_.sections_complete[d];
  }

  void count_splits_and_folds() {
    // Each section split at most once: by max_fold_s (any number of times),
    // by a gap, or still open at solve().
    for (const Section& s : secs_)
      if (s.split || s.end == SectionEnd::gap || s.end == SectionEnd::end_of_data) ++dg_.sections_split;
    // Two folds per gap (the validation pass counted the gaps) and two at solve().
    dg_.folds += 2u * dg_.continuity_breaks + 2u;
  }

  void store_sums() {
    for (int d = 0; d < 2; ++d) {
      DirectionSums<double, kCandidates>& sv = r_.stats.dir[d];
      DirectionSums<double, kCandidates>& sm = r_.magnitude.dir[d];
      Sum<double>* vals[9] = {&sv.sec_tt, &sv.sec_tv, &sv.sec_vv, &sv.sec_tu, &sv.sec_vu,
                              &sv.sec_uu, &sv.sec_xy, &sv.sec_xx, &sv.sec_yy};
      Sum<double>* mags[9] = {&sm.sec_tt, &sm.sec_tv, &sm.sec_vv, &sm.sec_tu, &sm.sec_vu,
                              &sm.sec_uu, &sm.sec_xy, &sm.sec_xx, &sm.sec_yy};
      for (int k = 0; k < 9; ++k) store(sec_sums_[d][k], *vals[k], *mags[k]);
      for (int i = 0; i < kCandidates; ++i) {
        store(cand_[d][0][i], sv.cand_et[i], sm.cand_et[i]);
        store(cand_[d][1][i], sv.cand_ev[i], sm.cand_ev[i]);
        store(cand_[d][2][i], sv.cand_eu[i], sm.cand_eu[i]);
        store(cand_[d][3][i], sv.cand_ee[i], sm.cand_ee[i]);
      }
      sm.sections = sv.sections;
    }
  }

  const std::vector<Interval>& ivs_;
  std::vector<Section>& secs_;
  const std::vector<int>& section_of_;
  BatchResult& r_;
  const Config<double>& c_;
  Diagnostics& dg_;
  double duration_[2] = {0.0, 0.0};  ///< quasi-steady time of the open fold period, per direction
  Acc sec_sums_[2][9];               ///< tt tv vv tu vu uu xy xx yy
  Acc cand_[2][4][kCandidates];      ///< et ev eu ee
};

}  // namespace

BatchResult batch_compute(const std::vector<Sample<double>>& samples, const Config<double>& cfg_in) {
  BatchResult r = batch_setup(cfg_in);
  const Config<double>& c = r.config;
  // Pass 1: accepted samples and intervals.
  const std::vector<Point> pts = validate(samples, c, r.diagnostics);
  const std::vector<Interval> ivs = intervals_of(pts, c, r.layout);
  // Pass 2: sections.
  std::vector<int> section_of;
  std::vector<Section> secs = label_sections(pts, ivs, c, section_of);
  mark_from_rest(pts, ivs, c, section_of, secs);
  // Pass 3: mass windows.
  const std::vector<Window> wins = cut_windows(ivs, c, r.diagnostics.mass_windows);
  // Pass 4: bands, window projections, totals.
  store_bands(ivs, r);
  store_window_projections(ivs, wins, r);
  store_totals_and_noise(pts, ivs, r);
  // Pass 5: folds, splits, paper points.
  SectionFolds(ivs, secs, section_of, r).run();
  return r;
}

BatchStatistics batch_statistics(const std::vector<Sample<double>>& samples, const Config<double>& cfg,
                                 Diagnostics* diag) {
  BatchResult r = batch_compute(samples, cfg);
  if (diag) *diag = r.diagnostics;
  return r.stats;
}

Estimate<double> batch_estimate(const std::vector<Sample<double>>& samples, const Config<double>& cfg,
                                Method method, Status* status) {
  const BatchResult r = batch_compute(samples, cfg);
  Estimate<double> e;
  e.method = method;
  const Status st = method == Method::paper ? analysis::solve_paper(r.stats, r.config, e)
                                            : analysis::solve_bands(r.stats, r.layout, r.config, e);
  if (status) *status = st;
  return e;
}

}  // namespace feedid::host
