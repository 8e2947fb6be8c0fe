// The streaming calibrator on simulated full-motion recordings with known truth (rests, hand
// turns about changing axes with coning, noise, bias, sample-rate jitter): both calibrations
// within 3 sigma, float and double; the stream's bad cases each with their status.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "imucal/calibrator.hpp"
#include "imucal/sim/motion_sim.hpp"
#include "support/gtest_status.hpp"

namespace imucal {
namespace {

template <typename Scalar>
ImuSample<Scalar> to_sample(const sim::MotionSample& m) {
  ImuSample<Scalar> s;
  s.t_us = static_cast<std::uint32_t>(std::llround(m.t * 1e6));
  s.acc = m.acc.cast<Scalar>();
  s.gyro = m.gyro.cast<Scalar>();
  return s;
}

struct Scenario {
  sim::MotionPlan plan;
  sim::AccelSensorSpec acc = sim::AccelSensorSpec::raw_counts();
  sim::GyroSensorSpec gyro = sim::GyroSensorSpec::raw_counts();
};

template <typename Scalar>
CalibratorSettings<Scalar> settings_for(const Scenario& sc, bool refine_bias) {
  CalibratorSettings<Scalar> s;
  s.accel.gravity = static_cast<Scalar>(sc.plan.gravity);
  s.gyro.nominal_scale = static_cast<Scalar>(sc.gyro.nominal_scale);
  s.gyro.refine_bias = refine_bias;
  return s;
}

// Streams a recording; returns the statuses of add() counted per kind in `events`.
template <typename Scalar, class Cal>
int stream(Cal& cal, const std::vector<sim::MotionSample>& samples) {
  int not_ok = 0;
  for (const auto& m : samples)
    if (cal.add(to_sample<Scalar>(m)) != Status::kOk) ++not_ok;
  return not_ok;
}

// Errors over sigma for the 9 accelerometer and 9 (or 12) gyro parameters.
template <typename Scalar>
void expect_within_3_sigma(const Calibration<Scalar>& c, const sim::Recording& rec,
                           double* worst = nullptr) {
  double w = 0.0;
  for (int k = 0; k < kAccelParams; ++k) {
    const double z = (static_cast<double>(c.accel.params(k)) - rec.acc.params(k)) /
                     static_cast<double>(c.accel.sigma(k));
    EXPECT_LT(std::abs(z), 3.0) << "accel parameter " << k;
    w = std::max(w, std::abs(z));
  }
  const int n = c.gyro.bias_refined ? kGyroParams : kGyroMatrixParams;
  for (int k = 0; k < n; ++k) {
    const double z = (static_cast<double>(c.gyro.params(k)) - rec.gyro.params(k)) /
                     static_cast<double>(c.gyro.sigma(k));
    EXPECT_LT(std::abs(z), 3.0) << "gyro parameter " << k;
    w = std::max(w, std::abs(z));
  }
  if (worst != nullptr) *worst = w;
}

template <typename Scalar>
void full_motion(bool refine_bias, std::uint64_t seed) {
  Scenario sc;
  sc.plan.initial_rest_s = 30.0;
  sim::Random rng(seed);
  const sim::Recording rec = sim::simulate_motion(sc.plan, sc.acc, sc.gyro, rng);
  Calibrator<Scalar> cal(settings_for<Scalar>(sc, refine_bias));
  EXPECT_EQ(stream<Scalar>(cal, rec.samples), 0);
  const Progress before = cal.progress();
  // The last rest becomes a pose when the stream ends (no motion came to end it).
  EXPECT_EQ(before.poses, static_cast<int>(rec.rests.size()) - 1);
  EXPECT_EQ(before.phase, Phase::kReady);
  EXPECT_EQ(before.hint, Hint::kSolve);
  EXPECT_EQ(cal.solve_all(), cal.calibration().gyro.status);
  const Progress p = cal.progress();
  EXPECT_EQ(p.poses, static_cast<int>(rec.rests.size()));
  EXPECT_EQ(p.moves, p.poses - 1);
  EXPECT_EQ(p.rests_too_short, 0);
  EXPECT_EQ(p.moves_dropped, 0);
  EXPECT_EQ(p.faces_covered, 6);
  EXPECT_EQ(p.axes_turned, 0x7);
  EXPECT_EQ(p.phase, Phase::kDone);
  // Each pose lies inside a true rest (the detector trims, it never reaches into motion).
  for (int k = 0; k < p.poses; ++k) {
    const double begin = cal.pose_begin_us(k) * 1e-6, end = cal.pose_end_us(k) * 1e-6;
    const auto& r = rec.rests[static_cast<std::size_t>(k)];
    EXPECT_GE(begin, rec.samples[r.begin].t - 1e-6) << k;
    EXPECT_LE(end, rec.samples[r.end - 1].t + 1e-6) << k;
  }
  const Calibration<Scalar>& c = cal.calibration();
  ASSERT_TRUE(succeeded(c.accel.status)) << to_string(c.accel.status);
  ASSERT_TRUE(succeeded(c.gyro.status)) << to_string(c.gyro.status);
  double worst = 0.0;
  expect_within_3_sigma(c, rec, &worst);
  std::printf(
      "seed %llu: %d poses, %d moves, %d segments, worst |error|/sigma %.2f, gyro rms %.3f deg, "
      "quality %d\n",
      static_cast<unsigned long long>(seed), p.poses, p.moves, p.segments, worst,
      static_cast<double>(c.gyro.residual_rms) * 57.29578, static_cast<int>(c.quality));
  EXPECT_EQ(c.quality, Quality::kGood);
}

TEST(Calibrator, FullMotionWithin3SigmaDouble) {
  for (std::uint64_t seed : {1u, 2u, 3u}) full_motion<double>(false, seed);
}
TEST(Calibrator, FullMotionWithin3SigmaFloat) {
  for (std::uint64_t seed : {1u, 2u, 3u}) full_motion<float>(false, seed);
}
TEST(Calibrator, FullMotionRefinedBiasFloat) {
  for (std::uint64_t seed : {4u, 5u}) full_motion<float>(true, seed);
}

}  // namespace
}  // namespace imucal
