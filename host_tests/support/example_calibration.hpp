// SPDX-License-Identifier: MIT
// Test support: a calibration as the xsens recording gives (raw 16-bit counts), with sigmas,
// quality, sample rate and temperature: the record, corrector and store tests share it (the
// record test's pinned version-1 bytes encode exactly this).
#pragma once

#include "imucal/calibrator/calibrator.hpp"
#include "imucal/models/mag_model.hpp"
#include "imucal/models/temperature_model.hpp"

namespace imucal::test {

inline Calibration<double> example_calibration() {
  Calibration<double> c;
  c.accel.params << 0.0021, -0.0013, 0.0007, 0.00241, 0.00239, 0.00243, -32990.0, -32770.5,
      -33120.25;
  for (int i = 0; i < kAccelParams; ++i) c.accel.sigma(i) = 1e-5 * (i + 1);
  c.accel.residual_rms = 0.0011;
  c.accel.poses = 41;
  c.accel.iterations = 5;
  c.accel.status = Status::kConvergedCost;
  c.gyro.params << 0.003, -0.002, 0.001, -0.004, 0.0025, -0.0015, 2.1e-4, 2.09e-4, 2.11e-4,
      -32750.0, -32800.5, -32690.0;
  for (int i = 0; i < kGyroParams; ++i) c.gyro.sigma(i) = 2e-5 * (i + 1);
  c.gyro.residual_rms = 0.0085;
  c.gyro.moves = 40;
  c.gyro.iterations = 7;
  c.gyro.status = Status::kConvergedStep;
  c.quality = Quality::kFair;
  c.sample_rate_hz = 100.0;
  c.has_temperature = true;
  c.temperature_c = 24.5;
  return c;
}

// A magnetometer calibration on raw counts (0.15 uT per count), aligned to the accelerometer.
inline MagCalibration<double> example_mag() {
  MagCalibration<double> m;
  m.status = Status::kConvergedCost;
  m.soft_iron << 0.151, 0.004, -0.002,  //
      0.003, 0.148, 0.005,              //
      -0.001, 0.006, 0.152;
  m.hard_iron << -120.5, 310.25, -45.0;
  m.hard_iron_sigma << 0.8, 0.9, 0.85;
  for (int i = 0; i < kMagSymEntries; ++i) m.soft_iron_sigma(i) = 2e-4 * (i + 1);
  m.field_ut = 48.7;
  m.fit_error_pct = 0.9;
  m.coverage = 0.86;
  m.samples = 96;
  m.quality = Quality::kGood;
  m.alignment_status = Status::kConvergedStep;
  m.dip_deg = 64.2;
  m.dip_sigma_deg = 0.3;
  return m;
}

// A temperature model of both biases (raw counts), linear or quadratic, fitted over 5..45 degC.
inline TemperatureModel<double> example_temperature(int order) {
  TemperatureModel<double> t;
  t.order = order;
  t.reference_c = 24.5;
  t.min_c = 5.0;
  t.max_c = 45.0;
  t.rests = 37;
  t.accel.b0 << -32991.0, -32769.5, -33121.0;
  t.accel.b1 << 0.41, -0.27, 0.63;
  t.accel.b0_sigma << 0.3, 0.3, 0.4;
  t.accel.b1_sigma << 0.02, 0.02, 0.03;
  t.gyro.b0 << -32751.0, -32801.0, -32689.5;
  t.gyro.b1 << 1.5, -0.8, 2.2;
  t.gyro.b0_sigma << 0.2, 0.2, 0.2;
  t.gyro.b1_sigma << 0.01, 0.01, 0.01;
  if (order == 2) {
    t.accel.b2 << 0.004, -0.002, 0.001;
    t.accel.b2_sigma << 0.001, 0.001, 0.001;
    t.gyro.b2 << -0.01, 0.02, 0.005;
    t.gyro.b2_sigma << 0.002, 0.002, 0.002;
  }
  t.accel.status = t.gyro.status = Status::kOk;
  return t;
}

}  // namespace imucal::test
