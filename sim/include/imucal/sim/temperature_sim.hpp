// SPDX-License-Identifier: MIT
// imucal/sim/temperature_sim.hpp: biases that drift with temperature, with known truth, for the
// temperature model's tests (temperature_model.hpp, temperature_fit.hpp, rest_monitor.hpp).
//
//   b(T) = b0 + b1 (T - T0) + b2 (T - T0)^2      (ADDED to the raw reading, raw units)
//   a_raw = (T_a K_a)^-1 f - b_a(T),   w_raw = (T_g K_g)^-1 w - b_g(T)       (+ white noise)
//
// Two products: rest summaries drawn directly (the mean of n white samples is exactly normal with
// sigma / sqrt(n), so the mean is drawn, not the samples), and a raw sample stream (rests and
// turns while the board warms up) generated one sample at a time, so that it needs no memory on
// the small Arm boards. Double precision, host and test code only (it allocates a little).
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>
#include <cmath>
#include <cstdint>
#include <vector>

#include "imucal/calibrator/settings.hpp"
#include "imucal/models/accel_model.hpp"
#include "imucal/models/gyro_model.hpp"
#include "imucal/models/temperature_model.hpp"
#include "imucal/sim/accel_sim.hpp"
#include "imucal/sim/motion_sim.hpp"
#include "imucal/sim/random.hpp"
#include "imucal/stream/gyro_segment.hpp"
#include "imucal/stream/rest_summary.hpp"

namespace imucal::sim {

// Temperature over time: hold start_c for hold_start_s, ramp linearly to end_c over ramp_s, then
// hold end_c (a plateau).
struct TemperatureProfile {
  double start_c = 10.0, end_c = 50.0;
  double hold_start_s = 0.0, ramp_s = 600.0;
  double at(double t) const {
    if (t <= hold_start_s) return start_c;
    if (t >= hold_start_s + ramp_s || ramp_s <= 0.0) return end_c;
    return start_c + (end_c - start_c) * (t - hold_start_s) / ramp_s;
  }
};

// Drift sizes, in physical units per deg C (converted with the sensors' nominal scales).
struct DriftSpec {
  double accel_slope_min = 0.5e-3, accel_slope_max = 1.5e-3;  // g per deg C (0.5 to 1.5 mg/C)
  double gyro_slope_min = 0.01, gyro_slope_max = 0.05;        // deg/s per deg C
  // Quadratic term (order 2): |b2| = U(min, max) * (a typical slope) / 20 deg C, so over 20 deg C
  // from T0 the curvature adds 30 to 100 % of what the slope does.
  double quad_min = 0.3, quad_max = 1.0;
};

struct TemperatureTruth {
  AccelTruth acc;                  // params' bias = b_a(T0)
  GyroTruth gyro;                  // params' bias = b_g(T0)
  TemperatureModel<double> model;  // b0 = those biases; sigmas zero

  Vector3<double> accel_bias(double t_c) const { return model.accel.at(t_c, model.reference_c); }
  Vector3<double> gyro_bias(double t_c) const { return model.gyro.at(t_c, model.reference_c); }

  // Noise-free raw readings at temperature t_c: at rest with gravity direction `up` (body
  // frame, unit), and for the body rate w (rad/s).
  Vector3<double> raw_accel(const Vector3<double>& f, double t_c) const {
    return accel_matrix(acc.params).inverse() * f - accel_bias(t_c);
  }
  Vector3<double> raw_gyro(const Vector3<double>& w, double t_c) const {
    return gyro_matrix<double>(gyro.params).inverse() * w - gyro_bias(t_c);
  }
};

inline double signed_uniform(Random& rng, double lo, double hi) {
  const double v = rng.uniform(lo, hi);
  return rng.uniform() < 0.5 ? -v : v;
}

// Draws T, K, b(T0) as the other simulators do, and the drift polynomial (order 1 or 2) about t0.
inline TemperatureTruth draw_temperature_truth(const AccelSensorSpec& acc_spec,
                                               const GyroSensorSpec& gyro_spec, int order,
                                               double t0, Random& rng,
                                               const DriftSpec& drift = DriftSpec{},
                                               double gravity = 9.80665) {
  TemperatureTruth t{};
  t.acc = draw_accel_truth(acc_spec, rng, gravity);
  t.gyro = draw_gyro_truth(gyro_spec, rng);
  t.model.order = order;
  t.model.reference_c = t0;
  t.model.accel.b0 = t.acc.params.tail<3>();
  t.model.gyro.b0 = t.gyro.params.tail<3>();
  const double acc_unit = 9.80665 / acc_spec.nominal_scale;                           // raw per g
  const double gyro_unit = 3.14159265358979323846 / 180.0 / gyro_spec.nominal_scale;  // per deg/s
  for (int i = 0; i < 3; ++i) {
    t.model.accel.b1(i) =
        signed_uniform(rng, drift.accel_slope_min, drift.accel_slope_max) * acc_unit;
    t.model.gyro.b1(i) =
        signed_uniform(rng, drift.gyro_slope_min, drift.gyro_slope_max) * gyro_unit;
  }
  if (order >= 2) {
    const double a_typ = 0.5 * (drift.accel_slope_min + drift.accel_slope_max) * acc_unit / 20.0;
    const double g_typ = 0.5 * (drift.gyro_slope_min + drift.gyro_slope_max) * gyro_unit / 20.0;
    for (int i = 0; i < 3; ++i) {
      t.model.accel.b2(i) = signed_uniform(rng, drift.quad_min, drift.quad_max) * a_typ;
      t.model.gyro.b2(i) = signed_uniform(rng, drift.quad_min, drift.quad_max) * g_typ;
    }
  }
  t.model.accel.status = t.model.gyro.status = Status::kOk;
  return t;
}

// The base calibration a unit calibrated at t0 would have: the truth's T, K and b(t0), plus an
// error in each bias (e.g. a calibration done at another temperature), marked usable.
inline Calibration<double> base_calibration(
    const TemperatureTruth& t, const Vector3<double>& accel_bias_error = Vector3<double>::Zero(),
    const Vector3<double>& gyro_bias_error = Vector3<double>::Zero()) {
  Calibration<double> c{};
  c.accel.params = t.acc.params;
  c.accel.params.tail<3>() += accel_bias_error;
  c.accel.status = Status::kOk;
  c.gyro.params = t.gyro.params;
  c.gyro.params.tail<3>() += gyro_bias_error;
  c.gyro.status = Status::kOk;
  c.quality = Quality::kGood;
  c.has_temperature = true;
  c.temperature_c = t.model.reference_c;
  return c;
}

// One rest of n samples at temperature t_c with gravity direction `up` (unit, body frame): the
// means of n noisy samples, drawn directly (truth + N(0, noise / sqrt(n)) per axis).
inline RestSummary<double> draw_rest(const TemperatureTruth& t, const AccelSensorSpec& acc_spec,
                                     const GyroSensorSpec& gyro_spec, const Vector3<double>& up,
                                     double t_c, std::uint32_t n, Random& rng,
                                     double rate_hz = 100.0) {
  RestSummary<double> r;
  const double k = 1.0 / std::sqrt(static_cast<double>(n));
  r.accel_mean = t.raw_accel(t.acc.gravity * up, t_c) + rng.normal3() * (acc_spec.noise * k);
  r.gyro_mean = t.raw_gyro(Vector3<double>::Zero(), t_c) + rng.normal3() * (gyro_spec.noise * k);
  r.temperature_c = t_c;
  r.has_temperature = true;
  r.samples = n;
  r.duration_s = static_cast<double>(n) / rate_hz;
  return r;
}

struct RestPlan {
  int rests = 30;
  double min_c = 10.0, max_c = 50.0;  // temperatures: one per stratum of [min_c, max_c], rising
  std::uint32_t samples = 500;        // per rest (5 s at 100 Hz)
  bool one_orientation = false;       // every rest with the same gravity direction (a fixed mount)
};

// Rests in random orientations (uniform over SO(3): random_rotation) at rising temperatures,
// one drawn uniformly in each of `rests` equal strata of [min_c, max_c].
inline std::vector<RestSummary<double>> simulate_rests(const TemperatureTruth& t,
                                                       const AccelSensorSpec& acc_spec,
                                                       const GyroSensorSpec& gyro_spec,
                                                       const RestPlan& plan, Random& rng) {
  std::vector<RestSummary<double>> out;
  out.reserve(static_cast<std::size_t>(plan.rests > 0 ? plan.rests : 0));
  const Vector3<double> fixed_up = random_rotation(rng).row(2).transpose();
  for (int i = 0; i < plan.rests; ++i) {
    const Vector3<double> up =
        plan.one_orientation ? fixed_up : Vector3<double>(random_rotation(rng).row(2).transpose());
    const double u = (static_cast<double>(i) + rng.uniform()) / static_cast<double>(plan.rests);
    const double t_c = plan.min_c + (plan.max_c - plan.min_c) * u;
    out.push_back(draw_rest(t, acc_spec, gyro_spec, up, t_c, plan.samples, rng));
  }
  return out;
}

// A raw stream: rests (durations rest_s) separated by turns of move_s, while the temperature
// follows `profile`. Generated on demand by next(), one sample at a time.
struct StreamPlan {
  double rate_hz = 100.0;
  double jitter = 0.05;  // each interval is (1 + U(-jitter, jitter)) / rate_hz
  std::vector<double> rest_s = {12.0, 12.0, 12.0};
  double move_s = 2.0;
  double move_angle_min = 1.0, move_angle_max = 2.5;  // rad, about a random axis
  double temperature_noise_c = 0.05;                  // per sample
  std::uint32_t t0_us = 0;  // timestamp of the first sample (choose near 2^32 to test wrapping)
  TemperatureProfile profile{};
};

class TemperatureStream {
 public:
  TemperatureStream(const TemperatureTruth& truth, const AccelSensorSpec& acc_spec,
                    const GyroSensorSpec& gyro_spec, const StreamPlan& plan, Random& rng)
      : truth_(truth), acc_spec_(acc_spec), gyro_spec_(gyro_spec), plan_(plan), rng_(rng) {
    r_ = random_rotation(rng_);
    begin_phase(0);
  }

  // The next sample; false once every phase is done.
  bool next(ImuSample<double>& out) {
    if (phase_ >= phases()) return false;
    if (started_) {
      const double j = plan_.jitter;
      const double dt = (1.0 + rng_.uniform(-j, j)) / plan_.rate_hz;
      t_ += dt;
      if (t_ >= phase_end_) {
        begin_phase(phase_ + 1);
        if (phase_ >= phases()) return false;
      }
      w_ = Vector3<double>::Zero();
      if (!still()) {
        const double tau = (t_ - phase_start_) / plan_.move_s;
        const double s = std::sin(3.14159265358979323846 * tau);
        w_ = axis_ * (2.0 * angle_ / plan_.move_s * s * s);
        r_ = r_ * rotation_exp<double>(Vector3<double>(w_ * dt));
      }
    }
    started_ = true;
    const double temp = plan_.profile.at(t_);
    const Vector3<double> f = r_.transpose() * Vector3<double>(0.0, 0.0, truth_.acc.gravity);
    out.t_us = plan_.t0_us + static_cast<std::uint32_t>(std::llround(t_ * 1e6) & 0xFFFFFFFFll);
    out.acc = truth_.raw_accel(f, temp) + noise(acc_spec_.noise);
    out.gyro = truth_.raw_gyro(w_, temp) + noise(gyro_spec_.noise);
    out.temperature = temp + plan_.temperature_noise_c * rng_.normal();
    return true;
  }

  double time() const { return t_; }
  bool still() const { return phase_ % 2 == 0; }  // rests are the even phases
  int rest_index() const { return phase_ / 2; }   // the current rest, or the last one
  // Gravity direction (body frame) of rest k (valid once it has begun).
  const Vector3<double>& rest_up(int k) const { return ups_[static_cast<std::size_t>(k)]; }
  int rests_begun() const { return static_cast<int>(ups_.size()); }

 private:
  int phases() const { return 2 * static_cast<int>(plan_.rest_s.size()) - 1; }

  void begin_phase(int p) {
    phase_ = p;
    phase_start_ = t_;
    if (p >= phases()) return;
    if (p % 2 == 0) {
      ups_.push_back(r_.row(2).transpose());
      phase_end_ = t_ + plan_.rest_s[static_cast<std::size_t>(p / 2)];
    } else {
      axis_ = random_direction(rng_);
      angle_ = rng_.uniform(plan_.move_angle_min, plan_.move_angle_max);
      phase_end_ = t_ + plan_.move_s;
    }
  }

  Vector3<double> noise(double sd) { return rng_.normal3() * sd; }

  const TemperatureTruth& truth_;
  const AccelSensorSpec& acc_spec_;
  const GyroSensorSpec& gyro_spec_;
  const StreamPlan& plan_;
  Random& rng_;
  Matrix3<double> r_ = Matrix3<double>::Identity();
  Vector3<double> w_ = Vector3<double>::Zero();
  Vector3<double> axis_ = Vector3<double>::UnitX();
  double angle_ = 0.0;
  double t_ = 0.0, phase_start_ = 0.0, phase_end_ = 0.0;
  int phase_ = 0;
  bool started_ = false;
  std::vector<Vector3<double>> ups_;
};

}  // namespace imucal::sim
