// SPDX-License-Identifier: MIT
// imucal/sim/field_settings.hpp: the field calibrator's settings for a simulated device, from what
// its sheet says (never the truth): the per-sample white noise over the Nyquist band from the
// datasheet densities, summed over the three axes in raw units squared, the gyro's and the
// accelerometer's nominal scales, the accelerometer's tolerances (its prior), the magnetometer's
// scale and the rate. The tests, the field bench and the instruction counts set it up alike; and
// the record a protocol calibration would have stored (from the truth, with a protocol's sigmas),
// for a device that starts the field from one.
#pragma once

#include <cmath>

#include "imucal/field/field_calibrator.hpp"
#include "imucal/sim/life_sim.hpp"

namespace imucal::sim {

inline FieldSettings<float> field_settings(const DeviceSheet& sheet) {
  FieldSettings<float> s;
  const double bw = std::sqrt(0.5 * sheet.rate_hz);
  const double g = sheet.gyro_noise_rad_s_rthz * bw / sheet.gyro_rad_s_per_count;
  const double a = sheet.accel_noise_m_s2_rthz * bw / sheet.accel_m_s2_per_count;
  s.gyro_noise = static_cast<float>(3.0 * g * g);
  s.accel_noise = static_cast<float>(3.0 * a * a);
  s.gyro_per_rad_s = static_cast<float>(1.0 / sheet.gyro_rad_s_per_count);
  s.accel.accel_per_m_s2 = static_cast<float>(1.0 / sheet.accel_m_s2_per_count);
  s.accel.gravity = static_cast<float>(sheet.gravity);
  // The prior's sigmas from the datasheet's bounds, read as uniform spreads (bound / sqrt 3).
  const double u = 1.0 / std::sqrt(3.0);
  s.accel.bias_sigma = static_cast<float>(sheet.accel_offset_m_s2 * u);
  s.accel.scale_sigma = static_cast<float>(sheet.accel_scale_tolerance * u);
  s.accel.misalignment_sigma = static_cast<float>(sheet.accel_misalignment_rad * u);
  s.accel.slope_sigma = static_cast<float>(sheet.accel_offset_drift_m_s2_c * u);
  // The magnetometer's model, with its nominal scale and the settings' default prior (a phone's
  // hard iron within 50 uT per axis, soft iron within a few per cent, the field's strength
  // unknown within 15 %).
  if (sheet.has_mag) s.mag.counts_per_ut = static_cast<float>(1.0 / sheet.mag_ut_per_count);
  s.nominal_rate_hz = static_cast<float>(sheet.rate_hz);
  return s;
}

// What a protocol calibration leaves in the record, from the truth: the accelerometer's model and
// both sensors' temperature curves with a protocol's sigmas, and the gyro's misalignment and
// scale off the truth by `off` (scales relative, misalignments in rad) with sigma `sigma`.
struct StoredCalibration {
  Calibration<float> cal{};
  TemperatureModel<float> model{};
};

inline StoredCalibration protocol_record(const LifeSimulator& life, double off, double sigma) {
  const DeviceSheet sheet = life.sheet();
  const TemperatureTruth& truth = life.imu_truth();
  StoredCalibration p;
  Calibration<float>& c = p.cal;
  c.accel.params = truth.acc.params.cast<float>();
  const double mg = 1e-3 * sheet.gravity / sheet.accel_m_s2_per_count;  // counts
  for (int i = 0; i < 3; ++i) {
    c.accel.sigma(kAlphaYz + i) = 2e-4f;
    c.accel.sigma(kScaleX + i) = static_cast<float>(2e-4 * truth.acc.params(kScaleX + i));
    c.accel.sigma(kBiasX + i) = static_cast<float>(0.5 * mg);
  }
  c.accel.poses = 24;
  c.accel.status = Status::kOk;
  const double signs[kGyroMatrixParams] = {1, -1, 0.5, -0.5, 1, -1, 1, -1, 0.5};
  for (int i = 0; i < kGyroMatrixParams; ++i) {
    const double t = truth.gyro.params(i);
    const bool scale = i >= kGyroScaleX;
    c.gyro.params(i) = static_cast<float>(scale ? t * (1.0 + off * signs[i]) : t + off * signs[i]);
    c.gyro.sigma(i) = static_cast<float>(scale ? sigma * t : sigma);
  }
  const double dps = 3.14159265358979323846 / 180.0 / sheet.gyro_rad_s_per_count;  // counts
  c.gyro.params.tail<3>() = truth.model.gyro.b0.cast<float>();
  c.gyro.sigma.tail<3>().setConstant(static_cast<float>(0.02 * dps));
  c.gyro.moves = 12;
  c.gyro.status = Status::kOk;
  c.has_temperature = true;
  c.temperature_c = static_cast<float>(truth.model.reference_c);
  TemperatureModel<float>& m = p.model;
  m.order = 2;
  m.reference_c = c.temperature_c;
  m.min_c = 10.0f;
  m.max_c = 50.0f;
  m.rests = 24;
  for (TemperatureBias<float>* b : {&m.accel, &m.gyro}) {
    const TemperatureBias<double>& t = b == &m.accel ? truth.model.accel : truth.model.gyro;
    b->b0 = t.b0.cast<float>();
    b->b1 = t.b1.cast<float>();
    b->b2 = t.b2.cast<float>();
    const double unit = b == &m.accel ? mg : 0.02 * dps;
    b->b0_sigma.setConstant(static_cast<float>(unit));
    b->b1_sigma.setConstant(static_cast<float>(0.05 * unit));
    b->b2_sigma.setConstant(static_cast<float>(0.005 * unit));
    b->status = Status::kOk;
  }
  return p;
}

}  // namespace imucal::sim
