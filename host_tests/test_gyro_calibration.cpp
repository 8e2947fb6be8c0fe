// SPDX-License-Identifier: MIT
// The gyro run (math.md section 4) on segment statistics: the analytic Jacobian against central
// differences, recovery of a known M and bias from exact and noisy moves, the scale search, the
// time slicing, the statuses for too little data, and the sigma the inputs held fixed add.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "imucal/models/accel_model.hpp"
#include "imucal/sim/accel_sim.hpp"
#include "imucal/sim/random.hpp"
#include "imucal/solve/gyro_calibration.hpp"
#include "support/gtest_status.hpp"
#include "support/soft_float.hpp"

namespace imucal {
namespace {

// Records the rows instead of folding them, for the derivative check.
template <int N>
struct RowRecorder {
  std::vector<Eigen::Matrix<double, N, 1>> rows;
  std::vector<double> residuals;
  Status add(const Eigen::Matrix<double, N, 1>& j, double e, double = 1.0) {
    rows.push_back(j);
    residuals.push_back(e);
    return Status::kOk;
  }
};

GyroVector<double> random_truth(sim::Random& rng, double scale) {
  GyroVector<double> p = GyroVector<double>::Zero();
  for (int k = 0; k < 6; ++k) p(k) = rng.uniform(-0.02, 0.02);
  for (int k = 6; k < 9; ++k) p(k) = scale * (1.0 + rng.uniform(-0.04, 0.04));
  return p;
}

// Moves generated from raw samples with known truth: each move turns about a drifting axis by
// 1-3 rad at ~100 Hz; the segment statistics are of u = w_raw + b0 (with white noise of
// raw_noise per sample), closed every 6 samples. The poses' gravity directions follow exactly
// from the true rotations: the gyro noise makes each move's residual independent.
template <typename Scalar>
struct MoveSet {
  std::vector<GyroSegment<Scalar>> segments;
  std::vector<GyroMove> moves;
  std::vector<Vector3<Scalar>> up;
  GyroData<Scalar> data() const {
    return {segments.data(), moves.data(), static_cast<int>(moves.size()), up.data(),
            static_cast<int>(up.size())};
  }
};

template <typename Scalar>
MoveSet<Scalar> make_moves(const GyroVector<double>& truth, const Vector3<double>& b0, int count,
                           double raw_noise, sim::Random& rng) {
  MoveSet<Scalar> set;
  const Matrix3<double> m_inv = gyro_matrix<double>(truth).inverse();
  const Vector3<double> b_true = truth.tail<3>();
  Vector3<double> up = sim::random_direction(rng);
  set.up.push_back(up.cast<Scalar>());
  for (int k = 0; k < count; ++k) {
    GyroMove mv;
    mv.first_segment = static_cast<int>(set.segments.size());
    mv.from_pose = k;
    mv.to_pose = k + 1;
    const Vector3<double> a0 = sim::random_direction(rng);
    const Vector3<double> a1 = sim::random_direction(rng);
    const double angle = rng.uniform(1.0, 3.0);
    const int n = 150 + static_cast<int>(rng.uniform(0, 100));
    Matrix3<double> r = Matrix3<double>::Identity();
    GyroSegment<Scalar> seg;
    for (int i = 0; i < n; ++i) {
      const double tau = (i + 0.5) / n;
      const double dt = 0.01 * rng.uniform(0.95, 1.05);
      const Vector3<double> axis = (a0 + 0.5 * std::sin(6.0 * tau) * a1).normalized();
      const double speed =
          2.0 * angle * std::pow(std::sin(3.141592653589793 * tau), 2) / (n * 0.01);
      const Vector3<double> w = speed * axis;
      r = r * rotation_exp(Vector3<double>(w * dt));
      const Vector3<double> u = m_inv * w - b_true + b0 + raw_noise * rng.normal3();
      seg.add(u.cast<Scalar>(), static_cast<Scalar>(dt));
      if (i % 6 == 5 || i == n - 1) {
        set.segments.push_back(seg);
        seg = GyroSegment<Scalar>{};
      }
    }
    mv.segments = static_cast<int>(set.segments.size()) - mv.first_segment;
    set.moves.push_back(mv);
    up = r.transpose() * up;
    set.up.push_back(up.cast<Scalar>());
  }
  return set;
}

template <int N>
void check_jacobian() {
  sim::Random rng(11);
  for (int trial = 0; trial < 20; ++trial) {
    GyroVector<double> truth = random_truth(rng, 1.0);
    truth.tail<3>() = Vector3<double>(0.01, -0.02, 0.015);
    const MoveSet<double> set = make_moves<double>(truth, Vector3<double>::Zero(), 3, 0.05, rng);
    GyroProblem<double> problem;
    problem.data = set.data();
    problem.refine_bias = N == kGyroParams;
    ASSERT_EQ(problem.size(), N);
    GyroVector<double> p = random_truth(rng, 1.1);
    p.tail<3>() = N == kGyroParams ? Vector3<double>(0.03, 0.01, -0.02) : Vector3<double>::Zero();
    RowRecorder<kGyroParams> at;
    ASSERT_EQ(problem.accumulate(p, at), Status::kOk);
    ASSERT_EQ(at.rows.size(), 6u);
    // With the bias held, its columns are 0 (the accumulator ignores them).
    if (N == kGyroMatrixParams) {
      for (const GyroVector<double>& row : at.rows)
        EXPECT_EQ(row.tail<3>(), Vector3<double>::Zero());
    }
    for (int k = 0; k < N; ++k) {
      const double h = 1e-6;
      GyroVector<double> pp = p, pm = p;
      pp(k) += h;
      pm(k) -= h;
      RowRecorder<kGyroParams> plus, minus;
      ASSERT_EQ(problem.accumulate(pp, plus), Status::kOk);
      ASSERT_EQ(problem.accumulate(pm, minus), Status::kOk);
      for (std::size_t r = 0; r < at.rows.size(); ++r) {
        const double numeric = (plus.residuals[r] - minus.residuals[r]) / (2.0 * h);
        EXPECT_NEAR(at.rows[r](k), numeric, 1e-7 * (1.0 + std::abs(numeric)))
            << "trial " << trial << " parameter " << k << " row " << r;
      }
    }
  }
}

TEST(GyroProblem, JacobianMatchesCentralDifferences9) { check_jacobian<kGyroMatrixParams>(); }
TEST(GyroProblem, JacobianMatchesCentralDifferences12) { check_jacobian<kGyroParams>(); }

// Slicing the pass gives the same accumulator as one pass, whatever the slice size.
TEST(GyroProblem, SlicedPassEqualsOnePass) {
  sim::Random rng(12);
  const GyroVector<double> truth = random_truth(rng, 1.0);
  const MoveSet<double> set = make_moves<double>(truth, Vector3<double>::Zero(), 8, 0.0, rng);
  GyroProblem<double> problem;
  problem.data = set.data();
  problem.refine_bias = true;
  const GyroVector<double> p = random_truth(rng, 1.05);
  NormalEquations<double, kGyroParams> whole, sliced;
  ASSERT_EQ(problem.accumulate(p, whole), Status::kOk);
  GyroProblem<double>::Cursor c;
  int calls = 0;
  Status s;
  while ((s = problem.accumulate_slice(p, sliced, c, 7)) == Status::kRunning) ++calls;
  ASSERT_EQ(s, Status::kOk);
  EXPECT_GT(calls, 20);
  EXPECT_NEAR(sliced.weighted_sse(), whole.weighted_sse(), 1e-12 * whole.weighted_sse());
  EXPECT_EQ(sliced.rows(), whole.rows());
}

template <typename Scalar>
GyroCalibration<Scalar> solve(const MoveSet<Scalar>& set, const Vector3<double>& b0,
                              const GyroSettings<Scalar>& settings, int* steps = nullptr) {
  GyroSolver<Scalar> solver(settings);
  Status s = solver.start(set.data(), b0.cast<Scalar>());
  int n = 0;
  while (s == Status::kRunning) {
    s = solver.step();
    ++n;
  }
  if (steps != nullptr) *steps = n;
  GyroCalibration<Scalar> out;
  solver.finish(out);
  return out;
}

// Noise-free moves: the solution is the truth to the precision of the segment expansion.
TEST(GyroSolver, RecoversTheTruthFromExactMoves) {
  sim::Random rng(13);
  for (int trial = 0; trial < 5; ++trial) {
    const double scale = 1.0 / 4770.0;  // raw counts, as on the xsens
    GyroVector<double> truth = random_truth(rng, scale);
    const Vector3<double> b0(-32777.0, -32459.0, -32512.0);
    truth.tail<3>() = b0 + Vector3<double>(3.0, -2.0, 4.0);
    const MoveSet<double> set = make_moves<double>(truth, b0, 12, 0.0, rng);
    GyroSettings<double> settings;
    settings.nominal_scale = scale;
    settings.refine_bias = true;
    const GyroCalibration<double> c = solve<double>(set, b0, settings);
    ASSERT_TRUE(succeeded(c.status)) << to_string(c.status) << " " << c.iterations;
    for (int k = 0; k < 6; ++k) EXPECT_NEAR(c.params(k), truth(k), 2e-5) << k;
    for (int k = 6; k < 9; ++k) EXPECT_NEAR(c.params(k) / truth(k), 1.0, 2e-5) << k;
    for (int k = 9; k < 12; ++k) EXPECT_NEAR(c.params(k), truth(k), 0.05) << k;
    EXPECT_LT(c.residual_rms, 1e-5);
  }
}

// Gyro white noise (15 counts per sample, as on the xsens), float and double, scale given and
// found by the search: over the recordings x 9 parameters the errors are consistent with the
// reported sigma. None lies beyond 3.5 sigma (P < 0.05 over 90 draws, 0.02 over 45), and the RMS
// of error/sigma lies within the 4 sigma band of the RMS of n unit normals, sqrt(chi^2_n / n),
// n = 9 x the recordings: between the quantiles of chi^2_n at 3.2e-5 and 1 - 3.2e-5 (n = 90:
// 46.0 and 153.9, an RMS within 0.715..1.308; n = 45: 16.5 and 93.3, 0.606..1.440), rounded
// outwards. Without an FPU (every operation a library call) 5 recordings instead of 10.
#if IMUCAL_TEST_SOFT_FLOAT
constexpr int kNoisyRecordings = 5;
constexpr double kRmsLow = 0.60, kRmsHigh = 1.44;
#else
constexpr int kNoisyRecordings = 10;
constexpr double kRmsLow = 0.71, kRmsHigh = 1.31;
#endif

template <typename Scalar>
void noisy_recovery(bool give_scale) {
  sim::Random rng(14);
  const double scale = 1.0 / 4770.0;
  double z2 = 0.0;
  int checked = 0;
  for (int trial = 0; trial < kNoisyRecordings; ++trial) {
    GyroVector<double> truth = random_truth(rng, scale);
    const Vector3<double> b0(-32777.0, -32459.0, -32512.0);
    truth.tail<3>() = b0;  // the initial rest got the bias right: 9 parameters
    const MoveSet<Scalar> set = make_moves<Scalar>(truth, b0, 30, 15.0, rng);
    GyroSettings<Scalar> settings;
    settings.nominal_scale = give_scale ? static_cast<Scalar>(scale) : Scalar(0);
    const GyroCalibration<Scalar> c = solve<Scalar>(set, b0, settings);
    ASSERT_TRUE(succeeded(c.status)) << to_string(c.status);
    for (int k = 0; k < 9; ++k) {
      ASSERT_GT(c.sigma(k), Scalar(0));
      const double z =
          (static_cast<double>(c.params(k)) - truth(k)) / static_cast<double>(c.sigma(k));
      EXPECT_LT(std::abs(z), 3.5) << "trial " << trial << " parameter " << k;
      z2 += z * z;
      ++checked;
    }
    // The angle noise of a move: 15 counts/sample over ~200 samples of 0.01 s, 4770 counts per
    // rad/s: sqrt(200) 0.01 15 / 4770 = 4.4e-4 rad per axis, two axes seen.
    EXPECT_GT(static_cast<double>(c.residual_rms), 3e-4);
    EXPECT_LT(static_cast<double>(c.residual_rms), 9e-4);
  }
  ASSERT_EQ(checked, 9 * kNoisyRecordings);
  const double rms_z = std::sqrt(z2 / checked);
  std::printf("RMS error/sigma over %d parameters: %.3f\n", checked, rms_z);
  EXPECT_GT(rms_z, kRmsLow);
  EXPECT_LT(rms_z, kRmsHigh);
}

TEST(GyroSolver, NoisyMovesWithin3SigmaDouble) { noisy_recovery<double>(true); }
TEST(GyroSolver, NoisyMovesWithin3SigmaFloat) { noisy_recovery<float>(true); }
TEST(GyroSolver, ScaleSearchWithoutNominalDouble) { noisy_recovery<double>(false); }
TEST(GyroSolver, ScaleSearchWithoutNominalFloat) { noisy_recovery<float>(false); }

// One step folds at most segments_per_step segments: the solve takes many bounded steps.
TEST(GyroSolver, StepsAreBoundedSlices) {
  sim::Random rng(15);
  const GyroVector<double> truth = random_truth(rng, 1.0);
  const MoveSet<float> set = make_moves<float>(truth, truth.tail<3>(), 20, 0.003, rng);
  GyroSettings<float> settings;
  settings.nominal_scale = 1.0f;
  settings.segments_per_step = 16;
  int steps = 0;
  const GyroCalibration<float> c = solve<float>(set, truth.tail<3>(), settings, &steps);
  ASSERT_TRUE(succeeded(c.status)) << to_string(c.status);
  const int per_pass = static_cast<int>(set.segments.size()) / 16;
  EXPECT_GE(steps, per_pass * (c.iterations + 1));
}

// The sigma that GyroInputUncertainty adds equals what re-solving with perturbed inputs gives: the
// accelerometer's parameters (through every pose's gravity direction) and the held bias, each
// moved by central differences and the gyro solved again, G = dp/dinput, Cov += G Cov_in G^T. With
// the bias refined (N = 12) only the accelerometer's parameters are inputs.
template <int N>
void widening_matches_re_solves() {
  sim::Random rng(21);
  const GyroVector<double> truth = random_truth(rng, 1.0);
  MoveSet<double> set = make_moves<double>(truth, truth.tail<3>(), 20, 0.003, rng);
  // Raw accelerometer readings whose calibrated directions are the poses' up vectors.
  AccelVector<double> pa;
  pa << 0.01, -0.02, 0.015, 1.02, 0.98, 1.01, 0.05, -0.03, 0.02;
  std::vector<Vector3<double>> raw;
  for (const Vector3<double>& u : set.up)
    raw.push_back(accel_matrix(pa).inverse() * (9.81 * u) - pa.tail<3>());
  const auto ups_for = [&](const AccelVector<double>& q) {
    std::vector<Vector3<double>> ups;
    for (const Vector3<double>& a : raw) ups.push_back(accel_apply(q, a).normalized());
    return ups;
  };
  // An accelerometer's covariance with correlations: 1e-3 rad, 1e-3, 0.01 m/s^2, and a random
  // correlation structure (L L^T with a random L).
  Eigen::Matrix<double, 9, 9> l = Eigen::Matrix<double, 9, 9>::Zero();
  for (int r = 0; r < 9; ++r)
    for (int c = 0; c <= r; ++c) l(r, c) = (r == c ? 1.0 : 0.4) * rng.normal();
  const AccelVector<double> sd_a =
      (AccelVector<double>() << 1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 0.01, 0.01, 0.01).finished();
  const Eigen::Matrix<double, 9, 9> cov_a =
      sd_a.asDiagonal() * l * l.transpose() * sd_a.asDiagonal() / l.rowwise().squaredNorm().mean();
  const Vector3<double> sd_b(2e-3, 3e-3, 1.5e-3);

  GyroSettings<double> settings;
  settings.nominal_scale = 1.0;
  settings.refine_bias = N == kGyroParams;
  const Vector3<double> b0 = truth.tail<3>();
  const auto solve_with = [&](const AccelVector<double>& q, const Vector3<double>& shift,
                              GyroSolver<double>& solver) {
    set.up = ups_for(q);
    GyroData<double> data = set.data();
    data.bias_shift = shift;
    Status s = solver.start(data, b0);
    while (s == Status::kRunning) s = solver.step();
    return s;
  };
  GyroSolver<double> solver(settings);
  ASSERT_TRUE(succeeded(solve_with(pa, Vector3<double>::Zero(), solver)));
  GyroCalibration<double> out;
  ASSERT_TRUE(succeeded(solver.finish(out)));
  const GyroVector<double> sigma0 = out.sigma;
  if (N == kGyroMatrixParams) out.sigma.tail<3>() = sd_b;  // the held bias's, as the calibrator

  GyroInputUncertainty<double> widen;
  widen.start(solver, cov_a);
  std::vector<Pose<double>> poses;
  for (const Vector3<double>& a : raw) poses.push_back({a, 100, 0.0});
  const PoseSpan<double> span{poses.data(), static_cast<int>(poses.size())};
  Status s;
  int steps = 0;
  while ((s = widen.step(solver, pa, span, 7)) == Status::kRunning) ++steps;
  ASSERT_EQ(s, Status::kOk);
  EXPECT_GT(steps, 20);  // bounded slices, as the solve's
  ASSERT_EQ(widen.finish(solver, out), Status::kOk);

  // Central differences of the whole solve.
  Eigen::Matrix<double, N, 9> ga;
  Eigen::Matrix<double, N, 3> gb = Eigen::Matrix<double, N, 3>::Zero();
  for (int j = 0; j < (N == kGyroMatrixParams ? 12 : 9); ++j) {
    AccelVector<double> hi = pa, lo = pa;
    Vector3<double> shift_hi = Vector3<double>::Zero(), shift_lo = shift_hi;
    const double h = j < 9 ? 1e-5 * std::max(1.0, std::abs(pa(j))) : 1e-5;
    if (j < 9) {
      hi(j) += h;
      lo(j) -= h;
    } else {
      shift_hi(j - 9) += h;
      shift_lo(j - 9) -= h;
    }
    GyroSolver<double> plus(settings), minus(settings);
    ASSERT_TRUE(succeeded(solve_with(hi, shift_hi, plus)));
    ASSERT_TRUE(succeeded(solve_with(lo, shift_lo, minus)));
    const Eigen::Matrix<double, N, 1> d =
        (plus.parameters() - minus.parameters()).template head<N>() / (2 * h);
    if (j < 9)
      ga.col(j) = d;
    else
      gb.col(j - 9) = d;
  }
  const Eigen::Matrix<double, N, N> extra =
      ga * cov_a * ga.transpose() +
      gb * Vector3<double>(sd_b.cwiseProduct(sd_b)).asDiagonal() * gb.transpose();
  double widest = 0.0;
  for (int k = 0; k < N; ++k) {
    const double expected = std::sqrt(sigma0(k) * sigma0(k) + extra(k, k));
    EXPECT_NEAR(out.sigma(k), expected, 0.01 * expected) << "parameter " << k;
    widest = std::max(widest, expected / sigma0(k));
  }
  EXPECT_GT(widest, 1.5);  // the inputs' uncertainty matters here: the check can tell
}

TEST(GyroInputUncertainty, AddsWhatReSolvesWithPerturbedInputsGive) {
  widening_matches_re_solves<kGyroMatrixParams>();
}

TEST(GyroInputUncertainty, AddsWhatReSolvesGiveWithTheBiasRefined) {
  widening_matches_re_solves<kGyroParams>();
}

TEST(GyroSolver, TooFewMoves) {
  sim::Random rng(16);
  const GyroVector<double> truth = random_truth(rng, 1.0);
  const MoveSet<double> set = make_moves<double>(truth, truth.tail<3>(), 4, 0.0, rng);
  GyroSettings<double> settings;
  settings.nominal_scale = 1.0;
  GyroSolver<double> solver(settings);
  EXPECT_EQ(solver.start(set.data(), truth.tail<3>()), Status::kTooFewMoves);
  GyroCalibration<double> out;
  EXPECT_EQ(solver.finish(out), Status::kTooFewMoves);
  EXPECT_EQ(out.params, GyroVector<double>::Zero());
}

// Every move about the same axis: the other axes' scales are not observable.
TEST(GyroSolver, SingleAxisMovesAreRefused) {
  sim::Random rng(17);
  GyroVector<double> truth = random_truth(rng, 1.0);
  MoveSet<double> set = make_moves<double>(truth, truth.tail<3>(), 12, 0.003, rng);
  // Replace every segment by a rotation about x only.
  for (auto& seg : set.segments) {
    seg.alpha = Vector3<double>(seg.alpha.norm(), 0.0, 0.0);
    seg.beta.setZero();
    seg.gamma = Vector3<double>(seg.gamma.norm(), 0.0, 0.0);
  }
  GyroSettings<double> settings;
  settings.nominal_scale = 1.0;
  const GyroCalibration<double> c = solve<double>(set, truth.tail<3>(), settings);
  EXPECT_FALSE(succeeded(c.status)) << to_string(c.status);
}

}  // namespace
}  // namespace imucal
