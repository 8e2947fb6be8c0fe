// SPDX-License-Identifier: MIT
// imucal/solve/ldlt.hpp: LDL^T factorisation and solve of a small symmetric positive-definite
// matrix, in place in a column-major array. Not templated on the size: the 9-, 12- and 4-unknown
// problems share one copy of the code.
//
// No pivoting. The normal equations are factored Jacobi-scaled (unit diagonal), where diagonal
// pivoting would keep the natural order anyway, and LDL^T of a positive-definite matrix is
// backward stable without it. A pivot that is not positive means the matrix is not positive
// definite: the factorisation stops there and says so.
#pragma once

#include <cmath>

#include "imucal/status.hpp"

namespace imucal {
namespace detail {

// Largest size ldlt_factor takes (its scratch row is on the stack).
constexpr int kMaxLdltSize = 16;

// Factors the n x n symmetric matrix whose lower triangle is in a (column-major, leading
// dimension n) as L D L^T: the strict lower triangle of a becomes L (unit diagonal), d the
// pivots. kOk when every pivot is positive and finite and the smallest is at least min_ratio
// times the largest; kIllConditioned when one is not finite or their ratio is below
// min_ratio; kRankDeficient when one is not positive; kInvalidArgument when n is outside
// 1..kMaxLdltSize. It stops at the first pivot that fails.
template <typename Scalar>
Status ldlt_factor(Scalar* a, int n, Scalar* d, Scalar min_ratio) {
  if (n < 1 || n > kMaxLdltSize) return Status::kInvalidArgument;
  Scalar w[kMaxLdltSize];  // L(k, j) D(j) for the column k being formed
  Scalar dmin = Scalar(0);
  Scalar dmax = Scalar(0);
  for (int k = 0; k < n; ++k) {
    Scalar* const ck = a + k * n;  // column k
    Scalar dk = ck[k];
    for (int j = 0; j < k; ++j) {
      const Scalar lkj = a[j * n + k];
      w[j] = lkj * d[j];
      dk -= lkj * w[j];
    }
    if (!std::isfinite(dk)) return Status::kIllConditioned;
    if (!(dk > Scalar(0))) return Status::kRankDeficient;
    d[k] = dk;
    // Column k below the diagonal: A(i, k) - sum_j L(i, j) w(j), a column at a time.
    for (int j = 0; j < k; ++j) {
      const Scalar* const cj = a + j * n;
      const Scalar wj = w[j];
      for (int i = k + 1; i < n; ++i) ck[i] -= cj[i] * wj;
    }
    for (int i = k + 1; i < n; ++i) ck[i] /= dk;
    if (k == 0 || dk < dmin) dmin = dk;
    if (dk > dmax) dmax = dk;
  }
  if (dmin < min_ratio * dmax) return Status::kIllConditioned;
  return Status::kOk;
}

// Solves L D L^T x = b in place (x holds b on entry), with L and d from ldlt_factor.
template <typename Scalar>
void ldlt_solve(const Scalar* l, const Scalar* d, int n, Scalar* x) {
  for (int j = 0; j < n; ++j) {  // L y = b, a column of L at a time
    const Scalar xj = x[j];
    for (int i = j + 1; i < n; ++i) x[i] -= l[j * n + i] * xj;
  }
  for (int i = 0; i < n; ++i) x[i] /= d[i];  // D z = y
  for (int i = n - 1; i >= 0; --i) {         // L^T x = z
    Scalar s = x[i];
    for (int j = i + 1; j < n; ++j) s -= l[i * n + j] * x[j];
    x[i] = s;
  }
}

}  // namespace detail
}  // namespace imucal
