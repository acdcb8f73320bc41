#include "diagnose_blocks.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "signals/filters.hpp"

namespace feedid::host::diag {

int Folds::of(double t) const {
  return static_cast<int>(std::upper_bound(edges.begin(), edges.end(), t) - edges.begin());
}

namespace {

int direction(double v, double v_min) { return v >= v_min ? 1 : (v <= -v_min ? -1 : 0); }

/// A clock that runs only while there is data: each gap (another run, a
/// logger pause: Signals::gap_before) counts as one sample period. Without
/// gaps it is the trace's own clock, to the bit.
struct DataClock {
  std::vector<double> tau;    ///< data time of each sample (s)
  std::vector<double> shift;  ///< t - tau of each sample: the gap time before it (s)
  explicit DataClock(const Signals& s) : tau(s.t), shift(s.t.size(), 0.0) {
    for (std::size_t k = 1; k < s.t.size(); ++k) {
      shift[k] = shift[k - 1] + (s.gap_before(k) ? s.t[k] - s.t[k - 1] - s.period_s() : 0.0);
      tau[k] = s.t[k] - shift[k];
    }
  }
  /// Trace time of data time u; inside a gap's one period, in the gap.
  double trace_time(double u) const {
    const std::size_t k = std::min<std::size_t>(std::upper_bound(tau.begin(), tau.end(), u) - tau.begin(), tau.size() - 1);
    return u + shift[k];
  }
};

/// Median data time between reversals of the motion (s); 0 if it never
/// reverses. A run starts with no direction: one that moves the other way
/// than the run before has not reversed.
double median_half_cycle(const Signals& s, const DataClock& c, double v_min) {
  std::vector<double> halves;
  int dir = 0;
  double since = c.tau.front();
  for (std::size_t k = 0; k < s.t.size(); ++k) {
    if (k > 0 && s.gap_before(k)) dir = 0;
    const int d = direction(s.v[k], v_min);
    if (d == 0 || d == dir) continue;
    if (dir != 0) halves.push_back(c.tau[k] - since);
    dir = d;
    since = c.tau[k];
  }
  if (halves.empty()) return 0.0;
  std::nth_element(halves.begin(), halves.begin() + static_cast<long>(halves.size() / 2), halves.end());
  return halves[halves.size() / 2];
}

/// Middles of dwells in data time: at least 20 ms slow with the position
/// within a few quanta (a slow stroke pauses between encoder counts; that
/// is not a dwell), inside one run.
std::vector<double> dwell_middles(const Signals& s, const DataClock& c, double v_min) {
  std::vector<double> rest;
  const double still = std::max(4.0 * s.position_quantum_m, 1e-9);
  for (std::size_t k = 0; s.has_position && k < s.t.size();) {
    if (std::fabs(s.v[k]) >= v_min) {
      ++k;
      continue;
    }
    const std::size_t a = k;
    while (k < s.t.size() && (k == a || !s.gap_before(k)) && std::fabs(s.v[k]) < v_min &&
           std::fabs(s.x[k] - s.x[a]) <= still)
      ++k;
    if (c.tau[k - 1] - c.tau[a] >= 0.02) rest.push_back(0.5 * (c.tau[a] + c.tau[k - 1]));
    k = std::max(k, a + 1);
  }
  return rest;
}

/// The acceleration for the compliance term and the force for the delay
/// term: zero-phase filters well above the motion's bandwidth.
double smoothing_cutoff_hz(const Signals& s) { return std::min(0.2 * s.sample_rate_hz, 300.0); }

}  // namespace

Folds make_folds(const Signals& s, int max_folds, double v_min) {
  // Folds are laid on the data clock: on the pooled one, with 10 s between
  // runs, held-out folds fell into the gaps ("0 held out").
  const DataClock clock(s);
  const double t0 = clock.tau.front(), duration = clock.tau.back() - t0;
  const double cycle = 2.0 * median_half_cycle(s, clock, v_min);
  int folds = max_folds;
  if (cycle > 0) folds = std::clamp(static_cast<int>(duration / (2.0 * cycle)), std::min(4, max_folds), max_folds);
  const double len = duration / folds;
  const std::vector<double> rest = dwell_middles(s, clock, v_min);
  Folds f;
  for (int i = 1; i < folds; ++i) {
    const double nominal = t0 + i * len;
    double edge = nominal, best = 0.5 * len;
    const auto it = std::lower_bound(rest.begin(), rest.end(), nominal);
    if (it != rest.end() && *it - nominal < best) {
      best = *it - nominal;
      edge = *it;
    }
    if (it != rest.begin() && nominal - *(it - 1) < best) edge = *(it - 1);
    edge = clock.trace_time(edge);
    if (f.edges.empty() || edge > f.edges.back()) f.edges.push_back(edge);
  }
  return f;
}

Observations::Observations(const Signals& s, double v_min, double block_s, const Folds& folds)
    : s_(s), pairing_(s.pairing()) {
  const double fc = smoothing_cutoff_hz(s);
  const std::vector<double> accel = central_difference(filtfilt_butter4(s.v, fc, s.sample_rate_hz), s.t);
  force_lp_ = filtfilt_butter4(s.u, fc, s.sample_rate_hz);
  force_integral_.assign(s.t.size(), 0.0);
  for (std::size_t k = 1; k < s.t.size(); ++k)
    force_integral_[k] = force_integral_[k - 1] + 0.5 * (force_lp_[k] + force_lp_[k - 1]) * (s.t[k] - s.t[k - 1]);
  make_blocks(v_min, block_s, folds);
  fine_ = make_segments(accel, v_min, block_s / 5.0);
  fine_lengths_ = index_lengths(fine_);
  make_observations(accel);
  coarse_ = make_segments(accel, v_min, 2.0 * block_s);
  coarse_lengths_ = index_lengths(coarse_);
  list_drawn_segments();
}

void Observations::list_drawn_segments() {
  for (const Resolution r : {Resolution::coarse, Resolution::fine}) {
    const std::vector<Segment>& segs = segments(r);
    for (const Rows rows : {Rows::all, Rows::identification}) {
      std::vector<std::size_t>& list = drawn_segments_[r == Resolution::fine][rows == Rows::identification];
      for (std::size_t i = 0; i < segs.size(); ++i)
        if (segs[i].block != Segment::kNoBlock && drawn(segs[i].block, rows)) list.push_back(i);
    }
  }
}

std::vector<double> Observations::index_lengths(std::vector<Segment>& segments) {
  std::vector<double> lengths;
  std::unordered_map<double, std::size_t> index;
  for (Segment& sg : segments) {
    const auto [it, added] = index.emplace(sg.dt, lengths.size());
    if (added) lengths.push_back(sg.dt);
    sg.length = it->second;
  }
  return lengths;
}

double Observations::interval_force(std::size_t j) const { return paired_force(s_.u, pairing_, j + 1, s_.stretch_start(j + 1)); }

double Observations::force_integral(double t, std::size_t& j) const {
  const std::vector<double>& ts = s_.t;
  const std::size_t n = ts.size();
  j = std::min(j, n - 1);
  // A jump by the sample rate first: the delay family asks for times up
  // to 25 periods past its hint, once per segment per delay tried. The
  // walks below then settle on the same sample as before.
  if (t > ts[j] && s_.sample_rate_hz > 0)
    j = std::min(n - 1, j + static_cast<std::size_t>((t - ts[j]) * s_.sample_rate_hz));
  while (j > 0 && ts[j] > t) --j;
  while (j + 1 < n && ts[j + 1] <= t) ++j;
  if (j + 1 >= n || t <= ts[j]) return force_integral_[j] + (t - ts[j]) * force_lp_[j];
  const double h = t - ts[j], slope = (force_lp_[j + 1] - force_lp_[j]) / (ts[j + 1] - ts[j]);
  return force_integral_[j] + h * (force_lp_[j] + 0.5 * slope * h);
}

double Observations::lowpass_force_mean(double t0, double t1, std::size_t j) const {
  const double a = force_integral(t0, j);
  return (force_integral(t1, j) - a) / (t1 - t0);
}

std::size_t Observations::set_aside_beyond(const Vec& prediction_variance, double max_variance) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < obs_.size(); ++i)
    if (obs_[i].heldout && prediction_variance(static_cast<Eigen::Index>(i)) > max_variance) {
      obs_[i].heldout = false;
      obs_[i].beyond_identification = true;
      ++n;
    }
  return n;
}

std::size_t Observations::heldout_count() const {
  return static_cast<std::size_t>(std::count_if(obs_.begin(), obs_.end(), [](const Observation& o) { return o.heldout; }));
}

void Observations::make_blocks(double v_min, double block_s, const Folds& folds) {
  Block b;
  bool open = false;
  auto close = [&](std::size_t j_end) {
    b.j1 = j_end;
    if (open && b.tau >= 0.5 * block_s) blocks_.push_back(b);
    open = false;
  };
  const std::size_t intervals = s_.t.size() - 1;
  for (std::size_t j = 0; j < intervals; ++j) {
    const int d = direction(interval_v(j), v_min);
    const int fold = folds.of(interval_t(j));
    const double dt = interval_dt(j);
    const bool gap = s_.gap_before(j + 1);
    if (open && (d != b.dir || fold != b.fold || gap)) close(j);
    if (d == 0 || gap) continue;  // no block holds the gap's interval
    if (!open) {
      b = Block{};
      b.j0 = j;
      b.t0 = s_.t[j];
      b.dir = d;
      b.fold = fold;
      open = true;
    }
    b.tau += dt;
    if (b.tau >= block_s) close(j + 1);
  }
  close(intervals);
}

void Observations::make_observations(const std::vector<double>& accel) {
  auto interval_accel = [&](std::size_t j) { return 0.5 * (accel[j] + accel[j + 1]); };
  // Distance since the last reversal at each block's start: its first fine segment's.
  std::vector<double> since_reversal(blocks_.size(), 0.0);
  for (auto it = fine_.rbegin(); it != fine_.rend(); ++it)
    if (it->block != Segment::kNoBlock) since_reversal[it->block] = it->rev0;
  for (std::size_t a = 0; a + 1 < blocks_.size(); ++a) {
    const Block& ba = blocks_[a];
    const Block& bb = blocks_[a + 1];
    if (bb.j0 != ba.j1 || bb.dir != ba.dir || bb.fold != ba.fold) continue;
    Observation o;
    o.a = a;
    o.t = bb.t0;
    o.x = 0.5 * (s_.x[ba.j0] + s_.x[bb.j1]);
    o.v = (s_.x[bb.j1] - s_.x[ba.j0]) / (ba.tau + bb.tau);
    if (!s_.has_position) {
      double sv = 0.0;
      for (std::size_t j = ba.j0; j < bb.j1; ++j) sv += interval_v(j) * interval_dt(j);
      o.v = sv / (ba.tau + bb.tau);
    }
    o.area = 0.5 * (ba.tau + bb.tau);
    o.since_reversal = since_reversal[a];
    o.accel_change = std::fabs(interval_accel(bb.j1 - 1) - interval_accel(ba.j0));
    o.dir = ba.dir;
    o.fold = ba.fold;
    o.heldout = Folds::heldout(ba.fold);
    obs_.push_back(o);
    // The triangle weight rises over block a and falls over block b.
    triangle_.push_back({a, 1.0 / (ba.tau * o.area), 1.0 / o.area, -1.0 / (bb.tau * o.area)});
  }
  identification_block_.assign(blocks_.size(), 0);
  observation_ending_.assign(blocks_.size(), static_cast<std::size_t>(-1));
  for (auto& rows : ending_row_) rows.assign(blocks_.size(), -1);
  for (std::size_t i = 0; i < obs_.size(); ++i) {
    const std::size_t b = obs_[i].a + 1;
    observation_ending_[b] = i;
    ending_row_[0][b] = static_cast<Eigen::Index>(i);
    if (!identification(i)) continue;
    ending_row_[1][b] = static_cast<Eigen::Index>(identification_obs_.size());
    identification_obs_.push_back(i);
    identification_block_[obs_[i].a] = identification_block_[b] = 1;
  }
}

std::vector<Segment> Observations::make_segments(const std::vector<double>& accel, double v_min, double segment_s) const {
  std::vector<Segment> segments;
  // Block of each interval, and where blocks start and end.
  std::size_t next_block = 0;
  std::size_t in_block = Segment::kNoBlock;
  int last_dir = 0;
  double x_rev = s_.x.empty() ? 0.0 : s_.x[0], x_start = x_rev;
  bool resting = true;
  Segment sg;
  std::size_t count = 0;
  double sum_v = 0.0, sum_a = 0.0, sum_t = 0.0;
  auto flush = [&](std::size_t j_end) {
    if (count == 0) return;
    sg.x1 = s_.x[j_end];
    sg.v = sum_v / sg.dt;
    sg.accel = sum_a / sg.dt;
    sg.t = sum_t / sg.dt;
    sg.t_rel = sg.block == Segment::kNoBlock ? 0.0 : sg.t - blocks_[sg.block].t0;
    segments.push_back(sg);
    count = 0;
  };
  const std::size_t intervals = s_.t.size() - 1;
  for (std::size_t j = 0; j < intervals; ++j) {
    if (in_block != Segment::kNoBlock && j == blocks_[in_block].j1) {
      flush(j);
      in_block = Segment::kNoBlock;
    }
    if (next_block < blocks_.size() && j == blocks_[next_block].j0) {
      flush(j);
      in_block = next_block++;
    }
    const double dt = interval_dt(j), vm = interval_v(j), xm = 0.5 * (s_.x[j] + s_.x[j + 1]);
    const int d = direction(vm, v_min);
    // A run starts as the trace does: no reversal or start from rest is
    // carried over the gap, nor the jump between the runs' positions.
    if (j > 0 && s_.gap_before(j)) last_dir = 0, resting = true;
    if (d != 0 && d != last_dir) x_rev = xm, last_dir = d;
    if (d != 0 && resting) x_start = xm;
    resting = d == 0;
    const double rev = std::fabs(xm - x_rev), start = std::min(rev, std::fabs(xm - x_start));
    if (count == 0) {
      sg = Segment{};
      sg.block = in_block;
      sg.j0 = j;
      sg.x0 = s_.x[j];
      sg.rev0 = rev;
      sg.start0 = start;
      sg.t_start = s_.t[j];
      sum_v = sum_a = sum_t = 0.0;
    }
    ++count;
    sg.dt += dt;
    sg.rev1 = rev;
    sg.start1 = start;
    sum_v += vm * dt;
    sum_a += 0.5 * (accel[j] + accel[j + 1]) * dt;
    sum_t += interval_t(j) * dt;
    if (sg.dt >= segment_s * (1.0 - 1e-9)) flush(j + 1);
  }
  flush(intervals);
  segments.shrink_to_fit();  // they are held to the end: at 1 ms each, the largest of the observations' parts
  return segments;
}

}  // namespace feedid::host::diag
