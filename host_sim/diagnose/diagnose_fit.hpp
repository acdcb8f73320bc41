// Least squares over the diagnosis's observations by cross products: the
// bank keeps every column's products with the others on the identification
// observations (computed on first use), so a fit on any subset of columns
// is a solve of its size, not a pass over the data. Host only.
#pragma once
#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <utility>
#include <vector>

#include "diagnose_blocks.hpp"

namespace feedid::host::diag {

struct LinearFit {
  Vec theta;            ///< coefficients, in the order the columns were given
  double ssr_id = 0.0;  ///< sum of squared residuals on the identification observations (N^2)
  bool ok = false;
};

class ColumnBank {
 public:
  /// y: the observed mean force; id: 1 for identification observations.
  ColumnBank(Vec y, std::vector<char> id);
  int add(Vec column);
  /// Bank column i on every observation.
  Vec column(int i) const;
  const Vec& y() const { return y_; }
  const std::vector<char>& id() const { return id_; }

  /// Columns not in the bank (a candidate on its grid), with their products
  /// with the bank columns `with`, which a fit may then combine them with.
  struct Extra {
    Mat cols;
    std::vector<int> with;
    Mat cross;  ///< with.size() x cols.cols()
    Mat gram;   ///< cols' own products
    Vec xty;
  };
  Extra extra(Mat cols, const std::vector<int>& with) const;

  /// Fit y on bank columns `cols` (then extra's, if given; cols must be in extra->with).
  LinearFit fit(const std::vector<int>& cols, const Extra* extra = nullptr) const;

  /// Rows of `cols` on the identification observations only, in order:
  /// all a fit reads of them. A search that only scores candidates (a
  /// family's grid) draws its columns there alone (Observations::Rows).
  Mat identification_rows(const Mat& cols) const;
  std::size_t identification_count() const { return id_rows_.size(); }

  /// A fit on bank columns `with`, held so that a search over many extra
  /// columns beside them (a family's grid) solves only for the extra ones:
  /// by the Schur complement of the held columns' products, the SSR of
  /// `with` plus extra is the held SSR less r' S^+ r, with
  /// S = X'X - C' G^+ C and r = X'y - C' theta (C: the extra's cross
  /// products). In exact arithmetic the same SSR as fit(with, &extra).
  struct Held {
    std::vector<int> with;
    Mat x_id;   ///< the held columns on the identification observations
    Mat g_inv;  ///< pseudo-inverse of the held columns' products
    double largest_eigenvalue = 0.0;  ///< of those products in correlation form
    LinearFit fit;
  };
  Held hold(const std::vector<int>& with) const;
  /// The identification SSR of the held fit with columns `cols_id` added,
  /// given on the identification observations alone (identification_rows);
  /// +infinity where either fit fails.
  double ssr_beside(const Held& held, const Mat& cols_id) const;
  /// A candidate's columns on the identification observations with what
  /// of their products does not depend on the held fit: their own and
  /// with y. A kept grid point (SearchColumns in diagnose.cpp) is scored
  /// beside many held fits, its own products taken once.
  struct Candidate {
    Mat cols_id;
    Mat gram;
    Vec xty;
  };
  Candidate candidate(Mat cols_id) const;
  /// ssr_beside of a candidate.
  double ssr_beside(const Held& held, const Candidate& c) const;
  /// Candidate columns that are differences of shared ones (edges: column
  /// b less column a), beside a held fit: the edges' products, from which
  /// each difference's SSR is read without drawing it. In exact arithmetic
  /// ssr_of_difference equals ssr_beside of the difference column.
  struct Edges {
    Mat cols_id;  ///< the edges on the identification observations
    Mat gram;     ///< their own products
    Mat s;        ///< gram less what the held columns explain of it
    Vec r;        ///< their products with y, less the held fit's
  };
  Edges edges_beside(const Held& held, Mat edges_id) const;
  /// The identification SSR of the held fit with edge b less edge a added:
  /// from the products where they resolve the difference, else (two edges
  /// alike on these observations, or their difference in the held span)
  /// from the difference column itself. The expansion's rounding grows
  /// with the held columns' condition (to 1e-7 of the SSR beside nearly
  /// collinear ones): a screen, which ssrs_of_differences completes.
  double ssr_of_difference(const Held& held, const Edges& e, Eigen::Index a, Eigen::Index b) const;
  /// ssr_beside of every difference (a, b) of `pairs`, to its bits where it
  /// matters: each screened by ssr_of_difference, then those within
  /// kRescoreMargin of the least read from their columns, so that the
  /// least and its ties are ssr_beside's own and equal columns tie exactly.
  std::vector<double> ssrs_of_differences(const Held& held, const Edges& e,
                                          const std::vector<std::pair<Eigen::Index, Eigen::Index>>& pairs) const;
  /// Relative distance from the least screened SSR within which a
  /// difference is read from its column: far above the expansion's
  /// rounding, far below the SSR differences a search tells apart.
  static constexpr double kRescoreMargin = 1e-5;
  /// y minus the fitted columns, on every observation.
  Vec residual(const std::vector<int>& cols, const Extra* extra, const Vec& theta) const;
  /// Leverage x_i' G^+ x_i of every observation under the fit on bank
  /// columns `cols` (G: their products on the identification observations):
  /// the variance of the fit's prediction there in units of the noise
  /// variance. Far above the identification observations' own (p / n), an
  /// observation lies where the identification data do not reach.
  Vec leverage(const std::vector<int>& cols) const;
  /// R^2 of each extra column regressed on bank columns `cols` (uncentred:
  /// the model has no intercept of its own); near 1: no new information.
  double max_collinearity(const std::vector<int>& cols, const Extra& extra) const;

 private:
  /// The held columns' products with each other (g) and with y (gy).
  void products(const std::vector<int>& cols, Mat& g, Vec& gy) const;
  /// Bank columns `cols` side by side.
  Mat gather(const std::vector<int>& cols) const;
  /// Column a on the given rows only.
  static Vec rows_of(const Vec& a, const std::vector<Eigen::Index>& rows);
  double gram(int i, int j) const;

  Vec y_, y_id_;
  std::vector<char> id_;
  /// The identification observations and the others, each ascending: the
  /// columns are kept in these two parts, each once. Every product reads
  /// the first alone.
  std::vector<Eigen::Index> id_rows_, other_rows_;
  double yty_ = 0.0;
  std::vector<Vec> cols_id_, cols_other_;
  std::vector<double> xty_;
  /// Lower triangle, NaN until used. Read and filled by concurrent
  /// candidate fits (diagnose's families in parallel); add() only between them.
  std::vector<std::unique_ptr<std::atomic<double>[]>> gram_;
};

/// Least squares from normal equations G theta = g, in correlation form (unit
/// diagonal) with eigenvalues below 1e-10 of the largest treated as zero:
/// exactly collinear columns (an offset beside Coulomb terms of both signs)
/// share their coefficient instead of blowing it up.
LinearFit solve_normal_equations(const Mat& g, const Vec& gy, double yty);
/// The same with g's pseudo-inverse already at hand.
LinearFit solve_with_inverse(const Mat& g_inv, const Mat& g, const Vec& gy, double yty);
/// Eigenvalues of the correlation-form products below this (relative to
/// the largest) are treated as zero.
inline constexpr double kNormalEquationsCut = 1e-10;
/// The pseudo-inverse that solve uses (correlation form, the same cut);
/// `largest`, if given, gets the largest eigenvalue of that form.
Mat pseudo_inverse_normal(const Mat& g, double* largest = nullptr);

/// Held-out improvement of a candidate over its noise-only spread, for n
/// held-out values in order, pair(k) = (r_cur, r_new) of the k-th. With
/// delta = r_cur - r_new (the candidate's predicted change, fitted on the
/// identification folds), the improvement is sum(2 r_new delta + delta^2);
/// where the candidate is wrong, r_new is noise and the sum's spread is
/// that of 2 r_new delta. That spread is taken from 20 contiguous groups of
/// held-out values (robust to correlation within a group). The spread of
/// the improvement itself (the old t statistic) grows with the effect, so a
/// strong effect scored t = 2.7. 0 with fewer than 30 values.
template <class Pair>
double improvement_z(std::size_t n, Pair pair) {
  const std::size_t groups = std::min<std::size_t>(20, n / 10);
  if (groups < 3) return 0.0;
  double gain = 0.0;
  std::vector<double> spread(groups, 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    const auto [cur, next] = pair(k);
    gain += cur * cur - next * next;
    spread[k * groups / n] += 2.0 * next * (cur - next);
  }
  double mean = 0.0, var = 0.0;
  for (double s : spread) mean += s / static_cast<double>(groups);
  for (double s : spread) var += (s - mean) * (s - mean);
  var *= static_cast<double>(groups) / static_cast<double>(groups - 1);
  return var > 0 ? gain / std::sqrt(var) : 0.0;
}

}  // namespace feedid::host::diag
