// SPDX-License-Identifier: MIT
// imucal/models/mag_model.hpp: the magnetometer model and the result of its calibration.
//
//   m_cal = S (m_raw + h)
//
// h (hard iron) is ADDED to the raw reading, in raw units, like the accelerometer's and the
// gyro's bias. S (soft iron, 3x3) maps raw units to microtesla: S = unit_ut * B_raw * W, with W
// symmetric, |W (m_raw + h)| = 1 on the fitted ellipsoid, B_raw = det(W)^(-1/3) the field
// strength in raw units and unit_ut the nominal microtesla per raw unit. So |m_cal| is the local
// field strength in uT and S changes volumes by exactly unit_ut^3. After the optional alignment
// to the accelerometer frame S = R * unit_ut * B_raw * W is a general 3x3 matrix (R a rotation).
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "imucal/models/accel_model.hpp"
#include "imucal/status.hpp"

namespace imucal {

// The six independent entries of a symmetric 3x3 matrix, in this order.
enum MagSymIndex : int { kS00 = 0, kS11, kS22, kS01, kS02, kS12, kMagSymEntries };
// Their names, in MagSymIndex order (the keys of the command's JSON).
inline constexpr const char* kMagSymNames[kMagSymEntries] = {"S00", "S11", "S22",
                                                             "S01", "S02", "S12"};
template <typename Scalar>
using MagSymVector = Eigen::Matrix<Scalar, kMagSymEntries, 1>;

template <typename Scalar>
struct MagCalibration {
  Status status = Status::kNotStarted;                      // succeeded(status): usable
  Matrix3<Scalar> soft_iron = Matrix3<Scalar>::Identity();  // S, uT per raw unit
  Vector3<Scalar> hard_iron = Vector3<Scalar>::Zero();      // h, raw units, added
  Vector3<Scalar> hard_iron_sigma = Vector3<Scalar>::Zero();
  // Sigma of the symmetric soft iron (before any alignment), MagSymIndex order, uT per raw unit.
  MagSymVector<Scalar> soft_iron_sigma = MagSymVector<Scalar>::Zero();
  Scalar field_ut = Scalar(0);       // |m_cal| on the fitted sphere (local field strength)
  Scalar fit_error_pct = Scalar(0);  // 100 * RMS(|m_cal| - field) / field over the samples held
  Scalar coverage = Scalar(0);       // fraction of direction cells (calibrated) holding a sample
  int samples = 0;                   // samples in the fit
  int iterations = 0;                // LM iterations of the geometric refinement
  Quality quality = Quality::kNone;
  // Optional alignment to the accelerometer frame (constant dip over static poses).
  Status alignment_status = Status::kNotStarted;  // succeeded: soft_iron includes R
  Scalar dip_deg = Scalar(0);  // inclination: angle of the field below horizontal
  Scalar dip_sigma_deg = Scalar(0);
  Vector3<Scalar> alignment_rotation = Vector3<Scalar>::Zero();  // R as a rotation vector (rad)
  Vector3<Scalar> alignment_sigma = Vector3<Scalar>::Zero();     // its sigma (rad)
  int alignment_rests = 0;
};

template <typename Scalar>
Vector3<Scalar> mag_apply(const MagCalibration<Scalar>& c, const Vector3<Scalar>& raw) {
  return c.soft_iron * (raw + c.hard_iron);
}

}  // namespace imucal
