// SPDX-License-Identifier: MIT
// imucal/stream/gyro_segment.hpp: second-order statistics of a short run of raw gyro samples
// (math.md section 4), so that the rotation over the run can be re-evaluated for ANY gyro matrix M
// and bias b (model w_cal = M (w_raw + b)) without keeping the samples: 10 numbers per segment.
// Sample steps may vary (logger jitter). Header-only, no allocation, no exceptions.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross()
#include <Eigen/LU>
#include <cmath>
#include <cstdint>

#include "imucal/models/accel_model.hpp"
#include "imucal/solve/elementary.hpp"

namespace imucal {

template <typename Scalar>
struct GyroSegment {
  Vector3<Scalar> alpha = Vector3<Scalar>::Zero();  // sum w_k dt_k                    (rad)
  Vector3<Scalar> beta = Vector3<Scalar>::Zero();   // sum_{k<l} (w_k dt_k) x (w_l dt_l) (rad^2)
  Vector3<Scalar> gamma = Vector3<Scalar>::Zero();  // sum_{k<l} dt_k dt_l (w_k - w_l)  (rad s)
  Scalar duration = Scalar(0);                      // sum dt_k                          (s)
  // No sample count: the duration is what the bias needs, and 40 bytes (float) instead of 44
  // is 64 more segments in the calibrator's default store.

  // Folds in one raw rate w (sensor units) held for dt seconds. B and C take the running sums
  // before they include this sample: the earlier sample stands on the left of each cross product,
  // which matches right-multiplied (body-frame) composition R = R_1 R_2 ... R_n.
  void add(const Vector3<Scalar>& w, Scalar dt) {
    // Written per component: this runs once per sample on the device (bench_stream).
    const Scalar sx = w(0) * dt, sy = w(1) * dt, sz = w(2) * dt;
    const Scalar ax = alpha(0), ay = alpha(1), az = alpha(2), t = duration;
    beta(0) += ay * sz - az * sy;
    beta(1) += az * sx - ax * sz;
    beta(2) += ax * sy - ay * sx;
    gamma(0) += ax * dt - sx * t;
    gamma(1) += ay * dt - sy * t;
    gamma(2) += az * dt - sz * t;
    alpha(0) = ax + sx;
    alpha(1) = ay + sy;
    alpha(2) = az + sz;
    duration = t + dt;
  }

  // Folds in w held for dt to first order: alpha and the duration only (a still sub-block's,
  // stream/sub_block.hpp).
  void add_first_order(const Vector3<Scalar>& w, Scalar dt) {
    alpha += w * dt;
    duration += dt;
  }

  // Appends the statistics of the run that directly follows this one: the result is exactly
  // the statistics of both runs' samples in order (the cross terms between the runs are
  // alpha_1 x alpha_2 and alpha_1 T_2 - alpha_2 T_1). add() is append() of one sample.
  void append(const GyroSegment& later) {
    beta += later.beta + alpha.cross(later.alpha);
    gamma += later.gamma + alpha * later.duration - later.alpha * duration;
    alpha += later.alpha;
    duration += later.duration;
  }

  // The same samples with db added to every rate (exact: gamma does not change).
  void add_bias(const Vector3<Scalar>& db) {
    beta += gamma.cross(db);
    alpha += duration * db;
  }
  // add_bias() of a first-order segment (add_first_order()'s: beta and gamma zero, and stay so).
  void add_bias_first_order(const Vector3<Scalar>& db) { alpha += duration * db; }

  // The segment's rotation vector for the model w_cal = M (w_raw + b), to second order
  // (Magnus/BCH): Omega = M alpha_b + 1/2 cof(M) beta_b with alpha_b = alpha + T b and
  // beta_b = B + C x b (exact: the b x b terms vanish), cof(M) = det(M) M^-T.
  Vector3<Scalar> rotation_vector(const Matrix3<Scalar>& m, const Vector3<Scalar>& b) const {
    const Vector3<Scalar> alpha_b = alpha + duration * b;
    const Vector3<Scalar> beta_b = beta + gamma.cross(b);
    const Matrix3<Scalar> cof = cofactor(m);
    return m * alpha_b + Scalar(0.5) * (cof * beta_b);
  }

  static Matrix3<Scalar> cofactor(const Matrix3<Scalar>& m) {
    Matrix3<Scalar> c;
    c.col(0) = m.col(1).cross(m.col(2));
    c.col(1) = m.col(2).cross(m.col(0));
    c.col(2) = m.col(0).cross(m.col(1));
    return c;  // det(M) M^-T, without dividing by det(M)
  }
};

// The bounds a new segment is held to: its path angle, the square of |alpha||beta|, and the path
// angle below which |alpha||beta| cannot reach its bound (|alpha| <= path and |beta| <= path^2 /
// 2, so |alpha||beta| <= path^3 / 2; 0.9^3 of it, a margin for rounding).
template <typename Scalar>
struct SegmentBounds {
  Scalar max_angle = Scalar(0), max_error = Scalar(0), max_error2 = Scalar(0);
  Scalar error_free_path = Scalar(0);

  void set(Scalar angle, Scalar error) {
    max_angle = angle;
    set_error(error);
  }
  void set_error(Scalar e) {
    max_error = e;
    max_error2 = e * e;
    error_free_path = Scalar(0.9) * std::cbrt(Scalar(2) * e);
  }
};

// Rodrigues coefficients of the rotation vector w, theta = |w|:
//   a = sin(theta)/theta, b = (1 - cos(theta))/theta^2, c = (theta - sin(theta))/theta^3.
// exp([w]x) = I + a [w]x + b [w]x^2 and the left Jacobian J_l = I + b [w]x + c [w]x^2.
// Below 0.2 rad the series is exact to float precision and avoids 0/0 and cancellation.
template <typename Scalar>
void rodrigues_coefficients(Scalar theta2, Scalar& a, Scalar& b, Scalar& c) {
  if (theta2 < Scalar(0.04)) {
    const Scalar t4 = theta2 * theta2;
    a = Scalar(1) - theta2 / Scalar(6) + t4 / Scalar(120) - t4 * theta2 / Scalar(5040);
    b = Scalar(0.5) - theta2 / Scalar(24) + t4 / Scalar(720) - t4 * theta2 / Scalar(40320);
    c = Scalar(1) / Scalar(6) - theta2 / Scalar(120) + t4 / Scalar(5040) -
        t4 * theta2 / Scalar(362880);
    return;
  }
  const Scalar theta = std::sqrt(theta2);
  Scalar s, co;
  detail::sin_cos(theta, s, co);
  a = s / theta;
  b = (Scalar(1) - co) / theta2;
  c = (theta - s) / (theta2 * theta);
}

template <typename Scalar>
Matrix3<Scalar> skew(const Vector3<Scalar>& v) {
  Matrix3<Scalar> s;
  s << Scalar(0), -v(2), v(1), v(2), Scalar(0), -v(0), -v(1), v(0), Scalar(0);
  return s;
}

// exp([v]x) as a rotation matrix (Rodrigues), exact for any angle.
template <typename Scalar>
Matrix3<Scalar> rotation_exp(const Vector3<Scalar>& v) {
  Scalar a, b, c;
  rodrigues_coefficients(v.squaredNorm(), a, b, c);
  const Matrix3<Scalar> w = skew(v);
  return Matrix3<Scalar>::Identity() + a * w + b * (w * w);
}

}  // namespace imucal
