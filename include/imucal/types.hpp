// SPDX-License-Identifier: MIT
// imucal/types.hpp: the types every part of imucal shares: fixed-size vectors, one raw sample of
// an IMU, and the finiteness test every input check uses. Header-only, no allocation.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "imucal/config.hpp"

namespace imucal {

template <typename Scalar>
using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
template <typename Scalar>
using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;

// One raw sample as the sensor gives it.
template <typename Scalar>
struct ImuSample {
  std::uint32_t t_us = 0;  // microseconds, wrapping (differences are taken modulo 2^32)
  Vector3<Scalar> acc = Vector3<Scalar>::Zero();   // raw accelerometer (counts or m/s^2)
  Vector3<Scalar> gyro = Vector3<Scalar>::Zero();  // raw gyroscope (counts or rad/s)
  // deg C, NaN if the sensor has none.
  Scalar temperature = std::numeric_limits<Scalar>::quiet_NaN();
};

// One raw frame of 16-bit counts, as a sensor's data registers or FIFO give it.
struct RawFrame {
  std::uint32_t t_us = 0;  // microseconds, wrapping (differences are taken modulo 2^32)
  std::int16_t acc[3] = {0, 0, 0};
  std::int16_t gyro[3] = {0, 0, 0};
};

inline bool all_finite(float x) { return std::isfinite(x); }
inline bool all_finite(double x) { return std::isfinite(x); }

namespace detail {
// NaN by its bits: on a core without an FPU, a compare of floats is a runtime call, this is not.
inline bool is_nan(float x) {
  std::uint32_t b;
  std::memcpy(&b, &x, sizeof b);
  return (b & 0x7FFFFFFFu) > 0x7F800000u;
}
inline bool is_nan(double x) {
  std::uint64_t b;
  std::memcpy(&b, &x, sizeof b);
  return (b & 0x7FFFFFFFFFFFFFFFull) > 0x7FF0000000000000ull;
}
}  // namespace detail

// Every coefficient finite (no NaN, no infinity).
template <typename Derived>
inline bool all_finite(const Eigen::MatrixBase<Derived>& m) {
  for (Eigen::Index i = 0; i < m.size(); ++i) {
    if (!std::isfinite(m.coeff(i))) return false;
  }
  return true;
}

}  // namespace imucal
