// SPDX-License-Identifier: MIT
// imucal/models/temperature_model.hpp: biases that move with temperature, and the fitted model.
//
//   b(T) = b0 + b1 (T - T0) + b2 (T - T0)^2          (per axis, raw units; b2 = 0 when linear)
//
// for the accelerometer's and the gyro's ADDED bias (a_cal = T K (a_raw + b(T)), the same for
// the gyro), T in deg C and T0 the reference temperature (the calibration's mean temperature).
// b0 is the bias at T0 and replaces the calibration's constant bias when the model is applied.
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "imucal/models/accel_model.hpp"
#include "imucal/status.hpp"

namespace imucal {

template <typename Scalar>
struct TemperatureBias {
  Vector3<Scalar> b0 = Vector3<Scalar>::Zero();  // bias at the reference temperature
  Vector3<Scalar> b1 = Vector3<Scalar>::Zero();  // per deg C
  Vector3<Scalar> b2 = Vector3<Scalar>::Zero();  // per deg C^2 (zero for a linear model)
  Vector3<Scalar> b0_sigma = Vector3<Scalar>::Zero();
  Vector3<Scalar> b1_sigma = Vector3<Scalar>::Zero();
  Vector3<Scalar> b2_sigma = Vector3<Scalar>::Zero();
  Status status = Status::kNotStarted;  // succeeded(status): usable

  Vector3<Scalar> at(Scalar t, Scalar t0) const {
    const Scalar d = t - t0;
    return b0 + d * (b1 + d * b2);
  }
};

template <typename Scalar>
struct TemperatureModel {
  int order = 1;                   // 1: linear, 2: quadratic
  Scalar reference_c = Scalar(0);  // T0
  Scalar min_c = Scalar(0);        // temperatures of the rests fitted: the model's range
  Scalar max_c = Scalar(0);
  int rests = 0;  // rests in the fit
  TemperatureBias<Scalar> accel{};
  TemperatureBias<Scalar> gyro{};
};

}  // namespace imucal
