// SPDX-License-Identifier: MIT
// imucal/field/mag_field.hpp: the magnetometer's hard and soft iron kept right from the rests of
// normal use (the design's field.md section 5; docs/field.md).
//
// The magnetometer's model is the accelerometer's problem again: a reading whose calibrated norm
// is a constant (the local field instead of gravity). Its hard iron h is the bias, added to the
// raw reading, and any soft iron S acts on a norm as an upper-triangular T K does
// (|S v| = |U v| with U' U = S' S, U = T K), so the field calibrator keeps it in a second
// AccelField (accel_field.hpp) with these settings: rests binned by field direction into cells
// that age, the prior's information added to theirs, a solution published only when the cells
// check it, a rest that disagrees held until a second one confirms a change (a magnetisation
// change: a new case, a battery, a speaker). The local field's strength is folded into the
// scales (the norm is the expected field_ut). The temperature does not enter: the cells are one
// band.
// Disturbances: a rest whose field, through the model, is further than max_field_error from the
// expected strength is refused (a magnet on the device); a passing magnet during a rest moves its
// field between pieces, which are refused as turning before they reach here; a rest or a reading
// in motion that disagrees with the model is held until a second one confirms a change.
// This header: the settings in the magnetometer's terms, and the conversions between the stored
// MagCalibration and the AccelField's parameters (the prior in, the published model out). The
// soft iron's frame (S = R U, R a rotation: the symmetric form's, or an alignment to the
// accelerometer) is kept from the prior. Header-only, no allocation.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/LU>  // inverse()
#include <cmath>
#include <limits>

#include "imucal/field/accel_field.hpp"
#include "imucal/models/mag_model.hpp"
#include "imucal/models/plausibility.hpp"
#include "imucal/status.hpp"
#include "imucal/types.hpp"

namespace imucal {

// The magnetometer part's settings (uT, relative, rad).
template <typename Scalar>
struct MagFieldSettings {
  bool enabled = true;
  Scalar counts_per_ut = std::numeric_limits<Scalar>::quiet_NaN();  // raw units per uT (NaN: off)
  // The local field's strength (uT) without a stored calibration (then the stored one's). The
  // scales fold in the difference; set it for the region (the world magnetic model) where it is
  // far from 50 uT.
  Scalar field_ut = Scalar(50);
  // The prior without a stored calibration: the nominal model with these sigmas.
  Scalar hard_iron_sigma_ut = Scalar(30);
  Scalar scale_sigma = Scalar(0.15);         // relative: soft iron and the field's strength
  Scalar misalignment_sigma = Scalar(0.08);  // the soft iron's off-diagonal part (relative)
  // What no rest mean is better than (the soft-iron model's misfit, a field not quite uniform):
  // caps a cell's weight. uT.
  Scalar floor_ut = Scalar(0.3);
  Scalar half_life_days = Scalar(30);
  Scalar change_sigma_ut = Scalar(30);  // a magnetisation change's step: its prior sigma
  Scalar confirm_seconds = Scalar(60);  // a held rest is confirmed this long after, or after motion
  // A rest whose field, through the model, is further than this from the expected strength
  // (relative) is refused: a magnet on the device. Nearer, it is judged against the model: a
  // magnet passing is held and dropped, a magnetisation change (a new case, a battery) is held
  // and confirmed by a second rest.
  Scalar max_field_error = Scalar(1);
  Scalar resolve_seconds = Scalar(600);  // known directions re-solved at most this often (s)
  // The cells must outnumber the parameters they determine by this many before a model is
  // believed: with a hard iron as large as the field, a few directions are fitted as well by a
  // centre mirrored through them.
  Scalar min_dof = Scalar(6);
};

// The AccelField settings that keep the magnetometer's model (the norm: field_ut).
template <typename Scalar>
AccelFieldSettings<Scalar> mag_norm_settings(const MagFieldSettings<Scalar>& m) {
  AccelFieldSettings<Scalar> a;
  a.enabled = m.enabled && !std::isnan(m.counts_per_ut);
  a.accel_per_m_s2 = m.counts_per_ut;
  a.gravity = m.field_ut;
  a.bias_sigma = m.hard_iron_sigma_ut;
  a.scale_sigma = m.scale_sigma;
  a.misalignment_sigma = m.misalignment_sigma;
  // No temperature enters (the cells are one band): the slope and curvature keep their prior
  // values, zero, with a sigma that nothing reads.
  a.slope_sigma = m.field_ut * Scalar(1e-6);
  a.curvature_sigma = m.field_ut * Scalar(1e-8);
  a.floor = m.floor_ut;
  a.half_life_days = m.half_life_days;
  a.change_sigma = m.change_sigma_ut;
  a.confirm_seconds = m.confirm_seconds;
  a.max_norm_error = m.max_field_error;
  a.resolve_seconds = m.resolve_seconds;
  a.min_dof = m.min_dof;
  return a;
}

// A stored magnetometer calibration as the AccelField's prior: the parameters of U (S' S = U' U,
// U = T K upper triangular, in uT per raw unit as the calibration's S) and the hard iron as the
// bias, with sigmas from the calibration's (the soft iron's entries' sigmas for U's, 0 where it
// has none: the settings' prior sigma then). frame: R = S U^-1, the rotation the published soft
// iron is turned back by. False (nothing written) for a calibration not usable: not succeeded,
// not finite, S singular or nearly so.
template <typename Scalar>
bool mag_prior(const MagCalibration<Scalar>& mag, AccelCalibration<Scalar>& prior,
               Matrix3<Scalar>& frame) {
  if (!succeeded(mag.status) || !all_finite(mag.soft_iron) || !all_finite(mag.hard_iron) ||
      !all_finite(mag.hard_iron_sigma) || !all_finite(mag.soft_iron_sigma) ||
      !(mag.field_ut > Scalar(0)) || !std::isfinite(mag.field_ut))
    return false;
  const Eigen::LLT<Matrix3<Scalar>> llt(mag.soft_iron.transpose() * mag.soft_iron);
  if (llt.info() != Eigen::Success) return false;
  const Matrix3<Scalar> u = llt.matrixU();
  if (!all_finite(u) || !(u(0, 0) > Scalar(0)) || !(u(1, 1) > Scalar(0)) || !(u(2, 2) > Scalar(0)))
    return false;
  // Nor one no magnetometer has, though S is not singular: an axis read at under a tenth of
  // another's scale (S nearly singular: every rest would then be off the field, refused for
  // good), or a misalignment beyond the models' bound.
  if (!(u.diagonal().minCoeff() >= Scalar(0.1) * u.diagonal().maxCoeff())) return false;
  AccelCalibration<Scalar> p;
  p.params(kScaleX) = u(0, 0);
  p.params(kScaleY) = u(1, 1);
  p.params(kScaleZ) = u(2, 2);
  p.params(kAlphaYz) = -u(0, 1) / u(1, 1);
  p.params(kAlphaZy) = u(0, 2) / u(2, 2);
  p.params(kAlphaZx) = -u(1, 2) / u(2, 2);
  for (int i = kAlphaYz; i <= kAlphaZx; ++i)
    if (!bounds::within(p.params(i), bounds::kMaxMisalignment)) return false;
  p.params.template segment<3>(kBiasX) = mag.hard_iron;
  const MagSymVector<Scalar>& s = mag.soft_iron_sigma;
  p.sigma(kScaleX) = s(kS00);
  p.sigma(kScaleY) = s(kS11);
  p.sigma(kScaleZ) = s(kS22);
  p.sigma(kAlphaYz) = s(kS01) / u(1, 1);
  p.sigma(kAlphaZy) = s(kS02) / u(2, 2);
  p.sigma(kAlphaZx) = s(kS12) / u(2, 2);
  p.sigma.template segment<3>(kBiasX) = mag.hard_iron_sigma;
  p.status = Status::kOk;
  frame = mag.soft_iron * u.inverse();
  if (!all_finite(frame)) return false;
  prior = p;
  return true;
}

// The AccelField's model (sensor units: model()) as a magnetometer calibration: S = frame T K,
// the hard iron, their sigmas (the soft iron's in MagSymIndex order: the scales', then the
// off-diagonal entries of U), the field strength the norm is (field_ut). The prior's alignment,
// if any, is kept in the frame and its fields copied from `like`.
template <typename Scalar>
void mag_from_model(const AccelCalibration<Scalar>& model, const Matrix3<Scalar>& frame,
                    Scalar field_ut, const MagCalibration<Scalar>& like,
                    MagCalibration<Scalar>& out) {
  out = like;
  out.status = Status::kOk;
  out.soft_iron = frame * accel_matrix(model.params);
  out.hard_iron = model.params.template segment<3>(kBiasX);
  out.hard_iron_sigma = model.sigma.template segment<3>(kBiasX);
  out.soft_iron_sigma(kS00) = model.sigma(kScaleX);
  out.soft_iron_sigma(kS11) = model.sigma(kScaleY);
  out.soft_iron_sigma(kS22) = model.sigma(kScaleZ);
  out.soft_iron_sigma(kS01) = model.sigma(kAlphaYz) * model.params(kScaleY);
  out.soft_iron_sigma(kS02) = model.sigma(kAlphaZy) * model.params(kScaleZ);
  out.soft_iron_sigma(kS12) = model.sigma(kAlphaZx) * model.params(kScaleZ);
  out.field_ut = field_ut;
}

}  // namespace imucal
