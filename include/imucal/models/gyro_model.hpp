// SPDX-License-Identifier: MIT
// imucal/models/gyro_model.hpp: the gyroscope model of Tedaldi et al. (ICRA 2014) in the seed's
// convention (math.md section 1).
//
//   w_cal = T K (w_raw + b),  T = [[1, -g_yz, g_zy], [g_xz, 1, -g_zx], [-g_xy, g_yx, 1]],
//   K = diag(s_x, s_y, s_z)
//
// The bias b is ADDED to the raw reading, as for the accelerometer (imu_tk subtracts an offset:
// offset = -b). Parameter order (imu_tk layout): [g_yz, g_zy, g_zx, g_xz, g_xy, g_yx, s_x, s_y,
// s_z], then, when the bias is refined, [b_x, b_y, b_z]. M = T K is a general 3x3 matrix; the 9
// parameters are a chart of it. Header-only, no allocation.
#pragma once

#include <Eigen/Core>

#include "imucal/models/accel_model.hpp"

namespace imucal {

enum GyroIndex : int {
  kGammaYz = 0,
  kGammaZy = 1,
  kGammaZx = 2,
  kGammaXz = 3,
  kGammaXy = 4,
  kGammaYx = 5,
  kGyroScaleX = 6,
  kGyroScaleY = 7,
  kGyroScaleZ = 8,
  kGyroBiasX = 9,
  kGyroBiasY = 10,
  kGyroBiasZ = 11,
  kGyroMatrixParams = 9,  // misalignment and scale
  kGyroParams = 12,       // and the bias
};

// The parameters' names, in GyroIndex order (as kAccelParamNames).
inline constexpr const char* kGyroParamNames[kGyroParams] = {
    "gamma_yz", "gamma_zy", "gamma_zx", "gamma_xz", "gamma_xy", "gamma_yx",
    "s_x",      "s_y",      "s_z",      "b_x",      "b_y",      "b_z"};

template <typename Scalar>
using GyroVector = Eigen::Matrix<Scalar, kGyroParams, 1>;

// M = T K from the first 9 parameters (any vector with at least 9 entries).
template <typename Scalar, class Derived>
Matrix3<Scalar> gyro_matrix(const Eigen::MatrixBase<Derived>& p) {
  Matrix3<Scalar> m;
  m << p(kGyroScaleX), -p(kGammaYz) * p(kGyroScaleY), p(kGammaZy) * p(kGyroScaleZ),  //
      p(kGammaXz) * p(kGyroScaleX), p(kGyroScaleY), -p(kGammaZx) * p(kGyroScaleZ),   //
      -p(kGammaXy) * p(kGyroScaleX), p(kGammaYx) * p(kGyroScaleY), p(kGyroScaleZ);
  return m;
}

// The calibrated rate in rad/s for all 12 parameters (bias included).
template <typename Scalar>
Vector3<Scalar> gyro_apply(const GyroVector<Scalar>& p, const Vector3<Scalar>& raw) {
  const Vector3<Scalar> b(p(kGyroBiasX), p(kGyroBiasY), p(kGyroBiasZ));
  return gyro_matrix<Scalar>(p) * (raw + b);
}

}  // namespace imucal
