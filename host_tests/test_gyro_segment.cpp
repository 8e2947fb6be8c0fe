// SPDX-License-Identifier: MIT
// Gyro segment statistics (math.md section 4) against the exact identity for re-evaluating the
// bias and matrix, and against a 4th-order Runge-Kutta quaternion reference on a coning move.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "imucal/calibrator/calibrator.hpp"
#include "imucal/sim/random.hpp"
#include "imucal/stream/gyro_segment.hpp"
#include "support/gtest_status.hpp"

namespace imucal {
namespace {

Matrix3<double> random_gyro_matrix(sim::Random& rng) {
  Matrix3<double> m = Matrix3<double>::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) += (r == c ? 0.03 : 0.015) * rng.uniform(-1, 1);
  return m;
}

// The float sin and cos behind a segment's rotation (elementary.hpp) against the double ones:
// within 2e-7 up to 8192 rad, finite beyond, NaN for NaN and infinities.
TEST(GyroSegment, FloatSinCosAreWithinTwoTenthsOfAMillionth) {
  double worst = 0;
  int n = 0;
  // Every 0.37 rad over the whole range, every 0.37 mrad over the first 8 rad: 88,000 values
  // (each compared with double sin and cos, soft float on most targets).
  for (double x = -8192.0; x <= 8192.0; x += 0.371) {
    for (const double xs : {x, x * 1e-3}) {
      const float xf = static_cast<float>(xs);
      float s = 0, c = 0;
      detail::sin_cos(xf, s, c);
      const double err = std::max(std::abs(double(s) - std::sin(double(xf))),
                                  std::abs(double(c) - std::cos(double(xf))));
      EXPECT_LE(err, 2e-7) << "x = " << xf;
      worst = std::max(worst, err);
      ++n;
    }
  }
  // The quadrant boundaries, exactly.
  for (int k = -8; k <= 8; ++k) {
    const float xf = static_cast<float>(k * 1.5707963267948966);
    float s = 0, c = 0;
    detail::sin_cos(xf, s, c);
    EXPECT_LE(std::abs(double(s) - std::sin(double(xf))), 2e-7) << "x = " << xf;
    EXPECT_LE(std::abs(double(c) - std::cos(double(xf))), 2e-7) << "x = " << xf;
  }
  std::printf("sin/cos: %d values, worst error %.3g\n", n, worst);
  float s = 0, c = 0;
  detail::sin_cos(1e6f, s, c);
  EXPECT_TRUE(std::isfinite(s) && std::isfinite(c) && std::abs(s) <= 1 && std::abs(c) <= 1);
  detail::sin_cos(std::numeric_limits<float>::infinity(), s, c);
  EXPECT_TRUE(std::isnan(s) && std::isnan(c));
  detail::sin_cos(std::numeric_limits<float>::quiet_NaN(), s, c);
  EXPECT_TRUE(std::isnan(s) && std::isnan(c));
}

// Statistics of raw samples re-evaluated for (M, b) equal the statistics of the calibrated
// samples M (w + b) evaluated for (I, 0): the bias and matrix transforms are exact algebra.
TEST(GyroSegment, ReEvaluationForAnyMatrixAndBiasIsExact) {
  sim::Random rng(1);
  for (int trial = 0; trial < 50; ++trial) {
    const Matrix3<double> m = random_gyro_matrix(rng);
    const Vector3<double> b = rng.normal3();
    GyroSegment<double> raw, calibrated;
    for (int k = 0; k < 12; ++k) {
      const Vector3<double> w = rng.normal3();
      const double dt = 0.01 * rng.uniform(0.9, 1.04);  // logger jitter
      raw.add(w, dt);
      calibrated.add(m * (w + b), dt);
    }
    const Vector3<double> a = raw.rotation_vector(m, b);
    const Vector3<double> c =
        calibrated.rotation_vector(Matrix3<double>::Identity(), Vector3<double>::Zero());
    EXPECT_LT((a - c).norm(), 1e-12 * c.norm()) << trial;
  }
}

// Appending the statistics of a later run equals adding its samples one by one: segments can
// be merged after the fact without the samples.
TEST(GyroSegment, AppendingARunEqualsAddingItsSamples) {
  sim::Random rng(5);
  GyroSegment<double> whole, first, second;
  for (int k = 0; k < 20; ++k) {
    const Vector3<double> w = rng.normal3();
    const double dt = 0.01 * rng.uniform(0.9, 1.1);
    whole.add(w, dt);
    (k < 7 ? first : second).add(w, dt);
  }
  first.append(second);
  EXPECT_LT((first.alpha - whole.alpha).norm(), 1e-15);
  EXPECT_LT((first.beta - whole.beta).norm(), 1e-15);
  EXPECT_LT((first.gamma - whole.gamma).norm(), 1e-15);
  EXPECT_NEAR(first.duration, whole.duration, 1e-15);
  EXPECT_GT(whole.beta.norm(), 1e-4);  // the cross terms are not trivially zero
  EXPECT_GT(whole.gamma.norm(), 1e-4);
}

TEST(GyroSegment, CofactorIsDeterminantTimesInverseTranspose) {
  sim::Random rng(2);
  const Matrix3<double> m = random_gyro_matrix(rng);
  const Matrix3<double> expected = m.determinant() * m.inverse().transpose();
  EXPECT_LT((GyroSegment<double>::cofactor(m) - expected).norm(), 1e-14);
}

// Coning: w(t) = (a cos ct, a sin ct, d), about 1 rad/s, 3 s: about 3 rad in all.
Vector3<double> coning_rate(double t) {
  return {0.6 * std::cos(2.0 * t), 0.6 * std::sin(2.0 * t), 0.8};
}

// RK4 on q' = 1/2 q (x) (0, w), body frame, rates interpolated linearly between samples.
Eigen::Quaterniond rk4_step(const Eigen::Quaterniond& q, const Vector3<double>& w0,
                            const Vector3<double>& w1, double h) {
  auto f = [](const Eigen::Vector4d& qc, const Vector3<double>& w) {
    const Eigen::Quaterniond qq(qc(3), qc(0), qc(1), qc(2));
    const Eigen::Quaterniond d = qq * Eigen::Quaterniond(0.0, w(0), w(1), w(2));
    return Eigen::Vector4d(0.5 * d.x(), 0.5 * d.y(), 0.5 * d.z(), 0.5 * d.w());
  };
  const Eigen::Vector4d y = q.coeffs();  // x y z w
  const Vector3<double> wm = 0.5 * (w0 + w1);
  const Eigen::Vector4d k1 = f(y, w0);
  const Eigen::Vector4d k2 = f(y + 0.5 * h * k1, wm);
  const Eigen::Vector4d k3 = f(y + 0.5 * h * k2, wm);
  const Eigen::Vector4d k4 = f(y + h * k3, w1);
  const Eigen::Vector4d n = y + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
  return Eigen::Quaterniond(n(3), n(0), n(1), n(2)).normalized();
}

struct MoveResult {
  double second_order_error;  // rad vs RK4: segments with the Magnus term
  double first_order_error;   // rad vs RK4: the same segments with M alpha_b only
  double truncation_error;    // rad vs the exact product of the per-interval exponentials
  int segments;
};

// A raw gyro (true rate w = M (w_raw + b)) sampled at ~100 Hz with jitter over the coning move;
// segments are closed when |alpha| passes theta_max. Both results against the RK4 reference.
MoveResult coning_move(double theta_max, const Matrix3<double>& m, const Vector3<double>& b) {
  sim::Random rng(3);
  double t = 0.0;
  Vector3<double> w_prev = coning_rate(0.0);
  const Matrix3<double> m_inv = m.inverse();
  Vector3<double> raw_prev = m_inv * w_prev - b;
  Eigen::Quaterniond ref = Eigen::Quaterniond::Identity();
  Matrix3<double> r2 = Matrix3<double>::Identity(), r1 = Matrix3<double>::Identity();
  Matrix3<double> exact = Matrix3<double>::Identity();
  GyroSegment<double> seg;
  int segments = 0;
  auto close = [&]() {
    r2 = r2 * rotation_exp(seg.rotation_vector(m, b));
    r1 = r1 * rotation_exp(Vector3<double>(m * (seg.alpha + seg.duration * b)));
    seg = GyroSegment<double>{};
    ++segments;
  };
  while (t < 3.0) {
    const double dt = 0.01 * rng.uniform(0.95, 1.05);
    const Vector3<double> w_next = coning_rate(t + dt);
    const Vector3<double> raw_next = m_inv * w_next - b;
    ref = rk4_step(ref, w_prev, w_next, dt);
    // The rate over the interval: the mean of its two end samples (as RK4's midpoint).
    seg.add(0.5 * (raw_prev + raw_next), dt);
    exact = exact * rotation_exp(Vector3<double>(m * (0.5 * (raw_prev + raw_next) + b) * dt));
    if (seg.rotation_vector(m, b).norm() > theta_max) close();
    t += dt;
    w_prev = w_next;
    raw_prev = raw_next;
  }
  if (seg.duration > 0.0) close();
  const Matrix3<double> rref = ref.toRotationMatrix();
  return {Eigen::AngleAxisd(r2.transpose() * rref).angle(),
          Eigen::AngleAxisd(r1.transpose() * rref).angle(),
          Eigen::AngleAxisd(r2.transpose() * exact).angle(), segments};
}

TEST(GyroSegment, MatchesTheRk4ReferenceOnAConingMove) {
  sim::Random rng(4);
  const Matrix3<double> m = random_gyro_matrix(rng);
  const Vector3<double> b(0.01, -0.02, 0.015);
  const MoveResult r = coning_move(0.1, m, b);
  std::printf("theta_max 0.1: %d segments, error %.2e rad (first order only %.2e rad)\n",
              r.segments, r.second_order_error, r.first_order_error);
  EXPECT_LT(r.second_order_error, 1e-4);
  EXPECT_GT(r.first_order_error, 1e-3);  // the second-order term is what makes it work
  EXPECT_GT(r.segments, 20);
  EXPECT_LT(r.segments, 50);
}

// Against the exact product of the per-interval exponentials (what the segments summarise), the
// truncation error of the second-order expansion falls steeply with the threshold; against RK4
// a floor of ~1e-5 rad remains: held mean rates vs RK4's linear interpolation between samples.
TEST(GyroSegment, TruncationErrorShrinksWithTheSegmentThreshold) {
  const Matrix3<double> m = Matrix3<double>::Identity();
  const Vector3<double> b = Vector3<double>::Zero();
  const MoveResult coarse = coning_move(0.4, m, b);
  const MoveResult medium = coning_move(0.1, m, b);
  const MoveResult fine = coning_move(0.05, m, b);
  std::printf("truncation error: theta 0.4 %.2e, 0.1 %.2e, 0.05 %.2e rad\n",
              coarse.truncation_error, medium.truncation_error, fine.truncation_error);
  EXPECT_LT(medium.truncation_error, coarse.truncation_error / 10.0);
  EXPECT_LT(fine.truncation_error, medium.truncation_error / 2.0);
  EXPECT_LT(medium.truncation_error, 1e-4);
}

// The calibrator's own segmentation with its default bounds (segment_max_angle, segment_max_error,
// merging of blocks) on the coning move between two rests, against RK4 on every sample over
// the same span (from the first pose's last sample to the second pose's first): below 1e-4 rad.
// (A template, instantiated only where the library has its double solvers.)
template <int kUnused = 0>
void calibrator_default_segments_match_rk4() {
  sim::Random rng(6);
  Calibrator<double> cal;  // SI units: M = I, b = 0
  const Vector3<double> up(0.0, 0.0, 9.81);
  std::vector<double> times;
  std::vector<Vector3<double>> rates;
  double t = 0.0;
  std::uint32_t t_us = 0;
  Matrix3<double> attitude = Matrix3<double>::Identity();
  auto feed = [&](const Vector3<double>& w, bool moving) {
    ImuSample<double> s;
    s.t_us = t_us;
    // Tiny noise: a noise-free sensor would be taken for a frozen one.
    s.acc = attitude.transpose() * up + 1e-3 * rng.normal3();
    if (moving) s.acc += Vector3<double>(0.5, -0.3, 0.2);
    s.gyro = w + 1e-7 * rng.normal3();
    times.push_back(t);
    rates.push_back(s.gyro);
    cal.add(s);
  };
  auto step = [&]() {
    const double dt = 0.01 * rng.uniform(0.95, 1.05);
    t += dt;
    t_us = static_cast<std::uint32_t>(std::llround(t * 1e6));
    return dt;
  };
  feed(Vector3<double>::Zero(), false);
  while (t < 12.0) {
    step();
    feed(Vector3<double>::Zero(), false);
  }  // initial rest (10 s)
  const double move_start = t;
  while (t < move_start + 3.0) {
    const double dt = step();
    const Vector3<double> w = coning_rate(t - move_start) *
                              std::pow(std::sin(3.141592653589793 * (t - move_start) / 3.0), 2);
    attitude = attitude * rotation_exp(Vector3<double>(w * dt));
    feed(w, true);
  }
  const double rest_start = t;
  while (t < rest_start + 4.0) {
    step();
    feed(Vector3<double>::Zero(), false);
  }
  // A last turn ends the second rest, which makes it a pose and closes the move.
  const double last = t;
  while (t < last + 1.0) {
    step();
    feed(Vector3<double>(0.0, 1.0, 0.0), true);
  }
  ASSERT_EQ(cal.progress().poses, 2);
  ASSERT_EQ(cal.move_count(), 1);
  const GyroMove& mv = cal.move(0);
  Matrix3<double> r = Matrix3<double>::Identity();
  for (int k = 0; k < mv.segments; ++k)
    r = r *
        rotation_exp(cal.segment(mv.first_segment + k)
                         .rotation_vector(Matrix3<double>::Identity(), Vector3<double>::Zero()));
  // RK4 over the same span: the pose times are sample times.
  const double from = cal.pose_end_us(0) * 1e-6, to = cal.pose_begin_us(1) * 1e-6;
  Eigen::Quaterniond ref = Eigen::Quaterniond::Identity();
  std::size_t i = 0;
  while (times[i] < from - 1e-7) ++i;
  for (; i + 1 < times.size() && times[i + 1] <= to + 1e-7; ++i)
    ref = rk4_step(ref, rates[i], rates[i + 1], times[i + 1] - times[i]);
  const double error = Eigen::AngleAxisd(r.transpose() * ref.toRotationMatrix()).angle();
  const double angle = Eigen::AngleAxisd(ref.toRotationMatrix()).angle();
  std::printf("calibrator defaults: %d segments over a %.2f rad coning move, error %.2e rad\n",
              mv.segments, angle, error);
  EXPECT_GT(angle, 1.0);
  EXPECT_LT(error, 1e-4);
}

TEST(GyroSegment, CalibratorDefaultSegmentsMatchRk4OnAConingMove) {
#ifdef IMUCAL_FLOAT_ONLY
  GTEST_SKIP() << "the double calibrator: not in a float-only build (IMUCAL_FLOAT_ONLY)";
#else
  calibrator_default_segments_match_rk4();
#endif
}

}  // namespace
}  // namespace imucal
