// SPDX-License-Identifier: MIT
// bench/field/chre_estimator.cpp: Android's CHRE calibration algorithms (the peer,
// ../shared/peers/chre-calibration, built as the chre_calibration library) fed as a phone's
// sensor hub feeds them: the counts scaled by the nominal scales only (rad/s, m/s^2, uT),
// nanosecond timestamps since boot, the temperature with every gyro sample and to the
// over-temperature model, each algorithm initialised with the settings Android uses
// (PEER.md, "The settings Android uses", from the BMI160 driver).
//
// The flow per sample (the BMI160 driver's): accel_cal runs on the raw accelerometer; gyro_cal
// sees the accelerometer with accel_cal's offset removed, the magnetometer with mag_cal's offset
// removed, and the raw gyro with the temperature; each new gyro_cal bias goes to over_temp_cal
// with its temperature; every temperature reading goes to over_temp_cal.
//
// What the device would apply each second: the gyro offset of over_temp_cal at the current
// temperature once it has one, else gyro_cal's last bias (a gyro update: a gyro_cal bias that
// over_temp_cal takes, not one it rejects as an outlier); accel_cal's newest offset (Android
// applies it at the next power cycle of the accelerometer: here as if that came every second,
// the peer's best case); mag_cal's offset. None states a sigma.
#include <cmath>
#include <cstdint>

#include "calibration/accelerometer/accel_cal.h"
#include "calibration/gyroscope/gyro_cal.h"
#include "calibration/magnetometer/mag_cal/mag_cal.h"
#include "calibration/over_temp/over_temp_cal.h"
#include "estimator.hpp"

namespace imucal::field_bench {
namespace {

constexpr float kMdegToRad = 3.14159265358979323846f / 180.0e3f;
constexpr std::uint64_t kNanosPerSecond = 1000000000ull;

GyroCalParameters android_gyro_cal() {
  GyroCalParameters p{};
  p.min_still_duration_nanos = 5 * kNanosPerSecond;
  p.max_still_duration_nanos = 5900000000ull;
  p.calibration_time_nanos = 0;
  p.window_time_duration_nanos = 1500000000ull;
  p.bias_x = p.bias_y = p.bias_z = 0.0f;
  p.stillness_threshold = 0.95f;
  p.stillness_mean_delta_limit = 40.0f * kMdegToRad;
  p.gyro_var_threshold = 7.5e-5f;
  p.gyro_confidence_delta = 1.5e-5f;
  p.accel_var_threshold = 4.5e-3f;
  p.accel_confidence_delta = 9.0e-4f;
  p.mag_var_threshold = 5.0f;
  p.mag_confidence_delta = 1.0f;
  p.temperature_delta_limit_celsius = 1.5f;
  p.gyro_calibration_enable = true;
  return p;
}

OverTempCalParameters android_over_temp_cal() {
  OverTempCalParameters p{};
  p.min_temp_update_period_nanos = 500000000ull;
  p.age_limit_nanos = 2ull * 24ull * 3600ull * kNanosPerSecond;
  p.delta_temp_per_bin = 0.75f;
  p.jump_tolerance = 40.0f * kMdegToRad;
  p.outlier_limit = 50.0f * kMdegToRad;
  p.temp_sensitivity_limit = 80.0f * kMdegToRad;
  p.sensor_intercept_limit = 3000.0f * kMdegToRad;
  p.significant_offset_change = 0.1f * kMdegToRad;
  p.min_num_model_pts = 5;
  p.over_temp_enable = true;
  return p;
}

AccelCalParameters android_accel_cal() {
  AccelCalParameters p{};
  p.t0 = 800000000u;  // ns
  p.n_s = 5;
  p.fx = p.fxb = p.fy = p.fyb = p.fz = p.fzb = p.fle = 15;
  p.th = 0.00025f;
  return p;
}

MagCalParameters android_mag_cal() {
  MagCalParameters p{};
  p.min_batch_window_in_micros = 3000000u;
  p.x_bias = p.y_bias = p.z_bias = 0.0f;
  p.c00 = p.c11 = p.c22 = 1.0f;
  p.c01 = p.c02 = p.c10 = p.c12 = p.c20 = p.c21 = 0.0f;
  return p;
}

DiversityCheckerParameters android_diversity_checker() {
  DiversityCheckerParameters p{};
  p.var_threshold = 6.0f;
  p.max_min_threshold = 10.0f;
  p.local_field = 48.0f;
  p.threshold_tuning_param = 0.5f;
  p.max_distance_tuning_param = 2.552f;
  p.min_num_diverse_vectors = 8;
  p.max_num_max_distance = 1;
  return p;
}

class ChreEstimator final : public Estimator {
 public:
  explicit ChreEstimator(const sim::DeviceSheet& sheet) : sheet_(sheet) {
    const GyroCalParameters gyro = android_gyro_cal();
    gyroCalInit(&gyro_, &gyro);
    const OverTempCalParameters otc = android_over_temp_cal();
    overTempCalInit(&otc_, &otc);
    const AccelCalParameters accel = android_accel_cal();
    accelCalInit(&accel_, &accel);
    const MagCalParameters mag = android_mag_cal();
    const DiversityCheckerParameters diversity = android_diversity_checker();
    initMagCal(&mag_, &mag, &diversity);
  }

  void feed(const sim::LifeSample& s, const sim::LifeTruth*) override {
    // Nanoseconds since boot (the life begins a second after boot).
    const std::uint64_t t_ns =
        kNanosPerSecond + static_cast<std::uint64_t>(std::llround(s.t_s * 1e9));
    const float temp = sheet_.has_temperature ? s.imu.temperature : 25.0f;
    const auto ga = static_cast<float>(sheet_.accel_m_s2_per_count);
    float ax = ga * s.imu.acc(0), ay = ga * s.imu.acc(1), az = ga * s.imu.acc(2);
    accelCalRun(&accel_, t_ns, ax, ay, az, temp);
    accelCalBiasRemove(&accel_, &ax, &ay, &az);
    gyroCalUpdateAccel(&gyro_, t_ns, ax, ay, az);

    if (s.mag_new) {
      const auto gm = static_cast<float>(sheet_.mag_ut_per_count);
      float mx = 0.0f, my = 0.0f, mz = 0.0f;
      magCalRemoveSoftiron(&mag_, gm * s.mag(0), gm * s.mag(1), gm * s.mag(2), &mx, &my, &mz);
      if (magCalUpdate(&mag_, t_ns / 1000u, mx, my, mz) & UPDATE_BIAS) {
        ++mag_updates_;
        mag_valid_ = true;
      }
      float cx = 0.0f, cy = 0.0f, cz = 0.0f;
      magCalRemoveBias(&mag_, mx, my, mz, &cx, &cy, &cz);
      gyroCalUpdateMag(&gyro_, t_ns, cx, cy, cz);
    }

    const auto gg = static_cast<float>(sheet_.gyro_rad_s_per_count);
    gyroCalUpdateGyro(&gyro_, t_ns, gg * s.imu.gyro(0), gg * s.imu.gyro(1), gg * s.imu.gyro(2),
                      temp);
    if (gyroCalNewBiasAvailable(&gyro_)) {
      float offset[3] = {0.0f, 0.0f, 0.0f};
      float offset_temp = 0.0f;
      std::uint64_t cal_time = 0;
      gyroCalGetBias(&gyro_, &offset[0], &offset[1], &offset[2], &offset_temp, &cal_time);
      // An update when over_temp_cal takes the estimate (it counts each outlier it rejects).
      const std::size_t outliers = otc_.num_outliers;
      if (sheet_.has_temperature) overTempCalUpdateSensorEstimate(&otc_, t_ns, offset, offset_temp);
      if (otc_.num_outliers != outliers + 1) ++gyro_updates_;
      gyro_valid_ = true;
    }
    if (sheet_.has_temperature && s.temperature_new) overTempCalSetTemperature(&otc_, t_ns, temp);
  }

  Estimate estimate() override {
    Estimate e;
    float otc_temp = INVALID_TEMPERATURE_CELSIUS;
    float otc_offset[3] = {0.0f, 0.0f, 0.0f};
    overTempCalGetOffset(&otc_, &otc_temp, otc_offset);
    if (otc_temp > INVALID_TEMPERATURE_CELSIUS) {
      e.gyro_bias.value =
          Eigen::Vector3f(otc_offset[0], otc_offset[1], otc_offset[2]).cast<double>();
    } else {
      float x = 0.0f, y = 0.0f, z = 0.0f, t = 0.0f;
      std::uint64_t when = 0;
      gyroCalGetBias(&gyro_, &x, &y, &z, &t, &when);
      e.gyro_bias.value = Eigen::Vector3f(x, y, z).cast<double>();
    }
    e.gyro_bias.valid = gyro_valid_;
    e.gyro_bias.updates = gyro_updates_;

    float ax = 0.0f, ay = 0.0f, az = 0.0f;
    if (accelCalUpdateBias(&accel_, &ax, &ay, &az)) {
      ++accel_updates_;
      accel_valid_ = true;
    }
    e.accel_bias.value = Eigen::Vector3f(ax, ay, az).cast<double>();
    e.accel_bias.valid = accel_valid_;
    e.accel_bias.updates = accel_updates_;

    float mx = 0.0f, my = 0.0f, mz = 0.0f;
    magCalGetBias(&mag_, &mx, &my, &mz);
    e.hard_iron.value = Eigen::Vector3f(mx, my, mz).cast<double>();
    e.hard_iron.valid = mag_valid_;
    e.hard_iron.updates = mag_updates_;
    return e;
  }

 private:
  sim::DeviceSheet sheet_;
  GyroCal gyro_{};
  OverTempCal otc_{};
  AccelCal accel_{};
  MagCal mag_{};
  bool gyro_valid_ = false, accel_valid_ = false, mag_valid_ = false;
  std::uint64_t gyro_updates_ = 0, accel_updates_ = 0, mag_updates_ = 0;
};

}  // namespace

std::unique_ptr<Estimator> make_chre_estimator(const sim::DeviceSheet& sheet) {
  return std::make_unique<ChreEstimator>(sheet);
}

}  // namespace imucal::field_bench
