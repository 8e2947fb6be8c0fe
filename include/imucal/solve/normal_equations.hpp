// SPDX-License-Identifier: MIT
// imucal/solve/normal_equations.hpp: the incremental normal-equations accumulator (math.md section
// 3). Residual rows (J_i, e_i, w_i) are folded in one at a time into H = sum w J^T J (one packed
// triangle), v = sum w J^T e, f = sum w e^2 and the row count: O(N^2) memory whatever the number
// of rows. Never allocates (fixed-size Eigen only), never throws, never returns NaN as a result.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <limits>
#include <type_traits>

#include "imucal/solve/ldlt.hpp"
#include "imucal/status.hpp"
#include "imucal/types.hpp"

namespace imucal {

// Smallest ratio of LDL^T pivots (of the Jacobi-scaled matrix) accepted as non-singular, for n
// unknowns.
template <typename Scalar>
constexpr Scalar min_pivot_ratio(int n) {
  return Scalar(100) * Scalar(n) * std::numeric_limits<Scalar>::epsilon();
}

namespace detail {

// The accumulator's arithmetic on n unknowns, written once for every size (NormalEquations holds
// the storage): h is the packed lower triangle, column by column, of an n x n matrix. The factor,
// the predicted decrease and the gradient cosine are kept out of line (one copy for every size and
// caller); the row fold, called once per residual in every evaluation, is inlined into each
// accumulator's one out-of-line add_row().
inline int packed_index(int n, int r, int c) { return c * n - c * (c - 1) / 2 + (r - c); }

// A symmetric N x N matrix to its packed lower triangle (the layout above) and back: a matrix
// kept between calls takes half the RAM. Exact both ways for a matrix that is exactly symmetric.
template <typename Scalar, int N>
void pack_symmetric(const Eigen::Matrix<Scalar, N, N>& m, Scalar* h) {
  for (int c = 0; c < N; ++c)
    for (int r = c; r < N; ++r) h[packed_index(N, r, c)] = m(r, c);
}
template <typename Scalar, int N>
Eigen::Matrix<Scalar, N, N> unpack_symmetric(const Scalar* h) {
  Eigen::Matrix<Scalar, N, N> m;
  for (int c = 0; c < N; ++c)
    for (int r = c; r < N; ++r) m(r, c) = m(c, r) = h[packed_index(N, r, c)];
  return m;
}

template <typename Scalar>
Status ne_add(Scalar* h, Scalar* v, Scalar& f, Scalar& trace, int n, const Scalar* j, Scalar e,
              Scalar w) {
  Scalar jj = Scalar(0);
  for (int c = 0; c < n; ++c) {
    if (!std::isfinite(j[c])) return Status::kNonFiniteInput;
    jj += j[c] * j[c];
  }
  if (!std::isfinite(e) || !std::isfinite(w)) return Status::kNonFiniteInput;
  if (w < Scalar(0)) return Status::kInvalidArgument;
  // Refuse a row that would overflow the sums. The diagonal of H is non-negative, so a finite
  // trace bounds it, and Cauchy-Schwarz bounds the rest (|H_rc| <= sqrt(H_rr H_cc),
  // |v_c| <= sqrt(H_cc f)): two checks instead of one per entry.
  const Scalar t = trace + w * jj;
  if (!std::isfinite(f + w * e * e) || !std::isfinite(t)) return Status::kNonFiniteInput;
  trace = t;
  int k = 0;
  for (int c = 0; c < n; ++c) {
    const Scalar wjc = w * j[c];
    for (int r = c; r < n; ++r) h[k++] += wjc * j[r];
    v[c] += wjc * e;
  }
  f += w * e * e;
  return Status::kOk;
}

// LDL^T of the Jacobi-scaled matrix (H + lambda diag(H)) / diag(H), into l (leading dimension n:
// L in its strict lower triangle) and the pivots d, with the scale 1 / sqrt(H_ii); checked for
// rank and conditioning (pivots below min_ratio of the largest: ill-conditioned).
template <typename Scalar>
__attribute__((noinline)) Status ne_factor(const Scalar* h, int rows, int n, Scalar lambda,
                                           Scalar* scale, Scalar* l, Scalar* d, Scalar min_ratio) {
  if (!std::isfinite(lambda) || lambda < Scalar(0)) return Status::kInvalidArgument;
  if (rows == 0) return Status::kRankDeficient;
  for (int i = 0; i < n; ++i) {
    const Scalar hi = h[packed_index(n, i, i)];
    if (!(hi > Scalar(0)) || !std::isfinite(hi)) return Status::kRankDeficient;
    scale[i] = Scalar(1) / std::sqrt(hi);
  }
  int k = 0;
  for (int c = 0; c < n; ++c) {
    l[c * n + c] = Scalar(1) + lambda;
    ++k;
    for (int r = c + 1; r < n; ++r) l[c * n + r] = h[k++] * scale[r] * scale[c];  // lower
  }
  return ldlt_factor(l, n, d, min_ratio);
}

// Gauss-Newton model of the decrease of f for a step delta: -(2 delta.v + delta^T H delta).
template <typename Scalar>
__attribute__((noinline)) Scalar ne_predicted_decrease(const Scalar* h, const Scalar* v, int n,
                                                       const Scalar* delta) {
  Scalar quad = Scalar(0), dv = Scalar(0);
  int k = 0;
  for (int c = 0; c < n; ++c) {
    dv += delta[c] * v[c];
    quad += h[k++] * delta[c] * delta[c];
    for (int r = c + 1; r < n; ++r) quad += Scalar(2) * h[k++] * delta[r] * delta[c];
  }
  return -(Scalar(2) * dv + quad);
}

// max_i |v_i| / sqrt(H_ii f) (NormalEquations::gradient_cosine()).
template <typename Scalar>
__attribute__((noinline)) Scalar ne_gradient_cosine(const Scalar* h, const Scalar* v, Scalar f,
                                                    int rows, int n) {
  if (rows == 0 || !std::isfinite(f)) return Scalar(1);
  if (f == Scalar(0)) return Scalar(0);  // an exact fit
  Scalar worst = Scalar(0);
  bool any = false;
  for (int i = 0; i < n; ++i) {
    const Scalar d = h[packed_index(n, i, i)];
    if (d > Scalar(0)) {
      any = true;
      const Scalar c = std::abs(v[i]) / std::sqrt(d * f);
      if (c > worst) worst = c;
    }
  }
  return any ? worst : Scalar(1);
}

}  // namespace detail

// The capacity the solvers share: the gyro's 12 unknowns, the accelerometer's 9 and the
// magnetometer's 9 and 4 at their run-time size in it, so that one copy of the LM and of its
// normal equations serves them all in a firmware.
constexpr int kSolverCapacity = 12;

// The normal equations of at most N unknowns; size() of them (N unless resize() says fewer) are
// solved for, the first size() entries of every vector. The entries beyond size() are ignored in
// the rows and 0 in every result: one accumulator (and one solver around it) serves a problem
// whose parameter count is known only at run time.
template <typename Scalar, int N>
class NormalEquations {
 public:
  static_assert(N > 0 && N <= detail::kMaxLdltSize, "sized for small calibration problems");
  using Vector = Eigen::Matrix<Scalar, N, 1>;
  using Matrix = Eigen::Matrix<Scalar, N, N>;
  static constexpr int kPackedSize = N * (N + 1) / 2;

  NormalEquations() { clear(); }

  // Cleared, for n unknowns (1 <= n <= N; anything else keeps the present size).
  void resize(int n) {
    if (n >= 1 && n <= N) n_ = n;
    clear();
  }
  int size() const { return n_; }

  void clear() {
    for (Scalar& x : h_) x = Scalar(0);
    v_.setZero();
    f_ = Scalar(0);
    trace_ = Scalar(0);
    rows_ = 0;
  }

  // Folds in one residual row e with Jacobian row j and weight w >= 0. A row with a non-finite
  // entry or a negative weight is refused and changes nothing.
  Status add(const Vector& j, Scalar e, Scalar w = Scalar(1)) { return add_row(j.data(), e, w); }
  // A row of a problem with M < N unknowns (at least size() entries; kInvalidArgument otherwise),
  // as a plain vector (an expression of M entries must be evaluated first).
  template <int M, typename = std::enable_if_t<(M < N)>>
  Status add(const Eigen::Matrix<Scalar, M, 1>& j, Scalar e, Scalar w = Scalar(1)) {
    return n_ > M ? Status::kInvalidArgument : add_row(j.data(), e, w);
  }

  int rows() const { return rows_; }

  // The smallest pivot ratio taken as non-singular (min_pivot_ratio(size()) unless set; 0 or
  // less restores that). A problem whose rows include a prior on every unknown is positive
  // definite by construction, and its weak directions are the prior's: there a ratio of a few
  // epsilon guards only against rounding.
  void set_min_pivot_ratio(Scalar ratio) { min_ratio_ = ratio; }
  Scalar weighted_sse() const { return f_; }     // f = sum w e^2
  const Vector& gradient() const { return v_; }  // v = sum w J^T e (half the gradient of f)

  Scalar h(int r, int c) const {  // element of H, either triangle (0 beyond size())
    if (r < c) {
      const int t = r;
      r = c;
      c = t;
    }
    return r < n_ ? h_[detail::packed_index(n_, r, c)] : Scalar(0);
  }

  Matrix information() const {  // H as a full symmetric matrix
    Matrix m;
    for (int c = 0; c < N; ++c)
      for (int r = c; r < N; ++r) m(r, c) = m(c, r) = h(r, c);
    return m;
  }

  // Solves (H + lambda diag(H)) delta = -v. Jacobi scaling makes the test for singularity
  // independent of the parameters' units. lambda = 0 is the Gauss-Newton step.
  Status solve_damped(Scalar lambda, Vector& delta) const {
    Vector scale;
    Scalar l[static_cast<std::size_t>(N * N)];
    Vector d;
    const Status s =
        detail::ne_factor(h_, rows_, n_, lambda, scale.data(), l, d.data(), min_ratio());
    if (s != Status::kOk) return s;
    Vector x = Vector::Zero();
    for (int i = 0; i < n_; ++i) x(i) = -scale(i) * v_(i);
    detail::ldlt_solve(l, d.data(), n_, x.data());
    for (int i = 0; i < n_; ++i) x(i) *= scale(i);
    if (!all_finite(x)) return Status::kIllConditioned;
    delta = x;
    return Status::kOk;
  }

  // Cov(p) = f / (m - n) * H^-1, valid at the minimum of f; or variance * H^-1 (as
  // standard_deviations()).
  Status covariance(Matrix& cov, Scalar variance = Scalar(-1)) const {
    Matrix c = Matrix::Zero();
    const Status s = for_each_inverse_column(
        variance, [&](int col, const Vector& column) { c.col(col) = column; });
    if (s != Status::kOk) return s;
    if (!all_finite(c)) return Status::kIllConditioned;
    cov = c;
    return Status::kOk;
  }

  // Calls f(c, column c of variance * H^-1) for each c < size() (variance < 0: f / (m - n)), one
  // column at a time: for what needs all of H^-1 without a matrix of it (nor an Eigen product
  // that may allocate) on the stack.
  template <class F>
  Status inverse_columns(Scalar variance, F f) const {
    return for_each_inverse_column(variance, f);
  }

  // Column c of variance * H^-1 (variance < 0: f / (m - n)) alone: a factorisation and one solve,
  // for a caller that spreads the covariance over several calls.
  Status inverse_column(int c, Scalar variance, Vector& out) const {
    if (c < 0 || c >= n_) return Status::kInvalidArgument;
    Vector result = Vector::Zero();
    const Status s = for_each_inverse_column(
        variance,
        [&](int k, const Vector& column) {
          if (k == c) result = column;
        },
        c);
    if (s != Status::kOk) return s;
    if (!all_finite(result)) return Status::kIllConditioned;
    out = result;
    return Status::kOk;
  }

  // sqrt(diag(Cov)) without forming the covariance: what a device needs, with less stack.
  // variance < 0: Cov = f / (m - n) H^-1 (the noise taken from the fit's own scatter); otherwise
  // Cov = variance H^-1 (rows weighted by a known noise model: variance 1 when it is exact).
  Status standard_deviations(Vector& sd, Scalar variance = Scalar(-1)) const {
    Vector out = Vector::Zero();
    const Status s = for_each_inverse_column(variance, [&](int col, const Vector& column) {
      out(col) = std::sqrt(column(col) > Scalar(0) ? column(col) : Scalar(0));
    });
    if (s != Status::kOk) return s;
    if (!all_finite(out)) return Status::kIllConditioned;
    sd = out;
    return Status::kOk;
  }

  // max_i |v_i| / sqrt(H_ii f): the largest cosine between the residual vector and a Jacobian
  // column. Unit-free; 0 at an exact minimum; 1 when nothing is known (no rows, a non-finite
  // cost, no column with information).
  Scalar gradient_cosine() const {
    return detail::ne_gradient_cosine(h_, v_.data(), f_, rows_, n_);
  }

  // Gauss-Newton model of the decrease of f for a step delta: -(2 delta.v + delta^T H delta),
  // computed from the packed triangle (no N x N temporary on the stack).
  Scalar predicted_decrease(const Vector& delta) const {
    return detail::ne_predicted_decrease(h_, v_.data(), n_, delta.data());
  }

 private:
  // The row's first size() entries: one copy of the fold for every row type.
  __attribute__((noinline)) Status add_row(const Scalar* j, Scalar e, Scalar w) {
    const Status s = detail::ne_add(h_, v_.data(), f_, trace_, n_, j, e, w);
    if (s == Status::kOk) ++rows_;
    return s;
  }

  // Calls f(c, column c of variance H^-1) for each c < size() (variance < 0: f/(m-n)), one column
  // at a time; or for column `only` alone (0 or more).
  template <class F>
  Status for_each_inverse_column(Scalar variance, F f, int only = -1) const {
    if (rows_ <= n_) return Status::kTooFewResiduals;
    if (!std::isfinite(variance)) return Status::kInvalidArgument;
    Vector scale;
    Scalar l[static_cast<std::size_t>(N * N)];
    Vector d;
    const Status s =
        detail::ne_factor(h_, rows_, n_, Scalar(0), scale.data(), l, d.data(), min_ratio());
    if (s != Status::kOk) return s;
    if (variance < Scalar(0)) variance = f_ / Scalar(rows_ - n_);
    for (int c = only < 0 ? 0 : only; c < (only < 0 ? n_ : only + 1); ++c) {
      Vector column = Vector::Zero();
      column(c) = Scalar(1);
      detail::ldlt_solve(l, d.data(), n_, column.data());
      const Scalar vc = variance * scale(c);
      for (int i = 0; i < n_; ++i) column(i) = vc * (scale(i) * column(i));
      f(c, column);
    }
    return Status::kOk;
  }

  Scalar h_[static_cast<std::size_t>(kPackedSize)] = {};
  Vector v_ = Vector::Zero();
  Scalar f_ = Scalar(0);
  Scalar trace_ = Scalar(0);  // trace of H: the overflow guard
  int rows_ = 0;
  int n_ = N;
  Scalar min_ratio_ = Scalar(0);

  Scalar min_ratio() const {
    return min_ratio_ > Scalar(0) ? min_ratio_ : min_pivot_ratio<Scalar>(n_);
  }
};

}  // namespace imucal
