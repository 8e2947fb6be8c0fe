// SPDX-License-Identifier: MIT
// imucal/models/calibration.hpp: what a calibration is, apart from how it is found: the
// accelerometer's and the gyroscope's parameters with their sigmas and status, and the two together
// with the quality. The record (record.hpp) and the corrector (corrector.hpp) need only this; the
// solvers (accel_calibration.hpp, gyro_calibration.hpp) and the streaming calibrator
// (calibrator.hpp) produce it. Models and parameter order: accel_model.hpp, gyro_model.hpp.
#pragma once

#include <cstdint>

#include "imucal/models/accel_model.hpp"
#include "imucal/models/gyro_model.hpp"
#include "imucal/status.hpp"

namespace imucal {

// Fewest poses accepted: one more than the parameters, so that every parameter gets a sigma.
constexpr int kAccelMinPoses = kAccelParams + 1;

// The accelerometer's calibration: a_cal = T K (a_raw + b). Sigma: see accel_calibration.hpp.
template <typename Scalar>
struct AccelCalibration {
  AccelVector<Scalar> params =
      AccelVector<Scalar>::Zero();  // seed order, sensor units in, m/s^2 out
  AccelVector<Scalar> sigma = AccelVector<Scalar>::Zero();  // one standard deviation each
  Scalar residual_rms = Scalar(0);  // m/s^2: sample-weighted RMS of |g| - |a_cal| over poses
  // Noise of one pose mean beyond what the rests' scatter explains (m/s^2, each axis): 0 when
  // the model explains the fit, or without the pose noise.
  Scalar pose_floor = Scalar(0);
  // chi2 / dof of the fit under the noise model (1 when the model is right; 0 without it).
  Scalar fit_to_noise = Scalar(0);
  // Bit k for parameter k (AccelIndex): weak (sigma above weak_normalised_sigma), or held at its
  // nominal value because the poses do not determine it (sigma 0 then).
  std::uint16_t weak = 0;
  std::uint16_t held = 0;
  int poses = 0;
  int iterations = 0;
  Status status = Status::kNotStarted;
};

template <typename Scalar>
struct GyroCalibration {
  // imu_tk layout, then the ADDED bias (absolute, sensor units): w_cal = T K (w_raw + b).
  GyroVector<Scalar> params = GyroVector<Scalar>::Zero();
  // The bias's sigma: from the LM when refined; otherwise the initial rest's (filled in by the
  // Calibrator; zero from GyroSolver alone, which does not see the rest).
  GyroVector<Scalar> sigma = GyroVector<Scalar>::Zero();
  Scalar residual_rms = Scalar(0);  // rad: RMS over moves of the sine of the gravity angle error
  int moves = 0;
  int iterations = 0;
  bool bias_refined = false;
  Status status = Status::kNotStarted;
};

// Both sensors, as the streaming calibrator gives them and the record stores them.
template <typename Scalar>
struct Calibration {
  AccelCalibration<Scalar> accel{};
  GyroCalibration<Scalar> gyro{};
  Quality quality = Quality::kNone;
  Scalar sample_rate_hz = Scalar(0);  // measured over the initial rest
  bool has_temperature = false;       // the samples carried a temperature
  Scalar temperature_c = Scalar(0);   // if so, its mean over the samples taken (deg C)
};

}  // namespace imucal
