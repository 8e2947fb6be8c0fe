// SPDX-License-Identifier: MIT
// bench/field/imucal_estimator.cpp: imucal's FieldCalibrator (include/imucal/field/) on a life,
// as a firmware would run it: every frame of 16-bit counts through add_raw() with the latest
// temperature, from the nominal prior (no stored calibration), set up from what the device's
// sheet says (the nominal gyro scale, the datasheet noise densities). What it would apply each
// second: the published bias models (gyro, accelerometer) at the current temperature, with their
// sigmas.
// The bias it publishes is ADDED to the counts; the bench's convention is an SI offset
// subtracted from the nominally scaled reading: -s_g * b (-s_a * b for the accelerometer).
#include <cmath>
#include <memory>

#include "estimator.hpp"
#include "imucal/field/field_calibrator.hpp"
#include "imucal/sim/field_settings.hpp"

namespace imucal::field_bench {
namespace {

class ImucalEstimator final : public Estimator {
 public:
  explicit ImucalEstimator(const sim::DeviceSheet& sheet)
      : scale_(sheet.gyro_rad_s_per_count), accel_scale_(sheet.accel_m_s2_per_count) {
    field_.start(sim::field_settings(sheet));
  }

  void feed(const sim::LifeSample& s, const sim::LifeTruth*) override {
    RawFrame f;
    f.t_us = s.t_us;
    for (int i = 0; i < 3; ++i) {
      f.acc[i] = s.acc_counts[static_cast<std::size_t>(i)];
      f.gyro[i] = s.gyro_counts[static_cast<std::size_t>(i)];
    }
    field_.add_raw(f, s.temperature_new ? s.imu.temperature : std::nanf(""));
    if (s.mag_new) field_.add_mag(s.mag);
  }

  Estimate estimate() override {
    Estimate e;
    Vector3<float> b;
    float sigma = 0.0f;
    e.gyro_bias.valid = field_.gyro_bias(b, &sigma);
    e.gyro_bias.value = -scale_ * b.cast<double>();
    e.gyro_bias.has_sigma = true;
    e.gyro_bias.sigma.setConstant(scale_ * static_cast<double>(sigma));
    e.gyro_bias.updates = field_.counts().updates;
    Vector3<float> a, sa;
    e.accel_bias.valid = field_.accel_bias(a, &sa);
    e.accel_bias.value = -accel_scale_ * a.cast<double>();
    e.accel_bias.has_sigma = true;
    e.accel_bias.sigma = accel_scale_ * sa.cast<double>();
    e.accel_bias.updates = field_.counts().accel_updates;
    return e;
  }

 private:
  double scale_, accel_scale_;
  FieldCalibrator<float> field_;
};

}  // namespace

std::unique_ptr<Estimator> make_imucal_estimator(const sim::DeviceSheet& sheet) {
  return std::make_unique<ImucalEstimator>(sheet);
}

}  // namespace imucal::field_bench
