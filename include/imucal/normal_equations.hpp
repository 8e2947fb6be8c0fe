// imucal/normal_equations.hpp: the incremental normal-equations accumulator (math.md section 3).
// Residual rows (J_i, e_i, w_i) are folded in one at a time into H = sum w J^T J (one packed
// triangle), v = sum w J^T e, f = sum w e^2 and the row count: O(N^2) memory whatever the number
// of rows. Never allocates (fixed-size Eigen only), never throws, never returns NaN as a result.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <limits>

#include "imucal/ldlt.hpp"
#include "imucal/status.hpp"

namespace imucal {

inline bool all_finite(float x) { return std::isfinite(x); }
inline bool all_finite(double x) { return std::isfinite(x); }

template <typename Derived>
inline bool all_finite(const Eigen::MatrixBase<Derived>& m) {
  for (Eigen::Index i = 0; i < m.size(); ++i) {
    if (!std::isfinite(m.coeff(i))) return false;
  }
  return true;
}

// Smallest ratio of LDL^T pivots (of the Jacobi-scaled matrix) accepted as non-singular.
template <typename Scalar, int N>
constexpr Scalar min_pivot_ratio() {
  return Scalar(100) * Scalar(N) * std::numeric_limits<Scalar>::epsilon();
}

template <typename Scalar, int N>
class NormalEquations {
 public:
  static_assert(N > 0 && N <= 16, "sized for small calibration problems");
  using Vector = Eigen::Matrix<Scalar, N, 1>;
  using Matrix = Eigen::Matrix<Scalar, N, N>;
  static constexpr int kPackedSize = N * (N + 1) / 2;

  NormalEquations() { clear(); }

  void clear() {
    for (Scalar& x : h_) x = Scalar(0);
    v_.setZero();
    f_ = Scalar(0);
    trace_ = Scalar(0);
    rows_ = 0;
  }

  // Folds in one residual row e with Jacobian row j and weight w >= 0. A row with a non-finite
  // entry or a negative weight is refused and changes nothing.
  Status add(const Vector& j, Scalar e, Scalar w = Scalar(1)) {
    if (!all_finite(j) || !std::isfinite(e) || !std::isfinite(w)) return Status::kNonFiniteInput;
    if (w < Scalar(0)) return Status::kInvalidArgument;
    // Refuse a row that would overflow the sums. The diagonal of H is non-negative, so a finite
    // trace bounds it, and Cauchy-Schwarz bounds the rest (|H_rc| <= sqrt(H_rr H_cc),
    // |v_c| <= sqrt(H_cc f)): two checks instead of one per entry.
    const Scalar trace = trace_ + w * j.squaredNorm();
    if (!std::isfinite(f_ + w * e * e) || !std::isfinite(trace)) return Status::kNonFiniteInput;
    trace_ = trace;
    int k = 0;
    for (int c = 0; c < N; ++c) {
      const Scalar wjc = w * j(c);
      for (int r = c; r < N; ++r) h_[k++] += wjc * j(r);
      v_(c) += wjc * e;
    }
    f_ += w * e * e;
    ++rows_;
    return Status::kOk;
  }

  int rows() const { return rows_; }
  Scalar weighted_sse() const { return f_; }     // f = sum w e^2
  const Vector& gradient() const { return v_; }  // v = sum w J^T e (half the gradient of f)

  Scalar h(int r, int c) const {  // element of H, either triangle
    if (r < c) {
      const int t = r;
      r = c;
      c = t;
    }
    return h_[c * N - c * (c - 1) / 2 + (r - c)];
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
    Matrix l;
    Vector d;
    const Status s = factor(lambda, scale, l, d);
    if (s != Status::kOk) return s;
    Vector x = -(scale.cwiseProduct(v_));
    detail::ldlt_solve(l.data(), d.data(), N, x.data());
    x = scale.cwiseProduct(x);
    if (!all_finite(x)) return Status::kIllConditioned;
    delta = x;
    return Status::kOk;
  }

  // Cov(p) = f / (m - N) * H^-1, valid at the minimum of f; or variance * H^-1 (as
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

  // Calls f(c, column c of variance * H^-1) for each c (variance < 0: f / (m - N)), one column at a
  // time: for what needs all of H^-1 without a matrix of it (nor an Eigen product that may
  // allocate) on the stack.
  template <class F>
  Status inverse_columns(Scalar variance, F f) const {
    return for_each_inverse_column(variance, f);
  }

  // sqrt(diag(Cov)) without forming the covariance: what a device needs, with less stack.
  // variance < 0: Cov = f / (m - N) H^-1 (the noise taken from the fit's own scatter); otherwise
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
    if (rows_ == 0 || !std::isfinite(f_)) return Scalar(1);
    if (f_ == Scalar(0)) return Scalar(0);  // an exact fit
    Scalar worst = Scalar(0);
    bool any = false;
    for (int i = 0; i < N; ++i) {
      const Scalar d = h(i, i);
      if (d > Scalar(0)) {
        any = true;
        const Scalar c = std::abs(v_(i)) / std::sqrt(d * f_);
        if (c > worst) worst = c;
      }
    }
    return any ? worst : Scalar(1);
  }

  // Gauss-Newton model of the decrease of f for a step delta: -(2 delta.v + delta^T H delta),
  // computed from the packed triangle (no N x N temporary on the stack).
  Scalar predicted_decrease(const Vector& delta) const {
    Scalar quad = Scalar(0);
    int k = 0;
    for (int c = 0; c < N; ++c) {
      quad += h_[k++] * delta(c) * delta(c);
      for (int r = c + 1; r < N; ++r) quad += Scalar(2) * h_[k++] * delta(r) * delta(c);
    }
    return -(Scalar(2) * delta.dot(v_) + quad);
  }

 private:
  Status scaled_matrix(Scalar lambda, Vector& scale, Matrix& a) const {
    if (!std::isfinite(lambda) || lambda < Scalar(0)) return Status::kInvalidArgument;
    if (rows_ == 0) return Status::kRankDeficient;
    for (int i = 0; i < N; ++i) {
      const Scalar d = h(i, i);
      if (!(d > Scalar(0)) || !std::isfinite(d)) return Status::kRankDeficient;
      scale(i) = Scalar(1) / std::sqrt(d);
    }
    for (int c = 0; c < N; ++c) {
      for (int r = c + 1; r < N; ++r) a(r, c) = h(r, c) * scale(r) * scale(c);  // lower triangle
      a(c, c) = Scalar(1) + lambda;
    }
    return Status::kOk;
  }

  // Calls f(c, column c of variance H^-1) for each c (variance < 0: f/(m-N)), one column at a
  // time.
  template <class F>
  Status for_each_inverse_column(Scalar variance, F f) const {
    if (rows_ <= N) return Status::kTooFewResiduals;
    if (!std::isfinite(variance)) return Status::kInvalidArgument;
    Vector scale;
    Matrix l;
    Vector d;
    const Status s = factor(Scalar(0), scale, l, d);
    if (s != Status::kOk) return s;
    if (variance < Scalar(0)) variance = f_ / Scalar(rows_ - N);
    for (int c = 0; c < N; ++c) {
      Vector column = Vector::Zero();
      column(c) = Scalar(1);
      detail::ldlt_solve(l.data(), d.data(), N, column.data());
      f(c, Vector(variance * scale(c) * scale.cwiseProduct(column)));
    }
    return Status::kOk;
  }

  // LDL^T of the Jacobi-scaled, damped matrix (L in the strict lower triangle of l, the pivots
  // in d), checked for rank and conditioning.
  Status factor(Scalar lambda, Vector& scale, Matrix& l, Vector& d) const {
    const Status s = scaled_matrix(lambda, scale, l);
    if (s != Status::kOk) return s;
    return detail::ldlt_factor(l.data(), N, d.data(), min_pivot_ratio<Scalar, N>());
  }

  Scalar h_[static_cast<std::size_t>(kPackedSize)] = {};
  Vector v_ = Vector::Zero();
  Scalar f_ = Scalar(0);
  Scalar trace_ = Scalar(0);  // trace of H: the overflow guard
  int rows_ = 0;
};

}  // namespace imucal
