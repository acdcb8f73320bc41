#include "diagnose_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace feedid::host::diag {

namespace {
/// candidate(): up to this many columns, their products are taken as dot
/// products rather than a matrix product.
constexpr Eigen::Index kDotProductsUpTo = 4;
/// ssr_of_difference: the share of the edges' own products below which a
/// difference's products are not taken from them (their rounding, the unit
/// roundoff of those, would be more than about 1e-10 of the difference's).
constexpr double kDifferenceResolved = 1e-6;

/// What one extra column lowers the SSR by, from its products in
/// correlation form (sc: its own less what the held columns explain, rc:
/// with the held fit's residual): its own eigenvector, as the eigensolver
/// of ssr_beside returns it for one column; nothing below the cut.
double one_column_drop(double sc, double rc, double cut) { return sc > cut ? rc * rc / sc : 0.0; }
}  // namespace

ColumnBank::ColumnBank(Vec y, std::vector<char> id) : y_(std::move(y)), id_(std::move(id)) {
  for (Eigen::Index i = 0; i < y_.size(); ++i) (id_[static_cast<std::size_t>(i)] ? id_rows_ : other_rows_).push_back(i);
  y_id_ = rows_of(y_, id_rows_);
  yty_ = y_id_.dot(y_id_);
}

Vec ColumnBank::rows_of(const Vec& a, const std::vector<Eigen::Index>& rows) {
  Vec out(static_cast<Eigen::Index>(rows.size()));
  for (std::size_t k = 0; k < rows.size(); ++k) out(static_cast<Eigen::Index>(k)) = a(rows[k]);
  return out;
}

Mat ColumnBank::identification_rows(const Mat& cols) const {
  Mat out(static_cast<Eigen::Index>(id_rows_.size()), cols.cols());
  for (Eigen::Index c = 0; c < cols.cols(); ++c) out.col(c) = rows_of(cols.col(c), id_rows_);
  return out;
}

Vec ColumnBank::column(int i) const {
  Vec out(y_.size());
  const Vec& id = cols_id_[static_cast<std::size_t>(i)];
  const Vec& other = cols_other_[static_cast<std::size_t>(i)];
  for (std::size_t k = 0; k < id_rows_.size(); ++k) out(id_rows_[k]) = id(static_cast<Eigen::Index>(k));
  for (std::size_t k = 0; k < other_rows_.size(); ++k) out(other_rows_[k]) = other(static_cast<Eigen::Index>(k));
  return out;
}

int ColumnBank::add(Vec column) {
  cols_id_.push_back(rows_of(column, id_rows_));
  cols_other_.push_back(rows_of(column, other_rows_));
  // A fit reads only the identification rows, but a NaN or an infinity
  // in the others would reach the held-out residual: such a column fails
  // every fit it is in, as it did when the products ran over all rows.
  xty_.push_back(column.allFinite() ? cols_id_.back().dot(y_id_) : std::numeric_limits<double>::quiet_NaN());
  const std::size_t n = cols_id_.size();
  gram_.push_back(std::make_unique<std::atomic<double>[]>(n));
  for (std::size_t j = 0; j < n; ++j) gram_.back()[j].store(std::numeric_limits<double>::quiet_NaN(), std::memory_order_relaxed);
  return static_cast<int>(n) - 1;
}

double ColumnBank::gram(int i, int j) const {
  if (i < j) std::swap(i, j);
  // Fits of several candidates may fill the same product at once: each
  // writes the same bits, so a relaxed atomic is all they need.
  std::atomic<double>& g = gram_[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
  double value = g.load(std::memory_order_relaxed);
  if (std::isnan(value)) {
    value = cols_id_[static_cast<std::size_t>(i)].dot(cols_id_[static_cast<std::size_t>(j)]);
    g.store(value, std::memory_order_relaxed);
  }
  return value;
}

Mat ColumnBank::gather(const std::vector<int>& cols) const {
  Mat x(y_.size(), static_cast<Eigen::Index>(cols.size()));
  for (std::size_t i = 0; i < cols.size(); ++i) x.col(static_cast<Eigen::Index>(i)) = column(cols[i]);
  return x;
}

ColumnBank::Extra ColumnBank::extra(Mat cols, const std::vector<int>& with) const {
  Extra e;
  e.with = with;
  e.cross.resize(static_cast<Eigen::Index>(with.size()), cols.cols());
  const Mat cols_id = identification_rows(cols);
  for (Eigen::Index c = 0; c < cols.cols(); ++c)
    for (std::size_t w = 0; w < with.size(); ++w)
      e.cross(static_cast<Eigen::Index>(w), c) = cols_id.col(c).dot(cols_id_[static_cast<std::size_t>(with[w])]);
  e.gram = cols_id.transpose() * cols_id;
  e.xty = cols_id.transpose() * y_id_;
  for (Eigen::Index c = 0; c < cols.cols(); ++c)  // as add(): a non-finite value anywhere fails the fit
    if (!cols.col(c).allFinite()) e.xty(c) = std::numeric_limits<double>::quiet_NaN();
  e.cols = std::move(cols);
  return e;
}

void ColumnBank::products(const std::vector<int>& cols, Mat& g, Vec& gy) const {
  const Eigen::Index p = static_cast<Eigen::Index>(cols.size());
  g.resize(p, p);
  gy.resize(p);
  for (Eigen::Index i = 0; i < p; ++i) {
    gy(i) = xty_[static_cast<std::size_t>(cols[static_cast<std::size_t>(i)])];
    for (Eigen::Index j = 0; j <= i; ++j) g(i, j) = g(j, i) = gram(cols[static_cast<std::size_t>(i)], cols[static_cast<std::size_t>(j)]);
  }
}

LinearFit ColumnBank::fit(const std::vector<int>& cols, const Extra* extra) const {
  const Eigen::Index p = static_cast<Eigen::Index>(cols.size()), q = extra ? extra->cols.cols() : 0;
  Mat gp;
  Vec gyp;
  products(cols, gp, gyp);
  Mat g(p + q, p + q);
  Vec gy(p + q);
  g.topLeftCorner(p, p) = gp;
  gy.head(p) = gyp;
  if (q > 0) {
    for (Eigen::Index i = 0; i < p; ++i) {
      const auto it = std::find(extra->with.begin(), extra->with.end(), cols[static_cast<std::size_t>(i)]);
      const auto w = static_cast<Eigen::Index>(it - extra->with.begin());
      g.block(i, p, 1, q) = extra->cross.row(w);
      g.block(p, i, q, 1) = extra->cross.row(w).transpose();
    }
    g.block(p, p, q, q) = extra->gram;
    gy.tail(q) = extra->xty;
  }
  return solve_normal_equations(g, gy, yty_);
}

ColumnBank::Held ColumnBank::hold(const std::vector<int>& with) const {
  Held h;
  h.with = with;
  Mat g;
  Vec gy;
  products(with, g, gy);
  h.x_id.resize(static_cast<Eigen::Index>(id_rows_.size()), static_cast<Eigen::Index>(with.size()));
  for (std::size_t w = 0; w < with.size(); ++w) h.x_id.col(static_cast<Eigen::Index>(w)) = cols_id_[static_cast<std::size_t>(with[w])];
  h.g_inv = with.empty() ? Mat() : pseudo_inverse_normal(g, &h.largest_eigenvalue);
  h.fit = solve_with_inverse(h.g_inv, g, gy, yty_);
  return h;
}

ColumnBank::Candidate ColumnBank::candidate(Mat cols_id) const {
  Candidate c;
  const Eigen::Index q = cols_id.cols();
  // A grid point has one to a few columns: dot by dot, where a matrix
  // product would first pack them (a third of the search's time on a
  // ripple's kept grid).
  c.gram.resize(q, q);
  c.xty.resize(q);
  if (q <= kDotProductsUpTo) {
    for (Eigen::Index j = 0; j < q; ++j) {
      c.xty(j) = cols_id.col(j).dot(y_id_);
      for (Eigen::Index i = 0; i <= j; ++i) c.gram(i, j) = c.gram(j, i) = cols_id.col(i).dot(cols_id.col(j));
    }
  } else {
    c.gram.noalias() = cols_id.transpose() * cols_id;
    c.xty.noalias() = cols_id.transpose() * y_id_;
  }
  c.cols_id = std::move(cols_id);
  return c;
}

double ColumnBank::ssr_beside(const Held& held, const Mat& cols_id) const { return ssr_beside(held, candidate(cols_id)); }

double ColumnBank::ssr_beside(const Held& held, const Candidate& cand) const {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (!held.fit.ok) return kInf;
  const Mat& cols_id = cand.cols_id;
  const Eigen::Index q = cols_id.cols();
  // The products a joint fit would take.
  Mat s = cand.gram;
  Vec r = cand.xty;
  const Vec diag = s.diagonal();
  if (held.x_id.cols() > 0) {
    // Column by column: a matrix-vector product each, where a matrix
    // product would repack the held columns for a grid point's one or two.
    Mat c(held.x_id.cols(), q);
    for (Eigen::Index k = 0; k < q; ++k) c.col(k).noalias() = held.x_id.transpose() * cols_id.col(k);
    s.noalias() -= c.transpose() * held.g_inv * c;
    r.noalias() -= c.transpose() * held.fit.theta;
  }
  // A column with a NaN or an infinity fails, as the joint fit does (the
  // search sees the identification rows only; the candidate's final fit,
  // extra(), sees them all).
  if (!(s.allFinite() && r.allFinite())) return kInf;
  if (q == 0) return held.fit.ssr_id;
  // What the extra columns add beyond the held ones, in the correlation
  // form of solve_normal_equations and about its cut: the joint matrix's
  // largest eigenvalue is at least the held one's and at least 1 (a unit
  // diagonal). A column (nearly) in the held columns' span adds nothing
  // instead of noise.
  const double cut = kNormalEquationsCut * std::max(1.0, held.largest_eigenvalue);
  Vec scale(q);
  for (Eigen::Index i = 0; i < q; ++i) scale(i) = diag(i) > 0 ? 1.0 / std::sqrt(diag(i)) : 0.0;
  const Mat sc = scale.asDiagonal() * s * scale.asDiagonal();
  const Vec rc = scale.asDiagonal() * r;
  double drop = 0.0;
  if (q == 1) {
    drop = one_column_drop(sc(0, 0), rc(0), cut);
  } else {
    Eigen::SelfAdjointEigenSolver<Mat> eig(sc);
    if (eig.info() != Eigen::Success) return kInf;
    for (Eigen::Index k = 0; k < q; ++k) {
      const double lambda = eig.eigenvalues()(k);
      if (lambda > cut) drop += std::pow(eig.eigenvectors().col(k).dot(rc), 2) / lambda;
    }
  }
  const double ssr = held.fit.ssr_id - drop;
  return std::isfinite(ssr) ? ssr : kInf;
}

ColumnBank::Edges ColumnBank::edges_beside(const Held& held, Mat edges_id) const {
  Edges e;
  e.gram.noalias() = edges_id.transpose() * edges_id;
  e.s = e.gram;
  e.r.noalias() = edges_id.transpose() * y_id_;
  if (held.x_id.cols() > 0) {
    const Mat c = held.x_id.transpose() * edges_id;
    e.s.noalias() -= c.transpose() * held.g_inv * c;
    e.r.noalias() -= c.transpose() * held.fit.theta;
  }
  e.cols_id = std::move(edges_id);
  return e;
}

double ColumnBank::ssr_of_difference(const Held& held, const Edges& e, Eigen::Index a, Eigen::Index b) const {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (!held.fit.ok) return kInf;
  // The difference's products expanded: b'b - 2 a'b + a'a. Their rounding
  // is at least the edges' own products' (G_aa + G_bb) times the unit
  // roundoff; a difference whose products are less than
  // kDifferenceResolved of those is read from its column instead, so that
  // a zero column stays exactly nothing. (The held columns' condition adds
  // to it: ssrs_of_differences reads the near-least from their columns.)
  const double scale_of_edges = e.gram(a, a) + e.gram(b, b);
  const double gram = e.gram(b, b) - 2.0 * e.gram(a, b) + e.gram(a, a);
  const double s = e.s(b, b) - 2.0 * e.s(a, b) + e.s(a, a);
  const double r = e.r(b) - e.r(a);
  if (!(gram > kDifferenceResolved * scale_of_edges && s > kDifferenceResolved * scale_of_edges && std::isfinite(r)))
    return ssr_beside(held, e.cols_id.col(b) - e.cols_id.col(a));
  // ssr_beside's steps for one column.
  const double cut = kNormalEquationsCut * std::max(1.0, held.largest_eigenvalue);
  const double scale = 1.0 / std::sqrt(gram);
  const double ssr = held.fit.ssr_id - one_column_drop(scale * s * scale, scale * r, cut);
  return std::isfinite(ssr) ? ssr : kInf;
}

std::vector<double> ColumnBank::ssrs_of_differences(const Held& held, const Edges& e,
                                                    const std::vector<std::pair<Eigen::Index, Eigen::Index>>& pairs) const {
  std::vector<double> out;
  double least = std::numeric_limits<double>::infinity();
  for (const auto& [a, b] : pairs) {
    out.push_back(ssr_of_difference(held, e, a, b));
    least = std::min(least, out.back());
  }
  if (!std::isfinite(least)) return out;
  for (std::size_t i = 0; i < pairs.size(); ++i)
    if (out[i] <= least + kRescoreMargin * std::fabs(least))
      out[i] = ssr_beside(held, e.cols_id.col(pairs[i].second) - e.cols_id.col(pairs[i].first));
  return out;
}

Vec ColumnBank::residual(const std::vector<int>& cols, const Extra* extra, const Vec& theta) const {
  Vec r = y_;
  for (std::size_t i = 0; i < cols.size(); ++i) {
    const double t = theta(static_cast<Eigen::Index>(i));
    const Vec& id = cols_id_[static_cast<std::size_t>(cols[i])];
    const Vec& other = cols_other_[static_cast<std::size_t>(cols[i])];
    for (std::size_t k = 0; k < id_rows_.size(); ++k) r(id_rows_[k]) -= t * id(static_cast<Eigen::Index>(k));
    for (std::size_t k = 0; k < other_rows_.size(); ++k) r(other_rows_[k]) -= t * other(static_cast<Eigen::Index>(k));
  }
  if (extra && extra->cols.cols() > 0) r -= extra->cols * theta.tail(extra->cols.cols());
  return r;
}

Vec ColumnBank::leverage(const std::vector<int>& cols) const {
  Mat g;
  Vec gy;
  products(cols, g, gy);
  const Mat x = gather(cols);
  const Mat g_inv = pseudo_inverse_normal(g);
  return ((x * g_inv).array() * x.array()).rowwise().sum();
}

double ColumnBank::max_collinearity(const std::vector<int>& cols, const Extra& extra) const {
  double worst = 0.0;
  for (Eigen::Index c = 0; c < extra.cols.cols(); ++c) {
    // Regress extra column c on the bank columns: its own normal equations.
    const Eigen::Index p = static_cast<Eigen::Index>(cols.size());
    Mat g(p, p);
    Vec gy(p);
    for (Eigen::Index i = 0; i < p; ++i) {
      const auto it = std::find(extra.with.begin(), extra.with.end(), cols[static_cast<std::size_t>(i)]);
      gy(i) = extra.cross(static_cast<Eigen::Index>(it - extra.with.begin()), c);
      for (Eigen::Index j = 0; j <= i; ++j) g(i, j) = g(j, i) = gram(cols[static_cast<std::size_t>(i)], cols[static_cast<std::size_t>(j)]);
    }
    const double cc = extra.gram(c, c);
    const LinearFit f = solve_normal_equations(g, gy, cc);
    if (cc > 0 && f.ok) worst = std::max(worst, 1.0 - std::max(f.ssr_id, 0.0) / cc);
  }
  return worst;
}

Mat pseudo_inverse_normal(const Mat& g, double* largest) {
  const Eigen::Index n = g.rows();
  Vec scale(n);
  for (Eigen::Index i = 0; i < n; ++i) scale(i) = g(i, i) > 0 ? 1.0 / std::sqrt(g(i, i)) : 0.0;
  Eigen::SelfAdjointEigenSolver<Mat> eig(scale.asDiagonal() * g * scale.asDiagonal());
  if (eig.info() != Eigen::Success) return Mat::Constant(n, n, std::numeric_limits<double>::quiet_NaN());
  const Vec& lambda = eig.eigenvalues();
  const double top = n > 0 ? std::max(lambda.maxCoeff(), 0.0) : 0.0;
  if (largest) *largest = top;
  const double cut = kNormalEquationsCut * top;
  Vec inv(n);
  for (Eigen::Index i = 0; i < n; ++i) inv(i) = lambda(i) > cut ? 1.0 / lambda(i) : 0.0;
  const Mat v = eig.eigenvectors();
  return scale.asDiagonal() * (v * inv.asDiagonal() * v.transpose()) * scale.asDiagonal();
}

LinearFit solve_normal_equations(const Mat& g, const Vec& gy, double yty) {
  return solve_with_inverse(g.rows() == 0 ? Mat() : pseudo_inverse_normal(g), g, gy, yty);
}

LinearFit solve_with_inverse(const Mat& g_inv, const Mat& g, const Vec& gy, double yty) {
  LinearFit f;
  if (g.rows() == 0) {
    f.theta = Vec();
    f.ssr_id = yty;
    f.ok = true;
    return f;
  }
  f.theta = g_inv * gy;
  f.ssr_id = yty - 2.0 * f.theta.dot(gy) + f.theta.dot(g * f.theta);
  f.ok = f.theta.allFinite() && std::isfinite(f.ssr_id);
  return f;
}

}  // namespace feedid::host::diag
