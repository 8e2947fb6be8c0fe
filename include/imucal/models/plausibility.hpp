// SPDX-License-Identifier: MIT
// imucal/models/plausibility.hpp: the physical bounds every calibration value is checked against
// before make_record(), encode_record(), decode_record() or Corrector accepts it, and which bound a
// refused value broke. Finite is not enough: a scale of 3e38 or a temperature slope of 1e38 is
// finite, encodes and decodes, and turns every corrected sample into infinity.
//
// The bounds hold for any MEMS part and any raw unit (counts of a 24-bit converter, g, m/s^2,
// deg/s, gauss): each is set well past the widest real part, never at a typical value.
//   accelerometer scale      1e-9 .. 1e3 m/s^2 per raw unit
//   gyro scale (|s|)         1e-10 .. 1e3 rad/s per raw unit
//   misalignment (|angle|)   at most 0.5 rad (the model is a small-angle one)
//   offset |T K b| per axis  1e4 m/s^2 (accelerometer), 1e3 rad/s (gyro): past any full scale,
//                            even for unsigned counts whose zero is mid-range
//   magnetometer             |S_ij| at most 1e3 uT per raw unit and det S > 0; |S h| at most
//                            1e5 uT per axis; field strength above 0 and at most 1e3 uT
//   temperature slopes       |T K b1| at most 1 m/s^2 (accelerometer) or 0.1 rad/s (gyro) per
//                            deg C; |T K b2| at most 0.01 m/s^2 or 1e-3 rad/s per deg C^2;
//                            the bias at the reference temperature as the offsets above
//   temperatures             -100 .. 200 deg C (calibration, model reference and range)
//   sample rate              0 .. 1e6 Hz
// Within these, every corrected value stays finite for raw readings up to 1e30.
// Header-only, templated on the scalar; never allocates.
#pragma once

#include <Eigen/LU>  // determinant() for the files that include this header
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "imucal/models/accel_model.hpp"
#include "imucal/models/gyro_model.hpp"
#include "imucal/models/temperature_model.hpp"

namespace imucal {

enum class Bound : std::uint8_t {
  kNone = 0,
  kNonFinite,          // NaN or infinity
  kTemperature,        // a temperature outside -100..200 deg C (or a model's min above max)
  kSampleRate,         // outside 0..1e6 Hz
  kAccelScale,         // outside 1e-9..1e3 m/s^2 per raw unit
  kAccelMisalignment,  // |angle| above 0.5 rad
  kAccelOffset,        // |T K b| above 1e4 m/s^2 on an axis
  kGyroScale,          // |s| outside 1e-10..1e3 rad/s per raw unit
  kGyroMisalignment,   // |angle| above 0.5 rad
  kGyroOffset,         // |T K b| above 1e3 rad/s on an axis
  kMagSoftIron,        // |S_ij| above 1e3 uT per raw unit, or det S not positive
  kMagOffset,          // |S h| above 1e5 uT on an axis
  kMagField,           // field strength not in (0, 1e3] uT
  kAccelSlope,         // |T K b1| above 1 m/s^2 per deg C (b2: 0.01 per deg C^2)
  kGyroSlope,          // |T K b1| above 0.1 rad/s per deg C (b2: 1e-3 per deg C^2)
};

inline const char* to_string(Bound b) {
  switch (b) {
    case Bound::kNone:
      return "within bounds";
    case Bound::kNonFinite:
      return "a value is NaN or infinite";
    case Bound::kTemperature:
      return "temperature outside -100..200 degC";
    case Bound::kSampleRate:
      return "sample rate outside 0..1e6 Hz";
    case Bound::kAccelScale:
      return "accelerometer scale outside 1e-9..1e3 m/s^2 per raw unit";
    case Bound::kAccelMisalignment:
      return "accelerometer misalignment above 0.5 rad";
    case Bound::kAccelOffset:
      return "accelerometer offset above 1e4 m/s^2";
    case Bound::kGyroScale:
      return "gyro scale outside 1e-10..1e3 rad/s per raw unit";
    case Bound::kGyroMisalignment:
      return "gyro misalignment above 0.5 rad";
    case Bound::kGyroOffset:
      return "gyro offset above 1e3 rad/s";
    case Bound::kMagSoftIron:
      return "magnetometer soft iron above 1e3 uT per raw unit or not positive definite";
    case Bound::kMagOffset:
      return "magnetometer offset above 1e5 uT";
    case Bound::kMagField:
      return "magnetic field strength outside 0..1e3 uT";
    case Bound::kAccelSlope:
      return "accelerometer temperature slope above 1 m/s^2/degC (0.01 m/s^2/degC^2)";
    case Bound::kGyroSlope:
      return "gyro temperature slope above 0.1 rad/s/degC (1e-3 rad/s/degC^2)";
  }
  return "unknown bound";
}

namespace bounds {

constexpr double kMinTemperatureC = -100.0, kMaxTemperatureC = 200.0;
constexpr double kMaxSampleRateHz = 1.0e6;
constexpr double kMinAccelScale = 1.0e-9, kMaxAccelScale = 1.0e3;
constexpr double kMinGyroScale = 1.0e-10, kMaxGyroScale = 1.0e3;
constexpr double kMaxMisalignment = 0.5;
constexpr double kMaxAccelOffset = 1.0e4, kMaxGyroOffset = 1.0e3;
constexpr double kMaxSoftIron = 1.0e3, kMaxMagOffset = 1.0e5, kMaxFieldUt = 1.0e3;
constexpr double kMaxAccelSlope = 1.0, kMaxAccelCurvature = 0.01;
constexpr double kMaxGyroSlope = 0.1, kMaxGyroCurvature = 1.0e-3;

// Compares of a float done on its bits (detail::bits_of), as integer compares: on a core without
// an FPU a float compare is a runtime call (and its routines 0.5 KB of flash), an integer compare
// is not. Each gives the float compare's result, NaN included; a double is compared as a double.
using detail::bits_of;
// |x|'s bits: they order as |x| does, NaN above infinity.
inline std::uint32_t magnitude_bits(float x) { return bits_of(x) & 0x7FFFFFFFu; }
// x's bits as an integer that orders as x does (-0 and +0 both 0); a NaN beyond the infinity of
// its sign.
inline std::int32_t order_bits(float x) {
  const std::uint32_t b = bits_of(x);
  const std::int32_t m = static_cast<std::int32_t>(b & 0x7FFFFFFFu);
  return (b >> 31) != 0u ? -m : m;
}

// x finite (not NaN, not infinite).
template <typename Scalar>
bool is_finite(Scalar x) {
  if constexpr (std::is_same<Scalar, float>::value)
    return detail::is_finite(x);
  else
    return all_finite(x);
}
// lo <= x <= hi (lo and hi not NaN), false for NaN.
template <typename Scalar>
bool in_range(Scalar x, Scalar lo, Scalar hi) {
  if constexpr (std::is_same<Scalar, float>::value) {
    const std::int32_t k = order_bits(x);
    return k >= order_bits(lo) && k <= order_bits(hi);
  } else {
    return x >= lo && x <= hi;
  }
}
// x > 0, false for NaN.
template <typename Scalar>
bool positive(Scalar x) {
  if constexpr (std::is_same<Scalar, float>::value)
    return bits_of(x) - 1u < 0x7F800000u;  // +0 wraps to the top
  else
    return x > Scalar(0);
}
// a <= b (neither NaN).
template <typename Scalar>
bool at_most(Scalar a, Scalar b) {
  if constexpr (std::is_same<Scalar, float>::value)
    return order_bits(a) <= order_bits(b);
  else
    return a <= b;
}
// |x| <= limit (limit >= 0), false for NaN.
template <typename Scalar>
bool abs_at_most(Scalar x, Scalar limit) {
  if constexpr (std::is_same<Scalar, float>::value)
    return magnitude_bits(x) <= magnitude_bits(limit);
  else
    return x <= limit && x >= -limit;
}

// Whether the scalar's arithmetic is runtime calls (a float on a core without an FPU). There the
// written-out forms below replace Eigen's (out-of-line code, its loops and its assignments) and
// round as Eigen's: the same operations in the same order, and no multiply-add is fused without
// an FPU. Elsewhere they are Eigen's.
template <typename Scalar>
constexpr bool soft_float() {
  return std::is_same<Scalar, float>::value && !detail::hardware_float<float>();
}

// -x; a soft float by its sign bit: a + negated(b) is a - b, bit for bit, and a program that
// subtracts only so links one of the runtime's two add routines (0.8 KB each on the M0+).
template <typename Scalar>
Scalar negated(Scalar x) {
  if constexpr (soft_float<Scalar>()) {
    const std::uint32_t b = bits_of(x) ^ 0x80000000u;
    float y;
    std::memcpy(&y, &b, sizeof y);
    return y;
  } else {
    return -x;
  }
}
// det m, as Eigen's determinant() computes it.
template <typename Scalar>
Scalar determinant(const Matrix3<Scalar>& m) {
  if constexpr (soft_float<Scalar>()) {
    const auto cofactor = [&m](int a, int b, int c) {
      return m(0, a) * (m(1, b) * m(2, c) + negated(m(1, c) * m(2, b)));
    };
    return cofactor(0, 1, 2) + negated(cofactor(1, 0, 2)) + cofactor(2, 0, 1);
  } else {
    return m.determinant();
  }
}
// out = m v (v, out: 3 values each, apart), as Eigen's product computes it.
template <typename Scalar>
void product(const Matrix3<Scalar>& m, const Scalar* v, Scalar* out) {
  if constexpr (soft_float<Scalar>()) {
    for (int i = 0; i < 3; ++i) out[i] = m(i, 0) * v[0] + (m(i, 1) * v[1] + m(i, 2) * v[2]);
  } else {
    Eigen::Map<Vector3<Scalar>>(out).noalias() = m * Eigen::Map<const Vector3<Scalar>>(v);
  }
}

// |x| <= limit, false for NaN (comparisons with NaN are false).
template <typename Scalar>
bool within(Scalar x, double limit) {
  return abs_at_most(x, static_cast<Scalar>(limit));
}
template <typename Scalar>
bool magnitude_in(Scalar x, double lo, double hi) {
  if constexpr (std::is_same<Scalar, float>::value) {
    const std::uint32_t a = magnitude_bits(x);
    return a >= bits_of(static_cast<float>(lo)) && a <= bits_of(static_cast<float>(hi));
  } else {
    const Scalar a = x < Scalar(0) ? -x : x;
    return a >= static_cast<Scalar>(lo) && a <= static_cast<Scalar>(hi);
  }
}
// Every one of v[0, n) finite: one function for every length.
template <typename Scalar>
bool finite(const Scalar* v, int n) {
  for (int i = 0; i < n; ++i)
    if (!is_finite(v[i])) return false;
  return true;
}
// |(m v)_i| <= limit for each row i (v: 3 values), false for NaN. The limit is converted where it
// is a constant, not in the call: at -Os the call is not inlined, and a double argument would be
// converted at run time (soft double on a single-precision FPU).
template <typename Scalar>
bool product_within(const Matrix3<Scalar>& m, const Scalar* v, Scalar limit) {
  Scalar x[3];
  product(m, v, x);
  for (int i = 0; i < 3; ++i)
    if (!abs_at_most(x[i], limit)) return false;
  return true;
}

}  // namespace bounds

template <typename Scalar>
bool temperature_plausible(Scalar t) {
  return bounds::in_range(t, static_cast<Scalar>(bounds::kMinTemperatureC),
                          static_cast<Scalar>(bounds::kMaxTemperatureC));
}

// The accelerometer's nine parameters (accel_model.hpp).
template <typename Scalar>
Bound accel_bound(const AccelVector<Scalar>& p) {
  if (!bounds::finite(p.data(), kAccelParams)) return Bound::kNonFinite;
  for (int i = kScaleX; i <= kScaleZ; ++i)
    if (!bounds::in_range(p(i), static_cast<Scalar>(bounds::kMinAccelScale),
                          static_cast<Scalar>(bounds::kMaxAccelScale)))
      return Bound::kAccelScale;
  for (int i = kAlphaYz; i <= kAlphaZx; ++i)
    if (!bounds::within(p(i), bounds::kMaxMisalignment)) return Bound::kAccelMisalignment;
  if (!bounds::product_within(accel_matrix(p), p.data() + kBiasX,
                              static_cast<Scalar>(bounds::kMaxAccelOffset)))
    return Bound::kAccelOffset;
  return Bound::kNone;
}

// The gyro's twelve parameters (gyro_model.hpp).
template <typename Scalar>
Bound gyro_bound(const GyroVector<Scalar>& p) {
  if (!bounds::finite(p.data(), kGyroParams)) return Bound::kNonFinite;
  for (int i = kGyroScaleX; i <= kGyroScaleZ; ++i)
    if (!bounds::magnitude_in(p(i), bounds::kMinGyroScale, bounds::kMaxGyroScale))
      return Bound::kGyroScale;
  for (int i = kGammaYz; i <= kGammaYx; ++i)
    if (!bounds::within(p(i), bounds::kMaxMisalignment)) return Bound::kGyroMisalignment;
  if (!bounds::product_within(gyro_matrix<Scalar>(p), p.data() + kGyroBiasX,
                              static_cast<Scalar>(bounds::kMaxGyroOffset)))
    return Bound::kGyroOffset;
  return Bound::kNone;
}

// The magnetometer's soft iron S (uT per raw unit), hard iron h (raw units) and field (uT).
template <typename Scalar>
Bound mag_bound(const Matrix3<Scalar>& s, const Vector3<Scalar>& h, Scalar field_ut) {
  if (!bounds::finite(s.data(), 9) || !bounds::finite(h.data(), 3) || !bounds::is_finite(field_ut))
    return Bound::kNonFinite;
  for (int i = 0; i < 9; ++i)
    if (!bounds::within(s(i), bounds::kMaxSoftIron)) return Bound::kMagSoftIron;
  if (!bounds::positive(bounds::determinant(s))) return Bound::kMagSoftIron;
  if (!bounds::product_within(s, h.data(), static_cast<Scalar>(bounds::kMaxMagOffset)))
    return Bound::kMagOffset;
  if (!bounds::positive(field_ut) ||
      !bounds::abs_at_most(field_ut, static_cast<Scalar>(bounds::kMaxFieldUt)))
    return Bound::kMagField;
  return Bound::kNone;
}

// One sensor's temperature bias through its matrix M = T K (raw units to physical).
template <typename Scalar>
Bound temperature_bias_bound(const TemperatureBias<Scalar>& b, const Matrix3<Scalar>& m,
                             bool accel) {
  if (!bounds::finite(b.b0.data(), 3) || !bounds::finite(b.b1.data(), 3) ||
      !bounds::finite(b.b2.data(), 3))
    return Bound::kNonFinite;
  // The offset, the slope and the curvature of the bias through m, each within its limit.
  const Scalar limits[2][3] = {
      {static_cast<Scalar>(bounds::kMaxGyroOffset), static_cast<Scalar>(bounds::kMaxGyroSlope),
       static_cast<Scalar>(bounds::kMaxGyroCurvature)},
      {static_cast<Scalar>(bounds::kMaxAccelOffset), static_cast<Scalar>(bounds::kMaxAccelSlope),
       static_cast<Scalar>(bounds::kMaxAccelCurvature)}};
  const Scalar* const terms[3] = {b.b0.data(), b.b1.data(), b.b2.data()};
  for (int k = 0; k < 3; ++k)
    if (!bounds::product_within(m, terms[k], limits[accel][k]))
      return k == 0 ? (accel ? Bound::kAccelOffset : Bound::kGyroOffset)
                    : (accel ? Bound::kAccelSlope : Bound::kGyroSlope);
  return Bound::kNone;
}

// A temperature model, for the sensors whose matrices are given (nullptr: that sensor's bias
// model is not checked; the caller uses it only with its calibration).
template <typename Scalar>
Bound temperature_model_bound(const TemperatureModel<Scalar>& t, const Matrix3<Scalar>* accel_m,
                              const Matrix3<Scalar>* gyro_m) {
  if (!bounds::is_finite(t.reference_c) || !bounds::is_finite(t.min_c) ||
      !bounds::is_finite(t.max_c))
    return Bound::kNonFinite;
  if (!temperature_plausible(t.reference_c) || !temperature_plausible(t.min_c) ||
      !temperature_plausible(t.max_c) || !bounds::at_most(t.min_c, t.max_c))
    return Bound::kTemperature;
  if (accel_m != nullptr && succeeded(t.accel.status)) {
    const Bound b = temperature_bias_bound(t.accel, *accel_m, true);
    if (b != Bound::kNone) return b;
  }
  if (gyro_m != nullptr && succeeded(t.gyro.status)) {
    const Bound b = temperature_bias_bound(t.gyro, *gyro_m, false);
    if (b != Bound::kNone) return b;
  }
  return Bound::kNone;
}

}  // namespace imucal
