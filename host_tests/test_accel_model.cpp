// SPDX-License-Identifier: MIT
// The seed's analytic Jacobian of e = |g|^2 - |T K (a + b)|^2, and that of the calibrated gravity
// direction, against central differences.
#include <gtest/gtest.h>

#include <cmath>

#include "imucal/models/accel_model.hpp"
#include "imucal/sim/accel_sim.hpp"
#include "support/gtest_status.hpp"

namespace imucal {
namespace {

// e is quadratic in each single parameter (c is linear in each), so central differences are exact
// up to rounding: a large step keeps the rounding error far below the 1e-7 tolerance. Steps:
// 0.01 rad for a misalignment, 1 % of a scale, and 0.01 m/s^2 (in sensor units) for a bias.
AccelVector<double> central_differences(const AccelVector<double>& p, const Vector3<double>& a,
                                        double g) {
  AccelVector<double> j;
  for (int k = 0; k < kAccelParams; ++k) {
    const double h = k < kScaleX  ? 0.01
                     : k < kBiasX ? 0.01 * std::abs(p(k))
                                  : 0.01 / std::abs(p(k - 3));
    AccelVector<double> hi = p, lo = p;
    hi(k) += h;
    lo(k) -= h;
    j(k) = (accel_residual(hi, a, g) - accel_residual(lo, a, g)) / (2 * h);
  }
  return j;
}

void expect_jacobian_matches(const sim::AccelSensorSpec& spec, std::uint64_t seed) {
  sim::Random rng(seed);
  for (int trial = 0; trial < 200; ++trial) {
    const sim::AccelTruth t = sim::draw_accel_truth(spec, rng);
    // Readings near gravity, and the parameters away from the truth, so e != 0.
    const Vector3<double> a = sim::raw_from_calibrated(t, 9.8 * sim::random_direction(rng));
    // Away from the truth (so e != 0): 0.01 rad, 2 % of scale, 0.05 m/s^2 of bias.
    AccelVector<double> p = t.params;
    for (int k = 0; k < 3; ++k) {
      p(kAlphaYz + k) += 0.01 * rng.normal();
      p(kScaleX + k) *= 1.0 + 0.02 * rng.normal();
      p(kBiasX + k) += 0.05 * rng.normal() / spec.nominal_scale;
    }
    AccelVector<double> analytic;
    accel_residual(p, a, 9.81, &analytic);
    const AccelVector<double> numeric = central_differences(p, a, 9.81);
    const double row_scale = numeric.cwiseAbs().maxCoeff();
    for (int k = 0; k < kAccelParams; ++k) {
      const double rel =
          std::abs(analytic(k) - numeric(k)) / std::max(std::abs(numeric(k)), 1e-9 * row_scale);
      EXPECT_LT(rel, 1e-7) << "parameter " << k << " trial " << trial << " analytic " << analytic(k)
                           << " numeric " << numeric(k);
    }
  }
}

TEST(AccelJacobian, MatchesCentralDifferencesSiUnits) {
  expect_jacobian_matches(sim::AccelSensorSpec::si(), 11);
}

TEST(AccelJacobian, MatchesCentralDifferencesRawCounts) {
  expect_jacobian_matches(sim::AccelSensorSpec::raw_counts(), 12);
}

// The seed's printed derivation of de/d(alpha_yz) differentiates +alpha_yz s_y (a_y + b_y) where
// c_x holds -alpha_yz s_y (a_y + b_y): read literally it gives -2 c_x u_y. The correct derivative
// (math.md's table, and the code) is +2 c_x u_y. This pins the sign with numbers.
TEST(AccelJacobian, AlphaYzSignIsPlusTwoCxUy) {
  AccelVector<double> p;
  p << 0.01, -0.02, 0.015, 1.02, 0.98, 1.01, 0.1, -0.2, 0.05;
  const Vector3<double> a(3.0, 5.0, 7.0);
  AccelVector<double> j;
  accel_residual(p, a, 9.81, &j);
  const double uy = p(kScaleY) * (a(1) + p(kBiasY));
  const Vector3<double> c = accel_apply(p, a);
  const double numeric = central_differences(p, a, 9.81)(kAlphaYz);
  EXPECT_NEAR(j(kAlphaYz), 2 * c(0) * uy, 1e-12 * std::abs(numeric));
  EXPECT_NEAR(numeric, 2 * c(0) * uy, 1e-7 * std::abs(numeric));
  EXPECT_GT(std::abs(numeric - (-2 * c(0) * uy)), 1.0);  // the literal reading is wrong
}

// The calibrated gravity direction's Jacobian (what carries the accelerometer's uncertainty into
// the gyro's sigma) against central differences of the normalised calibrated reading, in SI
// units and raw counts.
void expect_direction_jacobian_matches(const sim::AccelSensorSpec& spec, std::uint64_t seed) {
  sim::Random rng(seed);
  for (int trial = 0; trial < 100; ++trial) {
    const sim::AccelTruth t = sim::draw_accel_truth(spec, rng);
    const Vector3<double> a = sim::raw_from_calibrated(t, 9.8 * sim::random_direction(rng));
    const AccelVector<double>& p = t.params;
    const AccelDirectionJacobian<double> analytic = accel_direction_jacobian(p, a);
    for (int k = 0; k < kAccelParams; ++k) {
      // Small steps: the direction is not quadratic in a parameter. 1e-5 of a misalignment, of a
      // scale, and of gravity for a bias, in sensor units.
      const double h = k < kScaleX  ? 1e-5
                       : k < kBiasX ? 1e-5 * std::abs(p(k))
                                    : 1e-4 / std::abs(p(k - 3));
      AccelVector<double> hi = p, lo = p;
      hi(k) += h;
      lo(k) -= h;
      const Vector3<double> numeric =
          (accel_apply(hi, a).normalized() - accel_apply(lo, a).normalized()) / (2 * h);
      const double size = std::max(numeric.norm(), 1e-12);
      EXPECT_LT((analytic.col(k) - numeric).norm() / size, 1e-6)
          << "parameter " << k << " trial " << trial;
      // Perpendicular to the direction: a unit vector moves only sideways.
      EXPECT_LT(std::abs(accel_apply(p, a).normalized().dot(analytic.col(k))), 1e-9 * size + 1e-15);
    }
  }
}

TEST(AccelDirectionJacobian, MatchesCentralDifferencesSiUnits) {
  expect_direction_jacobian_matches(sim::AccelSensorSpec::si(), 13);
}

TEST(AccelDirectionJacobian, MatchesCentralDifferencesRawCounts) {
  expect_direction_jacobian_matches(sim::AccelSensorSpec::raw_counts(), 14);
}

TEST(AccelModel, ResidualIsGravityNormError) {
  AccelVector<double> p;
  p << 0.0, 0.0, 0.0, 2.0, 2.0, 2.0, 1.0, 0.0, 0.0;
  // a_cal = 2 * ((3,0,0) + (1,0,0)) = (8,0,0): e = 9^2 - 8^2 = 17.
  EXPECT_DOUBLE_EQ(accel_residual(p, Vector3<double>(3, 0, 0), 9.0), 17.0);
  const Vector3<double> c = accel_apply(p, Vector3<double>(3, 0, 0));
  EXPECT_DOUBLE_EQ(c(0), 8.0);
}

}  // namespace
}  // namespace imucal
