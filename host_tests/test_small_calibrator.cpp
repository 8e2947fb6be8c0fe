// SPDX-License-Identifier: MIT
// The small configuration (imucal/calibrator/small.hpp) on every target: its size holds to the
// 12 KiB a 32 KB part can spare, and on the xsens recording (16-bit counts through add_raw(), as a
// small part's driver hands them over) its parameters agree with the default calibrator's within
// their sigma. It keeps the first 24 of the recording's 41 poses and coarsens the moves, so the
// two estimates differ by the poses it does not see and by its coarser moves; the tolerance is
// the combined sigma sqrt(sigma_small^2 + sigma_default^2) of each parameter: every parameter
// within 2 of it (a 95 % band each, 21 parameters) and their RMS within 1. Runs on the Arm
// targets too (the recording read via semihosting, nothing stored).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "imucal/calibrator/small.hpp"
#include "support/xsens_reader.hpp"
#include "support/xsens_settings.hpp"

namespace imucal {
namespace {

static_assert(sizeof(SmallCalibrator) <= kSmallCalibratorBytes,
              "the small calibrator outgrew the RAM docs/small_parts.md promises");

// Unsigned 16-bit counts as the signed counts a driver reads: 32768 less (exact in float).
std::int16_t count(float unsigned_count) {
  return static_cast<std::int16_t>(std::lround(unsigned_count) - 32768);
}

struct Outcome {
  Calibration<float> cal;
  Progress progress;
};

template <class C>
Outcome finish(C& c) {
  c.end_stream();
  Outcome r;
  c.solve_all();
  r.cal = c.calibration();
  r.progress = c.progress();
  return r;
}

// Each |small - default| in units of sqrt(sigma_small^2 + sigma_default^2), within 2; the sum of
// their squares and their number added to *sum2 and *n, the largest returned.
template <class V>
double expect_within_sigma(const V& small, const V& small_sigma, const V& big, const V& big_sigma,
                           const char* sensor, double* sum2, int* n) {
  double worst = 0;
  for (int k = 0; k < small.size(); ++k) {
    const double ss = static_cast<double>(small_sigma(k)), sb = static_cast<double>(big_sigma(k));
    const double combined = std::sqrt(ss * ss + sb * sb);
    const double d = std::abs(static_cast<double>(small(k)) - static_cast<double>(big(k)));
    if (combined == 0.0) {  // a parameter held fixed: held at the same value
      EXPECT_EQ(small(k), big(k)) << sensor << " parameter " << k;
      continue;
    }
    EXPECT_LE(d, 2.0 * combined) << sensor << " parameter " << k << ": small " << small(k) << " +- "
                                 << ss << ", default " << big(k) << " +- " << sb;
    worst = std::max(worst, d / combined);
    *sum2 += (d / combined) * (d / combined);
    ++*n;
    std::printf("  %s p%-2d default % .6e +- %.2e, small % .6e +- %.2e (%.2f combined sigma)\n",
                sensor, k, static_cast<double>(big(k)), sb, static_cast<double>(small(k)), ss,
                d / combined);
  }
  return worst;
}

TEST(SmallCalibrator, XsensRecordingAsTheDefaultCalibrator) {
  IMUCAL_XSENS_DIR_OR_SKIP(dir);
  CalibratorSettings<float> set = test::xsens_calibrator_settings();
  set.accel_zero_hint = Vector3<float>::Zero();  // signed counts
  static SmallCalibrator small;                  // static: not on the small targets' stack
  static Calibrator<float> reference;            // the default, ~33 KB
  small.reset(set);
  reference.reset(set);
  test::XsensStream in;
  ASSERT_TRUE(in.open(dir)) << in.error();
  double t = 0;
  Vector3<float> acc, gyro;
  int refused = 0, full = 0;
  while (in.next(t, acc, gyro)) {
    RawFrame f;
    f.t_us = static_cast<std::uint32_t>(std::llround(t * 1e6));
    for (int i = 0; i < 3; ++i) {
      f.acc[i] = count(acc(i));
      f.gyro[i] = count(gyro(i));
    }
    if (reference.add_raw(f) != Status::kOk) ++refused;
    const Status s = small.add_raw(f);
    if (s == Status::kCapacityExceeded) ++full;
    if (s != Status::kOk && s != Status::kCapacityExceeded) ++refused;
  }
  ASSERT_TRUE(in.error().empty()) << in.error();
  EXPECT_EQ(refused, 0);
  EXPECT_EQ(full, 1);  // the pose store full: said once, the later rests not stored
  const Outcome s = finish(small), d = finish(reference);
  ASSERT_TRUE(succeeded(d.cal.accel.status) && succeeded(d.cal.gyro.status));
  ASSERT_TRUE(succeeded(s.cal.accel.status)) << to_string(s.cal.accel.status);
  ASSERT_TRUE(succeeded(s.cal.gyro.status)) << to_string(s.cal.gyro.status);
  // The protocol's first poses, as many as it holds, and every move between them; the default
  // sees the recording's 41.
  EXPECT_GE(d.progress.poses, 40);
  EXPECT_EQ(s.progress.poses, kSmallMaxPoses);
  EXPECT_EQ(s.progress.moves, kSmallMaxPoses - 1);
  std::printf(
      "small calibrator: %u bytes (default %u), %d poses, %d moves, %d segments (%d "
      "coarsenings; default %d segments, %d coarsenings)\n",
      static_cast<unsigned>(sizeof(SmallCalibrator)),
      static_cast<unsigned>(sizeof(Calibrator<float>)), s.progress.poses, s.progress.moves,
      s.progress.segments, s.progress.coarsenings, d.progress.segments, d.progress.coarsenings);
  double sum2 = 0;
  int n = 0;
  const double wa = expect_within_sigma(s.cal.accel.params, s.cal.accel.sigma, d.cal.accel.params,
                                        d.cal.accel.sigma, "accel", &sum2, &n);
  const double wg = expect_within_sigma(s.cal.gyro.params, s.cal.gyro.sigma, d.cal.gyro.params,
                                        d.cal.gyro.sigma, "gyro", &sum2, &n);
  ASSERT_GT(n, 0);
  const double rms = std::sqrt(sum2 / n);
  EXPECT_LE(rms, 1.0);
  std::printf(
      "worst: accel %.2f, gyro %.2f combined sigma, RMS %.2f over %d parameters; gyro RMS per "
      "move %.3f deg (default %.3f)\n",
      wa, wg, rms, n, static_cast<double>(s.cal.gyro.residual_rms) * 57.29577951308232,
      static_cast<double>(d.cal.gyro.residual_rms) * 57.29577951308232);
}

}  // namespace
}  // namespace imucal
