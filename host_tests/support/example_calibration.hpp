// Test support: a calibration as the xsens recording gives (raw 16-bit counts), with sigmas,
// quality, sample rate and temperature: the record, corrector and store tests share it (the
// record test's pinned version-1 bytes encode exactly this).
#pragma once

#include "imucal/calibrator.hpp"

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

}  // namespace imucal::test
