// SPDX-License-Identifier: MIT
// imucal/sim/field_settings.hpp: the field calibrator's settings for a simulated device, from what
// its sheet says (never the truth): the per-sample white noise over the Nyquist band from the
// datasheet densities, summed over the three axes in raw units squared, the gyro's and the
// accelerometer's nominal scales, the accelerometer's tolerances (its prior), the magnetometer's
// scale and the rate. The tests, the field bench and the instruction counts set it up alike.
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

}  // namespace imucal::sim
