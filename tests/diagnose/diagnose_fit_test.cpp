// The column bank's held fit. GIVEN a fit on some bank columns held once,
// WHEN extra columns are scored beside it (a family's grid search), THEN the
// SSR is the full joint fit's, also where an extra column lies in the held
// columns' span (it adds nothing) or the held columns are themselves
// collinear (an offset beside Coulomb terms of both signs).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "diagnose/diagnose_fit.hpp"

namespace feedid::test {
namespace {

using host::diag::ColumnBank;
using host::diag::Mat;
using host::diag::Vec;

struct Bank {
  ColumnBank bank;
  std::vector<int> with;
};

/// y = 2 a - b + 0.5 c + noise on 400 observations, a third of them held out.
Bank make_bank(bool collinear_held) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n01;
  const Eigen::Index n = 400;
  Vec a(n), b(n), c(n), y(n);
  std::vector<char> id(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) {
    a(i) = n01(rng), b(i) = std::sin(0.05 * static_cast<double>(i)), c(i) = n01(rng);
    y(i) = 2.0 * a(i) - b(i) + 0.5 * c(i) + 0.1 * n01(rng);
    id[static_cast<std::size_t>(i)] = i % 3 != 0;
  }
  Bank out{ColumnBank(y, id), {}};
  out.with.push_back(out.bank.add(a));
  out.with.push_back(out.bank.add(b));
  if (collinear_held) out.with.push_back(out.bank.add(a + b));
  return out;
}

double joint_ssr(const Bank& b, const Mat& cols) {
  const ColumnBank::Extra ex = b.bank.extra(cols, b.with);
  const host::diag::LinearFit f = b.bank.fit(b.with, &ex);
  return f.ok ? f.ssr_id : INFINITY;
}

TEST(DiagnoseFit, AHeldFitScoresExtraColumnsAsTheJointFit) {
  for (bool collinear : {false, true}) {
    Bank b = make_bank(collinear);
    const ColumnBank::Held held = b.bank.hold(b.with);
    const Vec& a = b.bank.column(b.with[0]);
    const Vec& s = b.bank.column(b.with[1]);
    Mat informative(a.size(), 2), in_span(a.size(), 1), mixed(a.size(), 2);
    for (Eigen::Index i = 0; i < a.size(); ++i) {
      informative(i, 0) = b.bank.y()(i) - 2.0 * a(i) + s(i);  // carries c: the SSR falls to the noise
      informative(i, 1) = std::cos(0.3 * static_cast<double>(i));
      in_span(i, 0) = 3.0 * a(i) - s(i);
      mixed(i, 0) = in_span(i, 0);
      mixed(i, 1) = informative(i, 0);
    }
    for (const Mat& cols : {informative, in_span, mixed}) {
      const double want = joint_ssr(b, cols);
      const double got = b.bank.ssr_beside(held, b.bank.identification_rows(cols));
      EXPECT_NEAR(got, want, 1e-9 * held.fit.ssr_id) << "collinear held columns: " << collinear;
    }
    // A column in the held span lowers nothing; the informative one does.
    EXPECT_NEAR(b.bank.ssr_beside(held, b.bank.identification_rows(in_span)), held.fit.ssr_id, 1e-9 * held.fit.ssr_id);
    EXPECT_LT(b.bank.ssr_beside(held, b.bank.identification_rows(informative)), 0.2 * held.fit.ssr_id);
  }
}

// A candidate column with a NaN fails as the joint fit does (it scored
// the held SSR, a finite number), also where the NaN is on a held-out row,
// and with nothing held the score is the candidate's own fit.
TEST(DiagnoseFit, ANonFiniteColumnFailsAndNothingHeldIsTheColumnsOwnFit) {
  Bank b = make_bank(false);
  const ColumnBank::Held held = b.bank.hold(b.with);
  Mat bad(b.bank.y().size(), 1);
  bad.col(0) = b.bank.column(b.with[0]);
  bad(7, 0) = NAN;
  const ColumnBank::Extra with_nan = b.bank.extra(bad, b.with);
  EXPECT_FALSE(b.bank.fit(b.with, &with_nan).ok);
  EXPECT_EQ(b.bank.ssr_beside(held, b.bank.identification_rows(bad)), INFINITY);

  // The same on a held-out row, which no product reads: the fit fails all
  // the same, where its residual would carry the NaN into the held-out error.
  Mat bad_heldout = bad;
  bad_heldout(7, 0) = b.bank.column(b.with[0])(7);
  bad_heldout(6, 0) = NAN;  // row 6: held out (every third)
  const ColumnBank::Extra with_nan_heldout = b.bank.extra(bad_heldout, b.with);
  EXPECT_FALSE(b.bank.fit(b.with, &with_nan_heldout).ok);
  Bank in_bank = make_bank(false);
  std::vector<int> cols = in_bank.with;
  cols.push_back(in_bank.bank.add(bad_heldout.col(0)));
  EXPECT_FALSE(in_bank.bank.fit(cols).ok);

  const ColumnBank::Held none = b.bank.hold({});
  Mat own(b.bank.y().size(), 2);
  own.col(0) = b.bank.column(b.with[0]);
  own.col(1) = b.bank.column(b.with[1]);
  const ColumnBank::Extra ex = b.bank.extra(own, {});
  const host::diag::LinearFit f = b.bank.fit({}, &ex);
  ASSERT_TRUE(f.ok);
  EXPECT_NEAR(b.bank.ssr_beside(none, b.bank.identification_rows(own)), f.ssr_id, 1e-9 * none.fit.ssr_id);
}

// Candidates that are differences of shared edge columns (position
// friction's ranges: the share below the upper edge less the share below
// the lower one) score from the edges' products as their drawn difference
// column does beside the same held fit: an informative one, one in the
// held span, one that is all zero on the identification rows, one that is
// zero but for a trace on one row (which the products cannot resolve), and
// with nothing held.
TEST(DiagnoseFit, DifferencesOfEdgesScoreAsTheirDrawnColumns) {
  for (bool collinear : {false, true}) {
    Bank b = make_bank(collinear);
    const Vec& a = b.bank.column(b.with[0]);
    const Vec& s = b.bank.column(b.with[1]);
    const Eigen::Index n = a.size();
    Mat edges(n, 5);
    for (Eigen::Index i = 0; i < n; ++i) {
      edges(i, 0) = std::cos(0.3 * static_cast<double>(i));
      edges(i, 1) = edges(i, 0) + b.bank.y()(i) - 2.0 * a(i) + s(i);  // 1 - 0 carries c
      edges(i, 2) = edges(i, 1) + 3.0 * a(i) - s(i);                  // 2 - 1 lies in the held span
      edges(i, 3) = edges(i, 2);                                      // 3 - 2 is zero
      edges(i, 4) = edges(i, 2) + (i == 4 ? 1e-9 : 0.0);              // 4 - 2 is zero but on row 4
    }
    for (const std::vector<int>& held_cols : {b.with, std::vector<int>{}}) {
      const ColumnBank::Held held = b.bank.hold(held_cols);
      const ColumnBank::Edges e = b.bank.edges_beside(held, b.bank.identification_rows(edges));
      for (const auto& [lo, hi] : {std::pair{0, 1}, {1, 2}, {2, 3}, {0, 3}, {1, 3}, {2, 4}, {0, 4}}) {
        const Mat diff = edges.col(hi) - edges.col(lo);
        const double want = b.bank.ssr_beside(held, b.bank.identification_rows(diff));
        EXPECT_NEAR(b.bank.ssr_of_difference(held, e, lo, hi), want, 1e-9 * b.bank.y().squaredNorm())
            << "edges " << lo << " to " << hi << ", collinear held columns: " << collinear << ", held " << held_cols.size();
      }
      EXPECT_EQ(b.bank.ssr_of_difference(held, e, 2, 3), held.fit.ssr_id);  // a zero column lowers nothing
    }
    const ColumnBank::Held held = b.bank.hold(b.with);
    const ColumnBank::Edges e = b.bank.edges_beside(held, b.bank.identification_rows(edges));
    EXPECT_LT(b.bank.ssr_of_difference(held, e, 0, 1), 0.2 * held.fit.ssr_id);
    EXPECT_NEAR(b.bank.ssr_of_difference(held, e, 1, 2), held.fit.ssr_id, 1e-9 * held.fit.ssr_id);
  }
}

// A NaN in an edge fails every difference that reads it, as the drawn column does.
TEST(DiagnoseFit, ANonFiniteEdgeFailsItsDifferences) {
  Bank b = make_bank(false);
  const ColumnBank::Held held = b.bank.hold(b.with);
  Mat edges(b.bank.y().size(), 3);
  edges.col(0) = b.bank.column(b.with[0]);
  edges.col(1) = 2.0 * edges.col(0);
  edges.col(2) = edges.col(1);
  edges(4, 2) = NAN;  // row 4: an identification row
  const ColumnBank::Edges e = b.bank.edges_beside(held, b.bank.identification_rows(edges));
  EXPECT_EQ(b.bank.ssr_of_difference(held, e, 1, 2), INFINITY);
  EXPECT_EQ(b.bank.ssr_of_difference(held, e, 0, 2), INFINITY);
  EXPECT_TRUE(std::isfinite(b.bank.ssr_of_difference(held, e, 0, 1)));
}

// Beside nearly collinear held columns (three close Stribeck-like
// columns) the expanded products round at 1e-7 of the SSR: the least and
// everything near it are read from their columns, to the bit of
// ssr_beside, so a search's choice and its ties are the drawn columns'.
TEST(DiagnoseFit, NearTheLeastDifferencesAreScoredFromTheirColumns) {
  std::mt19937 rng(5);
  std::normal_distribution<double> n01;
  const Eigen::Index n = 600;
  Vec y(n);
  std::vector<char> id(static_cast<std::size_t>(n));
  Mat held_cols(n, 3), edges(n, 12);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double x = static_cast<double>(i) / static_cast<double>(n);
    for (int k = 0; k < 3; ++k) held_cols(i, k) = std::exp(-std::pow(x / (0.30 + 0.001 * k), 2));
    for (int k = 0; k < 12; ++k) edges(i, k) = std::clamp((k / 11.0 - x) * 40.0, 0.0, 1.0);  // share below edge k
    y(i) = 3.0 * held_cols(i, 0) + 2.0 * (edges(i, 7) - edges(i, 4)) + 0.05 * n01(rng);
    id[static_cast<std::size_t>(i)] = i % 3 != 0;
  }
  ColumnBank bank(y, id);
  std::vector<int> with;
  for (int k = 0; k < 3; ++k) with.push_back(bank.add(held_cols.col(k)));
  const ColumnBank::Held held = bank.hold(with);
  const ColumnBank::Edges e = bank.edges_beside(held, bank.identification_rows(edges));
  std::vector<std::pair<Eigen::Index, Eigen::Index>> pairs;
  for (Eigen::Index a = 0; a < 12; ++a)
    for (Eigen::Index b = a + 1; b < 12; ++b) pairs.emplace_back(a, b);
  const std::vector<double> got = bank.ssrs_of_differences(held, e, pairs);
  std::vector<double> want;
  for (const auto& [a, b] : pairs) want.push_back(bank.ssr_beside(held, bank.identification_rows(Mat(edges.col(b) - edges.col(a)))));
  const std::size_t best = static_cast<std::size_t>(std::min_element(want.begin(), want.end()) - want.begin());
  EXPECT_EQ(pairs[best], (std::pair<Eigen::Index, Eigen::Index>{4, 7}));  // the range y carries
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    if (want[k] <= want[best] * (1.0 + 1e-6)) EXPECT_EQ(got[k], want[k]) << pairs[k].first << " to " << pairs[k].second;
    EXPECT_NEAR(got[k], want[k], 1e-6 * want[k]) << pairs[k].first << " to " << pairs[k].second;
  }
}

}  // namespace
}  // namespace feedid::test

namespace feedid::test {
namespace {

using host::diag::grid_window;
using host::diag::log_grid;
using host::diag::on_window_edge;

// GIVEN a log grid and a value between two of its points, WHEN a search
// looks again near it, THEN it gets the two places either side of the
// nearest point, fewer at the grid's ends, and only a result on the
// window's inner edge (not the grid's end) sends it to the whole grid.
TEST(DiagnoseGridWindow, TwoPlacesEitherSideOfTheNearestClippedAtTheEnds) {
  const std::vector<double> grid = log_grid(1.0, 1000.0, 31);  // 10 ** 0.1 a step
  const std::vector<double> mid = grid_window(grid, 1.1 * grid[10], 2);  // nearer grid[10] than grid[11]
  ASSERT_EQ(mid.size(), 5u);
  EXPECT_EQ(mid.front(), grid[8]);
  EXPECT_EQ(mid.back(), grid[12]);
  const std::vector<double> low = grid_window(grid, 0.5, 2);  // below the grid: its first point is nearest
  ASSERT_EQ(low.size(), 3u);
  EXPECT_EQ(low.front(), grid[0]);
  const std::vector<double> high = grid_window(grid, grid[29], 2);
  ASSERT_EQ(high.size(), 4u);
  EXPECT_EQ(high.back(), grid[30]);
  EXPECT_EQ(grid_window({5.0}, 3.0, 2), std::vector<double>{5.0});
  EXPECT_TRUE(grid_window({}, 3.0, 2).empty());

  EXPECT_TRUE(on_window_edge(grid, grid[10], 2, grid[8]));
  EXPECT_TRUE(on_window_edge(grid, grid[10], 2, grid[12]));
  EXPECT_FALSE(on_window_edge(grid, grid[10], 2, grid[10]));
  EXPECT_FALSE(on_window_edge(grid, grid[10], 2, 1.05 * grid[8]));  // Brent's step inside the window
  EXPECT_FALSE(on_window_edge(grid, grid[29], 2, grid[30]));        // the grid's own end
  EXPECT_TRUE(on_window_edge(grid, grid[29], 2, grid[27]));
  EXPECT_FALSE(on_window_edge(grid, grid[1], 2, grid[0]));

  // A descending grid (a ripple's on a short travel) keeps its order.
  const std::vector<double> down(grid.rbegin(), grid.rend());
  const std::vector<double> w = grid_window(down, grid[10], 1);
  ASSERT_EQ(w.size(), 3u);
  EXPECT_EQ(w.front(), grid[11]);
  EXPECT_EQ(w.back(), grid[9]);
}

}  // namespace
}  // namespace feedid::test
