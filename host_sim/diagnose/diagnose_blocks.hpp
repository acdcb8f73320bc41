// The diagnosis's observations and their regressors. A trace becomes time
// folds (odd ones held out), residual blocks of one direction inside a fold,
// and observations: pairs of adjacent blocks under a triangular weight.
// Every regressor is a column over the observations, built from two moments
// per block, so the candidate search scales with the blocks, not the
// samples (docs/diagnosis.md, "Cost"). Host only.
#pragma once
#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <type_traits>
#include <vector>

#include "identify/identify.hpp"

namespace feedid::host::diag {

using Vec = Eigen::VectorXd;
using Mat = Eigen::MatrixXd;

/// n values from lo to hi, evenly spaced in log (every grid of the diagnosis).
inline std::vector<double> log_grid(double lo, double hi, int n) {
  std::vector<double> g;
  for (int i = 0; i < n; ++i) g.push_back(lo * std::pow(hi / lo, static_cast<double>(i) / (n - 1)));
  return g;
}

/// Index of the grid value nearest v in log (positive values; 0 for an empty grid).
inline std::size_t nearest_in_log(const std::vector<double>& grid, double v) {
  std::size_t best = 0;
  for (std::size_t g = 0; g < grid.size(); ++g)
    if (std::fabs(std::log(grid[g] / v)) < std::fabs(std::log(grid[best] / v))) best = g;
  return best;
}

/// The grid values within `cells` places of the one nearest p, in grid
/// order: where a search looks again near an earlier best.
inline std::vector<double> grid_window(const std::vector<double>& grid, double p, std::size_t cells) {
  if (grid.empty()) return {};
  const std::size_t i = nearest_in_log(grid, p);
  return std::vector<double>(grid.begin() + static_cast<std::ptrdiff_t>(i - std::min(i, cells)),
                             grid.begin() + static_cast<std::ptrdiff_t>(std::min(grid.size(), i + cells + 1)));
}

/// Whether p, a search's result within grid_window(grid, first, cells), is
/// an edge of that window that is not an end of the grid: the least may
/// then lie beyond the window.
inline bool on_window_edge(const std::vector<double>& grid, double first, std::size_t cells, double p) {
  const std::vector<double> w = grid_window(grid, first, cells);
  return !w.empty() && ((p == w.front() && w.front() != grid.front()) || (p == w.back() && w.back() != grid.back()));
}

/// Time folds. Folds of fixed length alias with periodic motion (0.75 s
/// folds over a ladder whose strokes alternate every 0.75 s put every
/// positive stroke in the identification half), so each fold spans at
/// least two motion cycles and its edges sit in dwells where there are any.
/// Folds are laid on the time that holds data (gaps between pooled runs
/// and logger pauses taken out), so none falls into a gap; edges are
/// returned on the trace's clock.
struct Folds {
  std::vector<double> edges;  ///< interior edges, ascending (s)
  int of(double t) const;     ///< fold index of time t (0-based)
  int count() const { return static_cast<int>(edges.size()) + 1; }
  static bool heldout(int fold) { return fold % 2 == 1; }
};
Folds make_folds(const Signals& s, int max_folds, double v_min);

/// Moving stretch of one direction inside one fold, about block_s long.
/// Interval j runs from sample j to sample j + 1.
struct Block {
  std::size_t j0 = 0, j1 = 0;  ///< intervals [j0, j1)
  double t0 = 0.0, tau = 0.0;  ///< start time and length (s)
  int dir = 0;                 ///< +1 / -1
  int fold = 0;
};

/// An observation: blocks a and a + 1 under the weight w rising from 0 to 1
/// across a and falling back across a + 1. Under w, sum w dv telescopes to
/// the difference of the two blocks' mean velocities: no raw velocity
/// sample carries the inertia term (identify.cpp uses the same rule).
struct Observation {
  std::size_t a = 0;        ///< first block
  double t = 0.0;           ///< centre time (s)
  double x = 0.0, v = 0.0;  ///< mean position (m) and velocity (m/s)
  double area = 0.0;        ///< integral of w dt (s)
  double since_reversal = 0.0;  ///< distance since the last reversal at the start (m)
  double accel_change = 0.0;    ///< |a_end - a_start| (m/s^2)
  int dir = 0, fold = 0;
  bool heldout = false;
  bool beyond_identification = false;  ///< in a held-out fold but set aside (set_aside_beyond)
};

/// A stretch of one block (or of the time between blocks, block ==
/// kNoBlock) over which candidate regressors are evaluated as constant.
/// Fine segments of block_s / 5 (1 ms) hold a 2 mm ripple at 0.25 m/s
/// within 1 % and cost 8x less than samples at 8 kHz; coarse ones, a whole
/// block, serve the grid search that only has to find the right basin.
struct Segment {
  static constexpr std::size_t kNoBlock = static_cast<std::size_t>(-1);
  std::size_t block = kNoBlock;
  std::size_t j0 = 0;        ///< first interval
  double dt = 0.0;           ///< length (s)
  double t = 0.0;            ///< mid time (s)
  double t_rel = 0.0;        ///< mid time after the block's start (s)
  double t_start = 0.0;      ///< start (s)
  double x0 = 0.0, x1 = 0.0; ///< position at start and end (m)
  double v = 0.0;            ///< mean velocity (m/s)
  double rev0 = 0.0, rev1 = 0.0;      ///< distance since the last reversal, start and end (m)
  double start0 = 0.0, start1 = 0.0;  ///< ... since the last reversal or start from rest (m)
  double accel = 0.0;        ///< mean smoothed acceleration (m/s^2)
  std::size_t length = 0;    ///< index of dt among Observations::segment_lengths, exactly equal lengths one index
};

class Observations {
 public:
  /// Blocks of about block_s on the folds, paired into observations, and
  /// segments of about block_s / 5.
  Observations(const Signals& s, double v_min, double block_s, const Folds& folds);

  std::size_t size() const { return obs_.size(); }
  const std::vector<Observation>& obs() const { return obs_; }
  enum class Resolution { coarse, fine };
  /// Which observations a column is drawn on: all, or the identification
  /// folds' alone (in order; ColumnBank::identification_rows), which is
  /// all a search that only scores candidates reads. The held-out half's
  /// segments are then skipped: half the cost of a family's grid.
  enum class Rows { all, identification };
  /// How a family's columns are drawn.
  struct Draw {
    Resolution resolution = Resolution::fine;
    Rows rows = Rows::all;
  };
  const std::vector<Segment>& segments(Resolution r = Resolution::fine) const {
    return r == Resolution::fine ? fine_ : coarse_;
  }
  /// The distinct segment lengths (s) at resolution r, each once
  /// (Segment::length indexes them): a filter of the segments computes
  /// what depends on the length alone once per length. A logged clock's
  /// periods differ in their last bits (EMPS: 27 lengths in 25 s).
  const std::vector<double>& segment_lengths(Resolution r = Resolution::fine) const {
    return r == Resolution::fine ? fine_lengths_ : coarse_lengths_;
  }
  const Signals& signals() const { return s_; }
  /// Whether observation i is in an identification fold (as the
  /// observations were made: set_aside_beyond does not move it).
  bool identification(std::size_t i) const { return !Folds::heldout(obs_[i].fold); }
  std::size_t heldout_count() const;
  /// Takes the held-out observations whose prediction variance (in units of
  /// the noise variance) exceeds max_variance out of the held-out set; they
  /// lie where the identification folds do not reach. Returns how many.
  std::size_t set_aside_beyond(const Vec& prediction_variance, double max_variance);

  /// Column of w-weighted means of g(j) over each observation, g per interval j.
  template <typename G> Vec sample_column(G&& g, Rows rows = Rows::all) const {
    return sample_columns(1, [&g](std::size_t j, double* out) { out[0] = g(j); }, rows).col(0);
  }
  /// q columns at once from g(j, out[q]).
  template <typename G> Mat sample_columns(int q, G&& g, Rows rows = Rows::all) const {
    BlockSums sums(*this, q, rows);
    std::vector<double> value(static_cast<std::size_t>(q), 0.0);
    for (std::size_t b = 0; b < blocks_.size(); ++b) {
      if (!drawn(b, rows)) continue;
      for (std::size_t j = blocks_[b].j0; j < blocks_[b].j1; ++j) {
        g(j, value.data());
        sums.add(b, value.data(), interval_dt(j), interval_t(j) - blocks_[b].t0);
      }
    }
    return sums.columns();
  }
  /// The values of a segment g wrote, [first, end): a family whose
  /// columns are local says which (a spline's four of 2 (spans + 3)), and
  /// only they are summed.
  struct Band {
    int first = 0, end = 0;
  };
  /// b within [0, q], never inverted: a family's band cannot take the
  /// zeroing or the sums past its q values.
  static Band clamped(Band b, int q) {
    const int first = std::clamp(b.first, 0, q);
    return {first, std::clamp(b.end, first, q)};
  }
  /// Columns of w-weighted means of q values g(i, segment, out[q]) taken
  /// as constant over each segment. A stateful g (a filter) sees every
  /// segment in time order; otherwise only the segments of the blocks drawn.
  /// g returns nothing (it may write all q) or the Band it wrote.
  template <typename G> Mat segment_columns(int q, bool stateful, Draw draw, G&& g) const {
    BlockSums sums(*this, q, draw.rows);
    // g writes into zeros: the sums clear what they take (BlockSums::add),
    // and a segment only filtered, not summed, clears its band here.
    std::vector<double> buffer(static_cast<std::size_t>(q), 0.0);
    double* value = buffer.data();
    const std::vector<Segment>& segs = segments(draw.resolution);
    const auto visit = [&](std::size_t i, bool wanted) {
      const Segment& sg = segs[i];
      Band written{0, q};
      if constexpr (std::is_void_v<std::invoke_result_t<G&, std::size_t, const Segment&, double*>>) g(i, sg, value);
      else written = clamped(g(i, sg, value), q);
      if (wanted) sums.add(sg.block, value, sg.dt, sg.t_rel, written);
      else std::fill(value + written.first, value + written.end, 0.0);
    };
    if (stateful) {
      for (std::size_t i = 0; i < segs.size(); ++i) visit(i, segs[i].block != Segment::kNoBlock && drawn(segs[i].block, draw.rows));
    } else {
      for (const std::size_t i : drawn_segments_[draw.resolution == Resolution::fine][draw.rows == Rows::identification])
        visit(i, true);
    }
    return sums.columns();
  }

  double interval_dt(std::size_t j) const { return s_.t[j + 1] - s_.t[j]; }
  double interval_t(std::size_t j) const { return 0.5 * (s_.t[j + 1] + s_.t[j]); }
  double interval_v(std::size_t j) const { return 0.5 * (s_.v[j + 1] + s_.v[j]); }
  /// Force for interval j by the core's pairing rule.
  double interval_force(std::size_t j) const;
  /// Mean of the zero-phase low-passed force over [t0, t1] (linear between
  /// samples), searching from sample j: exact for a segment of any length.
  double lowpass_force_mean(double t0, double t1, std::size_t j) const;

 private:
  /// The observations' columns from per-block moments M0 = sum g dt and
  /// M1 = sum g (t - t0) dt, taken block by block as the values arrive
  /// (blocks in time order, each block's values together): an observation
  /// needs only its own two blocks' moments, so only the last block's are
  /// kept, not every block's for every column.
  class BlockSums {
   public:
    BlockSums(const Observations& o, int q, Rows rows)
        : o_(o), ending_row_(o.ending_row_[rows == Rows::all ? 0 : 1]), q_(static_cast<std::size_t>(q)), m_(3 * q_, 0.0),
          out_(Mat::Zero(static_cast<Eigen::Index>(rows == Rows::all ? o.obs_.size() : o.identification_obs_.size()), q)) {}
    /// g's q values into block b's moments, each cleared once taken (the
    /// caller's next values are written into zeros).
    void add(std::size_t b, double* g, double dt, double age) { add(b, g, dt, age, {0, static_cast<int>(q_)}); }
    /// The same where only `band` of g can be non-zero.
    void add(std::size_t b, double* g, double dt, double age, Band band) {
      if (b != block_) next_block(b);
      // Branch free, so that the loop vectorizes: a zero value adds +0,
      // which leaves every sum as it was (the sums start at +0).
      double* __restrict m0 = m_.data();
      double* __restrict m1 = m0 + q_;
      double* __restrict values = g;
      for (auto c = static_cast<std::size_t>(band.first); c < static_cast<std::size_t>(band.end); ++c) {
        const double v = values[c];
        values[c] = 0.0;
        m0[c] += v * dt;
        m1[c] += v * age * dt;
      }
    }
    Mat columns() {
      next_block(kNone);
      return std::move(out_);
    }

   private:
    static constexpr std::size_t kNone = static_cast<std::size_t>(-1);
    /// Closes the current block: the observation ending with it (its first
    /// block the one before) gets its values.
    void next_block(std::size_t b) {
      double* __restrict m0 = m_.data();
      double* __restrict m1 = m0 + q_;
      double* __restrict m1_before = m1 + q_;
      const Eigen::Index row = block_ != kNone ? ending_row_[block_] : -1;
      if (row >= 0 && before_ + 1 == block_) {
        // The observation's values and the moments' shift in one pass.
        const Triangle& w = o_.triangle_[o_.observation_ending_[block_]];
        double* out = out_.data() + row;
        const Eigen::Index stride = out_.rows();
        for (std::size_t c = 0; c < q_; ++c) {
          out[static_cast<Eigen::Index>(c) * stride] = w.rise * m1_before[c] + w.top * m0[c] + w.fall * m1[c];
          m1_before[c] = m1[c], m0[c] = m1[c] = 0.0;
        }
      } else {
        for (std::size_t c = 0; c < q_; ++c) m1_before[c] = m1[c], m0[c] = m1[c] = 0.0;
      }
      if (block_ != kNone) before_ = block_;
      block_ = b;
    }
    const Observations& o_;
    const std::vector<Eigen::Index>& ending_row_;
    std::size_t q_;
    std::vector<double> m_;  ///< the current block's M0 and M1, and the block before's M1, q each
    std::size_t block_ = kNone, before_ = kNone;
    Mat out_;
  };
  /// Whether block b is read by an observation on `rows`.
  bool drawn(std::size_t b, Rows rows) const { return rows == Rows::all || identification_block_[b]; }
  void make_blocks(double v_min, double block_s, const Folds& folds);
  void make_observations(const std::vector<double>& accel);
  std::vector<Segment> make_segments(const std::vector<double>& accel, double v_min, double segment_s) const;
  /// Sets each segment's length index; returns the distinct lengths.
  static std::vector<double> index_lengths(std::vector<Segment>& segments);

  const Signals& s_;
  feedid::ForcePairing<double> pairing_;
  std::vector<Block> blocks_;
  std::vector<Observation> obs_;
  /// Per observation, from_moments' weights of its blocks' moments (the
  /// divisions by the blocks' lengths and the area, done once).
  struct Triangle {
    std::size_t a;
    double rise, top, fall;  ///< of M1 of block a, M0 and M1 of block a + 1
  };
  std::vector<Triangle> triangle_;
  std::vector<std::size_t> identification_obs_;  ///< observations in identification folds, ascending
  std::vector<char> identification_block_;       ///< per block: read by one of them
  std::vector<std::size_t> observation_ending_;  ///< per block: the observation whose second block it is (or none)
  /// Per block, that observation's row in a column on all observations [0]
  /// and on the identification ones [1] (-1: none, or not on them).
  std::vector<Eigen::Index> ending_row_[2];
  std::vector<Segment> fine_, coarse_;
  std::vector<double> fine_lengths_, coarse_lengths_;
  /// The segments of drawn blocks, in time order: [fine][identification
  /// rows alone], so that a draw visits only the segments it sums.
  std::vector<std::size_t> drawn_segments_[2][2];
  void list_drawn_segments();
  double force_integral(double t, std::size_t& j) const;
  std::vector<double> force_lp_, force_integral_;  ///< per sample: low-passed force, its integral from the start
};

}  // namespace feedid::host::diag
