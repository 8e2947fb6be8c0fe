// SPDX-License-Identifier: MIT
// imucal/field/bias_filter.hpp: a bias that follows temperature, tracked by a small Kalman filter
// (field.md section 2). Per axis the state is x = [c, s, q]: the bias at the reference
// temperature T0, its slope and its curvature, so that b(T) = c + s d + q d^2 with d = T - T0; c
// walks at the rate random walk's density. The three axes share H = [1, d, d^2] and, measured
// together with one noise level, one 3x3 covariance: the filter is 9 numbers and a symmetric 3x3,
// and costs a few dozen operations per rest.
//
//   predict over dt:   P_cc += w dt                             (w: the walk's density squared)
//   measure z at T:    nu = z - H x,  S = H P H' + r             (r: the measurement's variance)
//                      chi2 = |nu|^2 / S                          (three axes: chi-square(3))
//                      x += P H' nu / S,  P -= P H' H P / S     (in square-root form)
//
// The slope and the curvature are observable only once rests span some temperature: until then
// they stay at their priors, with their prior variances (a curvature prior of zero variance
// makes the model linear). Without a temperature (NaN) H = [1, 0, 0]. Evaluated away from the
// temperatures it saw, the model is clamped to that range plus a margin (as
// Corrector::set_temperature does) while its variance keeps growing with the distance.
// Plain data with its arithmetic; no allocation, no exceptions. Header-only.
#pragma once

#include <Eigen/Cholesky>
#include <cmath>
#include <cstdint>
#include <limits>

#include "imucal/types.hpp"

namespace imucal {

// T - T0 for a model's measurements: 0 without a temperature (NaN).
template <typename Scalar>
Scalar temperature_offset(Scalar t, Scalar t0) {
  return std::isnan(t) ? Scalar(0) : t - t0;
}

// T - T0 for evaluating a model: T clamped to the temperatures it saw [lo, hi] widened by margin
// (0 without a temperature, or before any was seen: lo > hi).
template <typename Scalar>
Scalar clamped_temperature_offset(Scalar t, Scalar t0, Scalar lo, Scalar hi, Scalar margin) {
  if (std::isnan(t) || !(lo <= hi)) return Scalar(0);
  const Scalar a = lo - margin, b = hi + margin;
  return (t < a ? a : (t > b ? b : t)) - t0;
}

// A prior's standard deviation as a model takes it: the stated one when it is positive and at
// most the nominal one, else the nominal one (a stated sigma of 0 is a parameter held fixed
// where it was found, which says nothing of its uncertainty; one beyond the nominal knows less
// than the settings do, or comes from a corrupted record, and squared may not even be finite).
template <typename Scalar>
Scalar stated_sigma(Scalar stated, Scalar nominal) {
  return stated > Scalar(0) && stated <= nominal ? stated : nominal;
}

// The widest temperature offset a model's variance is evaluated at: far beyond any sensor's
// range, and where (d^4 times a curvature's variance) is still finite.
template <typename Scalar>
constexpr Scalar kMaxTemperatureOffset = Scalar(4096);

template <typename Scalar>
struct BiasFilter {
  Vector3<Scalar> c = Vector3<Scalar>::Zero();  // bias at reference_c (added, raw units)
  Vector3<Scalar> s = Vector3<Scalar>::Zero();  // its slope per deg C
  Vector3<Scalar> q = Vector3<Scalar>::Zero();  // its curvature per deg C^2
  Matrix3<Scalar> p = Matrix3<Scalar>::Zero();  // covariance of (c, s, q), the same for each axis
  Scalar reference_c = Scalar(0);               // T0
  // The temperatures of the measurements taken (min_c > max_c: none yet).
  Scalar min_c = std::numeric_limits<Scalar>::infinity();
  Scalar max_c = -std::numeric_limits<Scalar>::infinity();
  std::uint32_t measurements = 0;

  // Starts from a prior: c, s and q with standard deviations c_sigma, s_sigma and q_sigma
  // (uncorrelated) about the reference temperature t0.
  void start(const Vector3<Scalar>& c0, Scalar c_sigma, const Vector3<Scalar>& s0, Scalar s_sigma,
             const Vector3<Scalar>& q0, Scalar q_sigma, Scalar t0) {
    c = c0;
    s = s0;
    q = q0;
    p.setZero();
    p(0, 0) = c_sigma * c_sigma;
    p(1, 1) = s_sigma * s_sigma;
    p(2, 2) = q_sigma * q_sigma;
    reference_c = t0;
    min_c = std::numeric_limits<Scalar>::infinity();
    max_c = -std::numeric_limits<Scalar>::infinity();
    measurements = 0;
  }

  bool seen_temperature() const { return min_c <= max_c; }

  // T - T0 for the measurement model (0 without a temperature).
  Scalar offset(Scalar t) const { return temperature_offset(t, reference_c); }

  // T - T0 for evaluating the model: clamped to the temperatures seen, widened by margin.
  Scalar clamped_offset(Scalar t, Scalar margin) const {
    return clamped_temperature_offset(t, reference_c, min_c, max_c, margin);
  }

  // The random walk over dt seconds.
  void predict(Scalar dt, Scalar w) {
    if (dt > Scalar(0)) p(0, 0) += w * dt;
  }

  // A step of unknown size in the bias (a knock): its variance grows by var.
  void inflate(Scalar var) { p(0, 0) += var; }

  static Vector3<Scalar> h(Scalar d) { return Vector3<Scalar>(Scalar(1), d, d * d); }

  // The bias at offset d, and the variance of one axis of it.
  Vector3<Scalar> value(Scalar d) const { return c + d * (s + d * q); }
  Scalar variance(Scalar d) const {
    const Scalar v = h(d).dot(p * h(d));
    return v > Scalar(0) ? v : Scalar(0);  // rounding may take it just below zero far out
  }

  // The model at temperature t (NaN: at T0), clamped to the range seen plus margin; its variance
  // at t itself (it grows beyond the range; infinite at an infinite or absurd temperature).
  Vector3<Scalar> at(Scalar t, Scalar margin) const { return value(clamped_offset(t, margin)); }
  Scalar variance_at(Scalar t) const {
    const Scalar d = offset(t);
    return std::fabs(d) <= kMaxTemperatureOffset<Scalar> ? variance(d)
                                                         : std::numeric_limits<Scalar>::infinity();
  }

  // The innovation's chi-square (three degrees of freedom) of a measurement z of the bias at
  // temperature t, each axis of variance r.
  Scalar chi2(const Vector3<Scalar>& z, Scalar r, Scalar t) const {
    const Scalar d = offset(t);
    return (z - value(d)).squaredNorm() / (variance(d) + r);
  }

  // Takes the measurement. r must be positive.
  void update(const Vector3<Scalar>& z, Scalar r, Scalar t) {
    const Scalar d = offset(t);
    const Vector3<Scalar> nu = z - value(d);
    const Vector3<Scalar> ph = p * h(d);  // P H'
    const Scalar inv_s = Scalar(1) / (h(d).dot(ph) + r);
    c += (ph(0) * inv_s) * nu;
    s += (ph(1) * inv_s) * nu;
    q += (ph(2) * inv_s) * nu;
    take_variance(h(d), r);
    if (!std::isnan(t)) {
      if (t < min_c) min_c = t;
      if (t > max_c) max_c = t;
    }
    ++measurements;
  }

  // P -= P h h' P / (h' P h + r), in square-root form (Potter): with P = F F', phi = F' h,
  // a = 1 / (phi' phi + r) and g = 1 / (1 + sqrt(a r)), P+ = F (I - g a phi phi')^2 F'. The
  // direct subtraction loses the posterior variance where the prior's is many times the
  // measurement's (float keeps 24 bits: a prior 10^7 times r leaves a few bits of the result, and
  // 10^8 times none); here the factor's smallest singular value along phi, sqrt(a r), is formed
  // to a relative error of about eps / sqrt(a r). F from P's pivoted LDL^T, which takes a
  // semidefinite P (a parameter held fixed has a zero row).
  void take_variance(const Vector3<Scalar>& hd, Scalar r) {
    const Eigen::LDLT<Matrix3<Scalar>> ldlt(p);
    Matrix3<Scalar> f = ldlt.matrixL();
    const Vector3<Scalar> dv = ldlt.vectorD();
    for (int j = 0; j < 3; ++j) f.col(j) *= dv(j) > Scalar(0) ? std::sqrt(dv(j)) : Scalar(0);
    f = ldlt.transpositionsP().transpose() * f;
    const Vector3<Scalar> phi = f.transpose() * hd;
    const Scalar a = Scalar(1) / (phi.squaredNorm() + r);
    const Scalar g = Scalar(1) / (Scalar(1) + std::sqrt(a * r));
    f -= ((g * a) * (f * phi)) * phi.transpose();
    p = f * f.transpose();
  }

  bool finite() const {
    return all_finite(c) && all_finite(s) && all_finite(q) && all_finite(p) &&
           std::isfinite(reference_c) && p(0, 0) >= Scalar(0) && p(1, 1) >= Scalar(0) &&
           p(2, 2) >= Scalar(0);
  }
};

}  // namespace imucal
