// Fixed-size symmetric positive-definite algebra for the normal equations of
// the small least-squares problems in solve(). Sizes are compile-time (N <= 4
// here), everything lives on the caller's stack, nothing allocates.
// Context: task (solve), never per sample.
#pragma once

#include "feedid_port/math.hpp"

namespace feedid {

template <typename T, int N> struct SymMatrix {
  T a[N][N] = {};
};
template <typename T, int N> struct Vector {
  T v[N] = {};
};

/// In-place Cholesky A = L L^T of a symmetric matrix (lower triangle used).
/// Returns false when A is not numerically positive definite. The pivot test
/// is relative to the diagonal entry (not `== 0`): a column that is a linear
/// combination of the others within `rel_tol` counts as singular.
template <typename T, int N>
[[nodiscard]] bool cholesky(SymMatrix<T, N>& m, T rel_tol) {
  for (int j = 0; j < N; ++j) {
    const T diag0 = m.a[j][j];
    T d = diag0;
    for (int k = 0; k < j; ++k) d -= m.a[j][k] * m.a[j][k];
    if (!(d > rel_tol * diag0) || !(diag0 > T(0))) return false;
    const T l = port::sqrt(d);
    m.a[j][j] = l;
    for (int i = j + 1; i < N; ++i) {
      T s = m.a[i][j];
      for (int k = 0; k < j; ++k) s -= m.a[i][k] * m.a[j][k];
      m.a[i][j] = s / l;
    }
  }
  return true;
}

/// Solves L L^T x = b for a factor from cholesky().
template <typename T, int N>
Vector<T, N> cholesky_solve(const SymMatrix<T, N>& l, const Vector<T, N>& b) {
  Vector<T, N> y;
  for (int i = 0; i < N; ++i) {
    T s = b.v[i];
    for (int k = 0; k < i; ++k) s -= l.a[i][k] * y.v[k];
    y.v[i] = s / l.a[i][i];
  }
  Vector<T, N> x;
  for (int i = N - 1; i >= 0; --i) {
    T s = y.v[i];
    for (int k = i + 1; k < N; ++k) s -= l.a[k][i] * x.v[k];
    x.v[i] = s / l.a[i][i];
  }
  return x;
}

/// Diagonal of A^{-1} from its Cholesky factor: the variances of a
/// least-squares fit up to the residual variance factor.
template <typename T, int N>
Vector<T, N> cholesky_inverse_diagonal(const SymMatrix<T, N>& l) {
  Vector<T, N> diag;
  for (int c = 0; c < N; ++c) {
    Vector<T, N> e;
    e.v[c] = T(1);
    diag.v[c] = cholesky_solve(l, e).v[c];
  }
  return diag;
}

/// Scales rows/columns to unit diagonal before factorising, so the relative
/// pivot test means the same for columns in N, N s/m and kg. Solves A x = b;
/// returns false if singular. `inv_diag` (optional) receives diag(A^{-1}).
template <typename T, int N>
[[nodiscard]] bool solve_normal_equations(const SymMatrix<T, N>& a, const Vector<T, N>& b,
                                          T rel_tol, Vector<T, N>& x,
                                          Vector<T, N>* inv_diag = nullptr) {
  Vector<T, N> scale;
  for (int i = 0; i < N; ++i) {
    if (!(a.a[i][i] > T(0))) return false;
    scale.v[i] = T(1) / port::sqrt(a.a[i][i]);
  }
  SymMatrix<T, N> s;
  Vector<T, N> sb;
  for (int i = 0; i < N; ++i) {
    sb.v[i] = b.v[i] * scale.v[i];
    for (int j = 0; j < N; ++j) s.a[i][j] = a.a[i][j] * scale.v[i] * scale.v[j];
  }
  if (!cholesky(s, rel_tol)) return false;
  const Vector<T, N> sx = cholesky_solve(s, sb);
  for (int i = 0; i < N; ++i) x.v[i] = sx.v[i] * scale.v[i];
  if (inv_diag) {
    const Vector<T, N> d = cholesky_inverse_diagonal(s);
    for (int i = 0; i < N; ++i) inv_diag->v[i] = d.v[i] * scale.v[i] * scale.v[i];
  }
  return true;
}

/// The normal equations of a search over one nonlinear parameter, where
/// only the last column changes from fit to fit: the leading N-1 block is
/// scaled, factorised and forward-solved once (bordered_factor), and each
/// fit completes the last row (bordered_solve). The operations are those of
/// solve_normal_equations(), in the same order: the same result to the bit
/// where the compiler fuses no multiply-adds (x86-64 builds without FMA),
/// and to rounding where it fuses them differently in the two (the M4: 28 801
/// of 60 000 float fits differ in their last bits). A fit saves the leading
/// block's square roots and divisions.
template <typename T, int N> struct BorderedFactor {
  static_assert(N >= 2, "a bordered system has a leading block");
  SymMatrix<T, N> l{};  ///< the leading block's Cholesky factor (scaled)
  Vector<T, N> scale{}, y{};  ///< leading entries: 1/sqrt(a_ii), forward solution
  Vector<T, N> x_lead{};  ///< the leading block solved alone (last entry 0)
  bool ok = false;        ///< false: the leading block is singular
};

/// Factor of the leading N-1 block of a and b (the last row is not read).
template <typename T, int N>
BorderedFactor<T, N> bordered_factor(const SymMatrix<T, N>& a, const Vector<T, N>& b, T rel_tol) {
  constexpr int M = N - 1;
  BorderedFactor<T, N> f;
  for (int i = 0; i < M; ++i) {
    if (!(a.a[i][i] > T(0))) return f;
    f.scale.v[i] = T(1) / port::sqrt(a.a[i][i]);
  }
  SymMatrix<T, M> s;
  Vector<T, M> sb;
  for (int i = 0; i < M; ++i) {
    sb.v[i] = b.v[i] * f.scale.v[i];
    for (int j = 0; j < M; ++j) s.a[i][j] = a.a[i][j] * f.scale.v[i] * f.scale.v[j];
  }
  if (!cholesky(s, rel_tol)) return f;
  const Vector<T, M> sx = cholesky_solve(s, sb);
  for (int i = 0; i < M; ++i) {
    f.x_lead.v[i] = sx.v[i] * f.scale.v[i];
    T acc = sb.v[i];  // cholesky_solve()'s forward pass, kept for the border
    for (int k = 0; k < i; ++k) acc -= s.a[i][k] * f.y.v[k];
    f.y.v[i] = acc / s.a[i][i];
    for (int j = 0; j < M; ++j) f.l.a[i][j] = s.a[i][j];
  }
  f.ok = true;
  return f;
}

/// solve_normal_equations(a, b, rel_tol, x) for an `a` whose leading block
/// is the one f was formed from.
template <typename T, int N>
[[nodiscard]] bool bordered_solve(const BorderedFactor<T, N>& f, const SymMatrix<T, N>& a, const Vector<T, N>& b,
                                  T rel_tol, Vector<T, N>& x) {
  constexpr int M = N - 1;
  if (!f.ok || !(a.a[M][M] > T(0))) return false;
  const T scale = T(1) / port::sqrt(a.a[M][M]);
  T row[N];
  for (int j = 0; j < M; ++j) {
    T acc = a.a[M][j] * scale * f.scale.v[j];
    for (int k = 0; k < j; ++k) acc -= row[k] * f.l.a[j][k];
    row[j] = acc / f.l.a[j][j];
  }
  const T diag0 = a.a[M][M] * scale * scale;
  T d = diag0;
  for (int k = 0; k < M; ++k) d -= row[k] * row[k];
  if (!(d > rel_tol * diag0) || !(diag0 > T(0))) return false;
  row[M] = port::sqrt(d);
  T acc = b.v[M] * scale;
  for (int k = 0; k < M; ++k) acc -= row[k] * f.y.v[k];
  const T y_last = acc / row[M];
  T sx[N];
  sx[M] = y_last / row[M];
  for (int i = M - 1; i >= 0; --i) {
    T s = f.y.v[i];
    for (int k = i + 1; k < M; ++k) s -= f.l.a[k][i] * sx[k];
    s -= row[i] * sx[M];
    sx[i] = s / f.l.a[i][i];
  }
  for (int i = 0; i < M; ++i) x.v[i] = sx[i] * f.scale.v[i];
  x.v[M] = sx[M] * scale;
  return true;
}

}  // namespace feedid
