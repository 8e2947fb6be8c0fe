// SPDX-License-Identifier: MIT
// imucal/models/accel_model.hpp: the accelerometer model of Tedaldi et al. (ICRA 2014) in the
// seed's convention, its gravity-norm residual and the seed's analytic Jacobian.
//
//   a_cal = T K (a_raw + b),  T = [[1, -a_yz, a_zy], [0, 1, -a_zx], [0, 0, 1]],  K = diag(s)
//
// The bias b is ADDED to the raw reading (imu_tk and x-io Fusion subtract an offset: offset = -b).
// Parameter order: [a_yz, a_zy, a_zx, s_x, s_y, s_z, b_x, b_y, b_z]. Header-only, no allocation.
#pragma once

#include <Eigen/Core>

#include "imucal/types.hpp"

namespace imucal {

enum AccelIndex : int {
  kAlphaYz = 0,
  kAlphaZy = 1,
  kAlphaZx = 2,
  kScaleX = 3,
  kScaleY = 4,
  kScaleZ = 5,
  kBiasX = 6,
  kBiasY = 7,
  kBiasZ = 8,
  kAccelParams = 9,
};

// The parameters' names, in AccelIndex order: the keys of the command's JSON and the names its
// summary, its advice and the Python package print.
inline constexpr const char* kAccelParamNames[kAccelParams] = {
    "alpha_yz", "alpha_zy", "alpha_zx", "s_x", "s_y", "s_z", "b_x", "b_y", "b_z"};

template <typename Scalar>
using AccelVector = Eigen::Matrix<Scalar, kAccelParams, 1>;

// T K: the upper-triangular matrix of the model.
template <typename Scalar>
Matrix3<Scalar> accel_matrix(const AccelVector<Scalar>& p) {
  Matrix3<Scalar> m;
  m << p(kScaleX), -p(kAlphaYz) * p(kScaleY), p(kAlphaZy) * p(kScaleZ),  //
      Scalar(0), p(kScaleY), -p(kAlphaZx) * p(kScaleZ),                  //
      Scalar(0), Scalar(0), p(kScaleZ);
  return m;
}

template <typename Scalar>
Vector3<Scalar> accel_apply(const AccelVector<Scalar>& p, const Vector3<Scalar>& raw) {
  const Vector3<Scalar> b(p(kBiasX), p(kBiasY), p(kBiasZ));
  return accel_matrix(p) * (raw + b);
}

template <typename Scalar>
using AccelDirectionJacobian = Eigen::Matrix<Scalar, 3, kAccelParams>;

// How the calibrated gravity direction n = c / |c|, c = T K (a + b), of a raw reading a moves with
// the parameters: dn/dp = (I - n n^T) / |c| dc/dp (3 x 9).
template <typename Scalar>
AccelDirectionJacobian<Scalar> accel_direction_jacobian(const AccelVector<Scalar>& p,
                                                        const Vector3<Scalar>& raw) {
  const Vector3<Scalar> a = raw + Vector3<Scalar>(p(kBiasX), p(kBiasY), p(kBiasZ));
  const Vector3<Scalar> u(p(kScaleX) * a(0), p(kScaleY) * a(1), p(kScaleZ) * a(2));
  Matrix3<Scalar> t;  // T
  t << Scalar(1), -p(kAlphaYz), p(kAlphaZy), Scalar(0), Scalar(1), -p(kAlphaZx), Scalar(0),
      Scalar(0), Scalar(1);
  const Vector3<Scalar> c = t * u;
  AccelDirectionJacobian<Scalar> dc = AccelDirectionJacobian<Scalar>::Zero();
  dc(0, kAlphaYz) = -u(1);
  dc(0, kAlphaZy) = u(2);
  dc(1, kAlphaZx) = -u(2);
  for (int i = 0; i < 3; ++i) {
    dc.col(kScaleX + i) = t.col(i) * a(i);
    dc.col(kBiasX + i) = t.col(i) * p(kScaleX + i);
  }
  const Scalar norm = c.norm();
  const Vector3<Scalar> n = c / norm;
  const Matrix3<Scalar> project = (Matrix3<Scalar>::Identity() - n * n.transpose()) / norm;
  return project * dc;
}

// e = |g|^2 - |T K (a + b)|^2 and its analytic Jacobian row (the seed's derivation):
// with u = K (a + b) and c = T u, de/dp = -2 c . dc/dp.
template <typename Scalar>
Scalar accel_residual(const AccelVector<Scalar>& p, const Vector3<Scalar>& a, Scalar g,
                      AccelVector<Scalar>* jacobian = nullptr) {
  const Scalar ax = a(0) + p(kBiasX), ay = a(1) + p(kBiasY), az = a(2) + p(kBiasZ);
  const Scalar ux = p(kScaleX) * ax, uy = p(kScaleY) * ay, uz = p(kScaleZ) * az;
  const Scalar cx = ux - p(kAlphaYz) * uy + p(kAlphaZy) * uz;
  const Scalar cy = uy - p(kAlphaZx) * uz;
  const Scalar cz = uz;
  if (jacobian != nullptr) {
    AccelVector<Scalar>& j = *jacobian;
    const Scalar m2 = Scalar(-2);
    j(kAlphaYz) = m2 * cx * -uy;
    j(kAlphaZy) = m2 * cx * uz;
    j(kAlphaZx) = m2 * cy * -uz;
    // dc/ds_x = T (a_x + b_x, 0, 0) = (a_x + b_x, 0, 0)
    j(kScaleX) = m2 * cx * ax;
    // dc/ds_y = T (0, a_y + b_y, 0) = (-a_yz (a_y + b_y), a_y + b_y, 0)
    j(kScaleY) = m2 * (cx * -p(kAlphaYz) + cy) * ay;
    // dc/ds_z = T (0, 0, a_z + b_z) = (a_zy, -a_zx, 1) (a_z + b_z)
    j(kScaleZ) = m2 * (cx * p(kAlphaZy) - cy * p(kAlphaZx) + cz) * az;
    // dc/db_k = T (s_k e_k): the same columns of T, times s_k instead of (a_k + b_k)
    j(kBiasX) = m2 * cx * p(kScaleX);
    j(kBiasY) = m2 * (cx * -p(kAlphaYz) + cy) * p(kScaleY);
    j(kBiasZ) = m2 * (cx * p(kAlphaZy) - cy * p(kAlphaZx) + cz) * p(kScaleZ);
  }
  return g * g - (cx * cx + cy * cy + cz * cz);
}

}  // namespace imucal
