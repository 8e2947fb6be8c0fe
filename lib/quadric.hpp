// SPDX-License-Identifier: MIT
// lib/quadric.hpp: the algebraic quadric x^T Q x + u^T x = 1 that both closed-form ellipsoid
// starts fit by linear least squares (accelerometer poses, magnetometer samples): one row of it,
// and Q and u from the solution. Internal to the library.
#pragma once

#include <Eigen/Core>

#include "imucal/models/accel_model.hpp"

namespace imucal::detail {

template <typename Scalar>
using QuadricVector = Eigen::Matrix<Scalar, 9, 1>;

// theta = [Q00 Q11 Q22 Q01 Q02 Q12 u0 u1 u2]: the row phi with phi . theta = x^T Q x + u^T x.
template <typename Scalar>
QuadricVector<Scalar> quadric_row(const Vector3<Scalar>& x) {
  QuadricVector<Scalar> phi;
  phi << x(0) * x(0), x(1) * x(1), x(2) * x(2), Scalar(2) * x(0) * x(1), Scalar(2) * x(0) * x(2),
      Scalar(2) * x(1) * x(2), x(0), x(1), x(2);
  return phi;
}

template <typename Scalar>
void quadric_from(const QuadricVector<Scalar>& theta, Matrix3<Scalar>& q, Vector3<Scalar>& u) {
  q << theta(0), theta(3), theta(4),  //
      theta(3), theta(1), theta(5),   //
      theta(4), theta(5), theta(2);
  u << theta(6), theta(7), theta(8);
}

}  // namespace imucal::detail
