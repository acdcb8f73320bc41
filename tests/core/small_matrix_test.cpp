// The normal-equation solvers of solve(): the bordered solve that the
// Stribeck search uses for each fit must give what the full solve gives, to
// the bit, and fail where it fails.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "feedid/solve.hpp"

namespace {

using namespace feedid;

/// A symmetric positive-definite 3x3 of columns with very different scales
/// (N, N s/m, an exp share), as the friction fits' normal equations have.
template <typename T> SymMatrix<T, 3> random_normal_matrix(std::mt19937& rng, Vector<T, 3>& b) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double scale[3] = {1.0, 3e-3, 0.4};
  double x[12][3];
  for (auto& row : x)
    for (int c = 0; c < 3; ++c) row[c] = scale[c] * (c == 0 ? 1.0 + 0.1 * u(rng) : u(rng));
  SymMatrix<T, 3> a;
  for (int r = 0; r < 3; ++r) {
    b.v[r] = T(0);
    for (int c = 0; c < 3; ++c) {
      double s = 0.0;
      for (const auto& row : x) s += row[r] * row[c];
      a.a[r][c] = T(s);
    }
    for (const auto& row : x) b.v[r] += T(row[r] * (25.0 + 700.0 * row[1] + 8.0 * row[2]));
  }
  return a;
}

/// Where the compiler may fuse multiply-adds (FMA), it may fuse the two
/// solves differently: then they agree to rounding, not to the bit.
#if defined(__FMA__) || defined(__ARM_FEATURE_FMA) || defined(__aarch64__)
constexpr bool kFusedMultiplyAdd = true;
#else
constexpr bool kFusedMultiplyAdd = false;
#endif

template <typename T> bool same_bits(const Vector<T, 3>& x, const Vector<T, 3>& y) {
  if (kFusedMultiplyAdd) {
    const double tol = sizeof(T) == 4 ? 1e-3 : 1e-9;
    for (int k = 0; k < 3; ++k)
      if (!(std::fabs(double(x.v[k]) - double(y.v[k])) <= tol * (1.0 + std::fabs(double(y.v[k]))))) return false;
    return true;
  }
  return std::memcmp(x.v, y.v, sizeof(x.v)) == 0;
}

template <typename T> void expect_bordered_equals_full(T tol) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 500; ++trial) {
    Vector<T, 3> b;
    const SymMatrix<T, 3> a = random_normal_matrix<T>(rng, b);
    const BorderedFactor<T, 3> f = bordered_factor(a, b, tol);
    Vector<T, 3> full, bordered;
    const bool full_ok = solve_normal_equations(a, b, tol, full);
    ASSERT_EQ(bordered_solve(f, a, b, tol, bordered), full_ok) << "trial " << trial;
    if (full_ok) EXPECT_TRUE(same_bits(full, bordered)) << "trial " << trial;
    // The leading block alone: what the Coulomb + viscous fit solves.
    SymMatrix<T, 2> a2;
    Vector<T, 2> b2, x2;
    for (int r = 0; r < 2; ++r) {
      b2.v[r] = b.v[r];
      for (int c = 0; c < 2; ++c) a2.a[r][c] = a.a[r][c];
    }
    ASSERT_TRUE(solve_normal_equations(a2, b2, tol, x2));
    EXPECT_TRUE(same_bits(Vector<T, 3>{{x2.v[0], x2.v[1], T(0)}}, f.x_lead)) << "trial " << trial;
    EXPECT_EQ(f.x_lead.v[2], T(0));
  }
}

TEST(SmallMatrix, BorderedSolveIsTheFullSolveToTheBit) {
  expect_bordered_equals_full<double>(1e-10);
  expect_bordered_equals_full<float>(1e-5f);
}

TEST(SmallMatrix, BorderedSolveFailsWhereTheFullSolveFails) {
  // GIVEN a last column that is the sum of the first two (singular border)
  SymMatrix<double, 3> a;
  const double cols[4][3] = {{1, 2, 3}, {1, 0.5, 1.5}, {1, -1, 0}, {1, 3, 4}};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      for (const auto& row : cols) a.a[r][c] += row[r] * row[c];
  const Vector<double, 3> b{{1.0, 2.0, 3.0}};
  Vector<double, 3> x;
  EXPECT_FALSE(solve_normal_equations(a, b, 1e-10, x));
  EXPECT_FALSE(bordered_solve(bordered_factor(a, b, 1e-10), a, b, 1e-10, x));
  // AND a singular leading block: no factor, no solve
  SymMatrix<double, 3> z = a;
  z.a[1][1] = 0.0;
  const BorderedFactor<double, 3> f = bordered_factor(z, b, 1e-10);
  EXPECT_FALSE(f.ok);
  EXPECT_FALSE(bordered_solve(f, z, b, 1e-10, x));
  EXPECT_FALSE(solve_normal_equations(z, b, 1e-10, x));
}

}  // namespace
