// SPDX-License-Identifier: MIT
// Test support: the streaming calibrator's settings for the xsens recording, said once for the
// tests and the instruction benchmark (what the recording's README gives about it: the units and
// gravity; the detector's settings are the defaults).
#pragma once

#include "imucal/calibrator/calibrator.hpp"

namespace imucal::test {

constexpr double kXsensGravity = 9.81744;     // local gravity given with the recording
constexpr double kXsensCountsPerRadS = 4770;  // datasheet order of magnitude of the gyro

inline CalibratorSettings<float> xsens_calibrator_settings(bool refine_bias = false) {
  CalibratorSettings<float> s;
  s.accel.gravity = static_cast<float>(kXsensGravity);
  s.accel_zero_hint = Vector3<float>::Constant(32768.0f);  // unsigned 16-bit counts
  s.gyro.nominal_scale = static_cast<float>(1.0 / kXsensCountsPerRadS);
  s.gyro.refine_bias = refine_bias;
  return s;
}

}  // namespace imucal::test
