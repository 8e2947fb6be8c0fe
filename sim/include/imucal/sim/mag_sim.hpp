// SPDX-License-Identifier: MIT
// imucal/sim/mag_sim.hpp: simulated magnetometer readings with known truth (hard iron, symmetric
// soft iron, field strength and dip, and a small rotation to the accelerometer frame), and a
// free-hand rotation generator (a smooth random walk of attitudes: all round, about one body axis
// only, or within a cap). Double precision, host and test code only; no sample is stored.
//
// Conventions. C is the body (= accelerometer) to world attitude, world z up, x north. The world
// field is field_ut (cos dip, 0, -sin dip): dip > 0 points below the horizon. The accelerometer
// reads +g up at rest (C^T e_z g). The magnetometer's frame is rotated from the body's by R_true:
// m_body = R_true m_mag. Its raw reading is raw = S_true^-1 m_mag - h_true (+ noise), with S_true
// symmetric and det(S_true) = unit_ut^3, so |S_true (raw + h_true)| = field_ut exactly for a
// noise-free reading: the normalisation of imucal's model (mag_model.hpp), so the truth compares
// directly with the fit (an overall sensor gain is not separable from the field strength).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <cmath>

#include "imucal/models/accel_model.hpp"
#include "imucal/models/mag_model.hpp"
#include "imucal/sim/random.hpp"

namespace imucal::sim {

struct MagSensorSpec {
  double unit_ut;       // uT per raw unit (1: readings in uT; 0.15 for counts of a 16-bit part)
  double field_ut;      // local field strength, uT
  double dip_deg;       // inclination, degrees (positive: field below the horizon)
  double scale_spread;  // relative, uniform +- on the soft iron's diagonal (before normalising)
  double off_diagonal;  // relative, uniform +- on its off-diagonal entries (5-10 %)
  double hard_iron;     // raw units, uniform +- per axis
  double noise;         // per-sample white noise, raw units
  double misalignment;  // rad, uniform +- per axis of R_true's rotation vector (0: R_true = I)
  static MagSensorSpec microtesla() { return {1.0, 48.0, 62.0, 0.1, 0.08, 40.0, 0.4, 0.0}; }
  static MagSensorSpec counts() { return {0.15, 48.0, 62.0, 0.1, 0.08, 400.0, 3.0, 0.0}; }
};

struct MagTruth {
  Matrix3<double> S_true;  // symmetric, det = unit_ut^3
  Vector3<double> h_true;  // raw units, added
  double field_ut;
  double dip_deg;
  Matrix3<double> R_true;  // body (accelerometer) <- magnetometer
  double unit_ut;
};

inline Matrix3<double> mag_sim_exp(const Vector3<double>& phi) {
  const double t = phi.norm();
  if (t < 1e-12) return Matrix3<double>::Identity();
  return Eigen::AngleAxis<double>(t, phi / t).toRotationMatrix();
}

inline Vector3<double> mag_sim_log(const Matrix3<double>& r) {
  const Eigen::AngleAxis<double> aa(r);
  return aa.angle() * aa.axis();
}

inline MagTruth draw_mag_truth(const MagSensorSpec& spec, Random& rng) {
  MagTruth t{};
  Matrix3<double> shape = Matrix3<double>::Identity();
  for (int i = 0; i < 3; ++i) shape(i, i) = 1.0 + rng.uniform(-1, 1) * spec.scale_spread;
  for (int r = 0; r < 3; ++r)
    for (int c = r + 1; c < 3; ++c)
      shape(r, c) = shape(c, r) = rng.uniform(-1, 1) * spec.off_diagonal;
  t.S_true = spec.unit_ut * shape / std::cbrt(shape.determinant());
  for (int i = 0; i < 3; ++i) t.h_true(i) = rng.uniform(-1, 1) * spec.hard_iron;
  t.field_ut = spec.field_ut;
  t.dip_deg = spec.dip_deg;
  t.unit_ut = spec.unit_ut;
  Vector3<double> phi;
  for (int i = 0; i < 3; ++i) phi(i) = rng.uniform(-1, 1) * spec.misalignment;
  t.R_true = mag_sim_exp(phi);
  return t;
}

inline Vector3<double> mag_world(const MagTruth& t) {
  const double dip = t.dip_deg * 3.14159265358979323846 / 180.0;
  return t.field_ut * Vector3<double>(std::cos(dip), 0.0, -std::sin(dip));
}

// The true field in the magnetometer's frame at attitude c (body to world).
inline Vector3<double> mag_in_sensor(const MagTruth& t, const Matrix3<double>& c) {
  return t.R_true.transpose() * (c.transpose() * mag_world(t));
}

// The raw reading at attitude c, with white noise of sd `noise` (raw units) per axis.
inline Vector3<double> raw_mag(const MagTruth& t, const Matrix3<double>& c, double noise,
                               Random& rng) {
  const Vector3<double> clean = t.S_true.inverse() * mag_in_sensor(t, c) - t.h_true;
  const double nx = rng.normal(), ny = rng.normal(), nz = rng.normal();  // in this order
  return clean + noise * Vector3<double>(nx, ny, nz);
}

// The truth as the calibration imucal would return (symmetric: no alignment).
inline MagCalibration<double> mag_truth_calibration(const MagTruth& t) {
  MagCalibration<double> c;
  c.status = Status::kOk;
  c.soft_iron = t.S_true;
  c.hard_iron = t.h_true;
  c.field_ut = t.field_ut;
  return c;
}

// A free-hand rotation: a smooth random walk of attitudes. The body rate is an Ornstein-Uhlenbeck
// process (correlation time tau_s, standard deviation rate_rad_s per axis).
//   kFullSphere: any rotation; the field direction wanders all round the sphere.
//   kOneAxis:    only about one fixed body axis (the field traces one circle: a plane).
//   kCap:        any rotation, but the field direction in the body stays within cap_deg of where
//                it started (steps that would leave are undone and the rate reversed).
class HandRotation {
 public:
  enum class Kind { kFullSphere, kOneAxis, kCap };
  struct Options {
    Kind kind = Kind::kFullSphere;
    double rate_hz = 50.0;
    double rate_rad_s = 1.5;
    double tau_s = 0.5;
    double cap_deg = 60.0;
    Vector3<double> axis = Vector3<double>(0.0, 0.0, 1.0);  // body axis for kOneAxis
  };

  HandRotation(const Options& o, const Vector3<double>& field_world, Random& rng)
      : o_(o), field_(field_world.normalized()), rng_(rng) {
    c_ = random_rotation();
    cap_centre_ = c_.transpose() * field_;
    axis_ = o_.axis.normalized();
    for (int i = 0; i < 3; ++i) w_(i) = o_.rate_rad_s * rng_.normal();
  }

  const Matrix3<double>& attitude() const { return c_; }

  // The next attitude (one sample period later).
  const Matrix3<double>& next() {
    const double dt = 1.0 / o_.rate_hz;
    const double a = std::exp(-dt / o_.tau_s);
    const double b = o_.rate_rad_s * std::sqrt(1.0 - a * a);
    for (int i = 0; i < 3; ++i) w_(i) = a * w_(i) + b * rng_.normal();
    Vector3<double> w = w_;
    if (o_.kind == Kind::kOneAxis) w = axis_ * (axis_.dot(w_) + (axis_.dot(w_) < 0 ? -0.5 : 0.5));
    const Matrix3<double> c = c_ * mag_sim_exp(w * dt);
    if (o_.kind == Kind::kCap) {
      const double cos_cap = std::cos(o_.cap_deg * 3.14159265358979323846 / 180.0);
      if ((c.transpose() * field_).dot(cap_centre_) < cos_cap) {
        w_ = -w_;  // bounce off the cap's edge
        return c_;
      }
    }
    c_ = c;
    return c_;
  }

  Matrix3<double> random_rotation() {
    for (;;) {
      // One draw per statement: the order of evaluation of function arguments is unspecified
      // (GCC differs between x86 and Arm), and the same seed must give the same attitudes.
      const double w = rng_.normal(), x = rng_.normal(), y = rng_.normal(), z = rng_.normal();
      Eigen::Quaternion<double> q(w, x, y, z);
      const double n = q.norm();
      if (n > 1e-6) {
        q.coeffs() /= n;
        return q.toRotationMatrix();
      }
    }
  }

 private:
  Options o_;
  Vector3<double> field_;
  Random& rng_;
  Matrix3<double> c_ = Matrix3<double>::Identity();
  Vector3<double> cap_centre_ = Vector3<double>::UnitX();
  Vector3<double> axis_ = Vector3<double>::UnitZ();
  Vector3<double> w_ = Vector3<double>::Zero();
};

}  // namespace imucal::sim
