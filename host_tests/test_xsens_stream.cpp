// SPDX-License-Identifier: MIT
// The real xsens recording (raw 16-bit counts, 100 Hz with jitter) end to end through the
// streaming float calibrator, one sample at a time, as on the device: the accelerometer's
// per-sample gravity-norm residual over every pose sample, and the gyro's per-move angle between
// predicted and measured gravity. Runs on the Arm targets too (files read via semihosting,
// nothing stored).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "imucal/calibrator/calibrator.hpp"
#include "support/gtest_status.hpp"
#include "support/xsens_reader.hpp"
#include "support/xsens_settings.hpp"

namespace imucal {
namespace {

constexpr double kGravity = test::kXsensGravity;
constexpr double kDeg = 57.29577951308232;

std::string xsens_dir() {
  const std::string dir = test::find_xsens_dir();
#ifdef IMUCAL_REQUIRE_XSENS
  if (dir.empty()) ADD_FAILURE() << "xsens recording required but not found";
#endif
  return dir;
}

using XsensCalibrator = Calibrator<float>;

// Streams the whole recording; false (with a test failure) if it cannot be read.
bool stream(const std::string& dir, XsensCalibrator& cal, int& refused) {
  test::XsensStream in;
  if (!in.open(dir)) {
    ADD_FAILURE() << in.error();
    return false;
  }
  double t = 0;
  Vector3<float> acc, gyro;
  refused = 0;
  while (in.next(t, acc, gyro)) {
    ImuSample<float> s;
    s.t_us = static_cast<std::uint32_t>(std::llround(t * 1e6));
    s.acc = acc;
    s.gyro = gyro;
    if (cal.add(s) != Status::kOk) ++refused;
  }
  EXPECT_TRUE(in.error().empty()) << in.error();
  return in.error().empty();
}

// RMS over every sample inside a pose's time span of |g| - |a_cal| (second pass over the file),
// and of the scatter of |a_cal| about its pose mean (the sensor's own noise floor).
struct SampleResiduals {
  double rms = 0;
  double noise = 0;
  std::size_t samples = 0;
};

SampleResiduals sample_residuals(const std::string& dir, const XsensCalibrator& cal) {
  const AccelVector<double> p = cal.calibration().accel.params.cast<double>();
  test::XsensStream in;
  SampleResiduals r;
  if (!in.open(dir)) return r;
  const PoseSpan<float> poses = cal.poses();
  double t = 0, sum = 0, sum_noise = 0;
  Vector3<float> acc, gyro;
  int k = 0;
  // Pass 1 of a pose gives the mean norm; the noise floor is the scatter about it, so the
  // poses' mean norms are computed here from the stored means (the model is affine).
  while (in.next(t, acc, gyro) && k < poses.size) {
    const auto us = static_cast<std::uint32_t>(std::llround(t * 1e6));
    while (k < poses.size && us > cal.pose_end_us(k)) ++k;
    if (k >= poses.size || us < cal.pose_begin_us(k)) continue;
    const double norm = accel_apply(p, Vector3<double>(acc.cast<double>())).norm();
    const double mean_norm = accel_apply(p, Vector3<double>(poses[k].mean.cast<double>())).norm();
    sum += (kGravity - norm) * (kGravity - norm);
    sum_noise += (norm - mean_norm) * (norm - mean_norm);
    ++r.samples;
  }
  r.rms = std::sqrt(sum / static_cast<double>(r.samples));
  r.noise = std::sqrt(sum_noise / static_cast<double>(r.samples));
  return r;
}

void end_to_end(bool refine_bias) {
  const std::string dir = xsens_dir();
  if (dir.empty()) GTEST_SKIP() << "xsens recording not found (set IMUCAL_XSENS_DIR)";
  static XsensCalibrator cal;  // ~31 KB: static, not on the small targets' stack
  cal.reset(test::xsens_calibrator_settings(refine_bias));
  int refused = 0;
  ASSERT_TRUE(stream(dir, cal, refused));
  EXPECT_EQ(refused, 0);
  const Status s = cal.solve_all();
  const Calibration<float>& c = cal.calibration();
  const Progress p = cal.progress();
  ASSERT_TRUE(succeeded(c.accel.status)) << to_string(c.accel.status);
  ASSERT_TRUE(succeeded(c.gyro.status)) << to_string(c.gyro.status) << " " << to_string(s);
  const SampleResiduals r = sample_residuals(dir, cal);
  const double gyro_deg = static_cast<double>(c.gyro.residual_rms) * kDeg;
  std::printf(
      "xsens stream (bias %s): %d poses, %d moves, %d segments (%d coarsenings), %d rests too "
      "short, faces %d, quality %d\n  accel: pose RMS %.5f m/s^2, per-sample RMS %.5f m/s^2 over "
      "%zu samples (noise floor %.5f)\n  gyro: RMS per move %.3f deg, %d iterations\n",
      refine_bias ? "refined" : "from the initial rest", p.poses, p.moves, p.segments,
      p.coarsenings, p.rests_too_short, p.faces_covered, static_cast<int>(c.quality),
      static_cast<double>(c.accel.residual_rms), r.rms, r.samples, r.noise, gyro_deg,
      c.gyro.iterations);
  for (int k = 0; k < kGyroParams; ++k)
    std::printf("  gyro p%-2d % .6e +- %.2e\n", k, static_cast<double>(c.gyro.params(k)),
                static_cast<double>(c.gyro.sigma(k)));
  EXPECT_GE(p.poses, 40);  // the protocol has ~42 rests
  EXPECT_EQ(p.moves, p.poses - 1);
  EXPECT_LE(p.coarsenings, 1);  // once, in the motion that ends the recording
  EXPECT_EQ(p.faces_covered, 6);
  // The per-sample RMS cannot fall below the sensor's own scatter about each pose mean (the
  // noise floor, 0.00799 m/s^2 here); what the model adds on top is the pose-level misfit
  // (~0.0010 m/s^2, as in the double reference). A target of 0.008 would leave this recording's
  // own noise 0.0006 m/s^2 for the model, which no calibration of it reaches.
  EXPECT_LE(r.rms, 0.0081);
  EXPECT_LE(std::sqrt(r.rms * r.rms - r.noise * r.noise), 0.0012);
  EXPECT_LE(static_cast<double>(c.accel.residual_rms), 0.0012);
  EXPECT_LE(gyro_deg, 0.6);
  EXPECT_GT(gyro_deg, 0.05);  // real moves are not noise-free: a sanity bound
}

TEST(XsensStream, EndToEndBiasFromInitialRest) { end_to_end(false); }
TEST(XsensStream, EndToEndBiasRefined) { end_to_end(true); }

}  // namespace
}  // namespace imucal
