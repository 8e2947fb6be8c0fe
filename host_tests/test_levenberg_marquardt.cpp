// SPDX-License-Identifier: MIT
// The LM driver on problems with known minima: convergence, time slicing, stopping reasons.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <limits>

#include "imucal/solve/levenberg_marquardt.hpp"
#include "support/gtest_status.hpp"

namespace imucal {
namespace {

// Rosenbrock as least squares: r1 = 10 (y - x^2), r2 = 1 - x. Minimum at (1, 1), f = 0.
struct Rosenbrock {
  template <typename Scalar>
  Status accumulate(const Eigen::Matrix<Scalar, 2, 1>& p, NormalEquations<Scalar, 2>& ne) const {
    Status s = ne.add(Eigen::Matrix<Scalar, 2, 1>(Scalar(-20) * p(0), Scalar(10)),
                      Scalar(10) * (p(1) - p(0) * p(0)));
    if (s != Status::kOk) return s;
    return ne.add(Eigen::Matrix<Scalar, 2, 1>(Scalar(-1), Scalar(0)), Scalar(1) - p(0));
  }
};

// Exponential decay y = A exp(-k t) + noise-free data: a small-residual fit with a unique minimum.
// Its two unknowns in an LM of capacity N (entries from the third on unused). The data are one
// table for every N: the compiler may fold the constant expressions of each instantiation
// differently from the target's libm (it did on the Cortex-M7, in the last bit).
const std::array<double, 20> kDecayData = [] {
  std::array<double, 20> y{};
  for (int i = 0; i < 20; ++i) {
    const double t = 0.25 * i;
    y[static_cast<std::size_t>(i)] = 3.0 * std::exp(-0.7 * t) + 0.01 * std::sin(5.0 * i);
  }
  return y;
}();

template <int N>
struct ExpDecayIn {
  Status accumulate(const Eigen::Matrix<double, N, 1>& p, NormalEquations<double, N>& ne) const {
    for (int i = 0; i < 20; ++i) {
      const double t = 0.25 * i;
      const double y = kDecayData[static_cast<std::size_t>(i)];
      const double m = p(0) * std::exp(-p(1) * t);
      const Status s = ne.add(Eigen::Vector2d(std::exp(-p(1) * t), -t * m), m - y);
      if (s != Status::kOk) return s;
    }
    return Status::kOk;
  }
};
using ExpDecay = ExpDecayIn<2>;

TEST(LevenbergMarquardt, SolvesRosenbrockInDoubleAndFloat) {
  LevenbergMarquardt<double, 2> lm;
  EXPECT_TRUE(succeeded(lm.run(Rosenbrock{}, Eigen::Vector2d(-1.2, 1.0))));
  EXPECT_NEAR(lm.parameters()(0), 1.0, 1e-8);
  EXPECT_NEAR(lm.parameters()(1), 1.0, 1e-8);

  LevenbergMarquardt<float, 2> lmf;
  EXPECT_TRUE(succeeded(lmf.run(Rosenbrock{}, Eigen::Vector2f(-1.2f, 1.0f))));
  EXPECT_NEAR(lmf.parameters()(0), 1.0f, 1e-3f);
  EXPECT_NEAR(lmf.parameters()(1), 1.0f, 2e-3f);
}

TEST(LevenbergMarquardt, TimeSlicedStepsGiveTheSameAnswer) {
  LevenbergMarquardt<double, 2> whole;
  const Status final_status = whole.run(ExpDecay{}, Eigen::Vector2d(1.0, 0.1));
  ASSERT_TRUE(succeeded(final_status)) << to_string(final_status);

  LevenbergMarquardt<double, 2> sliced;
  Status s = sliced.start(ExpDecay{}, Eigen::Vector2d(1.0, 0.1));
  int calls = 0;
  while (s == Status::kRunning) {
    s = sliced.step(ExpDecay{});
    ++calls;
    ASSERT_LE(calls, sliced.settings().max_iterations);
  }
  EXPECT_EQ(s, final_status);
  EXPECT_EQ(calls, sliced.iterations());
  EXPECT_EQ(sliced.parameters(), whole.parameters());
  EXPECT_NEAR(sliced.parameters()(0), 3.0, 0.02);
  EXPECT_NEAR(sliced.parameters()(1), 0.7, 0.01);
  // Further calls after the end change nothing and repeat the reason.
  EXPECT_EQ(sliced.step(ExpDecay{}), final_status);
  EXPECT_EQ(sliced.iterations(), calls);
}

TEST(LevenbergMarquardt, StoppingReasons) {
  LevenbergMarquardt<double, 2> not_started;
  EXPECT_EQ(not_started.step(ExpDecay{}), Status::kNotStarted);

  LmSettings<double> one;
  one.max_iterations = 1;
  LevenbergMarquardt<double, 2> capped(one);
  EXPECT_EQ(capped.run(Rosenbrock{}, Eigen::Vector2d(-1.2, 1.0)), Status::kMaxIterations);
  EXPECT_TRUE(capped.parameters().allFinite());

  LevenbergMarquardt<double, 2> bad_start;
  EXPECT_EQ(bad_start.run(Rosenbrock{}, Eigen::Vector2d(NAN, 1.0)), Status::kNonFiniteInput);

  LmSettings<double> bad;
  bad.initial_lambda = -1.0;
  LevenbergMarquardt<double, 2> bad_settings(bad);
  EXPECT_EQ(bad_settings.run(Rosenbrock{}, Eigen::Vector2d(0, 0)), Status::kInvalidArgument);

  LevenbergMarquardt<double, 2> bad_size;
  EXPECT_EQ(bad_size.begin(Eigen::Vector2d(0, 0), 3), Status::kInvalidArgument);
  EXPECT_EQ(bad_size.begin(Eigen::Vector2d(0, 0), 0), Status::kInvalidArgument);
}

// The minimum (x = 5) lies beyond a wall of NaN at x = 2: the driver creeps up to the wall with
// ever more damping. Those shrinking steps must not be reported as convergence, in either type.
template <typename Scalar>
struct NanBeyondTwo {
  using V = Eigen::Matrix<Scalar, 1, 1>;
  Status accumulate(const V& p, NormalEquations<Scalar, 1>& ne) const {
    const Scalar e = p(0) > Scalar(2) ? std::numeric_limits<Scalar>::quiet_NaN() : p(0) - Scalar(5);
    return ne.add(V(Scalar(1)), e);
  }
};

template <typename Scalar>
void expect_not_converged_at_the_wall() {
  LevenbergMarquardt<Scalar, 1> lm;
  const Status s = lm.run(NanBeyondTwo<Scalar>{}, Eigen::Matrix<Scalar, 1, 1>(Scalar(0)));
  EXPECT_FALSE(succeeded(s)) << to_string(s);
  EXPECT_TRUE(s == Status::kMaxIterations || s == Status::kNoProgress) << to_string(s);
  EXPECT_TRUE(std::isfinite(lm.parameters()(0)));
  EXPECT_LE(lm.parameters()(0), Scalar(2));
  EXPECT_TRUE(std::isfinite(lm.normal_equations().weighted_sse()));
}

TEST(LevenbergMarquardt, NeverAcceptsAStepIntoNaNNorCallsTheWallConvergence) {
  expect_not_converged_at_the_wall<double>();
  expect_not_converged_at_the_wall<float>();
}

// A Jacobian of the wrong sign: every step raises the cost, damping runs out: kNoProgress.
struct WrongSign {
  Status accumulate(const Eigen::Vector2d& p, NormalEquations<double, 2>& ne) const {
    Status s = ne.add(Eigen::Vector2d(-1.0, 0.0), p(0) - 3.0);
    if (s != Status::kOk) return s;
    return ne.add(Eigen::Vector2d(0.0, -1.0), p(1) + 1.0);
  }
};

TEST(LevenbergMarquardt, AProblemThatCannotDecreaseReportsNoProgress) {
  LmSettings<double> settings;
  settings.max_iterations = 100;
  LevenbergMarquardt<double, 2> lm(settings);
  EXPECT_EQ(lm.run(WrongSign{}, Eigen::Vector2d(0.0, 0.0)), Status::kNoProgress);
  EXPECT_EQ(lm.parameters(), Eigen::Vector2d(0.0, 0.0));
}

// Residuals that overflow float: refused, never summed into an infinite cost.
struct Overflowing {
  Status accumulate(const Eigen::Vector2f& p, NormalEquations<float, 2>& ne) const {
    return ne.add(Eigen::Vector2f(1.0f, 1.0f), 1e20f + p(0));
  }
};

TEST(LevenbergMarquardt, AnOverflowingCostIsRefusedNotConverged) {
  LevenbergMarquardt<float, 2> lm;
  EXPECT_EQ(lm.run(Overflowing{}, Eigen::Vector2f(0.0f, 0.0f)), Status::kNonFiniteInput);
  EXPECT_TRUE(std::isfinite(lm.normal_equations().weighted_sse()));
}

// A parameter nothing depends on: the damped solve cannot cure it, so the run ends at once.
struct Unobservable {
  Status accumulate(const Eigen::Vector2d& p, NormalEquations<double, 2>& ne) const {
    return ne.add(Eigen::Vector2d(1.0, 0.0), p(0) - 1.0);
  }
};

TEST(LevenbergMarquardt, ARankDeficientProblemStopsWithThatReason) {
  LevenbergMarquardt<double, 2> lm;
  EXPECT_EQ(lm.run(Unobservable{}, Eigen::Vector2d(0.0, 0.0)), Status::kRankDeficient);
  EXPECT_EQ(lm.iterations(), 1);
}

// The same two-parameter fit in an LM of capacity 3 run at size 2 (as the accelerometer's 9 run in
// the gyro's 12): its own two-entry rows, the third parameter untouched, the same answer bit for
// bit.
TEST(LevenbergMarquardt, AProblemSmallerThanTheCapacitySolvesAsItsOwnSize) {
  LevenbergMarquardt<double, 2> own;
  const Status s2 = own.run(ExpDecay{}, Eigen::Vector2d(1.0, 0.1));
  ASSERT_TRUE(succeeded(s2)) << to_string(s2);
  LevenbergMarquardt<double, 3> wide;
  Status s3 = wide.start(ExpDecayIn<3>{}, Eigen::Vector2d(1.0, 0.1));  // its own p0: size 2
  while (s3 == Status::kRunning) s3 = wide.step(ExpDecayIn<3>{});
  EXPECT_EQ(s3, s2);
  EXPECT_EQ(wide.iterations(), own.iterations());
  EXPECT_EQ(wide.parameters().head<2>(), own.parameters());
  EXPECT_EQ(wide.parameters()(2), 0.0);
  EXPECT_EQ(wide.normal_equations().weighted_sse(), own.normal_equations().weighted_sse());
}

// reset(settings) is a new solver in place: not started, and its next run that of a new one.
TEST(LevenbergMarquardt, ResetIsANewSolverWithTheNewSettings) {
  LmSettings<double> few;
  few.max_iterations = 2;
  LevenbergMarquardt<double, 2> fresh(few);
  const Status expected = fresh.run(ExpDecay{}, Eigen::Vector2d(1.0, 0.1));
  ASSERT_EQ(expected, Status::kMaxIterations);

  LevenbergMarquardt<double, 2> reused;
  ASSERT_TRUE(succeeded(reused.run(ExpDecay{}, Eigen::Vector2d(1.0, 0.1))));
  ASSERT_GT(reused.iterations(), 2);
  reused.reset(few);
  EXPECT_EQ(reused.status(), Status::kNotStarted);
  EXPECT_EQ(reused.iterations(), 0);
  EXPECT_EQ(reused.parameters(), Eigen::Vector2d::Zero());
  EXPECT_EQ(reused.step(ExpDecay{}), Status::kNotStarted);
  EXPECT_EQ(reused.run(ExpDecay{}, Eigen::Vector2d(1.0, 0.1)), expected);
  EXPECT_EQ(reused.iterations(), fresh.iterations());
  EXPECT_EQ(reused.parameters(), fresh.parameters());
}

}  // namespace
}  // namespace imucal
