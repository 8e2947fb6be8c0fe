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
// A float's bits: compares on them are integer compares (on a core without an FPU a compare of
// floats is a runtime call).
inline std::uint32_t bits_of(float x) {
  std::uint32_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}
inline std::uint64_t bits_of(double x) {
  std::uint64_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}
// NaN by its bits.
inline bool is_nan(float x) { return (bits_of(x) & 0x7FFFFFFFu) > 0x7F800000u; }
// Finite (neither NaN nor infinite) by its bits.
inline bool is_finite(float x) { return (bits_of(x) & 0x7FFFFFFFu) < 0x7F800000u; }
inline bool is_nan(double x) {
  return (bits_of(x) & 0x7FFFFFFFFFFFFFFFull) > 0x7FF0000000000000ull;
}

// x as the scalar type, without the runtime's 64-bit conversion routines.
template <typename Scalar>
Scalar to_scalar(std::int64_t x) {
  const std::int32_t low = static_cast<std::int32_t>(x);
  if (x == low) return static_cast<Scalar>(low);  // one conversion, correctly rounded
  const std::int32_t hi = static_cast<std::int32_t>(x >> 32);
  const std::uint32_t lo = static_cast<std::uint32_t>(x);
  return static_cast<Scalar>(hi) * Scalar(4294967296.0) + static_cast<Scalar>(lo);
}
template <typename Scalar>
Scalar to_scalar(std::uint64_t x) {
  const std::uint32_t hi = static_cast<std::uint32_t>(x >> 32);
  const std::uint32_t lo = static_cast<std::uint32_t>(x);
  if (hi == 0) return static_cast<Scalar>(lo);
  return static_cast<Scalar>(hi) * Scalar(4294967296.0) + static_cast<Scalar>(lo);
}

// Whether the scalar type's arithmetic is in hardware (an FPU, or a host): there, a float
// operation costs about what an integer one does; elsewhere each is a runtime call.
template <typename Scalar>
constexpr bool hardware_float() {
#if defined(__x86_64__) || defined(__i386__) || defined(__aarch64__)
  return true;
#elif defined(__ARM_FP)
  return sizeof(Scalar) == 4 ? (__ARM_FP & 4) != 0 : (__ARM_FP & 8) != 0;
#elif defined(__riscv_flen)
  return static_cast<int>(sizeof(Scalar)) * 8 <= __riscv_flen;
#else
  return false;
#endif
}

// Temperatures travel the per-sample path in fixed point, 1/4096 deg C (kTemperatureQ): one
// conversion a reading, then integer compares and sums, the float work once a sub-block.
constexpr std::int32_t kTemperatureQ = 4096;
// Beyond this (in 1/4096 deg C; 262,144 deg C) a reading saturates, infinity included.
constexpr std::int32_t kTemperatureQMax = 1 << 30;

// t (not NaN) x 4096, rounded half away from zero, saturated at +-kTemperatureQMax, from the
// float's bits with no float arithmetic (a core without an FPU pays no runtime call).
inline std::int32_t to_temperature_q_bits(float t) {
  std::uint32_t b;
  std::memcpy(&b, &t, sizeof b);
  const std::int32_t e = static_cast<std::int32_t>((b >> 23) & 0xFFu);
  const std::uint32_t m =
      (b & 0x7FFFFFu) | 0x800000u;  // |t| = m 2^(e - 150), t 4096 = m 2^(e - 138)
  std::int32_t q;
  if (e == 0) {
    q = 0;  // zero or subnormal
  } else if (e >= 145) {
    q = kTemperatureQMax;  // m 2^7 >= 2^30 already (infinity too)
  } else if (e >= 138) {
    q = static_cast<std::int32_t>(m << (e - 138));
  } else {
    const std::int32_t sh = 138 - e;
    q = sh > 24 ? 0 : static_cast<std::int32_t>((m + (1u << (sh - 1))) >> sh);
  }
  return (b >> 31) != 0u ? -q : q;
}
// The same with float arithmetic: the product (exact: a power of two), truncated, its fraction
// (exact) rounded.
inline std::int32_t to_temperature_q_float(float t) {
  const float x = t * static_cast<float>(kTemperatureQ);
  if (!(x < static_cast<float>(kTemperatureQMax))) return kTemperatureQMax;
  if (!(x > -static_cast<float>(kTemperatureQMax))) return -kTemperatureQMax;
  std::int32_t i = static_cast<std::int32_t>(x);
  const float fraction = x - static_cast<float>(i);
  if (fraction >= 0.5f) ++i;
  if (fraction <= -0.5f) --i;
  return i;
}
// Whichever of the two is cheaper on this core: the same result.
inline std::int32_t to_temperature_q(float t) {
  return hardware_float<float>() ? to_temperature_q_float(t) : to_temperature_q_bits(t);
}
inline std::int32_t to_temperature_q(double t) {
  if (!(std::fabs(t) * kTemperatureQ < static_cast<double>(kTemperatureQMax)))
    return t < 0 ? -kTemperatureQMax : kTemperatureQMax;
  return static_cast<std::int32_t>(std::round(t * kTemperatureQ));
}
template <typename Scalar>
Scalar from_temperature_q(std::int32_t q) {
  return static_cast<Scalar>(q) * Scalar(1.0 / kTemperatureQ);
}
// A sum of them, wider than 32 bits.
template <typename Scalar>
Scalar from_temperature_q_sum(std::int64_t q) {
  return to_scalar<Scalar>(q) * Scalar(1.0 / kTemperatureQ);
}
// Saturating conversion of a non-negative limit to an unsigned 32-bit one: what is not positive
// gives 0, what is not below the cap (NaN and infinity too) the cap.
template <typename Scalar>
std::uint32_t to_u32_limit(Scalar x, std::uint32_t cap) {
  if (!(x < static_cast<Scalar>(cap))) return cap;
  return x > Scalar(0) ? static_cast<std::uint32_t>(x) : 0u;
}
// Seconds as whole microseconds in 32 bits, truncated as a cast truncates: NaN and what is not
// positive give 0, what is 2^32 us (71.6 minutes) or more the largest. Settings are converted
// with it before they are checked, so an absurd one converts without undefined behaviour.
template <typename Scalar>
std::uint32_t seconds_to_us(Scalar seconds) {
  const Scalar us = seconds * Scalar(1e6);
  return std::isnan(us) ? 0u : to_u32_limit(us, 0xFFFFFFFFu);
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
