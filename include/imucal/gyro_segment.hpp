// imucal/gyro_segment.hpp: second-order statistics of a short run of raw gyro samples (math.md
// section 4), so that the rotation over the run can be re-evaluated for ANY gyro matrix M and
// bias b (model w_cal = M (w_raw + b)) without keeping the samples: 10 numbers per segment.
// Sample steps may vary (logger jitter). Header-only, no allocation, no exceptions.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <cmath>
#include <cstdint>

#include "imucal/accel_model.hpp"

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

  // Appends the statistics of the run that directly follows this one: the result is exactly
  // the statistics of both runs' samples in order (the cross terms between the runs are
  // alpha_1 x alpha_2 and alpha_1 T_2 - alpha_2 T_1). add() is append() of one sample.
  void append(const GyroSegment& later) {
    beta += later.beta + alpha.cross(later.alpha);
    gamma += later.gamma + alpha * later.duration - later.alpha * duration;
    alpha += later.alpha;
    duration += later.duration;
  }

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

// exp([v]x) as a rotation matrix (Rodrigues), exact for any angle.
template <typename Scalar>
Matrix3<Scalar> rotation_exp(const Vector3<Scalar>& v) {
  const Scalar angle = v.norm();
  if (angle < Scalar(1e-12)) {
    Matrix3<Scalar> r = Matrix3<Scalar>::Identity();
    r(0, 1) = -v(2);
    r(0, 2) = v(1);
    r(1, 0) = v(2);
    r(1, 2) = -v(0);
    r(2, 0) = -v(1);
    r(2, 1) = v(0);
    return r;
  }
  return Eigen::AngleAxis<Scalar>(angle, v / angle).toRotationMatrix();
}

}  // namespace imucal
