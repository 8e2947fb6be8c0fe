// SPDX-License-Identifier: MIT
// imucal/solve/symmetric_eigen3.hpp: eigenvalues and eigenvectors of a symmetric 3 x 3 matrix by
// cyclic Jacobi rotations (the magnetometer's ellipsoid, the temperature fit's spread of
// orientations). Square roots only, no trigonometry linked, under 1 KB of code; every
// eigenvalue within a few units in the last place of the largest (test_mag_calibration), close
// and repeated ones included. Header-only, no allocation.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <limits>

#include "imucal/models/accel_model.hpp"  // Vector3, Matrix3

namespace imucal {

// The eigenvalues of the symmetric matrix a (its upper triangle is read) in ascending order, and
// if `vectors` is given the unit eigenvectors as its columns, in the same order (a = V diag V^T).
// False, with nothing written, if an entry is not finite or the rotations did not converge.
template <typename Scalar>
bool symmetric_eigen3(const Matrix3<Scalar>& a, Vector3<Scalar>& values,
                      Matrix3<Scalar>* vectors = nullptr) {
  Scalar m[3][3];
  Scalar v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int r = 0; r < 3; ++r)
    for (int c = r; c < 3; ++c) {
      m[r][c] = m[c][r] = a(r, c);
      if (!std::isfinite(a(r, c))) return false;
    }
  constexpr int kPairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  bool converged = false;
  for (int sweep = 0; sweep < 32 && !converged; ++sweep) {
    converged = true;
    for (const auto& pair : kPairs) {
      const int p = pair[0], q = pair[1], k = 3 - p - q;
      const Scalar apq = m[p][q];
      // Zero, or negligible against the diagonal entries: set to zero (the eigenvalues move by
      // at most |apq|, half an ulp of the larger entry).
      const Scalar scale = std::abs(m[p][p]) + std::abs(m[q][q]);
      if (std::abs(apq) <= std::numeric_limits<Scalar>::epsilon() * Scalar(0.5) * scale) {
        m[p][q] = m[q][p] = Scalar(0);
        continue;
      }
      converged = false;
      // The rotation that zeroes m[p][q]: t = tan of its angle, the smaller root.
      const Scalar theta = (m[q][q] - m[p][p]) / (Scalar(2) * apq);
      const Scalar t = (theta >= Scalar(0) ? Scalar(1) : Scalar(-1)) /
                       (std::abs(theta) + std::sqrt(theta * theta + Scalar(1)));
      const Scalar c = Scalar(1) / std::sqrt(t * t + Scalar(1)), s = t * c;
      m[p][p] -= t * apq;
      m[q][q] += t * apq;
      m[p][q] = m[q][p] = Scalar(0);
      const Scalar akp = m[k][p], akq = m[k][q];
      m[k][p] = m[p][k] = c * akp - s * akq;
      m[k][q] = m[q][k] = s * akp + c * akq;
      for (int r = 0; r < 3; ++r) {
        const Scalar vrp = v[r][p], vrq = v[r][q];
        v[r][p] = c * vrp - s * vrq;
        v[r][q] = s * vrp + c * vrq;
      }
    }
  }
  if (!converged) return false;
  int order[3] = {0, 1, 2};  // ascending by value
  for (int i = 1; i < 3; ++i)
    for (int j = i; j > 0 && m[order[j]][order[j]] < m[order[j - 1]][order[j - 1]]; --j) {
      const int o = order[j];
      order[j] = order[j - 1];
      order[j - 1] = o;
    }
  for (int i = 0; i < 3; ++i) {
    values(i) = m[order[i]][order[i]];
    if (vectors)
      for (int r = 0; r < 3; ++r) (*vectors)(r, i) = v[r][order[i]];
  }
  return true;
}

}  // namespace imucal
