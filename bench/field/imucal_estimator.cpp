// SPDX-License-Identifier: MIT
// bench/field/imucal_estimator.cpp: imucal's FieldCalibrator (include/imucal/field/) on a life,
// as a firmware would run it: every frame of 16-bit counts through add_raw() with the latest
// temperature, from the nominal prior (no stored calibration), set up from what the device's
// sheet says (the nominal gyro scale, the datasheet noise densities). What it would apply each
// second: the published bias models (gyro, accelerometer) at the current temperature and the
// magnetometer's hard iron, with their sigmas.
// The bias it publishes is ADDED to the counts; the bench's convention is an SI offset
// subtracted from the nominally scaled reading: -s_g * b (-s_a * b for the accelerometer, -s_m * h
// for the magnetometer).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>

#include "estimator.hpp"
#include "imucal/field/field_calibrator.hpp"
#include "imucal/sim/field_settings.hpp"

namespace imucal::field_bench {
namespace {

class ImucalEstimator final : public Estimator {
 public:
  explicit ImucalEstimator(const sim::DeviceSheet& sheet)
      : scale_(sheet.gyro_rad_s_per_count),
        accel_scale_(sheet.accel_m_s2_per_count),
        mag_scale_(sheet.mag_ut_per_count) {
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
    FieldEvent<float> ev;
    while (trace_ != nullptr && field_.take_event(ev))
      std::fprintf(trace_, "trace %s %s %s %s %u s: %.2f degC, chi2 %.3g, value %.4g %.4g %.4g\n",
                   name_, field_sensor_name(ev.sensor), field_event_name(ev.kind),
                   field_reason_name(ev.reason), ev.time_s, static_cast<double>(ev.temperature_c),
                   static_cast<double>(ev.chi2), static_cast<double>(ev.value(0)),
                   static_cast<double>(ev.value(1)), static_cast<double>(ev.value(2)));
  }

  // Its events (field_calibrator.hpp's FieldEvent: the value in raw units, added).
  void trace(std::FILE* out, const char* name) override {
    trace_ = out;
    name_ = name;
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
    Vector3<float> v, sv;
    const bool accel = field_.accel_bias(v, &sv);
    e.accel_bias = per_axis(accel, v, sv, accel_scale_, field_.counts().accel_updates);
    const bool mag = field_.mag_hard_iron(v, &sv);
    e.hard_iron = per_axis(mag, v, sv, mag_scale_, field_.counts().mag_updates);
    return e;
  }

 private:
  // A bias with a sigma per axis (raw, added) in the bench's convention.
  static Estimate3 per_axis(bool valid, const Vector3<float>& value, const Vector3<float>& sigma,
                            double scale, std::uint64_t updates) {
    Estimate3 out;
    out.valid = valid;
    out.value = -scale * value.cast<double>();
    out.has_sigma = true;
    out.sigma = scale * sigma.cast<double>();
    out.updates = updates;
    return out;
  }

  double scale_, accel_scale_, mag_scale_;
  FieldCalibrator<float> field_;
  std::FILE* trace_ = nullptr;
  const char* name_ = "";
};

}  // namespace

std::unique_ptr<Estimator> make_imucal_estimator(const sim::DeviceSheet& sheet) {
  return std::make_unique<ImucalEstimator>(sheet);
}

}  // namespace imucal::field_bench
