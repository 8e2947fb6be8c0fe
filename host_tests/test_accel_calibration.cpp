// SPDX-License-Identifier: MIT
// Accelerometer calibration against a simulator with known truth: the closed-form start, the
// LM estimate within 3 sigma, sigma that matches the real scatter, float against double, and a
// specific status for every kind of degenerate input.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "imucal/solve/accel_calibration.hpp"
#include "imucal/solve/levenberg_marquardt.hpp"
#include "support/gtest_status.hpp"
#include "support/sim_poses.hpp"

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

namespace imucal {
namespace {

using test::DoubleStore;
using test::simulate_poses;
using test::to_float;

const char* const kNames[kAccelParams] = {"alpha_yz", "alpha_zy", "alpha_zx", "s_x", "s_y",
                                          "s_z",      "b_x",      "b_y",      "b_z"};

template <typename Scalar>
AccelSettings<Scalar> settings_for(double gravity) {
  AccelSettings<Scalar> s;
  s.gravity = static_cast<Scalar>(gravity);
  return s;
}

template <typename Scalar>
void expect_no_nan(const AccelCalibration<Scalar>& c) {
  EXPECT_TRUE(c.params.allFinite());
  EXPECT_TRUE(c.sigma.allFinite());
  EXPECT_TRUE(std::isfinite(c.residual_rms));
}

TEST(AccelCalibration, NoiseFreePosesGiveTheTruthExactly) {
  for (const auto& spec : {sim::AccelSensorSpec::si(), sim::AccelSensorSpec::raw_counts()}) {
    sim::AccelSensorSpec clean = spec;
    clean.noise = 0.0;
    sim::Random rng(21);
    const sim::AccelTruth truth = sim::draw_accel_truth(clean, rng);
    DoubleStore poses;
    for (int i = 0; i < 20; ++i)
      poses.add(sim::raw_from_calibrated(truth, truth.gravity * sim::random_direction(rng)), 100);

    // The closed-form fit alone is already exact on noise-free data.
    Vector3<double> centre;
    double scale = 0;
    ASSERT_EQ(check_poses(poses.span(), settings_for<double>(truth.gravity), centre, scale),
              Status::kOk);
    AccelVector<double> pn;
    ASSERT_EQ(fit_ellipsoid(poses.span(), centre, scale, pn), Status::kOk);
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(pn(i), truth.params(i), 1e-9);
      EXPECT_NEAR(pn(kScaleX + i) * truth.gravity / scale, truth.params(kScaleX + i),
                  1e-9 * truth.params(kScaleX + i));
      EXPECT_NEAR(scale * pn(kBiasX + i) - centre(i), truth.params(kBiasX + i),
                  1e-9 * (std::abs(truth.params(kBiasX + i)) + 1));
    }
    AccelCalibration<double> out;
    const Status s =
        calibrate_accelerometer(poses.span(), settings_for<double>(truth.gravity), out);
    ASSERT_TRUE(succeeded(s)) << to_string(s);
    for (int k = 0; k < kAccelParams; ++k)
      EXPECT_NEAR(out.params(k), truth.params(k), 1e-8 * (std::abs(truth.params(k)) + 1e-3))
          << kNames[k];
    EXPECT_LT(out.residual_rms, 1e-9);
  }
}

template <typename Scalar>
void expect_within_three_sigma(const sim::AccelSensorSpec& spec, std::uint64_t seed) {
  const test::SimulatedPoses sim = simulate_poses(spec, seed);
  AccelCalibration<Scalar> out;
  Status s;
  if constexpr (sizeof(Scalar) == sizeof(float)) {
    const test::FloatStore fposes = to_float(sim.poses);
    s = calibrate_accelerometer(fposes.span(), settings_for<Scalar>(sim.truth.gravity), out);
  } else {
    s = calibrate_accelerometer(sim.poses.span(), settings_for<Scalar>(sim.truth.gravity), out);
  }
  ASSERT_TRUE(succeeded(s)) << to_string(s);
  expect_no_nan(out);
  for (int k = 0; k < kAccelParams; ++k) {
    const double err = static_cast<double>(out.params(k)) - sim.truth.params(k);
    const double sigma = static_cast<double>(out.sigma(k));
    EXPECT_GT(sigma, 0.0) << kNames[k];
    EXPECT_LT(std::abs(err), 3.0 * sigma) << kNames[k] << " error " << err << " sigma " << sigma;
  }
  // The pose residual is at the level of the noise on a pose mean (sensor noise / sqrt(~275)).
  const double noise_ms2 = spec.noise * spec.nominal_scale / std::sqrt(275.0);
  EXPECT_LT(static_cast<double>(out.residual_rms), 2.0 * noise_ms2);
}

TEST(AccelCalibration, WithinThreeSigmaSiUnitsDouble) {
  expect_within_three_sigma<double>(sim::AccelSensorSpec::si(), 101);
}
TEST(AccelCalibration, WithinThreeSigmaRawCountsDouble) {
  expect_within_three_sigma<double>(sim::AccelSensorSpec::raw_counts(), 102);
}
TEST(AccelCalibration, WithinThreeSigmaSiUnitsFloat) {
  expect_within_three_sigma<float>(sim::AccelSensorSpec::si(), 103);
}
TEST(AccelCalibration, WithinThreeSigmaRawCountsFloat) {
  expect_within_three_sigma<float>(sim::AccelSensorSpec::raw_counts(), 104);
}

// One seed can pass by luck; over 40 simulated recordings the z-scores (error / sigma) must have
// RMS near 1 for every parameter: sigma neither flatters nor hides the real scatter. With 40
// runs and 21 degrees of freedom the RMS has a 3-sigma band of about 0.65..1.35.
TEST(AccelCalibration, SigmaMatchesTheScatterOverManyRecordings) {
  for (const auto& spec : {sim::AccelSensorSpec::si(), sim::AccelSensorSpec::raw_counts()}) {
    constexpr int kRuns = 40;
    AccelVector<double> sum_z2 = AccelVector<double>::Zero();
    double worst = 0.0;
    for (int run = 0; run < kRuns; ++run) {
      const test::SimulatedPoses sim = simulate_poses(spec, 1000 + static_cast<std::uint64_t>(run));
      AccelCalibration<double> out;
      const Status s =
          calibrate_accelerometer(sim.poses.span(), settings_for<double>(sim.truth.gravity), out);
      ASSERT_TRUE(succeeded(s)) << to_string(s) << " run " << run;
      const AccelVector<double> z = (out.params - sim.truth.params).cwiseQuotient(out.sigma);
      sum_z2 += z.cwiseProduct(z);
      worst = std::max(worst, z.cwiseAbs().maxCoeff());
    }
    for (int k = 0; k < kAccelParams; ++k) {
      const double rms = std::sqrt(sum_z2(k) / kRuns);
      EXPECT_GT(rms, 0.65) << kNames[k];
      EXPECT_LT(rms, 1.35) << kNames[k];
    }
    EXPECT_LT(worst, 4.5);
  }
}

// Efficiency (math.md section 6): over 200 noise realisations of one fixed geometry, each
// parameter's RMS error divided by its Cramer-Rao bound at the truth. With the rest directions as
// unknown nuisance parameters and isotropic noise, the information about the 9 parameters is
// exactly that of the gravity-norm residual: CRB = (sum J_i J_i^T / var e_i)^-1 with
// var e_i = 4 sigma^2 / n_i |(T K)^T c_i|^2. 1.0 is the limit; the 3-sigma band of an RMS over
// 200 runs is about 0.85..1.15 (1000 runs measured 0.95..1.02 for all nine).
TEST(AccelCalibration, EfficiencyAgainstTheCramerRaoBound) {
  for (const auto& spec : {sim::AccelSensorSpec::si(), sim::AccelSensorSpec::raw_counts()}) {
    sim::Random geometry(500);
    const sim::AccelTruth truth = sim::draw_accel_truth(spec, geometry);
    constexpr int kPoses = 30;
    Vector3<double> clean[kPoses];
    std::uint32_t n[kPoses];
    Eigen::Matrix<double, kAccelParams, kAccelParams> info =
        Eigen::Matrix<double, kAccelParams, kAccelParams>::Zero();
    const Matrix3<double> tk = accel_matrix(truth.params);
    for (int i = 0; i < kPoses; ++i) {
      clean[i] = sim::raw_from_calibrated(truth, truth.gravity * sim::random_direction(geometry));
      n[i] = static_cast<std::uint32_t>(150 + geometry.next() % 251);
      AccelVector<double> j;
      accel_residual(truth.params, clean[i], truth.gravity, &j);
      const Vector3<double> c = accel_apply(truth.params, clean[i]);
      const double var_e =
          4.0 * spec.noise * spec.noise / n[i] * (tk.transpose() * c).squaredNorm();
      info += j * j.transpose() / var_e;
    }
    const AccelVector<double> crb = info.inverse().diagonal().cwiseSqrt();

    constexpr int kRuns = 200;
    AccelVector<double> sum_e2 = AccelVector<double>::Zero();
    sim::Random noise(501);
    for (int run = 0; run < kRuns; ++run) {
      DoubleStore poses;
      for (int i = 0; i < kPoses; ++i) {
        const double sd = spec.noise / std::sqrt(static_cast<double>(n[i]));
        poses.add(clean[i] + sd * noise.normal3(), n[i]);
      }
      AccelCalibration<double> out;
      ASSERT_TRUE(succeeded(
          calibrate_accelerometer(poses.span(), settings_for<double>(truth.gravity), out)));
      const AccelVector<double> e = out.params - truth.params;
      sum_e2 += e.cwiseProduct(e);
    }
    for (int k = 0; k < kAccelParams; ++k) {
      const double efficiency = std::sqrt(sum_e2(k) / kRuns) / crb(k);
      std::printf("%s %-8s RMS error / CRB = %.3f\n", spec.nominal_scale == 1.0 ? "SI " : "raw",
                  kNames[k], efficiency);
      EXPECT_GT(efficiency, 0.85) << kNames[k];
      EXPECT_LT(efficiency, 1.15) << kNames[k];
    }
  }
}

// The device path (float) against the reference (double) on the same data: every parameter
// within 0.1 sigma, in SI units and in raw 16-bit counts (~33000, bias ~ -32768).
TEST(AccelCalibration, FloatAgreesWithDoubleWithinATenthOfSigma) {
  for (const auto& spec : {sim::AccelSensorSpec::si(), sim::AccelSensorSpec::raw_counts()}) {
    for (std::uint64_t seed = 200; seed < 210; ++seed) {
      const test::SimulatedPoses sim = simulate_poses(spec, seed, 40);
      const test::FloatStore fposes = to_float(sim.poses);
      AccelCalibration<double> d;
      AccelCalibration<float> f;
      ASSERT_TRUE(succeeded(
          calibrate_accelerometer(sim.poses.span(), settings_for<double>(sim.truth.gravity), d)));
      const Status fs =
          calibrate_accelerometer(fposes.span(), settings_for<float>(sim.truth.gravity), f);
      ASSERT_TRUE(succeeded(fs)) << to_string(fs) << " seed " << seed;
      for (int k = 0; k < kAccelParams; ++k) {
        const double diff = std::abs(static_cast<double>(f.params(k)) - d.params(k));
        EXPECT_LT(diff, 0.1 * d.sigma(k)) << kNames[k] << " seed " << seed << " float "
                                          << f.params(k) << " double " << d.params(k);
        EXPECT_NEAR(static_cast<double>(f.sigma(k)), d.sigma(k), 0.05 * d.sigma(k)) << kNames[k];
      }
    }
  }
}

TEST(AccelCalibration, TimeSlicedSolveEqualsTheOneShotSolve) {
  const test::SimulatedPoses sim = simulate_poses(sim::AccelSensorSpec::raw_counts(), 300);
  const test::FloatStore fposes = to_float(sim.poses);
  AccelCalibration<float> whole;
  const Status ws =
      calibrate_accelerometer(fposes.span(), settings_for<float>(sim.truth.gravity), whole);
  ASSERT_TRUE(succeeded(ws));

  AccelSolver<float> solver(settings_for<float>(sim.truth.gravity));
  Status s = solver.start(fposes.span());
  int slices = 0;
  while (s == Status::kRunning) {
    s = solver.step();
    ++slices;
    ASSERT_LE(slices, 50);
  }
  AccelCalibration<float> sliced;
  EXPECT_EQ(solver.finish(sliced), ws);
  EXPECT_EQ(sliced.params, whole.params);
  EXPECT_EQ(sliced.iterations, slices);
  EXPECT_GE(slices, 1);
}

// The closed-form start is usually already at the optimum, so the tests above barely exercise
// the LM. Here it must do the work: from starts perturbed by up to 5 % (and 0.05 rad, 0.05 g),
// in float and double, it converges in several iterations to the reference optimum (within 0.1
// sigma), and the cost never increases between iterations.
template <typename Scalar, typename Store>
void expect_lm_recovers_from(const Store& poses, double gravity,
                             const AccelCalibration<double>& ref, std::uint64_t seed) {
  AccelSettings<Scalar> settings = settings_for<Scalar>(gravity);
  typename AccelSolver<Scalar>::Problem problem;
  problem.poses = poses.span();
  Scalar scale = 1;
  ASSERT_EQ(check_poses(poses.span(), settings, problem.centre, scale), Status::kOk);
  problem.scale = scale;
  AccelVector<Scalar> p0;
  ASSERT_EQ(fit_ellipsoid(poses.span(), problem.centre, scale, p0), Status::kOk);
  sim::Random rng(seed);
  for (int k = 0; k < kAccelParams; ++k) p0(k) += static_cast<Scalar>(0.05 * rng.uniform(-1, 1));

  typename AccelSolver<Scalar>::Lm lm(settings.lm);
  Status s = lm.start(problem, p0);
  Scalar last = lm.normal_equations().weighted_sse();
  while (s == Status::kRunning) {
    s = lm.step(problem);
    EXPECT_LE(lm.normal_equations().weighted_sse(), last);
    last = lm.normal_equations().weighted_sse();
  }
  ASSERT_TRUE(succeeded(s)) << to_string(s);
  EXPECT_GE(lm.iterations(), 3);
  for (int k = 0; k < kAccelParams; ++k) {
    // Back to sensor units (as AccelSolver::finish does) and against the reference.
    double v = static_cast<double>(lm.parameters()(k));
    if (k >= kScaleX && k < kBiasX) v *= gravity / static_cast<double>(scale);
    if (k >= kBiasX)
      v = static_cast<double>(scale) * v - static_cast<double>(problem.centre(k - kBiasX));
    EXPECT_LT(std::abs(v - ref.params(k)), 0.1 * ref.sigma(k)) << kNames[k];
  }
}

TEST(AccelCalibration, LevenbergMarquardtConvergesFromPerturbedStarts) {
  for (const auto& spec : {sim::AccelSensorSpec::si(), sim::AccelSensorSpec::raw_counts()}) {
    for (std::uint64_t seed = 600; seed < 605; ++seed) {
      const test::SimulatedPoses sim = simulate_poses(spec, seed);
      AccelCalibration<double> ref;
      ASSERT_TRUE(succeeded(
          calibrate_accelerometer(sim.poses.span(), settings_for<double>(sim.truth.gravity), ref)));
      expect_lm_recovers_from<double>(sim.poses, sim.truth.gravity, ref, seed);
      expect_lm_recovers_from<float>(to_float(sim.poses), sim.truth.gravity, ref, seed);
    }
  }
}

// Poses are weighted by their sample count: 12 long rests (10000 samples) and 12 short ones (10
// samples, 30 times the noise on their mean). Unweighted, the short rests would pull the
// estimate many sigma away; weighted, it stays within 3 sigma of the truth.
TEST(AccelCalibration, PosesAreWeightedBySampleCount) {
  const sim::AccelSensorSpec spec = sim::AccelSensorSpec::si();
  sim::Random rng(700);
  const sim::AccelTruth truth = sim::draw_accel_truth(spec, rng);
  DoubleStore poses, short_only;
  for (int i = 0; i < 24; ++i) {
    const std::uint32_t n = i % 2 == 0 ? 10000u : 10u;
    const Vector3<double> m = sim::noisy_pose_mean(truth, spec, sim::random_direction(rng), n, rng);
    poses.add(m, n);
    if (n == 10u) short_only.add(m, n);
  }
  AccelCalibration<double> out, short_out;
  ASSERT_TRUE(
      succeeded(calibrate_accelerometer(poses.span(), settings_for<double>(truth.gravity), out)));
  ASSERT_TRUE(succeeded(
      calibrate_accelerometer(short_only.span(), settings_for<double>(truth.gravity), short_out)));
  for (int k = 0; k < kAccelParams; ++k) {
    EXPECT_LT(std::abs(out.params(k) - truth.params(k)), 3.0 * out.sigma(k)) << kNames[k];
    // Weighted, the long rests set the precision (~30x better than the short ones); an
    // unweighted fit would be about as uncertain as the short rests alone.
    EXPECT_LT(out.sigma(k), 0.2 * short_out.sigma(k)) << kNames[k];
  }
}

// --- Degenerate input: a specific status, never a NaN. ---

template <typename Store>
AccelCalibration<double> expect_status(const Store& poses, Status expected) {
  AccelCalibration<double> out;
  const Status s = calibrate_accelerometer(poses.span(), settings_for<double>(9.80665), out);
  EXPECT_EQ(s, expected) << "got: " << to_string(s);
  EXPECT_EQ(out.status, expected);
  expect_no_nan(out);
  return out;
}

// Poses carrying their noise (Pose::noise) whose means also wander by a floor the rests' scatter
// does not show (bias instability: an offset per pose, sd `floor` on each axis), with sample
// counts from 100 to 5000: a mean over 5000 samples is not 50 times better than one over 100.
// The fit finds the floor from its chi-square and weights each pose by the noise of its mean;
// over many recordings the error in sigmas has an RMS near 1 for every parameter, and the floor
// found is near the truth.
TEST(AccelNoiseModel, LongRestsMeetAFloorAndSigmaFollowsIt) {
  const sim::AccelSensorSpec spec = sim::AccelSensorSpec::raw_counts();
  const double floor = 0.3;  // counts: the noise of a 120-sample mean (3.3 / sqrt(120))
  constexpr int kRuns = 200;
  AccelVector<double> sum_z2 = AccelVector<double>::Zero();
  double floor_sum = 0.0;
  for (int run = 0; run < kRuns; ++run) {
    sim::Random rng(5000 + static_cast<std::uint64_t>(run));
    const sim::AccelTruth truth = sim::draw_accel_truth(spec, rng);
    DoubleStore poses;
    for (int i = 0; i < 24; ++i) {
      const auto n = static_cast<std::uint32_t>(i % 4 == 0 ? 5000 : 100 + rng.next() % 200);
      const Vector3<double> offset = rng.normal3();
      const Vector3<double> m =
          sim::noisy_pose_mean(truth, spec, sim::random_direction(rng), n, rng) + floor * offset;
      poses.add(m, n, spec.noise * spec.noise);
    }
    AccelCalibration<double> out;
    ASSERT_TRUE(
        succeeded(calibrate_accelerometer(poses.span(), settings_for<double>(truth.gravity), out)))
        << "run " << run;
    const AccelVector<double> z = (out.params - truth.params).cwiseQuotient(out.sigma);
    sum_z2 += z.cwiseProduct(z);
    floor_sum += out.pose_floor / spec.nominal_scale;  // back to counts (scale ~ nominal)
  }
  for (int k = 0; k < kAccelParams; ++k) {
    const double rms = std::sqrt(sum_z2(k) / kRuns);
    EXPECT_GT(rms, 0.8) << kNames[k];
    EXPECT_LT(rms, 1.25) << kNames[k];
  }
  // The floor found, in counts, on average within 20 % of the truth.
  EXPECT_NEAR(floor_sum / kRuns, floor, 0.2 * floor);
}

// Twelve gravity directions, none between the x and y axes: alpha_yz is not determined.
std::vector<Vector3<double>> no_pose_between_x_and_y() {
  const double r = std::sqrt(0.5);
  return {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1},  {0, 0, -1},
          {r, 0, r}, {-r, 0, r}, {0, r, r}, {0, -r, r}, {r, 0, -r}, {0, r, -r}};
}

// No pose has gravity between the x and y axes: alpha_yz (which couples them) enters the norm
// only at second order, and the poses do not determine it. It is held at 0 and named, never
// reported with a small sigma; every other parameter is still within 4 sigma. (A held
// parameter's own error reaches the others at second order, alpha^2 / 2 on scale_y, outside
// their sigma: the truth here is 1 mrad.) The closed-form start's quadric is undetermined in its
// xy term too, and is settled by its pull toward a sphere. Another parameter left undetermined
// with alpha_yz would be refused (unobservable), never given a small sigma: almost every
// recording is solved.
TEST(AccelNoiseModel, AnUndeterminedMisalignmentIsHeldAndNamed) {
  const sim::AccelSensorSpec spec = sim::AccelSensorSpec::raw_counts();
  const std::vector<Vector3<double>> dirs = no_pose_between_x_and_y();
  int refused = 0;
  for (std::uint64_t seed = 0; seed < 20; ++seed) {
    sim::Random rng(6000 + seed);
    sim::AccelTruth truth = sim::draw_accel_truth(spec, rng);
    truth.params(kAlphaYz) = 1e-3;
    DoubleStore poses;
    for (const Vector3<double>& d : dirs)
      poses.add(sim::noisy_pose_mean(truth, spec, d, 300, rng), 300, spec.noise * spec.noise);
    for (bool hold : {true, false}) {
      AccelSettings<double> settings = settings_for<double>(truth.gravity);
      settings.hold_undetermined_misalignment = hold;
      AccelCalibration<double> out;
      const Status s = calibrate_accelerometer(poses.span(), settings, out);
      if (!hold) {
        EXPECT_TRUE(s == Status::kUnobservable || s == Status::kNotAnEllipsoid) << "seed " << seed;
        continue;
      }
      if (s == Status::kNotAnEllipsoid || s == Status::kUnobservable) {
        ++refused;
        continue;
      }
      ASSERT_TRUE(succeeded(s)) << to_string(s) << " seed " << seed;
      EXPECT_EQ(out.held, 1u << kAlphaYz) << "seed " << seed;
      EXPECT_EQ(out.params(kAlphaYz), 0.0);
      EXPECT_EQ(out.sigma(kAlphaYz), 0.0);
      for (int k = 0; k < kAccelParams; ++k) {
        if (k == kAlphaYz) continue;
        EXPECT_LT(std::abs(out.params(k) - truth.params(k)), 4.0 * out.sigma(k))
            << kNames[k] << " seed " << seed;
      }
    }
  }
  EXPECT_LE(refused, 1);
  EXPECT_STRNE(accel_orientation_hint(kAlphaYz), "");
  EXPECT_STREQ(accel_parameter_name(kAlphaYz), "alpha_yz");
}

// The covariance the gyro's sigma takes from the accelerometer: in sensor units, its diagonal is
// sigma squared, it is symmetric and positive semi-definite, and a held parameter's row and column
// are 0.
TEST(AccelNoiseModel, CovarianceMatchesSigmaAndHoldsTheHeld) {
  const sim::AccelSensorSpec spec = sim::AccelSensorSpec::raw_counts();
  const std::vector<Vector3<double>> dirs = no_pose_between_x_and_y();
  int held_seen = 0;
  for (std::uint64_t seed = 0; seed < 4; ++seed) {
    sim::Random rng(6100 + seed);
    const sim::AccelTruth truth = sim::draw_accel_truth(spec, rng);
    DoubleStore poses;
    for (const Vector3<double>& d : dirs)
      poses.add(sim::noisy_pose_mean(truth, spec, d, 300, rng), 300, spec.noise * spec.noise);
    AccelSolver<double> solver(settings_for<double>(truth.gravity));
    Status s = solver.start(poses.span());
    while (s == Status::kRunning) s = solver.step();
    AccelCalibration<double> out;
    if (!succeeded(solver.finish(out))) continue;
    Eigen::Matrix<double, kAccelParams, kAccelParams> cov;
    ASSERT_EQ(solver.covariance(cov), Status::kOk);
    EXPECT_LT((cov - cov.transpose()).cwiseAbs().maxCoeff(), 1e-12 * cov.cwiseAbs().maxCoeff());
    for (int k = 0; k < kAccelParams; ++k) {
      if (out.held & (1u << k)) {
        ++held_seen;
        EXPECT_EQ(cov.row(k).cwiseAbs().maxCoeff(), 0.0);
        EXPECT_EQ(cov.col(k).cwiseAbs().maxCoeff(), 0.0);
      } else {
        EXPECT_NEAR(std::sqrt(cov(k, k)), out.sigma(k), 1e-9 * out.sigma(k)) << kNames[k];
      }
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, kAccelParams, kAccelParams>> eig(cov);
    EXPECT_GE(eig.eigenvalues().minCoeff(), -1e-12 * eig.eigenvalues().maxCoeff());
  }
  EXPECT_GT(held_seen, 0);  // no pose between x and y: alpha_yz held in these recordings
}

TEST(AccelDegenerate, FewerThanTenPoses) {
  const test::SimulatedPoses sim = simulate_poses(sim::AccelSensorSpec::si(), 400, 8);
  expect_status(sim.poses, Status::kTooFewPoses);
  // Nine poses would fit the nine parameters exactly, leaving no residual for a sigma.
  const test::SimulatedPoses nine = simulate_poses(sim::AccelSensorSpec::si(), 401, 9);
  expect_status(nine.poses, Status::kTooFewPoses);
  DoubleStore empty;
  expect_status(empty, Status::kTooFewPoses);
}

TEST(AccelDegenerate, AllPosesInOnePlane) {
  // Turned about one horizontal axis only: gravity sweeps a great circle.
  sim::Random rng(401);
  const sim::AccelTruth truth = sim::draw_accel_truth(sim::AccelSensorSpec::si(), rng);
  Vector3<double> dirs[12];
  for (int i = 0; i < 12; ++i) {
    const double a = 0.5236 * i;
    dirs[i] = Vector3<double>(std::cos(a), 0.0, std::sin(a));
  }
  expect_status(test::poses_from_directions(truth, sim::AccelSensorSpec::si(), dirs, 402),
                Status::kPosesCoplanar);

  // Turned about a tilted axis: gravity sweeps a small circle (a cone), still one plane.
  const Vector3<double> axis = Vector3<double>(1.0, 2.0, 3.0).normalized();
  const Vector3<double> e1 = axis.unitOrthogonal();
  const Vector3<double> e2 = axis.cross(e1);
  for (int i = 0; i < 12; ++i) {
    const double a = 0.5236 * i;
    dirs[i] = (0.6 * axis + 0.8 * (std::cos(a) * e1 + std::sin(a) * e2)).normalized();
  }
  expect_status(test::poses_from_directions(truth, sim::AccelSensorSpec::si(), dirs, 403),
                Status::kPosesCoplanar);
}

TEST(AccelDegenerate, AFailedSolveLeavesNoStaleEstimate) {
  const test::SimulatedPoses good = simulate_poses(sim::AccelSensorSpec::si(), 405, 20);
  AccelCalibration<double> out;
  ASSERT_TRUE(
      succeeded(calibrate_accelerometer(good.poses.span(), settings_for<double>(9.80665), out)));
  const test::SimulatedPoses few = simulate_poses(sim::AccelSensorSpec::si(), 406, 8);
  EXPECT_EQ(calibrate_accelerometer(few.poses.span(), settings_for<double>(9.80665), out),
            Status::kTooFewPoses);
  EXPECT_EQ(out.params, AccelVector<double>::Zero());
  EXPECT_EQ(out.sigma, AccelVector<double>::Zero());
  EXPECT_EQ(out.residual_rms, 0.0);
  EXPECT_EQ(out.status, Status::kTooFewPoses);
}

TEST(AccelDegenerate, AQuadricThatIsNotAnEllipsoid) {
  // Points in general position on the hyperboloid x^2 + y^2/2.25 - z^2/4 = 1: spread in 3-D and
  // determining a unique quadric, but no ellipsoid.
  DoubleStore poses;
  sim::Random rng(450);
  for (int i = 0; i < 20; ++i) {
    const double a = rng.uniform(0.0, 6.283), z = rng.uniform(-1.5, 1.5);
    const double r = std::sqrt(1.0 + z * z / 4.0);
    poses.add(Vector3<double>(r * std::cos(a), 1.5 * r * std::sin(a), z), 100);
  }
  Vector3<double> centre;
  double scale = 0;
  ASSERT_EQ(check_poses(poses.span(), settings_for<double>(1.0), centre, scale), Status::kOk);
  AccelVector<double> p = AccelVector<double>::Constant(7.0);
  EXPECT_EQ(fit_ellipsoid(poses.span(), centre, scale, p), Status::kNotAnEllipsoid);
  EXPECT_EQ(p, AccelVector<double>::Constant(7.0));
  expect_status(poses, Status::kNotAnEllipsoid);
}

TEST(AccelDegenerate, TwoConesAboutOneAxisAreNotObservable) {
  // Not coplanar, but two circles on the sphere do not pin down an ellipsoid.
  sim::Random rng(410);
  const sim::AccelTruth truth = sim::draw_accel_truth(sim::AccelSensorSpec::si(), rng);
  Vector3<double> dirs[16];
  for (int i = 0; i < 16; ++i) {
    const double a = 0.7854 * (i % 8);
    const double z = i < 8 ? 0.5 : -0.3;
    const double r = std::sqrt(1 - z * z);
    dirs[i] = Vector3<double>(r * std::cos(a), r * std::sin(a), z);
  }
  AccelCalibration<double> out;
  const Status s = calibrate_accelerometer(
      test::poses_from_directions(truth, sim::AccelSensorSpec::si(), dirs, 411).span(),
      settings_for<double>(truth.gravity), out);
  EXPECT_EQ(s, Status::kUnobservable);
  expect_no_nan(out);
}

TEST(AccelDegenerate, DuplicatePoses) {
  // Twelve poses but only six directions (each held twice): too few distinct directions.
  const test::SimulatedPoses sim = simulate_poses(sim::AccelSensorSpec::si(), 420, 6);
  DoubleStore doubled;
  for (int rep = 0; rep < 2; ++rep)
    for (int i = 0; i < sim.poses.size(); ++i) doubled.add(sim.poses[i].mean, sim.poses[i].samples);
  expect_status(doubled, Status::kTooFewDistinctPoses);
  // All the same direction.
  DoubleStore same;
  for (int i = 0; i < 12; ++i) same.add(Vector3<double>(0.1, 0.2, 9.8), 100);
  expect_status(same, Status::kTooFewDistinctPoses);
}

TEST(AccelDegenerate, NonFiniteReadingsAreRefusedAndNothingIsLost) {
  const test::SimulatedPoses sim = simulate_poses(sim::AccelSensorSpec::si(), 430, 12);
  DoubleStore store = sim.poses;
  EXPECT_EQ(store.add(Vector3<double>(kNaN, 0, 9.8), 100), Status::kNonFiniteInput);
  EXPECT_EQ(store.add(Vector3<double>(0, kInf, 9.8), 100), Status::kNonFiniteInput);
  EXPECT_EQ(store.add(Vector3<double>(0, 0, 9.8), 0), Status::kInvalidArgument);
  EXPECT_EQ(store.size(), 12);
  AccelCalibration<double> out;
  EXPECT_TRUE(succeeded(
      calibrate_accelerometer(store.span(), settings_for<double>(sim.truth.gravity), out)));

  // Poses that bypass the store (a caller's own array) are checked by the solver as well.
  Pose<double> raw[12];
  for (int i = 0; i < 12; ++i) raw[i] = store[i];
  raw[5].mean(2) = kNaN;
  EXPECT_EQ(calibrate_accelerometer(PoseSpan<double>{raw, 12}, settings_for<double>(9.8), out),
            Status::kNonFiniteInput);
  raw[5].mean(2) = -kInf;
  EXPECT_EQ(calibrate_accelerometer(PoseSpan<double>{raw, 12}, settings_for<double>(9.8), out),
            Status::kNonFiniteInput);
  expect_no_nan(out);
}

TEST(AccelDegenerate, FullStoreRefusesAndKeepsWhatItHas) {
  PoseStore<float, 9> store;
  for (int i = 0; i < 9; ++i)
    ASSERT_EQ(store.add(Vector3<float>(1.0f * float(i), 0, 0), 10), Status::kOk);
  EXPECT_TRUE(store.full());
  EXPECT_EQ(store.add(Vector3<float>(99, 0, 0), 10), Status::kCapacityExceeded);
  EXPECT_EQ(store.size(), 9);
  EXPECT_EQ(store[8].mean(0), 8.0f);
}

TEST(AccelDegenerate, BadSettings) {
  const test::SimulatedPoses sim = simulate_poses(sim::AccelSensorSpec::si(), 440, 12);
  AccelSettings<double> s;
  s.gravity = -1.0;
  AccelCalibration<double> out;
  EXPECT_EQ(calibrate_accelerometer(sim.poses.span(), s, out), Status::kInvalidArgument);
  s.gravity = kNaN;
  EXPECT_EQ(calibrate_accelerometer(sim.poses.span(), s, out), Status::kInvalidArgument);
  expect_no_nan(out);
}

}  // namespace
}  // namespace imucal
