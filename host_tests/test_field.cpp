// SPDX-License-Identifier: MIT
// The field calibrator (include/imucal/field/): its bias filter on its own, its statuses on bad
// input, and on simulated lives with known truth (sim/life_sim.hpp): the bias it publishes, the
// sigma it states, the changes it finds and the updates it refuses.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <vector>

#include "imucal/field/accel_field.hpp"
#include "imucal/field/bias_filter.hpp"
#include "imucal/field/field_calibrator.hpp"
#include "imucal/field/field_store.hpp"
#include "imucal/port/sim_nor_flash.hpp"
#include "imucal/sim/field_settings.hpp"
#include "imucal/sim/life_sim.hpp"
#include "imucal/sim/random.hpp"
#include "support/fifo_bytes.hpp"

namespace imucal {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// ---- The bias filter ----

TEST(BiasFilter, LearnsBiasSlopeAndCurvatureWithinTheirSigmas) {
  sim::Random rng(5);
  BiasFilter<double> f;
  f.start(Vector3<double>::Zero(), 50.0, Vector3<double>::Zero(), 1.0, Vector3<double>::Zero(),
          0.05, 25.0);
  const Vector3<double> c(3.0, -40.0, 7.5), s(0.2, -0.3, 0.05), q(0.004, -0.002, 0.0);
  const double r = 0.01;  // each measurement's variance per axis
  double chi2_sum = 0.0;
  const int n = 400;
  for (int k = 0; k < n; ++k) {
    const double t = 15.0 + 30.0 * rng.uniform();
    const double d = t - 25.0;
    const Vector3<double> z = c + d * (s + d * q) + rng.normal3() * std::sqrt(r);
    if (k >= 50) chi2_sum += f.chi2(z, r, t);
    f.update(z, r, t);
  }
  // Innovations of a consistent filter: chi-square(3), mean 3.
  EXPECT_NEAR(chi2_sum / (n - 50), 3.0, 0.6);
  const double sc = std::sqrt(f.p(0, 0)), ss = std::sqrt(f.p(1, 1)), sq = std::sqrt(f.p(2, 2));
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT(std::fabs(f.c(i) - c(i)), 4.0 * sc) << i;
    EXPECT_LT(std::fabs(f.s(i) - s(i)), 4.0 * ss) << i;
    EXPECT_LT(std::fabs(f.q(i) - q(i)), 4.0 * sq) << i;
  }
  EXPECT_NEAR(f.min_c, 15.0, 0.5);
  EXPECT_NEAR(f.max_c, 45.0, 0.5);
  EXPECT_EQ(f.measurements, static_cast<std::uint32_t>(n));
}

TEST(BiasFilter, ClampsBeyondWhatItSawWhileItsVarianceGrows) {
  BiasFilter<double> f;
  f.start(Vector3<double>::Zero(), 10.0, Vector3<double>::Zero(), 1.0, Vector3<double>::Zero(), 0.0,
          20.0);
  for (int k = 0; k <= 10; ++k) {
    const double t = 20.0 + k;  // 20 to 30 degC, bias = 2 (T - 20)
    f.update(Vector3<double>::Constant(2.0 * (t - 20.0)), 1e-4, t);
  }
  // Within the range plus the 5 degC margin the model is applied; beyond it, clamped.
  EXPECT_NEAR(f.at(34.0, 5.0)(0), 28.0, 0.05);
  EXPECT_NEAR(f.at(50.0, 5.0)(0), 30.0, 0.05);
  EXPECT_NEAR(f.at(-10.0, 5.0)(0), -10.0, 0.05);
  EXPECT_NEAR(f.at(std::numeric_limits<double>::quiet_NaN(), 5.0)(0), 0.0, 0.05);  // at T0
  EXPECT_GT(f.variance_at(50.0), 4.0 * f.variance_at(25.0));
  // The walk widens only the bias at T0.
  const double p11 = f.p(1, 1), p00 = f.p(0, 0);
  f.predict(100.0, 0.01);
  EXPECT_NEAR(f.p(0, 0), p00 + 1.0, 1e-12);
  EXPECT_EQ(f.p(1, 1), p11);
}

// In float, the variance after a measurement survives a prior many times wider than the
// measurement: a 20 deg/s bias prior in counts (940 per rad/s) and rests at the 1e-5 rad/s floor,
// a ratio of about 4e8, where P - P h h' P / S rounds to 0. The float filter follows the double
// one to a part in a thousand (a relative error about eps / sqrt(r / p)); the first rest's
// variance is r's to that accuracy.
TEST(BiasFilter, FloatKeepsTheVarianceUnderAWidePrior) {
  for (const double curvature_sigma : {1.7e-5, 0.0}) {
    const double k = 940.0;
    BiasFilter<float> f;
    BiasFilter<double> g;
    f.start(Vector3<float>::Zero(), static_cast<float>(0.35 * k), Vector3<float>::Zero(),
            static_cast<float>(5.2e-4 * k), Vector3<float>::Zero(),
            static_cast<float>(curvature_sigma * k), 25.0f);
    g.start(Vector3<double>::Zero(), 0.35 * k, Vector3<double>::Zero(), 5.2e-4 * k,
            Vector3<double>::Zero(), curvature_sigma * k, 25.0);
    sim::Random rng(8);
    const double floor_r = (1.7e-5 * k) * (1.7e-5 * k);
    for (int n = 0; n < 60; ++n) {
      const double t = n == 0 ? 25.0 : 15.0 + 30.0 * rng.uniform();
      const double r = n < 3 ? floor_r : floor_r + 0.16 * rng.uniform();
      const Vector3<double> z = Vector3<double>(3.0, -40.0, 7.5) + rng.normal3() * std::sqrt(r);
      f.update(z.cast<float>(), static_cast<float>(r), static_cast<float>(t));
      g.update(z, r, t);
      if (n == 0) {
        EXPECT_NEAR(f.p(0, 0), floor_r, 2e-3 * floor_r);
      }
      for (int i = 0; i < 3; ++i) {
        EXPECT_NEAR(f.p(i, i), g.p(i, i), 2e-3 * g.p(i, i)) << "rest " << n << " entry " << i;
        EXPECT_NEAR(f.c(i), g.c(i), 1e-3 * std::sqrt(g.p(0, 0)) + 1e-6 * std::fabs(g.c(i)))
            << "rest " << n << " axis " << i;
      }
    }
    EXPECT_TRUE(f.finite());
  }
}

// ---- The calibrator on bad input ----

FieldSettings<float> settings_for(const sim::DeviceSheet& sheet) {
  return sim::field_settings(sheet);
}

FieldSettings<float> plain_settings() {
  FieldSettings<float> s;
  s.gyro_noise = 4.0f;
  s.accel_noise = 100.0f;
  s.gyro_per_rad_s = 940.0f;
  return s;
}

TEST(FieldCalibrator, SettingsOutOfRangeRefuseEverySample) {
  FieldCalibrator<float> f;
  FieldSettings<float> s = plain_settings();
  s.gyro_per_rad_s = kNaN;
  EXPECT_EQ(f.start(s), Status::kInvalidArgument);
  ImuSample<float> x;
  x.acc = Vector3<float>(0, 0, 4096);
  EXPECT_EQ(f.add(x), Status::kInvalidArgument);
  s = plain_settings();
  s.gate_chi2 = -1.0f;
  EXPECT_EQ(f.start(s), Status::kInvalidArgument);
  s = plain_settings();
  s.better_ratio = 1.5f;
  EXPECT_EQ(f.start(s), Status::kInvalidArgument);
  s = plain_settings();
  s.curvature_sigma = kNaN;
  EXPECT_EQ(f.start(s), Status::kInvalidArgument);
  s = plain_settings();
  s.gyro_matrix.gate_chi2 = -1.0f;
  EXPECT_EQ(f.start(s), Status::kInvalidArgument);
  s = plain_settings();
  s.gyro_matrix.segment_max_angle = kNaN;
  EXPECT_EQ(f.start(s), Status::kInvalidArgument);
  // A scale whose prior variances overflow the float range, or whose inverse does (a denormal).
  s = plain_settings();
  s.gyro_per_rad_s = 1e30f;
  EXPECT_EQ(f.start(s), Status::kInvalidArgument);
  s = plain_settings();
  s.gyro_per_rad_s = 1e-39f;
  EXPECT_EQ(f.start(s), Status::kInvalidArgument);
  s = plain_settings();
  s.bias_sigma = 1e30f;
  EXPECT_EQ(f.start(s), Status::kInvalidArgument);
  s = plain_settings();
  s.accel.accel_per_m_s2 = 4096.0f / 9.80665f;  // the accelerometer's model on
  s.accel.resolve_seconds = 1e12f;
  EXPECT_EQ(f.start(s), Status::kInvalidArgument);
  EXPECT_EQ(f.start(plain_settings()), Status::kOk);
  EXPECT_EQ(f.add(x), Status::kOk);
}

TEST(FieldCalibrator, APriorWithANaNIsRefusedAndTheNominalOneUsed) {
  FieldCalibrator<float> f;
  Calibration<float> prior;
  prior.gyro.status = Status::kOk;
  prior.gyro.params(kGyroBiasX) = kNaN;
  EXPECT_EQ(f.start(plain_settings(), &prior), Status::kNonFiniteInput);
  EXPECT_FALSE(f.published());
  Vector3<float> b;
  EXPECT_FALSE(f.gyro_bias(25.0f, b));
  EXPECT_TRUE(all_finite(b));
  // A usable prior is published from the start, with its sigma.
  prior.gyro.params(kGyroBiasX) = 12.0f;
  prior.gyro.sigma.tail<3>().setConstant(0.5f);
  prior.has_temperature = true;
  prior.temperature_c = 30.0f;
  EXPECT_EQ(f.start(plain_settings(), &prior), Status::kOk);
  float sigma = 0.0f;
  EXPECT_TRUE(f.gyro_bias(30.0f, b, &sigma));
  EXPECT_FLOAT_EQ(b(0), 12.0f);
  EXPECT_FLOAT_EQ(sigma, 0.5f);
}

TEST(FieldCalibrator, BadSamplesAreRefusedWithTheirStatusAndChangeNothing) {
  FieldCalibrator<float> f;
  ASSERT_EQ(f.start(plain_settings()), Status::kOk);
  ImuSample<float> x;
  x.acc = Vector3<float>(0, 0, 4096);
  x.t_us = 1000;
  EXPECT_EQ(f.add(x), Status::kOk);
  ImuSample<float> bad = x;
  bad.t_us = 11000;
  bad.gyro(1) = kNaN;
  EXPECT_EQ(f.add(bad), Status::kNonFiniteInput);
  bad = x;
  bad.t_us = 500;
  EXPECT_EQ(f.add(bad), Status::kTimeBackwards);
  EXPECT_EQ(f.add_mag(Vector3<float>(kNaN, 0, 0)), Status::kNonFiniteInput);
  EXPECT_EQ(f.monitor().samples_refused(), 2u);
  EXPECT_EQ(f.counts().rests, 0u);
  x.t_us = 11000;
  EXPECT_EQ(f.add(x), Status::kOk);
}

// ---- The accelerometer's model from field rests ----

// A device whose accelerometer reads 1000 counts per m/s^2 nominally, with a known model (the
// truth) and rests that the test chooses: each rest's mean reading with a per-axis error of the
// pose floor (what the model's weights assume).
struct AccelTruth {
  AccelVector<double> p = AccelVector<double>::Zero();  // sensor units, as a calibration's
  Vector3<double> slope = Vector3<double>::Zero();      // counts per deg C
  Vector3<double> curvature = Vector3<double>::Zero();  // counts per deg C^2
  double t0 = 25.0;

  AccelTruth() {
    p << 0.004, -0.003, 0.002, 1e-3 * 1.012, 1e-3 * 0.991, 1e-3 * 1.006, 120.0, -80.0, 150.0;
    slope << 3.0, -2.0, 4.0;  // 0.3, 0.2, 0.4 mg/degC
    curvature << 0.05, -0.04, 0.03;
  }
  Vector3<double> bias(double t) const {
    const double d = t - t0;
    return p.tail<3>() + d * slope + d * d * curvature;
  }
  // The raw mean reading at rest in unit direction u, temperature t.
  Vector3<double> reading(const Vector3<double>& u, double t, double g) const {
    AccelVector<double> q = p;
    q.tail<3>().setZero();
    return accel_matrix(q).inverse() * (g * u) - bias(t);
  }
};

AccelFieldSettings<float> accel_settings() {
  AccelFieldSettings<float> s;
  s.accel_per_m_s2 = 1000.0f;
  return s;
}

// Feeds one rest and runs the solve that follows to its end.
AccelFieldEvent feed_rest(AccelField<float>& a, const AccelTruth& truth, const Vector3<double>& u,
                          double t, double floor_counts, sim::Random& rng, std::uint64_t time_us,
                          std::uint32_t group, bool* updated = nullptr) {
  const Vector3<double> x = truth.reading(u, t, 9.80665) + floor_counts * rng.normal3();
  const AccelFieldEvent e = a.add(x.cast<float>(), 1.0f, static_cast<float>(t), time_us, group);
  int steps = 0;
  while (a.busy() && steps < 10000) {
    if (a.step() == AccelFieldEvent::kUpdated && updated != nullptr) *updated = true;
    ++steps;
  }
  EXPECT_FALSE(a.busy());
  return e;
}

// Ten directions (the six faces and four corners of a cube, each within its cell) at the
// temperatures that make every parameter observable: the faces at 15 and 35 deg C, the corners at
// 25: sixteen cells, the model's capacity.
struct StructuredRest {
  Vector3<double> u;
  double t;
};
StructuredRest structured_rest(int i, sim::Random& rng) {
  static const double kFaces[6][3] = {{1, 0, 0},  {-1, 0, 0}, {0, 1, 0},
                                      {0, -1, 0}, {0, 0, 1},  {0, 0, -1}};
  static const double kCorners[4][3] = {{1, 1, 1}, {-1, -1, 1}, {1, -1, -1}, {-1, 1, -1}};
  const int k = i % 16;
  Vector3<double> u;
  double t = 25.0;
  if (k < 12) {
    u = Vector3<double>(kFaces[k % 6][0], kFaces[k % 6][1], kFaces[k % 6][2]);
    t = k < 6 ? 15.0 : 35.0;
  } else {
    u = Vector3<double>(kCorners[k - 12][0], kCorners[k - 12][1], kCorners[k - 12][2]);
  }
  u += 0.05 * rng.normal3();  // a hand's placement
  return {u / u.norm(), t + 0.5 * rng.normal()};
}

// The truth's parameters in the model's normalised units (scales relative to nominal, biases
// and their temperature terms in units of gravity), AccelField's order.
AccelField<float>::Vector normalised(const AccelTruth& truth) {
  const double g_counts = 1000.0 * 9.80665;
  AccelField<float>::Vector v;
  for (int k = 0; k < kAccelParams; ++k)
    v(k) = static_cast<float>(truth.p(k) *
                              (k >= kBiasX ? 1.0 / g_counts : (k >= kScaleX ? 1000.0 : 1.0)));
  for (int i = 0; i < 3; ++i) {
    v(kAccelParams + i) = static_cast<float>(truth.slope(i) / g_counts);
    v(kAccelParams + 3 + i) = static_cast<float>(truth.curvature(i) / g_counts);
  }
  return v;
}

// Rests all round the sphere at temperatures over 15-35 deg C: every parameter is determined,
// and each ends within 3.5 sigma of the truth, the sigmas small against the prior's.
TEST(AccelField, RestsAllRoundDetermineTheFullModelWithinSigma) {
  AccelField<float> a;
  ASSERT_EQ(a.start(accel_settings()), Status::kOk);
  const AccelTruth truth;
  sim::Random rng(7);
  const double floor_counts = 4.9;  // the default floor, 0.5 mg, in counts
  std::uint64_t t_us = 1000000;
  for (int i = 0; i < 64; ++i) {
    const StructuredRest r = structured_rest(i, rng);
    feed_rest(a, truth, r.u, r.t, floor_counts, rng, t_us, static_cast<std::uint32_t>(i));
    t_us += 60000000u;
  }
  ASSERT_TRUE(a.published());
  EXPECT_EQ(a.solve_status(), Status::kOk);
  const AccelField<float>::Vector want = normalised(truth);
  const AccelField<float>::Vector& got = a.published_parameters();
  const AccelField<float>::Vector& sigma = a.published_sigmas();
  for (int k = 0; k < AccelField<float>::kParams; ++k) {
    EXPECT_LT(std::fabs(got(k) - want(k)), 3.5f * sigma(k)) << "parameter " << k;
    // The curvature needs a wider span than 20 deg C at the pose floor to be determined.
    if (k < AccelField<float>::kCurvatureX) {
      EXPECT_LT(sigma(k), 0.5f * a.prior_sigmas()(k)) << "parameter " << k;
    }
  }
  // The bias applied at 30 deg C, raw counts, against the truth's.
  Vector3<float> b, sb;
  EXPECT_TRUE(a.bias(30.0f, 5.0f, b, &sb));
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT(std::fabs(static_cast<double>(b(i)) - truth.bias(30.0)(i)),
              3.5 * static_cast<double>(sb(i)))
        << "axis " << i;
    EXPECT_LT(sb(i), 49.0f);  // counts: 5 mg, the curvature's share most of it
  }
}

// A rest that comes while a solve adds the prior's rows waits for the next solve: the pass takes
// the cells there when it began, so no prior row is added twice (a parameter no rest determines
// would come out with its prior sigma over sqrt(2)).
TEST(AccelField, ARestDuringASolveWaitsForTheNext) {
  AccelField<float> a;
  AccelFieldSettings<float> s = accel_settings();
  s.iterations = 1;
  ASSERT_EQ(a.start(s), Status::kOk);
  const AccelTruth truth;
  sim::Random rng(9);
  std::uint64_t t_us = 1000000;
  std::uint32_t group = 0;
  auto add = [&](const Vector3<double>& u) {
    const Vector3<double> x = truth.reading(u, 25.0, 9.80665) + 4.9 * rng.normal3();
    a.add(x.cast<float>(), 1.0f, 25.0f, t_us, group++);
    t_us += 60000000u;
  };
  add(Vector3<double>(0.0, 0.0, 1.0));
  ASSERT_TRUE(a.busy());
  constexpr int kParams = AccelField<float>::kParams;
  const int before = kBiasY + 2;  // the cell's row and the prior's rows before kBiasY's
  for (int i = 0; i < before; ++i) a.step();
  add(Vector3<double>(1.0, 0.0, 0.0));
  ASSERT_EQ(a.cells(), 2u);
  // The rest of the pass (one row more if the new cell were taken in it), its one Gauss-Newton
  // step and the covariance's columns; then the cells are judged, which leaves the sigmas.
  for (int i = 0; i < 1 + kParams - before + 1 + 1 + kParams; ++i) a.step();
  ASSERT_TRUE(a.busy());
  const float prior = a.prior_sigmas()(kBiasY);
  EXPECT_NEAR(a.solution_sigmas()(kBiasY), prior, 1e-3f * prior);
  for (int i = 0; i < 10000 && a.busy(); ++i) a.step();
  EXPECT_FALSE(a.busy());
  EXPECT_NEAR(a.solution_sigmas()(kBiasY), prior, 1e-3f * prior);  // the next solve's, both cells
}

// One orientation for a long time (z up), over temperatures: the bias and scale along gravity are
// refined only as a combination; the other axes' biases keep their prior value and sigma.
TEST(AccelField, OneOrientationRefinesOnlyWhatItDetermines) {
  AccelField<float> a;
  ASSERT_EQ(a.start(accel_settings()), Status::kOk);
  const AccelTruth truth;
  sim::Random rng(8);
  std::uint64_t t_us = 1000000;
  for (int i = 0; i < 200; ++i) {
    const double temp = 15.0 + 25.0 * static_cast<double>(i % 11) / 10.0;
    feed_rest(a, truth, Vector3<double>(0.0, 0.0, 1.0), temp, 4.9, rng, t_us,
              static_cast<std::uint32_t>(i));
    t_us += 600000000u;  // ten minutes apart: 33 hours
  }
  ASSERT_TRUE(a.published());
  const AccelField<float>::Vector& got = a.published_parameters();
  const AccelField<float>::Vector& sigma = a.published_sigmas();
  const AccelField<float>::Vector& prior = a.prior_sigmas();
  for (int k : {kBiasX, kBiasY, kScaleX, kScaleY}) {
    EXPECT_GT(sigma(k), 0.95f * prior(k)) << "parameter " << k;
    EXPECT_LT(std::fabs(got(k) - (k >= kBiasX ? 0.0f : 1.0f)), 0.1f * prior(k))
        << "parameter " << k << " moved without data";
  }
  // Along gravity the model now reads |g| at every temperature seen: the residual of a fresh rest
  // is within the floor's noise (e = 1 - |c|^2 ~ -2 e_z: 3 sigma of 2 x 0.5 mg).
  for (double temp : {16.0, 27.0, 39.0}) {
    const Vector3<double> x = truth.reading(Vector3<double>(0.0, 0.0, 1.0), temp, 9.80665);
    Vector3<float> b;
    a.bias(static_cast<float>(temp), 5.0f, b);
    AccelCalibration<float> cal;
    TemperatureBias<float> model;
    a.model(cal, model);
    cal.params.tail<3>() = b;  // the bias at this temperature
    const Vector3<float> xf = x.cast<float>();
    const Vector3<float> c = accel_apply(cal.params, xf);
    EXPECT_NEAR(c.norm(), 9.80665f, 3.0f * 2.0f * 0.0049f) << temp << " deg C";
  }
  // The slope along gravity is determined; across it, it stays at the prior.
  EXPECT_LT(sigma(AccelField<float>::kSlopeX + 2), 0.2f * prior(AccelField<float>::kSlopeX + 2));
  EXPECT_GT(sigma(AccelField<float>::kSlopeX), 0.95f * prior(AccelField<float>::kSlopeX));
}

// From a converged model: one rest that disagrees is held and dropped when the next agrees (the
// published model unchanged); a bias step seen by two rests after motion is a change, and the
// model follows it to within sigma.
TEST(AccelField, AStepIsHeldThenConfirmedAndFollowed) {
  AccelField<float> a;
  ASSERT_EQ(a.start(accel_settings()), Status::kOk);
  AccelTruth truth;
  sim::Random rng(9);
  std::uint64_t t_us = 1000000;
  std::uint32_t group = 0;
  const auto rest = [&](const Vector3<double>& u, bool* updated = nullptr) {
    const AccelFieldEvent e = feed_rest(a, truth, u, 25.0, 4.9, rng, t_us, group++, updated);
    t_us += 60000000u;
    return e;
  };
  for (int i = 0; i < 48; ++i) {
    const StructuredRest r = structured_rest(i, rng);
    feed_rest(a, truth, r.u, r.t, 4.9, rng, t_us, group++);
    t_us += 60000000u;
  }
  ASSERT_TRUE(a.published());
  const AccelField<float>::Vector before = a.published_parameters();
  // One disturbed rest (a 30 mg error along gravity), then agreeing ones: dropped.
  AccelTruth disturbed = truth;
  disturbed.p(kBiasZ) += 294.0;
  const Vector3<double> up(0.0, 0.0, 1.0);
  EXPECT_EQ(feed_rest(a, disturbed, up, 25.0, 4.9, rng, t_us, group++), AccelFieldEvent::kHeld);
  t_us += 60000000u;
  EXPECT_EQ(rest(up), AccelFieldEvent::kUnconfirmed);
  for (int k = 0; k < AccelField<float>::kParams; ++k)
    EXPECT_LT(std::fabs(a.published_parameters()(k) - before(k)),
              0.5f * a.published_sigmas()(k) + 1e-6f)
        << "parameter " << k;
  // A step of 20 mg on z, seen by rests after motion: held, then a change. Until the cells
  // support a new model, the published one stays with its bias's sigma widened to cover the step.
  truth.p(kBiasZ) += 196.0;
  EXPECT_EQ(rest(up), AccelFieldEvent::kHeld);
  bool updated = false;
  EXPECT_EQ(rest(-up, &updated), AccelFieldEvent::kChangeDetected);
  const float want = static_cast<float>(truth.p(kBiasZ) / 9806.65);
  EXPECT_LT(std::fabs(a.published_parameters()(kBiasZ) - want),
            3.5f * a.published_sigmas()(kBiasZ));
  bool change_published = updated && a.update_reason() == 3;
  for (int i = 0; i < 32; ++i) {
    const StructuredRest r = structured_rest(i, rng);
    updated = false;
    feed_rest(a, truth, r.u, r.t, 4.9, rng, t_us, group++, &updated);
    if (updated && a.update_reason() == 3) change_published = true;
    t_us += 60000000u;
  }
  EXPECT_TRUE(change_published);
  EXPECT_LT(std::fabs(a.published_parameters()(kBiasZ) - want),
            3.5f * a.published_sigmas()(kBiasZ));
  EXPECT_LT(a.published_sigmas()(kBiasZ), 0.1f * 0.029f);  // back below 3 mg
}

// Started from the right model with a protocol's sigmas, rests that agree change nothing beyond
// those sigmas.
TEST(AccelField, TheRightPriorIsKept) {
  const AccelTruth truth;
  AccelCalibration<float> prior;
  prior.params = truth.p.cast<float>();
  prior.sigma << 1e-4f, 1e-4f, 1e-4f, 1e-7f, 1e-7f, 1e-7f, 2.0f, 2.0f, 2.0f;
  prior.status = Status::kOk;
  TemperatureModel<float> model;
  model.reference_c = 25.0f;
  model.min_c = 15.0f;
  model.max_c = 35.0f;
  model.accel.b0 = truth.p.tail<3>().cast<float>();
  model.accel.b1 = truth.slope.cast<float>();
  model.accel.b2 = truth.curvature.cast<float>();
  model.accel.b1_sigma.setConstant(0.2f);
  model.accel.b2_sigma.setConstant(0.01f);
  model.accel.status = Status::kOk;
  AccelField<float> a;
  ASSERT_EQ(a.start(accel_settings(), &prior, &model, 25.0f), Status::kOk);
  ASSERT_TRUE(a.published());
  const AccelField<float>::Vector start = a.published_parameters();
  const AccelField<float>::Vector start_sigma = a.published_sigmas();
  sim::Random rng(10);
  std::uint64_t t_us = 1000000;
  for (int i = 0; i < 48; ++i) {
    const StructuredRest r = structured_rest(i, rng);
    EXPECT_NE(feed_rest(a, truth, r.u, r.t, 4.9, rng, t_us, static_cast<std::uint32_t>(i)),
              AccelFieldEvent::kChangeDetected);
    t_us += 60000000u;
  }
  for (int k = 0; k < AccelField<float>::kParams; ++k)
    EXPECT_LT(std::fabs(a.published_parameters()(k) - start(k)), 2.0f * start_sigma(k) + 1e-7f)
        << "parameter " << k;
}

TEST(AccelField, SettingsOutOfRangeAndBadRestsAreRefused) {
  AccelField<float> a;
  AccelFieldSettings<float> s = accel_settings();
  s.floor = -1.0f;
  EXPECT_EQ(a.start(s), Status::kInvalidArgument);
  EXPECT_FALSE(a.enabled());
  s = accel_settings();
  s.accel_per_m_s2 = kNaN;
  EXPECT_EQ(a.start(s), Status::kInvalidArgument);
  ASSERT_EQ(a.start(accel_settings()), Status::kOk);
  AccelCalibration<float> nan_prior;
  nan_prior.status = Status::kOk;
  nan_prior.params(kScaleX) = kNaN;
  EXPECT_EQ(a.start(accel_settings(), &nan_prior), Status::kNonFiniteInput);
  EXPECT_FALSE(a.published());
  EXPECT_EQ(a.add(Vector3<float>(kNaN, 0.0f, 9806.0f), 1.0f, 25.0f, 1000000u, 0u),
            AccelFieldEvent::kNone);
  EXPECT_EQ(a.cells(), 0u);
  EXPECT_FALSE(a.busy());
  // A reading whose norm overflows, or a negative variance, is no gravity: refused, no cell made
  // (with the tolerance of a magnetometer's model, |norm - 1| <= 1, as with the accelerometer's).
  for (float tolerance : {0.05f, 1.0f}) {
    AccelFieldSettings<float> loose = accel_settings();
    loose.max_norm_error = tolerance;
    ASSERT_EQ(a.start(loose), Status::kOk);
    const float huge = 3e38f;
    for (const Vector3<float>& x :
         {Vector3<float>(huge, huge, huge), Vector3<float>(huge, -huge, huge)}) {
      EXPECT_EQ(a.add(x, 1.0f, 25.0f, 1000000u, 0u), AccelFieldEvent::kImplausible) << tolerance;
    }
    EXPECT_EQ(a.add(Vector3<float>(0.0f, 0.0f, 9806.0f), -1.0f, 25.0f, 2000000u, 1u),
              AccelFieldEvent::kImplausible)
        << tolerance;
    EXPECT_EQ(a.cells(), 0u) << tolerance;
    EXPECT_TRUE(all_finite(a.published_parameters()));
  }
  // The field calibrator refuses its settings when the accelerometer's are out of range.
  FieldSettings<float> f;
  f.gyro_noise = 1.0f;
  f.accel_noise = 1.0f;
  f.gyro_per_rad_s = 1000.0f;
  f.accel = accel_settings();
  f.accel.half_life_days = 0.0f;
  FieldCalibrator<float> field;
  EXPECT_EQ(field.start(f), Status::kInvalidArgument);
}

// ---- On simulated lives ----

// The next sample of the life into the calibrator, as a firmware feeds it (frames of counts, the
// temperature when one was read, the magnetometer when a reading came). False at the life's end.
RawFrame frame_of(const sim::LifeSample& s) {
  RawFrame fr;
  fr.t_us = s.t_us;
  for (std::size_t i = 0; i < 3; ++i) {
    fr.acc[i] = s.acc_counts[i];
    fr.gyro[i] = s.gyro_counts[i];
  }
  return fr;
}

bool feed_next(sim::LifeSimulator& life, FieldCalibrator<float>& f, sim::LifeSample& s,
               sim::LifeTruth& t) {
  if (!life.next(s, t)) return false;
  const RawFrame fr = frame_of(s);
  const Status st = f.add_raw(fr, s.temperature_new ? s.imu.temperature : kNaN);
  EXPECT_TRUE(st == Status::kOk || sample_taken(st)) << to_string(st);
  if (life.sheet().has_mag && s.mag_new) {
    // A magnet at the sensor reads beyond any field the settings allow: refused.
    const Status m = f.add_mag(s.mag);
    EXPECT_TRUE(m == Status::kOk || (m == Status::kGlitch && t.magnet_near)) << to_string(m);
  }
  return true;
}

// A FIFO batch is its frames, one by one: a hand-held life fed in batches of 25 frames (the
// sensor's own layout: 14-byte frames, big-endian, the axes in another order, per-frame
// timestamps, one repeated) decides exactly what the same frames fed to add_raw() decide, with
// the batch's temperature going with its first frame taken. A batch that cannot be read refuses
// each frame and changes nothing else.
TEST(FieldCalibrator, AFifoBatchIsItsFrames) {
  sim::LifePlan plan;
  sim::LifeOptions o;
  o.magnetometer = false;
  ASSERT_TRUE(sim::make_life("handheld", 2, 2.0, o, plan));
  sim::LifeSimulator life(plan);
  static FieldCalibrator<float> one, batch;
  ASSERT_EQ(one.start(settings_for(life.sheet())), Status::kOk);
  ASSERT_EQ(batch.start(settings_for(life.sheet())), Status::kOk);
  FifoLayout layout;
  layout.stride = 14;
  layout.acc_offset = 8;  // the gyro first, as many IMUs store it
  layout.gyro_offset = 2;
  layout.axis_order[0] = 1;  // body x is the frame's second reading, y the third, z the first
  layout.axis_order[1] = 2;
  layout.axis_order[2] = 0;
  layout.big_endian = true;
  constexpr std::uint32_t kBatch = 25;
  std::uint8_t bytes[kBatch * 14] = {};
  std::uint32_t stamps[kBatch] = {};
  RawFrame frames[kBatch];
  Status want[kBatch], got[kBatch];
  sim::LifeSample s;
  sim::LifeTruth t;
  std::uint32_t batches = 0, repeated = 0;
  bool more = true;
  while (more) {
    float temperature = kNaN;
    std::uint32_t n = 0;
    for (; n < kBatch && (more = life.next(s, t)); ++n) {
      RawFrame& f = frames[n];
      f.t_us = s.t_us;
      for (std::size_t i = 0; i < 3; ++i) {
        f.acc[i] = s.acc_counts[i];
        f.gyro[i] = s.gyro_counts[i];
      }
      if (n == 0 && s.temperature_new) temperature = s.imu.temperature;
    }
    if (n == 0) break;
    if (batches == 100 && n > 3) frames[3].t_us = frames[2].t_us;  // a repeated timestamp
    float carried = temperature;  // with the first frame taken (or read and refused, a glitch)
    for (std::uint32_t k = 0; k < n; ++k) {
      test::put_fifo_frame(bytes, k, layout, frames[k]);
      stamps[k] = frames[k].t_us;
      want[k] = one.add_raw(frames[k], carried);
      if (sample_taken(want[k]) || want[k] == Status::kGlitch) carried = kNaN;
    }
    FifoTiming timing;
    timing.t_us = stamps;
    const FifoResult r = batch.add_fifo(bytes, n, layout, timing, temperature, got);
    std::uint32_t taken = 0;
    for (std::uint32_t k = 0; k < n; ++k) {
      ASSERT_EQ(got[k], want[k]) << "batch " << batches << " frame " << k;
      if (sample_taken(want[k])) ++taken;
      if (want[k] == Status::kTimeRepeated) ++repeated;
    }
    EXPECT_EQ(r.taken, taken);
    EXPECT_EQ(r.taken + r.refused, n);
    ++batches;
  }
  EXPECT_EQ(repeated, 1u);
  EXPECT_EQ(batch.monitor().samples_refused(), one.monitor().samples_refused());
  const FieldCounts& a = one.counts();
  const FieldCounts& b = batch.counts();
  EXPECT_GT(a.updates, 0u);  // the life published: the comparison below compares something
  EXPECT_EQ(b.rests, a.rests);
  EXPECT_EQ(b.taken, a.taken);
  EXPECT_EQ(b.held, a.held);
  EXPECT_EQ(b.updates, a.updates);
  EXPECT_EQ(b.accel_updates, a.accel_updates);
  Vector3<float> bias_one, bias_batch;
  float sigma_one = 0.0f, sigma_batch = 0.0f;
  ASSERT_TRUE(one.gyro_bias(bias_one, &sigma_one));
  ASSERT_TRUE(batch.gyro_bias(bias_batch, &sigma_batch));
  EXPECT_EQ(bias_batch, bias_one);  // the same arithmetic in the same order: the same bits
  EXPECT_EQ(sigma_batch, sigma_one);

  // Unreadable: an invalid layout, or no buffer.
  const std::uint32_t refused = batch.monitor().samples_refused();
  FifoLayout bad = layout;
  bad.axis_order[1] = bad.axis_order[0];
  FifoTiming timing;
  timing.first_us = frames[0].t_us + 1000000u;
  timing.period_q8 = 10000u * 256u;
  const FifoResult r = batch.add_fifo(bytes, 10, bad, timing, 25.0f, got);
  EXPECT_EQ(r.refused, 10u);
  EXPECT_EQ(r.taken, 0u);
  EXPECT_EQ(r.first_refusal, Status::kInvalidArgument);
  EXPECT_EQ(got[9], Status::kInvalidArgument);
  EXPECT_EQ(batch.add_fifo(nullptr, 3, layout, timing).refused, 3u);
  EXPECT_EQ(batch.monitor().samples_refused(), refused + 13u);
  EXPECT_EQ(batch.counts().rests, a.rests);
  ASSERT_TRUE(batch.gyro_bias(bias_batch));
  EXPECT_EQ(bias_batch, bias_one);
}

struct LifeRun {
  std::vector<double> err;  // per second, the norm of the published bias's error (mdeg/s)
  double z2 = 0.0;          // sum of (error / sigma)^2 over seconds and axes
  std::size_t zn = 0;
  double first_s = -1.0;
  int false_updates = 0;  // a publication more than 5 sigma from the truth on an axis
  std::uint32_t updates = 0, changes = 0;
  // The accelerometer's published bias: (error / sigma)^2 summed over seconds and axes, false
  // updates (more than 5 sigma on an axis), publications.
  double accel_z2 = 0.0;
  std::size_t accel_zn = 0;
  int accel_false_updates = 0;
  std::uint32_t accel_updates = 0;
  double accel_honesty() const { return std::sqrt(accel_z2 / static_cast<double>(accel_zn)); }
  double change_after_knock_s = -1.0;
  double knock_s = -1.0;
  // The magnetometer's published hard iron: per second, the norm of its error (uT); (error /
  // sigma)^2 summed over seconds and axes; false updates (more than 5 sigma on an axis),
  // publications, changes, the time from the change to its detection, and the seconds after the
  // change that its sigma did not cover (more than 5 sigma on an axis).
  std::vector<double> mag_err;
  double mag_z2 = 0.0;
  std::size_t mag_zn = 0;
  int mag_false_updates = 0;
  std::uint32_t mag_updates = 0, mag_changes = 0;
  double hard_iron_step_s = -1.0, mag_change_after_step_s = -1.0;
  int mag_uncovered_s = 0;
  double mag_honesty() const { return std::sqrt(mag_z2 / static_cast<double>(mag_zn)); }
  double mag_median() const {
    std::vector<double> e = mag_err;
    std::sort(e.begin(), e.end());
    return e.empty() ? 0.0 : e[e.size() / 2];
  }

  double median() const {
    std::vector<double> e = err;
    std::sort(e.begin(), e.end());
    return e.empty() ? 0.0 : e[e.size() / 2];
  }
  double honesty() const { return std::sqrt(z2 / static_cast<double>(zn)); }
};

LifeRun run_life(const char* name, double hours, bool mag, std::uint64_t seed = 1) {
  sim::LifePlan plan;
  sim::LifeOptions o;
  o.magnetometer = mag;
  EXPECT_TRUE(sim::make_life(name, seed, hours, o, plan));
  sim::LifeSimulator life(plan);
  const sim::DeviceSheet sheet = life.sheet();
  FieldCalibrator<float> f;
  EXPECT_EQ(f.start(settings_for(sheet)), Status::kOk);
  const double k = sheet.gyro_rad_s_per_count * 180e3 / 3.14159265358979323846;  // mdeg/s
  LifeRun out;
  if (!plan.hard_iron_steps.empty()) out.hard_iron_step_s = plan.hard_iron_steps.front().t_s;
  sim::LifeSample s;
  sim::LifeTruth t;
  double next = 1.0;
  std::uint32_t seen_updates = 0;
  while (feed_next(life, f, s, t)) {
    if (t.phase == sim::PhaseKind::kKnock && out.knock_s < 0.0) out.knock_s = s.t_s;
    FieldEvent<float> e;
    while (f.take_event(e)) {
      if (e.kind != FieldEventKind::kChangeDetected) continue;
      if (e.sensor == FieldSensor::kGyro && out.knock_s >= 0.0 && out.change_after_knock_s < 0.0)
        out.change_after_knock_s = s.t_s - out.knock_s;
      if (e.sensor == FieldSensor::kMag && out.hard_iron_step_s >= 0.0 &&
          s.t_s > out.hard_iron_step_s && out.mag_change_after_step_s < 0.0)
        out.mag_change_after_step_s = s.t_s - out.hard_iron_step_s;
    }
    if (s.t_s < next) continue;
    next += 1.0;
    Vector3<float> h, hs;
    if (f.mag_hard_iron(h, &hs)) {
      const double ut = sheet.mag_ut_per_count;
      const Vector3<double> error = h.cast<double>() - t.hard_iron;
      out.mag_err.push_back(error.norm() * ut);
      const bool after_step = out.hard_iron_step_s >= 0.0 && s.t_s >= out.hard_iron_step_s;
      bool uncovered = false;
      for (int i = 0; i < 3; ++i) {
        const double z = error(i) / static_cast<double>(hs(i));
        out.mag_z2 += z * z;
        uncovered = uncovered || (after_step && std::fabs(z) > 5.0);
        if (f.counts().mag_updates != out.mag_updates && std::fabs(z) > 5.0) {
          ++out.mag_false_updates;
          ADD_FAILURE() << name << ": false magnetometer update at " << s.t_s << " s, axis " << i
                        << " error " << error(i) * ut << " sigma "
                        << static_cast<double>(hs(i)) * ut << " (uT)";
        }
      }
      out.mag_zn += 3;
      out.mag_uncovered_s += uncovered;
      out.mag_updates = f.counts().mag_updates;
    }
    Vector3<float> ab, as;
    if (f.accel_bias(ab, &as)) {
      const Vector3<double> error = ab.cast<double>() - t.accel_bias;
      for (int i = 0; i < 3; ++i) {
        const double z = error(i) / static_cast<double>(as(i));
        out.accel_z2 += z * z;
        if (f.counts().accel_updates != out.accel_updates && std::fabs(z) > 5.0) {
          ++out.accel_false_updates;
          ADD_FAILURE() << name << ": false accelerometer update at " << s.t_s << " s, axis " << i
                        << " error " << error(i) << " sigma " << as(i) << " (counts)";
        }
      }
      out.accel_zn += 3;
      out.accel_updates = f.counts().accel_updates;
    }
    Vector3<float> b;
    float sigma_f = 0.0f;
    if (!f.gyro_bias(b, &sigma_f)) continue;
    const double sigma = static_cast<double>(sigma_f);
    if (out.first_s < 0.0) out.first_s = s.t_s;
    const Vector3<double> error = b.cast<double>() - t.gyro_bias;
    out.err.push_back(error.norm() * k);
    for (int i = 0; i < 3; ++i) out.z2 += error(i) * error(i) / (sigma * sigma);
    out.zn += 3;
    if (f.counts().updates != seen_updates) {
      seen_updates = f.counts().updates;
      if (error.cwiseAbs().maxCoeff() > 5.0 * sigma) {
        ++out.false_updates;
        ADD_FAILURE() << name << ": false update at " << s.t_s << " s, error "
                      << error.transpose() * k << " mdeg/s, sigma " << sigma * k;
      }
    }
  }
  out.updates = f.counts().updates;
  out.changes = f.counts().changes;
  out.mag_changes = f.counts().mag_changes;
  // The gyro's part, the rest monitor, the accelerometer's and the magnetometer's models: what
  // docs/field.md and the README state, 11,008 B on the Arm cores, is 11,040 B on x86-64 (its
  // layout differs). A part that grows fails here until the figures are measured again.
  EXPECT_LE(sizeof(f), 11040u);
  return out;
}

// A desk: long rests in a few places, picked up now and then, warming and cooling over the day;
// a knock steps the bias mid-life.
TEST(FieldLife, DeskBiasWithinAFewMdegPerSecondSigmaHonestKnockFound) {
  const LifeRun r = run_life("desk", 18.0, true);
  // The rest noise over 5 s is 3.2 mdeg/s per axis; the filter's steady state about half that.
  EXPECT_LT(r.median(), 4.0);
  EXPECT_GT(r.first_s, 0.0);
  EXPECT_LT(r.first_s, 120.0);  // the first rest of the life, verified by the field
  EXPECT_EQ(r.false_updates, 0);
  EXPECT_GT(r.honesty(), 0.7);
  EXPECT_LT(r.honesty(), 1.3);
  ASSERT_GE(r.knock_s, 0.0);
  EXPECT_GE(r.changes, 1u);
  EXPECT_GT(r.change_after_knock_s, 0.0);
  EXPECT_LT(r.change_after_knock_s, 60.0);  // a verified rest 10 s after the held one
  // The accelerometer's model: published, never falsely, its sigma honest (the prior's sigma
  // for what the desk's orientations leave undetermined: a uniform draw within the datasheet's
  // bounds is 0.58 of them at most).
  EXPECT_GT(r.accel_updates, 0u);
  EXPECT_EQ(r.accel_false_updates, 0);
  EXPECT_GT(r.accel_honesty(), 0.5);
  EXPECT_LT(r.accel_honesty(), 1.3);
  // The magnetometer at rest: a magnetisation change during a rest shows in the next reading
  // looked at (its field's strength, or its angle to gravity), and the sigma
  // covers it from then on (one reading a second is looked at: the second of the change and the
  // next may be uncovered). The sigma is conservative here: each cell's floor (0.3 uT) stands for
  // a field not quite uniform, and the simulated one is.
  ASSERT_GE(r.hard_iron_step_s, 0.0);
  EXPECT_GE(r.mag_changes, 1u);
  EXPECT_EQ(r.mag_false_updates, 0);
  EXPECT_LE(r.mag_uncovered_s, 2);
  EXPECT_GT(r.mag_honesty(), 0.5);
  EXPECT_LT(r.mag_honesty(), 1.3);
}

// In the hand and the pocket: the magnetometer's hard iron from the readings in motion and the
// rests, within a few tenths of a microtesla, its sigma honest; a magnetisation change in motion
// covered by the sigma from the next reading looked at (one a second), found within minutes and
// followed.
TEST(FieldLife, HandheldHardIronWithinTenthsOfAMicroteslaChangeFound) {
  const LifeRun r = run_life("handheld", 12.0, true);
  ASSERT_FALSE(r.mag_err.empty());
  // One reading's noise is 0.3 uT and each of the 26 cells is capped at 0.3 uT: about 0.1 uT
  // per axis, 0.2 uT as a norm.
  EXPECT_LT(r.mag_median(), 0.5);
  EXPECT_EQ(r.mag_false_updates, 0);
  EXPECT_GT(r.mag_honesty(), 0.7);
  EXPECT_LT(r.mag_honesty(), 1.3);
  ASSERT_GE(r.hard_iron_step_s, 0.0);
  EXPECT_LE(r.mag_uncovered_s, 2);
  EXPECT_GE(r.mag_changes, 1u);
  EXPECT_GT(r.mag_change_after_step_s, 0.0);
  EXPECT_LT(r.mag_change_after_step_s, 600.0);
}

// The magnetometer's model from a stored calibration and back: with no rest taken, the published
// calibration is the stored one (its soft iron in its own frame, its hard iron, its field), and
// every reading calibrates alike.
TEST(MagField, AStoredCalibrationComesBackUnchanged) {
  sim::Random rng(5);
  const sim::MagSensorSpec spec{0.15, 48.0, 62.0, 0.03, 0.02, 50.0 / 0.15, 2.0, 0.0};
  const sim::MagTruth truth = sim::draw_mag_truth(spec, rng);
  MagCalibration<float> stored;
  const MagCalibration<double> exact = sim::mag_truth_calibration(truth);
  stored.status = Status::kOk;
  stored.soft_iron = exact.soft_iron.cast<float>();
  stored.hard_iron = exact.hard_iron.cast<float>();
  stored.hard_iron_sigma.setConstant(1.0f);
  stored.soft_iron_sigma.setConstant(1e-3f);
  stored.field_ut = 48.0f;
  FieldSettings<float> s = plain_settings();
  s.mag.counts_per_ut = 1.0f / 0.15f;
  FieldCalibrator<float> f;
  ASSERT_EQ(f.start(s, nullptr, nullptr, &stored), Status::kOk);
  MagCalibration<float> out;
  ASSERT_TRUE(f.mag_calibration(out));
  EXPECT_FLOAT_EQ(out.field_ut, 48.0f);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(out.hard_iron(i), stored.hard_iron(i), 1e-3f);
  EXPECT_LT((out.soft_iron - stored.soft_iron).norm(), 1e-5f * stored.soft_iron.norm());
  for (int k = 0; k < 20; ++k) {
    const Vector3<float> m = (Vector3<float>::Random() * 400.0f).eval();
    EXPECT_LT((mag_apply(out, m) - mag_apply(stored, m)).norm(), 1e-3f);
  }
  // A stored calibration that is not one (a singular soft iron; one nearly so, though a record
  // takes it: a positive determinant; one skewed beyond any magnetometer) is refused: the nominal
  // prior.
  Matrix3<float> skewed = Matrix3<float>::Identity() * 0.15f;
  skewed(0, 2) = 0.15f;
  for (const Matrix3<float>& bad :
       {Matrix3<float>(Matrix3<float>::Zero()),
        Matrix3<float>(Vector3<float>(0.15f, 0.15f, 1e-6f).asDiagonal()), skewed}) {
    stored.soft_iron = bad;
    FieldCalibrator<float> g;
    EXPECT_EQ(g.start(s, nullptr, nullptr, &stored), Status::kNonFiniteInput) << bad;
    EXPECT_FALSE(g.mag_calibration(out));
  }
}

// The handheld life from a stored magnetometer calibration: the right one is kept within its
// sigma and no change is reported; one whose hard iron is 20 uT off on every axis (stated to
// 0.3 uT) is found wrong, reported as a change, and the estimate converges to within 2 sigma.
TEST(FieldLife, HandheldFromAStoredMagnetometerCalibration) {
  for (double offset_ut : {0.0, 20.0}) {
    sim::LifePlan plan;
    sim::LifeOptions o;
    o.hard_iron_step = false;
    ASSERT_TRUE(sim::make_life("handheld", 1, 4.0, o, plan));
    sim::LifeSimulator life(plan);
    const sim::DeviceSheet sheet = life.sheet();
    const double ut = sheet.mag_ut_per_count;
    const MagCalibration<double> exact = sim::mag_truth_calibration(life.mag_truth());
    MagCalibration<float> stored;
    stored.status = Status::kOk;
    stored.soft_iron = exact.soft_iron.cast<float>();
    stored.hard_iron = (exact.hard_iron + Vector3<double>::Constant(offset_ut / ut)).cast<float>();
    stored.hard_iron_sigma.setConstant(static_cast<float>(0.3 / ut));
    stored.soft_iron_sigma.setConstant(static_cast<float>(0.003 * ut));
    stored.field_ut = static_cast<float>(life.mag_truth().field_ut);
    FieldCalibrator<float> f;
    ASSERT_EQ(f.start(settings_for(sheet), nullptr, nullptr, &stored), Status::kOk);
    sim::LifeSample s;
    sim::LifeTruth t;
    while (feed_next(life, f, s, t)) {
    }
    Vector3<float> h, hs;
    ASSERT_TRUE(f.mag_hard_iron(h, &hs));
    const Vector3<double> error = h.cast<double>() - t.hard_iron;
    for (int i = 0; i < 3; ++i) {
      // Against both sigmas: the stored one's and the estimate's (the truth the stored one was).
      const double sigma = std::hypot(static_cast<double>(hs(i)), 0.3 / ut);
      EXPECT_LT(std::fabs(error(i)), 2.0 * sigma) << "offset " << offset_ut << " axis " << i;
    }
    if (offset_ut == 0.0) {
      EXPECT_EQ(f.counts().mag_changes, 0u);
    } else {
      EXPECT_GE(f.counts().mag_changes, 1u);
    }
  }
}

// A platform turning slowly about the vertical most of the time (a turn that looks like a rest
// to the detector): with the magnetometer the turns are refused, and no update is false. Each
// turn slows to a stop over 2 s; the first piece of the rest after it holds the last of it,
// about 20 mdeg/s about the vertical, which neither the field nor the chi-square(3) of the
// pieces shows. Seed 5 has such pieces: taken at full weight after a long turn, each would be
// published 6 to 7 sigma off.
TEST(FieldLife, TurntableTurnsAreNotTakenForABias) {
  for (std::uint64_t seed : {1u, 5u}) {
    const LifeRun r = run_life("turntable", 12.0, true, seed);
    EXPECT_EQ(r.false_updates, 0) << "seed " << seed;
    EXPECT_GT(r.updates, 0u) << "seed " << seed;
    EXPECT_LT(r.median(), 15.0) << "seed " << seed;  // the turns are 200 to 2000 mdeg/s
  }
}

// A vehicle: steady bends, an idling engine, driving. No false update, with or without the
// magnetometer.
TEST(FieldLife, VehicleBendsMakeNoFalseUpdate) {
  for (bool mag : {true, false}) {
    const LifeRun r = run_life("vehicle", 12.0, mag);
    EXPECT_EQ(r.false_updates, 0) << "magnetometer " << mag;
    EXPECT_EQ(r.accel_false_updates, 0) << "magnetometer " << mag;
    EXPECT_GT(r.updates, 0u) << "magnetometer " << mag;
    EXPECT_LT(r.median(), 10.0) << "magnetometer " << mag;
  }
}

// A node in one orientation without a magnetometer: a knock whose step lies across gravity is a
// bias, not a turn (a turn would have turned gravity), so the next steady piece 10 s on confirms
// it; the bias stays right through it (no other rest would come in another orientation, nor
// after motion for minutes). Without that reading, the knock waited for rests across vibration
// over ten minutes: a 95th percentile of 245 mdeg/s on the two-day life.
TEST(FieldLife, FixedWithoutMagnetometerAKnockAcrossGravityIsFoundAtOnce) {
  const LifeRun r = run_life("fixed", 16.0, false);
  ASSERT_GE(r.knock_s, 0.0);
  ASSERT_GT(r.first_s, 0.0);
  ASSERT_LT(r.first_s, r.knock_s);  // published before the knock: the step is a change
  EXPECT_GE(r.changes, 1u);
  EXPECT_GT(r.change_after_knock_s, 0.0);
  EXPECT_LT(r.change_after_knock_s, 60.0);
  EXPECT_EQ(r.false_updates, 0);
  EXPECT_GT(r.honesty(), 0.7);
  EXPECT_LT(r.honesty(), 1.3);
  // One second in a hundred may be the knock's own: the 95th percentile is the rests' noise.
  std::vector<double> e = r.err;
  std::sort(e.begin(), e.end());
  ASSERT_FALSE(e.empty());
  EXPECT_LT(e[e.size() * 95 / 100], 10.0);
}

// The events the reference calibrator has waiting, the other has the same (kind, sensor, time,
// value), and no more; how many.
template <class Reference, class Other>
std::size_t expect_same_events(Reference& reference, Other& other) {
  std::size_t n = 0;
  FieldEvent<float> a, b;
  while (reference.take_event(a)) {
    if (!other.take_event(b)) {
      ADD_FAILURE() << "an event missing";
      return n;
    }
    EXPECT_EQ(a.kind, b.kind);
    EXPECT_EQ(a.sensor, b.sensor);
    EXPECT_EQ(a.time_s, b.time_s);
    EXPECT_EQ(a.value, b.value);
    ++n;
  }
  EXPECT_FALSE(other.take_event(b));
  return n;
}

void expect_same_counts(const FieldCounts& reference, const FieldCounts& other) {
  EXPECT_EQ(other.rests, reference.rests);
  EXPECT_EQ(other.taken, reference.taken);
  EXPECT_EQ(other.updates, reference.updates);
  EXPECT_EQ(other.accel_updates, reference.accel_updates);
}

// Built without a magnetometer (MagCells 0, its model compiled out): on a life without one it
// decides exactly what the default build decides, frame by frame, in 2,800 B less; settings
// that enable a magnetometer are refused.
TEST(FieldCalibrator, BuiltWithoutAMagnetometerDecidesTheSameInLessMemory) {
  sim::LifePlan plan;
  sim::LifeOptions o;
  o.magnetometer = false;
  ASSERT_TRUE(sim::make_life("drone", 1, 8.0, o, plan));
  sim::LifeSimulator life(plan);
  const sim::DeviceSheet sheet = life.sheet();
  ASSERT_FALSE(sheet.has_mag);
  FieldCalibrator<float> full;
  FieldCalibrator<float, 8, 0> small;
  ASSERT_EQ(full.start(settings_for(sheet)), Status::kOk);
  ASSERT_EQ(small.start(settings_for(sheet)), Status::kOk);
  sim::LifeSample s;
  sim::LifeTruth t;
  RawFrame fr;
  std::size_t events = 0;
  while (life.next(s, t)) {
    fr = frame_of(s);
    const float temperature = s.temperature_new ? s.imu.temperature : kNaN;
    ASSERT_EQ(small.add_raw(fr, temperature), full.add_raw(fr, temperature));
    events += expect_same_events(full, small);
  }
  const FieldCounts& cf = full.counts();
  expect_same_counts(cf, small.counts());
  // Not a trivial agreement: both published the gyro's bias and the accelerometer's model.
  EXPECT_GT(events, 0u);
  EXPECT_GT(cf.updates, 0u);
  EXPECT_GT(cf.accel_updates, 0u);
  Vector3<float> bf, bs, sf, ss;
  float gf = 0.0f, gs = 0.0f;
  ASSERT_TRUE(full.gyro_bias(bf, &gf));
  ASSERT_TRUE(small.gyro_bias(bs, &gs));
  EXPECT_EQ(bs, bf);
  EXPECT_EQ(gs, gf);
  ASSERT_TRUE(full.accel_bias(bf, &sf));
  ASSERT_TRUE(small.accel_bias(bs, &ss));
  EXPECT_EQ(bs, bf);
  EXPECT_EQ(ss, sf);
  EXPECT_FALSE(small.mag_hard_iron(bs));
  // What docs/field.md and the README state, 7,984 B on the Arm cores, is 8,000 B on x86-64: the
  // magnetometer's model is 3,040 B of the default build's 11,040.
  EXPECT_LE(sizeof(small), 8000u);
  EXPECT_GE(sizeof(full) - sizeof(small), 3040u);
  // A magnetometer's scale set: this build has no model for it.
  FieldSettings<float> with_mag = settings_for(sheet);
  with_mag.mag.counts_per_ut = 10.0f;
  EXPECT_EQ(small.start(with_mag), Status::kInvalidArgument);
  EXPECT_EQ(small.add_raw(fr, kNaN), Status::kInvalidArgument);
  EXPECT_EQ(full.start(with_mag), Status::kOk);
}

// ---- The gyro's misalignment and scale from natural moves ----

// Built without the gyro's matrix (GyroMatrix false: its model and the moves the rest monitor
// keeps for it compiled out): from a protocol's record, where the default build walks the moves,
// it decides exactly what the default build decides with the matrix's learning turned off, frame
// by frame, in about 1,900 B less, keeps the stored matrix as it is, and saves and resumes
// through the record store like the default build.
TEST(FieldCalibrator, BuiltWithoutTheGyroMatrixDecidesTheSameInLessMemory) {
  sim::LifePlan plan;
  sim::LifeOptions o;
  o.magnetometer = false;
  ASSERT_TRUE(sim::make_life("drone", 1, 8.0, o, plan));
  sim::LifeSimulator life(plan);
  const sim::StoredCalibration prior = sim::protocol_record(life, 0.01, 0.02);
  const FieldSettings<float> settings = settings_for(life.sheet());
  FieldSettings<float> off = settings;
  off.gyro_matrix.enabled = false;
  static FieldCalibrator<float, 8, 0> learning, full;
  static FieldCalibrator<float, 8, 0, false> lean;
  ASSERT_EQ(learning.start(settings, &prior.cal, &prior.model), Status::kOk);
  ASSERT_EQ(full.start(off, &prior.cal, &prior.model), Status::kOk);
  ASSERT_EQ(lean.start(settings, &prior.cal, &prior.model), Status::kOk);  // enabled: ignored
  EXPECT_TRUE(learning.monitor().keeps_moves());
  EXPECT_FALSE(lean.monitor().keeps_moves());
  sim::LifeSample s;
  sim::LifeTruth t;
  std::size_t events = 0;
  while (life.next(s, t)) {
    const RawFrame fr = frame_of(s);
    const float temperature = s.temperature_new ? s.imu.temperature : kNaN;
    ASSERT_EQ(lean.add_raw(fr, temperature), full.add_raw(fr, temperature));
    learning.add_raw(fr, temperature);
    events += expect_same_events(full, lean);
    FieldEvent<float> e;
    while (learning.take_event(e)) {
    }
  }
  const FieldCounts& cf = full.counts();
  expect_same_counts(cf, lean.counts());
  EXPECT_EQ(lean.counts().gyro_moves, 0u);
  // Not a trivial agreement: the bias was published, and the default build walked the moves.
  EXPECT_GT(events, 0u);
  EXPECT_GT(cf.updates, 0u);
  EXPECT_GT(learning.counts().gyro_moves, 0u);
  Calibration<float> cal_full, cal_lean;
  TemperatureModel<float> model_full, model_lean;
  ASSERT_TRUE(full.calibration(cal_full, model_full));
  ASSERT_TRUE(lean.calibration(cal_lean, model_lean));
  EXPECT_EQ(cal_lean.gyro.params, cal_full.gyro.params);
  EXPECT_EQ(cal_lean.gyro.sigma, cal_full.gyro.sigma);
  EXPECT_EQ(cal_lean.accel.params, cal_full.accel.params);
  EXPECT_EQ(cal_lean.accel.sigma, cal_full.accel.sigma);
  // The stored matrix, kept as it is.
  EXPECT_EQ(cal_lean.gyro.params.head<kGyroMatrixParams>(),
            prior.cal.gyro.params.head<kGyroMatrixParams>());
  // What docs/field.md and the README state for the Arm cores holds on x86-64 too: 1,900 B less.
  EXPECT_GE(sizeof(full) - sizeof(lean), 1900u);
  // Saved and resumed through the record store as the default build is.
  using Flash = SimNorFlash<2048, 1024, 64>;
  static Flash flash;
  flash = Flash();
  RecordStore store(flash);
  lean.finish();
  bool saved = false;
  ASSERT_EQ(save_field(lean, store, 1u, 2u, &saved), Status::kOk);
  ASSERT_TRUE(saved);
  static FieldCalibrator<float, 8, 0, false> resumed;
  ASSERT_EQ(resume_field(resumed, settings, store), Status::kOk);
  Calibration<float> cal_resumed;
  TemperatureModel<float> model_resumed;
  ASSERT_TRUE(resumed.calibration(cal_resumed, model_resumed));
  for (int i = 0; i < kGyroMatrixParams; ++i)
    EXPECT_FLOAT_EQ(cal_resumed.gyro.params(i), cal_lean.gyro.params(i)) << i;
  Vector3<float> b;
  ASSERT_TRUE(resumed.gyro_bias(model_lean.reference_c, b));
  for (int i = 0; i < 3; ++i) EXPECT_FLOAT_EQ(b(i), cal_lean.gyro.params(kGyroBiasX + i)) << i;
}

struct GyroMatrixRun {
  GyroVector<double> truth = GyroVector<double>::Zero();
  GyroVector<float> start = GyroVector<float>::Zero(), end = GyroVector<float>::Zero();
  GyroVector<float> start_sigma = GyroVector<float>::Zero(), end_sigma = GyroVector<float>::Zero();
  FieldCounts counts{};
  // The largest |error| / sigma of a publication, over the nine parameters and every one.
  double worst_z = 0.0;
  double change_s = -1.0;  // when the first change of the matrix was found (s into the life)
  // The largest relative scale error and misalignment error (rad) of a matrix.
  double scale_error(const GyroVector<float>& p) const {
    double e = 0.0;
    for (int i = kGyroScaleX; i <= kGyroScaleZ; ++i)
      e = std::max(e, std::fabs(static_cast<double>(p(i)) / truth(i) - 1.0));
    return e;
  }
  double misalignment_error(const GyroVector<float>& p) const {
    double e = 0.0;
    for (int i = 0; i < kGyroScaleX; ++i)
      e = std::max(e, std::fabs(static_cast<double>(p(i)) - truth(i)));
    return e;
  }
  double scale_error() const { return scale_error(end); }
  double misalignment_error() const { return misalignment_error(end); }
};

GyroMatrixRun run_gyro_matrix(const char* name, double hours, std::uint64_t seed, double off,
                              double sigma) {
  sim::LifePlan plan;
  EXPECT_TRUE(sim::make_life(name, seed, hours, {}, plan));
  sim::LifeSimulator life(plan);
  const sim::StoredCalibration prior = sim::protocol_record(life, off, sigma);
  FieldCalibrator<float> f;
  EXPECT_EQ(f.start(settings_for(life.sheet()), &prior.cal, &prior.model), Status::kOk);
  GyroMatrixRun r;
  r.truth = life.imu_truth().gyro.params;
  r.start = prior.cal.gyro.params;
  r.start_sigma = prior.cal.gyro.sigma;
  sim::LifeSample s;
  sim::LifeTruth t;
  while (feed_next(life, f, s, t)) {
    FieldEvent<float> e;
    while (f.take_event(e)) {
      if (e.sensor == FieldSensor::kGyroMatrix && e.kind == FieldEventKind::kChangeDetected &&
          r.change_s < 0.0)
        r.change_s = e.time_s;
      if (e.sensor != FieldSensor::kGyroMatrix || e.kind != FieldEventKind::kUpdated) continue;
      const GyroField<float>& g = f.gyro_field();
      const GyroField<float>::Vector sd = g.published_sigmas();
      for (int i = 0; i < kGyroMatrixParams; ++i) {
        const double z =
            (static_cast<double>(g.published()(i)) - r.truth(i)) / static_cast<double>(sd(i));
        r.worst_z = std::max(r.worst_z, std::fabs(z));
      }
    }
  }
  f.finish();
  Calibration<float> cal;
  TemperatureModel<float> model;
  f.calibration(cal, model);
  r.end = cal.gyro.params;
  r.end_sigma = cal.gyro.sigma;
  r.counts = f.counts();
  return r;
}

void print(const char* what, std::uint64_t seed, const GyroMatrixRun& r) {
  std::printf(
      "[ gyro matrix %s seed %d ] %u moves, %u refused, %u updates, %u changes: scale %.1e, "
      "misalignment %.1e rad from the truth (from %.0e, %.0e), worst publication %.2f "
      "sigma\n",
      what, static_cast<int>(seed), static_cast<unsigned>(r.counts.gyro_moves),
      static_cast<unsigned>(r.counts.gyro_moves_refused),
      static_cast<unsigned>(r.counts.gyro_matrix_updates),
      static_cast<unsigned>(r.counts.gyro_matrix_changes), r.scale_error(), r.misalignment_error(),
      r.scale_error(r.start), r.misalignment_error(r.start), r.worst_z);
}

// From a gyro matrix 1 % (scales) and 10 mrad (misalignments) off the truth with a datasheet's
// sigmas (2 %, 20 mrad), the moves between natural rests over a day learn it: on a desk and on a
// drone the scales within 0.3 % and the misalignments within 5 mrad; in the hand, whose rests are
// short and its moves long, less (no worse than the prior); every publication within 3 sigma of
// the truth (no false update), each stated sigma no larger than the prior's.
TEST(FieldLife, GyroMatrixLearnedFromNaturalMoves) {
  struct Life {
    const char* name;
    double scale, misalignment;  // the largest errors allowed at the end
  };
  for (const Life& life :
       {Life{"desk", 0.003, 0.005}, Life{"drone", 0.003, 0.005}, Life{"handheld", 0.01, 0.01}}) {
    for (std::uint64_t seed : {1u, 2u}) {
      const char* name = life.name;
      const GyroMatrixRun r = run_gyro_matrix(name, 24.0, seed, 0.01, 0.02);
      print(name, seed, r);
      EXPECT_GT(r.counts.gyro_moves, 5u) << name << " seed " << seed;
      EXPECT_GT(r.counts.gyro_matrix_updates, 0u) << name << " seed " << seed;
      EXPECT_LT(r.worst_z, 3.0) << name << " seed " << seed;
      EXPECT_EQ(r.counts.gyro_matrix_changes, 0u) << name << " seed " << seed;
      EXPECT_LT(r.scale_error(), life.scale) << name << " seed " << seed;
      EXPECT_LT(r.misalignment_error(), life.misalignment) << name << " seed " << seed;
      for (int i = 0; i < kGyroMatrixParams; ++i)
        EXPECT_LE(r.end_sigma(i), r.start_sigma(i)) << name << " seed " << seed << " " << i;
    }
  }
}

// The rest monitor keeps the moves only while they can teach the gyro's matrix: with an
// accelerometer known well (a protocol's record), not from the datasheet's tolerances, not when
// the gyro's matrix is not learned.
TEST(FieldCalibrator, MovesAreKeptOnlyWithAWellKnownAccelerometer) {
  sim::LifePlan plan;
  ASSERT_TRUE(sim::make_life("desk", 1, 0.1, {}, plan));
  sim::LifeSimulator life(plan);
  const sim::StoredCalibration prior = sim::protocol_record(life, 0.01, 0.02);
  FieldSettings<float> s = settings_for(life.sheet());
  FieldCalibrator<float> f;
  ASSERT_EQ(f.start(s), Status::kOk);
  EXPECT_FALSE(f.monitor().keeps_moves());
  ASSERT_EQ(f.start(s, &prior.cal, &prior.model), Status::kOk);
  EXPECT_TRUE(f.monitor().keeps_moves());
  s.gyro_matrix.enabled = false;
  ASSERT_EQ(f.start(s, &prior.cal, &prior.model), Status::kOk);
  EXPECT_FALSE(f.monitor().keeps_moves());
}

// A vehicle's moves are turns about the vertical in a cradle: they teach little, and nothing
// false.
TEST(FieldLife, GyroMatrixMakesNoFalseUpdateInAVehicle) {
  const GyroMatrixRun r = run_gyro_matrix("vehicle", 24.0, 1, 0.01, 0.02);
  print("vehicle", 1, r);
  EXPECT_LT(r.worst_z, 3.0);
  EXPECT_EQ(r.counts.gyro_matrix_changes, 0u);
  EXPECT_LE(r.scale_error(), 0.0101);
}

// Started from the right matrix with a protocol's sigmas, the moves change nothing beyond them.
TEST(FieldLife, GyroMatrixTheRightPriorIsKept) {
  const GyroMatrixRun r = run_gyro_matrix("desk", 24.0, 1, 0.0, 5e-4);
  print("desk, right prior", 1, r);
  EXPECT_GT(r.counts.gyro_moves, 5u);
  EXPECT_LT(r.worst_z, 3.0);
  for (int i = 0; i < kGyroMatrixParams; ++i)
    EXPECT_LT(std::fabs(r.end(i) - r.start(i)), 2.0f * r.start_sigma(i)) << kGyroParamNames[i];
}

// The stored matrix is wrong far beyond its sigma (the board bent by a knock, or remounted: 1.5 %
// and 15 mrad against a protocol's 5e-4): every informative move is refused, and once five of
// them within ten agree on one new matrix, the change is found and that matrix published; the
// moves after it refine it as from a datasheet's prior. Never on the lives whose matrix is right
// or merely uncertain (the tests above).
TEST(FieldLife, GyroMatrixAChangeIsFoundAndLearned) {
  for (const char* name : {"desk", "drone"}) {
    for (std::uint64_t seed : {1u, 2u}) {
      const GyroMatrixRun r = run_gyro_matrix(name, 24.0, seed, 0.015, 5e-4);
      print(name, seed, r);
      std::printf("[ gyro matrix %s seed %d ] change found after %.1f h\n", name,
                  static_cast<int>(seed), r.change_s / 3600.0);
      EXPECT_EQ(r.counts.gyro_matrix_changes, 1u) << name << " seed " << seed;
      EXPECT_LT(r.worst_z, 3.0) << name << " seed " << seed;
      EXPECT_LT(r.scale_error(), 0.003) << name << " seed " << seed;
      EXPECT_LT(r.misalignment_error(), 0.006) << name << " seed " << seed;
    }
  }
}

// The refused moves that prove a change are kept in fixed room: a setting asking for more than
// that room, or for a single move, is refused, and nothing is taken.
TEST(GyroField, ChangeMovesBeyondItsRoomAreRefused) {
  GyroField<float> g;
  GyroFieldSettings<float> s;
  const GyroField<float>::Vector prior =
      (GyroField<float>::Vector() << 0, 0, 0, 0, 0, 0, 1, 1, 1).finished();
  const GyroField<float>::Vector sigma = GyroField<float>::Vector::Constant(0.01f);
  EXPECT_EQ(g.start(s, prior, sigma), Status::kOk);
  EXPECT_TRUE(g.enabled());
  for (int n : {1, kChangeMoves + 1}) {
    s.change_moves = n;
    EXPECT_EQ(g.start(s, prior, sigma), Status::kInvalidArgument) << n;
    EXPECT_FALSE(g.enabled()) << n;
  }
  s.change_moves = kChangeMoves;
  EXPECT_EQ(g.start(s, prior, sigma), Status::kOk);
  EXPECT_EQ(g.changes(), 0u);
}

// ---- Saved and resumed ----

using Flash = SimNorFlash<2048, 1024, 64>;  // two slots of one 1 KB erase unit

// A desk life through the calibrator, saving as the budget allows; stops once a save is due
// after `saves` saves (then the calibrator holds an unsaved publication), or at the life's end.
struct Saving {
  FieldCalibrator<float> field;
  std::uint32_t saves = 0;
  double first_save_s = -1.0;
  Calibration<float> last_saved{};  // what the last save wrote
  TemperatureModel<float> last_model{};
  MagCalibration<float> last_mag{};
  bool saved_mag = false;
};

void run_saving(Saving& r, Flash& flash, double hours, std::uint32_t stop_after_saves,
                float interval_s) {
  sim::LifePlan plan;
  ASSERT_TRUE(sim::make_life("desk", 3, hours, {}, plan));
  sim::LifeSimulator life(plan);
  FieldSettings<float> settings = settings_for(life.sheet());
  settings.save_interval_s = interval_s;
  ASSERT_EQ(r.field.start(settings), Status::kOk);
  RecordStore store(flash);
  sim::LifeSample s;
  sim::LifeTruth t;
  while (feed_next(life, r.field, s, t)) {
    if (r.saves >= stop_after_saves && r.field.save_due()) return;
    bool saved = false;
    ASSERT_EQ(save_field(r.field, store, 7u, 0x6A68u, &saved), Status::kOk);
    if (!saved) continue;
    if (r.first_save_s < 0.0) r.first_save_s = s.t_s;
    ++r.saves;
    ASSERT_TRUE(r.field.calibration(r.last_saved, r.last_model));
    r.saved_mag = r.field.mag_calibration(r.last_mag);
  }
}

TEST(FieldStore, SavesWithinTheWearBudgetAndResumesWhereItStopped) {
  static Flash flash;
  flash = Flash();
  static Saving r;
  r = Saving{};
  run_saving(r, flash, 30.0, 1000u, 1800.0f);
  // Publications come every few minutes; saves at most 5 a day, 30 min apart, none in the first
  // 30 min after start.
  EXPECT_GE(r.first_save_s, 1800.0);
  EXPECT_GE(r.saves, 5u);
  EXPECT_LE(r.saves, 10u);  // 30 h: one day's 5, then at most 5 more
  EXPECT_EQ(r.field.counts().saves, r.saves);
  // A reboot: the calibrator resumes from the last record saved.
  RecordStore store(flash);
  static FieldCalibrator<float> resumed;
  CalibrationRecord loaded;
  ASSERT_EQ(resume_field(resumed, r.field.settings(), store, &loaded), Status::kOk);
  ASSERT_TRUE(resumed.published());
  ASSERT_TRUE(loaded.parts & kRecordTemperature) << "the temperature model was left out";
  EXPECT_EQ(loaded.temperature.order, 2);
  const float t0 = r.last_model.reference_c;
  Vector3<float> b;
  float sigma = 0.0f;
  ASSERT_TRUE(resumed.gyro_bias(t0, b, &sigma));
  for (int i = 0; i < 3; ++i) EXPECT_FLOAT_EQ(b(i), r.last_saved.gyro.params(kGyroBiasX + i));
  EXPECT_NEAR(sigma, r.last_saved.gyro.sigma(kGyroBiasX), 1e-6f);
  // The model and its range: the same bias at another temperature the model saw.
  const float t1 = 0.5f * (r.last_model.min_c + r.last_model.max_c) + 2.0f;
  ASSERT_TRUE(resumed.gyro_bias(t1, b));
  const Vector3<float> expected = r.last_model.gyro.at(t1, t0);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(b(i), expected(i), 1e-3f) << i;
  // The stored range is the temperatures seen plus the margin: resumed, the calibrator would
  // store the same range again, reboot after reboot, not one margin wider each time.
  ASSERT_LT(loaded.temperature.min_c, loaded.temperature.max_c);
  Calibration<float> again;
  TemperatureModel<float> again_model;
  ASSERT_TRUE(resumed.calibration(again, again_model));
  EXPECT_NEAR(again_model.min_c, loaded.temperature.min_c, 1e-4f);
  EXPECT_NEAR(again_model.max_c, loaded.temperature.max_c, 1e-4f);
  static FieldCalibrator<float> second;
  ASSERT_EQ(second.start(r.field.settings(), &again, &again_model), Status::kOk);
  Calibration<float> third;
  TemperatureModel<float> third_model;
  ASSERT_TRUE(second.calibration(third, third_model));
  EXPECT_NEAR(third_model.min_c, loaded.temperature.min_c, 1e-4f);
  EXPECT_NEAR(third_model.max_c, loaded.temperature.max_c, 1e-4f);
  // The magnetometer's published calibration went in, and comes back as the resumed one's.
  ASSERT_TRUE(r.saved_mag);
  ASSERT_TRUE(loaded.parts & kRecordMag);
  MagCalibration<float> mag;
  ASSERT_TRUE(resumed.mag_calibration(mag));
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(mag.hard_iron(i), r.last_mag.hard_iron(i), 1e-3f);
  EXPECT_LT((mag.soft_iron - r.last_mag.soft_iron).norm(), 1e-5f * r.last_mag.soft_iron.norm());
  EXPECT_FLOAT_EQ(mag.field_ut, r.last_mag.field_ut);
}

TEST(FieldStore, APowerCutAtEveryStepOfASaveLosesNothingSaved) {
  static Flash base_flash;
  base_flash = Flash();
  static Saving r;
  r = Saving{};
  run_saving(r, base_flash, 12.0, 2u, 600.0f);  // two saves, then one due
  ASSERT_EQ(r.saves, 2u);
  ASSERT_TRUE(r.field.save_due());
  Calibration<float> next;
  TemperatureModel<float> next_model;
  ASSERT_TRUE(r.field.calibration(next, next_model));
  static Flash flash;
  static FieldCalibrator<float> field, resumed;
  int completed = 0;
  for (std::uint32_t n = 0; n < 4000u && completed == 0; ++n) {
    flash = base_flash;
    field = r.field;
    flash.cut_power_after(n);
    RecordStore store(flash);
    bool saved = false;
    const Status s = save_field(field, store, 7u, 0x6A68u, &saved);
    if (s == Status::kOk) {
      ASSERT_TRUE(saved);
      ++completed;
    } else {
      EXPECT_TRUE(field.unsaved()) << n;  // still to be saved: nothing lost in RAM either
    }
    flash.power_on();
    RecordStore after(flash);
    ASSERT_EQ(resume_field(resumed, r.field.settings(), after), Status::kOk) << n;
    Vector3<float> b;
    ASSERT_TRUE(resumed.gyro_bias(kNaN, b)) << n;
    const bool old_one = b(0) == r.last_saved.gyro.params(kGyroBiasX);
    const bool new_one = b(0) == next.gyro.params(kGyroBiasX);
    EXPECT_TRUE(old_one || new_one) << n;
    if (s == Status::kOk) {
      EXPECT_TRUE(new_one) << n;
    }
  }
  EXPECT_EQ(completed, 1);
}

TEST(FieldStore, CorruptedRecordsLeaveTheNominalPriorAndSayWhy) {
  static Flash flash;
  flash = Flash();
  static Saving r;
  r = Saving{};
  run_saving(r, flash, 6.0, 2u, 600.0f);
  ASSERT_EQ(r.saves, 2u);
  for (std::uint32_t at : {40u, 1024u + 40u}) flash.raw()[at] ^= 0x10u;  // both records
  RecordStore store(flash);
  static FieldCalibrator<float> resumed;
  const Status s = resume_field(resumed, r.field.settings(), store);
  EXPECT_NE(s, Status::kOk);
  EXPECT_FALSE(resumed.published());
  // It runs on from the nominal prior.
  ImuSample<float> x;
  x.acc = Vector3<float>(0, 0, 4096);
  EXPECT_EQ(resumed.add(x), Status::kOk);
}

// ---- Faults in a running calibrator: time, clock resets, priors, temperatures, readings ----

// A device at 100 Hz in raw counts (the gyro 940 per rad/s, the accelerometer 4096 per g) whose
// gyro reads the bias negated plus its noise: at rest with gravity along `up` (turning about x
// at tilt_rate rad/s from tilt_from_us on), or moving.
struct Frames {
  sim::Random rng{11};
  std::uint32_t t = 1000000;
  Eigen::Vector3d bias = Eigen::Vector3d(10.0, -5.0, 3.0);  // added to a reading
  Eigen::Vector3d up = Eigen::Vector3d(0.0, 0.0, 1.0);
  double tilt_rate = 0.0;
  std::uint32_t tilt_from_us = 0;
  int k = 0;

  static std::int16_t count(double x) { return static_cast<std::int16_t>(std::lround(x)); }
  RawFrame rest() {
    RawFrame f;
    f.t_us = t;
    const double th = tilt_rate * 1e-6 * static_cast<double>(t - tilt_from_us);
    const double a[3] = {up(0), up(1) * std::cos(th) + up(2) * std::sin(th),
                         up(2) * std::cos(th) - up(1) * std::sin(th)};
    for (int i = 0; i < 3; ++i) {
      f.acc[i] = count(4096.0 * a[i] + 5.8 * rng.normal());
      f.gyro[i] = count(-bias(i) + (i == 0 ? tilt_rate * 940.0 : 0.0) + 1.15 * rng.normal());
    }
    next();
    return f;
  }
  RawFrame move() {
    RawFrame f;
    f.t_us = t;
    const double ph = 0.02 * k;
    for (int i = 0; i < 3; ++i) {
      f.acc[i] = count(2000.0 * std::sin(ph + i) + 4096.0 * up(i) + 30.0 * rng.normal());
      f.gyro[i] = count(800.0 * std::cos(1.3 * ph + i) - bias(i));
    }
    next();
    return f;
  }
  void next() {
    t += 10000;
    ++k;
  }
};

bool taken(Status s) { return s == Status::kOk || sample_taken(s); }

FieldSettings<float> fault_settings() {
  FieldSettings<float> s = plain_settings();
  s.accel_min = s.gyro_min = -32768.0f;  // a reading of 32767 is at full scale
  s.accel_max = s.gyro_max = 32767.0f;
  return s;
}

// Rests of 12 s and moves of 2 s, each frame with the temperature (NaN: none), until the first
// publication (true) or the cycles run out.
bool until_published(FieldCalibrator<float>& f, Frames& g, float temperature, int cycles = 20) {
  for (int c = 0; c < cycles; ++c) {
    for (int i = 0; i < 1400; ++i) {
      const Status st = f.add_raw(i < 1200 ? g.rest() : g.move(), temperature);
      EXPECT_TRUE(taken(st)) << to_string(st);
      if (f.published()) return true;
    }
  }
  return false;
}

// The monitor starts again at the first publication (the detector then takes the gyro as a
// cue): a frame behind the latest is still refused, and the clock does not jump.
TEST(FieldFaults, AFrameBehindIsRefusedRightAfterTheFirstPublication) {
  static FieldCalibrator<float> f;
  ASSERT_EQ(f.start(fault_settings()), Status::kOk);
  Frames g;
  ASSERT_TRUE(until_published(f, g, kNaN));
  const float seconds = f.seconds();
  RawFrame behind = g.rest();
  behind.t_us -= 50000;  // 40 ms behind the latest frame taken
  EXPECT_EQ(f.add_raw(behind), Status::kTimeBackwards);
  EXPECT_EQ(f.seconds(), seconds);
  for (int i = 0; i < 10; ++i) EXPECT_TRUE(taken(f.add_raw(g.rest())));
  EXPECT_NEAR(f.seconds(), seconds + 0.11f, 0.0015f);  // ten frames after the one refused
}

// The stream's counts are the whole stream's: the monitor's restart at the first publication
// keeps them, and a clock reset after it is counted as one and adds no time.
TEST(FieldFaults, TheStreamCountsGoOnThroughTheFirstPublication) {
  static FieldCalibrator<float> f;
  ASSERT_EQ(f.start(fault_settings()), Status::kOk);
  Frames g;
  for (int i = 0; i < 100; ++i) ASSERT_TRUE(taken(f.add_raw(g.rest())));
  RawFrame same = g.rest();
  ASSERT_TRUE(taken(f.add_raw(same)));
  EXPECT_EQ(f.add_raw(same), Status::kTimeRepeated);
  g.t -= 50000;  // frames behind the latest: two refused, the third resynchronises
  for (int i = 0; i < 2; ++i) EXPECT_EQ(f.add_raw(g.rest()), Status::kTimeBackwards);
  EXPECT_EQ(f.add_raw(g.rest()), Status::kClockReset);
  ASSERT_TRUE(until_published(f, g, kNaN));
  EXPECT_EQ(f.monitor().samples_refused(), 3u);
  EXPECT_EQ(f.monitor().stream_counts().time_repeated, 1u);
  EXPECT_EQ(f.monitor().stream_counts().time_backwards, 2u);
  EXPECT_EQ(f.monitor().stream_counts().clock_resets, 1u);
  const float seconds = f.seconds();
  g.t -= 3000000;  // the clock starts again 3 s back
  for (int i = 0; i < 2; ++i) EXPECT_EQ(f.add_raw(g.rest()), Status::kTimeBackwards);
  EXPECT_EQ(f.add_raw(g.rest()), Status::kClockReset);
  for (int i = 0; i < 10; ++i) EXPECT_TRUE(taken(f.add_raw(g.rest())));
  EXPECT_EQ(f.monitor().samples_refused(), 5u);
  EXPECT_EQ(f.monitor().stream_counts().clock_resets, 2u);
  EXPECT_NEAR(f.seconds(), seconds + 0.1f, 0.015f);
}

// A save the flash fails (a worn sector) counts against the wear budget: calling save_field()
// again writes nothing until the interval has passed, then the publication is saved.
TEST(FieldStore, AFailedSaveWaitsItsTurnInTheWearBudget) {
  static FieldCalibrator<float> f;
  FieldSettings<float> settings = plain_settings();
  settings.save_interval_s = 60.0f;
  ASSERT_EQ(f.start(settings), Status::kOk);
  Frames g;
  ASSERT_TRUE(until_published(f, g, kNaN));
  for (int i = 0; i < 10000 && !f.save_due(); ++i) ASSERT_TRUE(taken(f.add_raw(g.rest())));
  ASSERT_TRUE(f.save_due());
  static Flash flash;
  flash = Flash();
  flash.cut_power_after(100);  // the flash fails within the save
  RecordStore store(flash);
  bool saved = true;
  const Status failed = save_field(f, store, 7u, 0x6A68u, &saved);
  EXPECT_TRUE(failed == Status::kStorageError || failed == Status::kStorageVerifyFailed)
      << to_string(failed);
  EXPECT_FALSE(saved);
  EXPECT_TRUE(f.unsaved());
  EXPECT_FALSE(f.save_due());
  flash.power_on();
  RecordStore again(flash);
  const std::uint32_t ops = flash.byte_operations();
  for (int i = 0; i < 5900; ++i) {  // 59 s: not its turn yet
    EXPECT_EQ(save_field(f, again, 7u, 0x6A68u, &saved), Status::kOk);
    EXPECT_FALSE(saved);
    EXPECT_TRUE(taken(f.add_raw(g.rest())));
  }
  EXPECT_EQ(flash.byte_operations(), ops);  // nothing erased or written meanwhile
  for (int i = 0; i < 200 && !f.save_due(); ++i) EXPECT_TRUE(taken(f.add_raw(g.rest())));
  ASSERT_TRUE(f.save_due());
  EXPECT_EQ(save_field(f, again, 7u, 0x6A68u, &saved), Status::kOk);
  EXPECT_TRUE(saved);
  EXPECT_FALSE(f.unsaved());
  EXPECT_EQ(f.counts().saves, 1u);
  CalibrationRecord loaded;
  EXPECT_EQ(again.load(loaded), Status::kOk);
}

// The sensor's clock starts again: three frames behind it make a clock reset, and the time
// between is not counted, whether the frame that makes it is taken with the accelerometer at
// full scale or refused with the gyro at full scale.
TEST(FieldFaults, AClockResetAddsNoTimeWhateverElseItsFrameSays) {
  for (int variant = 0; variant < 3; ++variant) {  // plain, accelerometer, gyro at full scale
    static FieldCalibrator<float> f;
    ASSERT_EQ(f.start(fault_settings()), Status::kOk);
    Frames g;
    for (int i = 0; i < 2000; ++i) ASSERT_TRUE(taken(f.add_raw(g.rest())));
    const float seconds = f.seconds();
    g.t = 5000;
    Status st[3];
    for (int i = 0; i < 3; ++i) {
      RawFrame fr = g.move();
      if (i == 2 && variant == 1) fr.acc[0] = 32767;
      if (i == 2 && variant == 2) fr.gyro[0] = 32767;
      st[i] = f.add_raw(fr);
    }
    EXPECT_EQ(st[0], Status::kTimeBackwards) << variant;
    EXPECT_EQ(st[1], Status::kTimeBackwards) << variant;
    EXPECT_EQ(st[2], variant == 2 ? Status::kGyroSaturated : Status::kClockReset) << variant;
    for (int i = 0; i < 10; ++i) EXPECT_TRUE(taken(f.add_raw(g.move())));
    EXPECT_EQ(f.monitor().stream_counts().clock_resets, 1u);
    EXPECT_EQ(f.monitor().stream_counts().accel_saturated, variant == 1 ? 1u : 0u);
    EXPECT_NEAR(f.seconds(), seconds + 0.1f, 0.015f) << variant;
  }
}

// A rest whose gravity turns (2 mrad/s about x) is refused as turning, whether a gap or a clock
// reset ends it: the rests a reset ends are placed on the clock they were timed with.
TEST(FieldFaults, ARestAClockResetEndsIsJudgedAsOneAGapEnds) {
  FieldCounts counts[2];
  for (int variant = 0; variant < 2; ++variant) {  // a gap, a clock reset
    static FieldCalibrator<float> f;
    ASSERT_EQ(f.start(fault_settings()), Status::kOk);
    Frames g;
    for (int i = 0; i < 200; ++i) f.add_raw(g.move());
    g.tilt_rate = 2e-3;
    g.tilt_from_us = g.t;
    for (int i = 0; i < 900; ++i) ASSERT_TRUE(taken(f.add_raw(g.rest())));
    g.tilt_rate = 0.0;
    g.t = variant == 0 ? g.t + 3000000u : 5000u;
    for (int i = 0; i < 203; ++i) f.add_raw(g.move());
    counts[variant] = f.counts();
  }
  EXPECT_GT(counts[0].rests, 0u);
  EXPECT_EQ(counts[0].taken, 0u);
  EXPECT_GT(counts[0].turning, 0u);
  EXPECT_EQ(counts[1].rests, counts[0].rests);
  EXPECT_EQ(counts[1].taken, counts[0].taken);
  EXPECT_EQ(counts[1].turning, counts[0].turning);
}

// A stored calibration that states a sigma beyond the settings' nominal one (a corrupted record
// that passed its checks: finite, but squared beyond a float) starts from the nominal sigma, and
// the filter learns the bias as from the nominal prior.
TEST(FieldFaults, AStoredSigmaBeyondTheNominalOneGivesWayToIt) {
  const FieldSettings<float> settings = fault_settings();
  Frames g;
  Calibration<float> prior;
  prior.gyro.status = Status::kOk;
  prior.gyro.params.segment<3>(kGyroScaleX).setConstant(1.0f / 940.0f);
  prior.gyro.params.tail<3>() = g.bias.cast<float>();
  prior.gyro.sigma.setConstant(1e20f);
  prior.has_temperature = true;
  prior.temperature_c = 25.0f;
  static FieldCalibrator<float> f;
  ASSERT_EQ(f.start(settings, &prior), Status::kOk);
  Vector3<float> b;
  float sigma = 0.0f;
  ASSERT_TRUE(f.gyro_bias(25.0f, b, &sigma));
  EXPECT_FLOAT_EQ(sigma, settings.bias_sigma * settings.gyro_per_rad_s);
  for (int c = 0; c < 4; ++c)
    for (int i = 0; i < 1400; ++i) ASSERT_TRUE(taken(f.add_raw(i < 1200 ? g.rest() : g.move())));
  EXPECT_TRUE(f.filter().finite());
  ASSERT_TRUE(f.gyro_bias(25.0f, b, &sigma));
  ASSERT_TRUE(std::isfinite(sigma));
  EXPECT_LT(sigma, 0.2f);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(b(i), g.bias(i), 5.0f * sigma) << i;
  Calibration<float> cal;
  TemperatureModel<float> model;
  f.calibration(cal, model);
  EXPECT_TRUE(all_finite(cal.gyro.params));
  EXPECT_TRUE(all_finite(cal.gyro.sigma));
  EXPECT_LE(cal.gyro.sigma(0), settings.gyro_matrix.misalignment_sigma);
}

// The bias asked for at an infinite or absurd temperature: clamped to what the model saw, with
// an infinite sigma (its variance grows with the distance), never a NaN.
TEST(FieldFaults, AtAnAbsurdTemperatureTheSigmaIsInfiniteNotANaN) {
  const float inf = std::numeric_limits<float>::infinity();
  BiasFilter<float> linear;  // the curvature's variance 0: inf * 0 would be a NaN
  linear.start(Vector3<float>::Zero(), 1.0f, Vector3<float>::Zero(), 0.1f, Vector3<float>::Zero(),
               0.0f, 25.0f);
  for (float t : {inf, -inf, 1e20f, -1e20f}) EXPECT_EQ(linear.variance_at(t), inf) << t;
  EXPECT_FLOAT_EQ(linear.variance_at(kNaN), 1.0f);  // no temperature: at the reference
  EXPECT_TRUE(std::isfinite(linear.variance_at(4000.0f)));

  FieldSettings<float> settings = fault_settings();
  settings.accel.accel_per_m_s2 = 4096.0f / 9.80665f;
  static FieldCalibrator<float> f;
  ASSERT_EQ(f.start(settings), Status::kOk);
  Frames g;
  ASSERT_TRUE(until_published(f, g, 25.0f));
  for (float t : {inf, -inf, 1e20f}) {
    Vector3<float> b, as;
    float sigma = 0.0f;
    EXPECT_TRUE(f.gyro_bias(t, b, &sigma));
    EXPECT_TRUE(all_finite(b)) << t;
    EXPECT_EQ(sigma, inf) << t;
    f.accel_bias(t, b, &as);
    EXPECT_TRUE(all_finite(b)) << t;
    for (int i = 0; i < 3; ++i) EXPECT_EQ(as(i), inf) << t;
  }
}

// A temperature sensor that fails (NaN, or a reading out of range) after the model learned its
// slope over 20 to 40 deg C: its rests are not taken for rests at the reference temperature
// (a change of the bias), the published bias at the last temperature stays right, and the
// refusals say why.
TEST(FieldFaults, ATemperatureSensorThatFailsLeavesTheModelRight) {
  const Eigen::Vector3d b25(10.0, -5.0, 3.0), slope(0.5, -0.4, 0.3);
  const double faces[6][3] = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}};
  for (float failed : {kNaN, 500.0f}) {
    static FieldCalibrator<float> f;
    ASSERT_EQ(f.start(fault_settings()), Status::kOk);
    Frames g;
    float t = 25.0f;
    const auto cycle = [&](float reading) {
      for (int i = 0; i < 1400; ++i)
        ASSERT_TRUE(taken(f.add_raw(i < 1200 ? g.rest() : g.move(), reading)));
    };
    for (int c = 0; c < 42; ++c) {
      t = 20.0f + static_cast<float>(c % 21);
      g.bias = b25 + slope * static_cast<double>(t - 25.0f);
      g.up = Eigen::Vector3d(faces[c % 6][0], faces[c % 6][1], faces[c % 6][2]);
      cycle(t);
    }
    ASSERT_TRUE(f.published());
    const std::uint32_t changes = f.counts().changes;
    for (int c = 0; c < 20; ++c) cycle(failed);  // the device stays at 40 deg C
    Vector3<float> b;
    float sigma = 0.0f;
    ASSERT_TRUE(f.gyro_bias(t, b, &sigma));
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(b(i), g.bias(i), 5.0f * sigma) << i;
    EXPECT_EQ(f.counts().changes, changes);
    EXPECT_GT(f.counts().no_temperature, 0u);
    EXPECT_NEAR(f.temperature(), t, 1.0f);  // the last smoothed one stays
  }
}

// A FIFO batch whose first frame is refused: its temperature goes with the first frame taken.
TEST(FieldFaults, AFifoBatchWhoseFirstFrameIsRefusedKeepsItsTemperature) {
  static FieldCalibrator<float> f;
  ASSERT_EQ(f.start(fault_settings()), Status::kOk);
  Frames g;
  const FifoLayout layout;
  constexpr std::uint32_t kBatch = 25;
  std::uint8_t bytes[kBatch * 12] = {};
  std::uint32_t stamps[kBatch] = {};
  std::uint32_t last = 0;
  for (std::uint32_t batch = 0; batch < 40; ++batch) {
    for (std::uint32_t k = 0; k < kBatch; ++k) {
      RawFrame fr = g.rest();
      if (batch > 0 && k == 0) fr.t_us = last;  // the previous batch's last frame again
      test::put_fifo_frame(bytes, k, layout, fr);
      stamps[k] = fr.t_us;
    }
    last = stamps[kBatch - 1];
    FifoTiming timing;
    timing.t_us = stamps;
    Status got[kBatch];
    const FifoResult r = f.add_fifo(bytes, kBatch, layout, timing, 30.0f, got);
    EXPECT_EQ(got[0], batch > 0 ? Status::kTimeRepeated : Status::kOk) << batch;
    EXPECT_EQ(r.taken, batch > 0 ? kBatch - 1 : kBatch);
  }
  ASSERT_FALSE(f.published());  // no restart of the monitor: its count is every reading's
  EXPECT_EQ(f.monitor().temperatures().count(), 40u);
}

// A magnetometer reading beyond any field the settings allow (a saturated sensor) is refused,
// and does not hide the turn about the vertical the field shows in the rest around it.
TEST(FieldFaults, AMagnetometerReadingBeyondAnyFieldIsRefused) {
  FieldCalibrator<float> unstarted;
  EXPECT_EQ(unstarted.add_mag(Vector3<float>(200.0f, 0.0f, -450.0f)), Status::kInvalidArgument);
  FieldSettings<float> settings = fault_settings();
  settings.mag.counts_per_ut = 10.0f;
  FieldCounts counts[2];
  for (int variant = 0; variant < 2; ++variant) {  // clean, one reading at full scale
    static FieldCalibrator<float> f;
    ASSERT_EQ(f.start(settings), Status::kOk);
    Frames g;
    for (int i = 0; i < 200; ++i) f.add_raw(g.move());
    const double rate = 0.02;  // rad/s about the vertical: the gyro reads it as a bias
    const std::uint32_t t0 = g.t;
    for (int i = 0; i < 900; ++i) {
      RawFrame fr = g.rest();
      fr.gyro[2] = static_cast<std::int16_t>(fr.gyro[2] + std::lround(rate * 940.0));
      ASSERT_TRUE(taken(f.add_raw(fr)));
      if (i % 10 == 0) {  // 10 Hz
        const double a = rate * 1e-6 * static_cast<double>(fr.t_us - t0);
        Vector3<float> m(static_cast<float>(200.0 * std::cos(a) + 3.0 * g.rng.normal()),
                         static_cast<float>(-200.0 * std::sin(a) + 3.0 * g.rng.normal()),
                         static_cast<float>(-450.0 + 3.0 * g.rng.normal()));
        if (variant == 1 && i == 700) {
          EXPECT_EQ(f.add_mag(Vector3<float>(32767.0f, 32767.0f, 32767.0f)), Status::kGlitch);
        }
        EXPECT_EQ(f.add_mag(m), Status::kOk);
      }
    }
    for (int i = 0; i < 300; ++i) f.add_raw(g.move());
    counts[variant] = f.counts();
  }
  EXPECT_GT(counts[0].turning, 0u);
  EXPECT_EQ(counts[1].turning, counts[0].turning);
  EXPECT_EQ(counts[1].taken, counts[0].taken);
  EXPECT_EQ(counts[1].mag_glitches, 1u);
  // A stored hard iron far beyond the settings' sigma (600 uT: a speaker's magnet beside the
  // sensor): the readings around it are fields; one at full scale still is not.
  MagCalibration<float> stored;
  stored.status = Status::kOk;
  stored.soft_iron = Matrix3<float>::Identity() * 0.1f;  // uT per count
  stored.hard_iron = Vector3<float>(-6000.0f, 0.0f, 0.0f);
  stored.hard_iron_sigma.setConstant(5.0f);
  stored.soft_iron_sigma.setConstant(1e-3f);
  stored.field_ut = 49.0f;
  static FieldCalibrator<float> known;
  ASSERT_EQ(known.start(settings, nullptr, nullptr, &stored), Status::kOk);
  EXPECT_EQ(known.add_mag(Vector3<float>(6200.0f, 0.0f, -450.0f)), Status::kOk);
  EXPECT_EQ(known.add_mag(Vector3<float>(32767.0f, 32767.0f, 32767.0f)), Status::kGlitch);
  // The reach is a sphere: 1 % inside it is a field and 1 % beyond it a glitch, along an axis and
  // along the diagonal (where each axis is within the reach); 0.1 % either side along a direction
  // whose largest axis is between the inner cube's and the reach, where |m|^2 decides.
  const MagFieldSettings<float>& ms = settings.mag;
  const float reach =
      (2.0f * ms.field_ut + 5.0f * (ms.hard_iron_sigma_ut + ms.change_sigma_ut)) * ms.counts_per_ut;
  static FieldCalibrator<float> edge;
  ASSERT_EQ(edge.start(settings), Status::kOk);
  const Vector3<float> axis(0.0f, 0.0f, -1.0f), diagonal = Vector3<float>::Ones().normalized();
  for (const Vector3<float>& u : {axis, diagonal}) {
    EXPECT_EQ(edge.add_mag(u * (0.99f * reach)), Status::kOk) << u.transpose();
    EXPECT_EQ(edge.add_mag(u * (1.01f * reach)), Status::kGlitch) << u.transpose();
  }
  const Vector3<float> between(0.8f, 0.0f, -0.6f);
  EXPECT_EQ(edge.add_mag(between * (0.999f * reach)), Status::kOk);
  EXPECT_EQ(edge.add_mag(between * (1.001f * reach)), Status::kGlitch);
  EXPECT_EQ(edge.counts().mag_glitches, 3u);
}

// A magnetometer stuck on one reading (a hung bus) is refused once a rest has shown it stuck, and
// verifies nothing: frame by frame the calibrator decides what it decides without a
// magnetometer, also through a rest turning about the vertical after the first publication
// (held, and not confirmed as a change by pieces over which the field seemed to hold still).
TEST(FieldFaults, AStuckMagnetometerIsRefusedAndVerifiesNothing) {
  FieldSettings<float> settings = fault_settings();
  settings.mag.counts_per_ut = 10.0f;
  static FieldCalibrator<float> plain, stuck;
  ASSERT_EQ(plain.start(settings), Status::kOk);
  ASSERT_EQ(stuck.start(settings), Status::kOk);
  Frames g;
  std::vector<Status> statuses;
  std::size_t events = 0;
  const auto both = [&](const RawFrame& fr, bool rest) {
    EXPECT_EQ(stuck.add_raw(fr), plain.add_raw(fr));
    if (rest && fr.t_us % 100000u == 0u)  // 10 Hz
      statuses.push_back(stuck.add_mag(Vector3<float>(200.0f, 0.0f, -450.0f)));
    events += expect_same_events(plain, stuck);
  };
  for (int c = 0; c < 6; ++c) {
    for (int i = 0; i < 200; ++i) both(g.move(), false);
    for (int i = 0; i < 1200; ++i) both(g.rest(), true);
  }
  ASSERT_GT(plain.counts().updates, 0u);
  for (int i = 0; i < 200; ++i) both(g.move(), false);
  for (int i = 0; i < 4000; ++i) {  // 40 s turning at 0.002 rad/s about the vertical
    RawFrame fr = g.rest();
    fr.gyro[2] = static_cast<std::int16_t>(fr.gyro[2] + std::lround(0.002 * 940.0));
    both(fr, true);
  }
  for (int i = 0; i < 300; ++i) both(g.move(), false);
  EXPECT_GT(events, 0u);
  EXPECT_GT(plain.counts().held, 0u);
  EXPECT_EQ(plain.counts().changes, 0u);
  expect_same_counts(plain.counts(), stuck.counts());
  EXPECT_EQ(stuck.counts().held, plain.counts().held);
  EXPECT_EQ(stuck.counts().changes, plain.counts().changes);
  std::size_t frozen = 0;
  for (std::size_t k = 0; k < statuses.size(); ++k) {
    if (k < FieldCalibrator<float>::kMagFrozenReadings) {
      EXPECT_EQ(statuses[k], Status::kOk) << k;
    }
    EXPECT_TRUE(statuses[k] == Status::kOk || statuses[k] == Status::kSensorFrozen) << k;
    frozen += statuses[k] == Status::kSensorFrozen ? 1u : 0u;
  }
  EXPECT_GT(frozen, statuses.size() / 4);
}

// A sensor frozen for longer than the microsecond clock's 71.6 minutes: its frames are refused
// all along, and the time they span still passes (the bias's random walk over the spell).
TEST(FieldFaults, AFreezeLongerThanTheClockKeepsTheTime) {
  static FieldCalibrator<float> f;
  ASSERT_EQ(f.start(fault_settings()), Status::kOk);
  Frames g;
  for (int i = 0; i < 1000; ++i) ASSERT_TRUE(taken(f.add_raw(g.rest())));
  const float before = f.seconds();
  const RawFrame stuck = g.rest();
  std::uint32_t refused = 0;
  const std::uint32_t frames = 75u * 60u * 100u;  // 75 minutes at 100 Hz
  for (std::uint32_t k = 0; k < frames; ++k) {
    RawFrame fr = stuck;
    fr.t_us = g.t;
    g.next();
    const Status st = f.add_raw(fr);
    if (st == Status::kSensorFrozen) ++refused;
  }
  EXPECT_EQ(refused, frames - 50u);  // after frozen_seconds (0.5 s)
  for (int i = 0; i < 100; ++i) ASSERT_TRUE(taken(f.add_raw(g.rest())));
  EXPECT_NEAR(f.seconds() - before, 75.0f * 60.0f + 1.0f, 0.05f);
}

}  // namespace
}  // namespace imucal
