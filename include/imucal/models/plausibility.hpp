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

#include <Eigen/LU>  // determinant()
#include <cstdint>

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

// |x| <= limit, false for NaN (comparisons with NaN are false).
template <typename Scalar>
bool within(Scalar x, double limit) {
  return x <= static_cast<Scalar>(limit) && x >= -static_cast<Scalar>(limit);
}
template <typename Scalar>
bool magnitude_in(Scalar x, double lo, double hi) {
  const Scalar a = x < Scalar(0) ? -x : x;
  return a >= static_cast<Scalar>(lo) && a <= static_cast<Scalar>(hi);
}
// Every one of v[0, n) finite: one function for every length.
template <typename Scalar>
bool finite(const Scalar* v, int n) {
  return all_finite(Eigen::Map<const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>>(v, n));
}
// |(m v)_i| <= limit for each row i (v: 3 values), false for NaN. The limit is converted where it
// is a constant, not in the call: at -Os the call is not inlined, and a double argument would be
// converted at run time (soft double on a single-precision FPU).
template <typename Scalar>
bool product_within(const Matrix3<Scalar>& m, const Scalar* v, Scalar limit) {
  const Vector3<Scalar> x = m * Eigen::Map<const Vector3<Scalar>>(v);
  for (int i = 0; i < 3; ++i)
    if (!(x(i) <= limit && x(i) >= -limit)) return false;
  return true;
}

}  // namespace bounds

template <typename Scalar>
bool temperature_plausible(Scalar t) {
  return t >= static_cast<Scalar>(bounds::kMinTemperatureC) &&
         t <= static_cast<Scalar>(bounds::kMaxTemperatureC);
}

// The accelerometer's nine parameters (accel_model.hpp).
template <typename Scalar>
Bound accel_bound(const AccelVector<Scalar>& p) {
  if (!bounds::finite(p.data(), kAccelParams)) return Bound::kNonFinite;
  for (int i = kScaleX; i <= kScaleZ; ++i)
    if (!(p(i) >= static_cast<Scalar>(bounds::kMinAccelScale) &&
          p(i) <= static_cast<Scalar>(bounds::kMaxAccelScale)))
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
  if (!bounds::finite(s.data(), 9) || !bounds::finite(h.data(), 3) || !all_finite(field_ut))
    return Bound::kNonFinite;
  for (int i = 0; i < 9; ++i)
    if (!bounds::within(s(i), bounds::kMaxSoftIron)) return Bound::kMagSoftIron;
  if (!(s.determinant() > Scalar(0))) return Bound::kMagSoftIron;
  if (!bounds::product_within(s, h.data(), static_cast<Scalar>(bounds::kMaxMagOffset)))
    return Bound::kMagOffset;
  if (!(field_ut > Scalar(0) && field_ut <= static_cast<Scalar>(bounds::kMaxFieldUt)))
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
  if (!all_finite(t.reference_c) || !all_finite(t.min_c) || !all_finite(t.max_c))
    return Bound::kNonFinite;
  if (!temperature_plausible(t.reference_c) || !temperature_plausible(t.min_c) ||
      !temperature_plausible(t.max_c) || !(t.min_c <= t.max_c))
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
