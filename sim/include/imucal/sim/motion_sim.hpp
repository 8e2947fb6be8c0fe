// SPDX-License-Identifier: MIT
// imucal/sim/motion_sim.hpp: a simulated raw IMU stream of Tedaldi's hand-held calibration
// protocol with known truth: an initial rest, then alternating hand rotations and rests, with
// white noise and sample-rate jitter, to feed the streaming calibrator (stillness detection,
// accelerometer and gyroscope calibration) in tests. Double precision, host and test code only (it
// allocates).
//
// Conventions (math.md sections 1, 4, 5). R is the body-to-world attitude. Sample k >= 1 closes
// the interval dt_k = t_k - t_{k-1}, and its true body rate w_k is HELD over that interval:
// R_k = R_{k-1} exp([w_k dt_k]x). This zero-order hold is exactly what generates the truth, so a
// calibrator that integrates exp([M (w_raw + b) dt_k]x) recovers the rotation up to noise. The
// accelerometer reads the specific force at the sample instant, f = R_k^T (g e_z + a_lin(t_k)).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "imucal/models/accel_model.hpp"
#include "imucal/models/gyro_model.hpp"
#include "imucal/sim/accel_sim.hpp"
#include "imucal/sim/random.hpp"
#include "imucal/stream/gyro_segment.hpp"  // rotation_exp: the same matrices as the calibrator's tests

namespace imucal::sim {

struct GyroSensorSpec {
  double nominal_scale;  // rad/s per sensor unit (1 for SI, 1/4770 for xsens-like counts)
  double nominal_bias;   // ADDED to the raw reading (-32768 for unsigned 16-bit counts)
  double scale_spread;   // relative, uniform +-
  double bias_spread;    // sensor units, uniform +-
  double misalignment;   // rad, uniform +- (all six gammas)
  double noise;          // per-sample white noise, sensor units
  static GyroSensorSpec si() { return {1.0, 0.0, 0.03, 0.02, 0.015, 0.003}; }
  static GyroSensorSpec raw_counts() { return {1.0 / 4770.0, -32768.0, 0.03, 100.0, 0.015, 15.0}; }
};

struct GyroTruth {
  GyroVector<double> params;  // 9 matrix parameters (gyro_model.hpp), then the ADDED bias
};

inline GyroTruth draw_gyro_truth(const GyroSensorSpec& spec, Random& rng) {
  GyroTruth t{};
  for (int i = 0; i < 6; ++i) t.params(kGammaYz + i) = rng.uniform(-1, 1) * spec.misalignment;
  for (int i = 0; i < 3; ++i)
    t.params(kGyroScaleX + i) = spec.nominal_scale * (1.0 + rng.uniform(-1, 1) * spec.scale_spread);
  for (int i = 0; i < 3; ++i)
    t.params(kGyroBiasX + i) = spec.nominal_bias + rng.uniform(-1, 1) * spec.bias_spread;
  return t;
}

// The raw reading that calibrates to the body rate w (rad/s): w_raw = M^-1 w - b, M = T K.
inline Vector3<double> raw_gyro_from_rate(const GyroTruth& t, const Vector3<double>& w) {
  const Matrix3<double> m = gyro_matrix<double>(t.params);
  const Vector3<double> b(t.params(kGyroBiasX), t.params(kGyroBiasY), t.params(kGyroBiasZ));
  return m.inverse() * w - b;
}

// The rotation vector of r (angle in [0, pi]); Eigen goes through the quaternion, which stays
// well conditioned near pi.
inline Vector3<double> so3_log(const Matrix3<double>& r) {
  const Eigen::AngleAxis<double> aa(r);
  return aa.angle() * aa.axis();
}

// Uniform over SO(3): a normalised 4-D Gaussian is a uniform unit quaternion.
inline Matrix3<double> random_rotation(Random& rng) {
  for (;;) {
    Eigen::Quaternion<double> q = rng.normal_quaternion();
    const double n = q.norm();
    if (n > 1e-6) {
      q.coeffs() /= n;
      return q.toRotationMatrix();
    }
  }
}

struct MotionPlan {
  double rate_hz = 100.0;
  double jitter = 0.05;  // each sample interval is (1 + U(-jitter, +jitter)) / rate_hz
  double initial_rest_s = 10.0;
  int poses = 30;  // rests after the initial one
  double rest_min_s = 3.0, rest_max_s = 6.0;
  double move_min_s = 1.5, move_max_s = 3.0;
  double move_angle_min = 1.2, move_angle_max = 3.0;  // rad, net rotation of one move
  double coning = 0.6;        // relative amplitude of the rotation-axis wobble during a move
  double linear_accel = 1.0;  // m/s^2, smooth hand acceleration during moves (0 at rest)
  double gravity = 9.81;
  int bump_rest = -1;       // 0-based rest after the initial one, split mid-way by a bump; -1 none
  double bump_angle = 0.1;  // rad, net rotation left by the bump
  double bump_s = 0.3;      // s, duration of the bump
  // Keep the true attitude of every sample (72 bytes each): off for the small Arm boards.
  bool record_attitude = true;
  // Rests held in the hand (0: set down): during every rest the body turns with a tremor of this
  // RMS rate (rad/s; three sinusoids of 4-11 Hz about random axes) and a slow turn of
  // hand_drift rad over the rest, and accelerates with hand_accel m/s^2 RMS (2-8 Hz). The
  // rests are still in the truth (`still`): a person would mark them so.
  double hand_tremor = 0.0;
  double hand_drift = 0.0;
  double hand_accel = 0.0;
  bool hand_initial_rest = false;  // the initial rest held in the hand too (else set down)
  // A warming board: the raw accelerometer reading drifts along (1, 1, 1)/sqrt(3) by
  // accel_drift * warm_s * (1 - exp(-t / warm_s)) sensor units (accel_drift per second at first).
  double accel_drift = 0.0;
  double warm_s = 30.0;
};

struct MotionSample {
  double t;              // s, strictly increasing
  Vector3<double> acc;   // raw accelerometer (sensor units, noisy)
  Vector3<double> gyro;  // raw gyroscope (sensor units, noisy)
  Vector3<double> rate;  // true body rate, rad/s (noise-free), held over (t_{k-1}, t_k]
  bool still;            // truth: the device is at rest at this sample
};

// [begin, end) sample indices of a true rest; the initial rest comes first.
struct StillInterval {
  std::size_t begin, end;
};

struct Recording {
  std::vector<MotionSample> samples;
  std::vector<StillInterval> rests;
  std::vector<Eigen::Matrix3d> attitude;  // true body-to-world rotation at each sample
  AccelTruth acc;
  GyroTruth gyro;
};

// The warming board's accelerometer offset at time t, along (1, 1, 1)/sqrt(3) (sensor units).
inline double accel_offset(const MotionPlan& plan, double t) {
  return plan.accel_drift * plan.warm_s * (1.0 - std::exp(-t / plan.warm_s));
}

namespace detail {

inline constexpr double kPi = 3.14159265358979323846;  // M_PI is POSIX, not C++17

// Smooth world-frame hand acceleration over a phase of length T: a sin^2 envelope (zero with zero
// slope at both ends, so the stream has no step at the rest edges) times three sinusoids.
struct HandAccel {
  std::array<Vector3<double>, 3> amplitude{};
  std::array<double, 3> omega{}, phase{};
  double period = 1.0;

  static HandAccel draw(double magnitude, double period, Random& rng) {
    HandAccel h;
    h.period = period;
    for (std::size_t j = 0; j < 3; ++j) {
      h.amplitude[j] = random_direction(rng) * (magnitude * rng.uniform(0.3, 0.7));
      h.omega[j] = 2.0 * kPi * rng.uniform(0.5, 2.5) / period;
      h.phase[j] = rng.uniform(0.0, 2.0 * kPi);
    }
    return h;
  }

  Vector3<double> at(double tau) const {
    const double s = std::sin(kPi * tau / period);
    Vector3<double> a = Vector3<double>::Zero();
    for (std::size_t j = 0; j < 3; ++j) a += amplitude[j] * std::sin(omega[j] * tau + phase[j]);
    return (s * s) * a;
  }
};

// The six body faces +x, -x, +y, -y, +z, -z as unit vectors.
inline Vector3<double> face(int i) {
  Vector3<double> v = Vector3<double>::Zero();
  v(i / 2) = (i % 2 == 0) ? 1.0 : -1.0;
  return v;
}

inline double angle_between(const Vector3<double>& a, const Vector3<double>& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

// Chooses where each move takes the body "up" (gravity direction in the body frame, R^T e_z).
// Even moves aim at the least-visited reachable face, so all six are covered; odd moves at the
// best of a few random directions (farthest from the rests so far), so the rest is spread over
// the sphere. Every target is at least kMinSeparation from the current up, so consecutive rests
// always give the gyro residual a real rotation to measure.
class TargetPlanner {
 public:
  static constexpr double kMinSeparation = 25.0 * kPi / 180.0;
  static constexpr double kFaceHit = 15.0 * kPi / 180.0;

  explicit TargetPlanner(double max_angle) : max_angle_(max_angle) {}

  void record_rest(const Vector3<double>& up) {
    ups_.push_back(up);
    for (int i = 0; i < 6; ++i)
      if (angle_between(up, face(i)) < kFaceHit) ++visits_[static_cast<std::size_t>(i)];
  }

  Vector3<double> target(int move, const Vector3<double>& up, Random& rng) const {
    if (move % 2 == 0) {
      int best = -1, best_visits = 0, ties = 0;
      for (int i = 0; i < 6; ++i) {
        const double d = angle_between(up, face(i));
        if (d < kMinSeparation || d > max_angle_) continue;
        const int v = visits_[static_cast<std::size_t>(i)];
        if (best < 0 || v < best_visits) {
          best = i;
          best_visits = v;
          ties = 1;
        } else if (v == best_visits) {
          ++ties;  // reservoir choice: each equally visited face wins with probability 1/ties
          if (rng.uniform() * static_cast<double>(ties) < 1.0) best = i;
        }
      }
      if (best >= 0) return face(best);
    }
    Vector3<double> chosen = Vector3<double>::Zero();
    double chosen_score = -1.0;
    int found = 0;
    for (int tries = 0; tries < 200 && found < 4; ++tries) {
      const Vector3<double> c = random_direction(rng);
      const double d = angle_between(up, c);
      if (d < kMinSeparation || d > max_angle_) continue;
      ++found;
      double score = kPi;
      for (const Vector3<double>& u : ups_) score = std::min(score, angle_between(u, c));
      if (score > chosen_score) {
        chosen_score = score;
        chosen = c;
      }
    }
    if (found > 0) return chosen;
    // max_angle_ below kMinSeparation: take a step of max_angle_ in a random direction.
    Vector3<double> side = random_direction(rng);
    side = (side - side.dot(up) * up).normalized();
    return std::cos(max_angle_) * up + std::sin(max_angle_) * side;
  }

 private:
  double max_angle_;
  std::vector<Vector3<double>> ups_;
  std::array<int, 6> visits_{};
};

// A rotation Q (R_after = R_before Q) that takes the body up to `target` (Q^T up = target) with
// net angle theta >= the angle between them: the minimal turn, preceded by a yaw about up whose
// size makes up the rest of theta (the two axes are perpendicular, so cos(theta/2) =
// cos(psi/2) cos(delta/2)). The yaw adds a rotation-axis component along up, so over the run the
// move axes excite all three body axes.
inline Matrix3<double> turn_to(const Vector3<double>& up, const Vector3<double>& target,
                               double theta, Random& rng) {
  const double delta = angle_between(target, up);
  Vector3<double> n = target.cross(up);
  if (n.norm() < 1e-9) n = up.unitOrthogonal();
  const Matrix3<double> q_min = rotation_exp<double>(n.normalized() * delta);
  const double ratio = std::min(1.0, std::cos(0.5 * theta) / std::cos(0.5 * delta));
  const double psi = 2.0 * std::acos(ratio) * (rng.uniform() < 0.5 ? -1.0 : 1.0);
  return rotation_exp<double>(up * psi) * q_min;
}

// Builds the sample stream phase by phase; keeps the current time and attitude.
class MotionBuilder {
 public:
  // sink: if set, each sample goes to it instead of into rec.samples (a long recording in little
  // memory); rec.rests are counted either way.
  MotionBuilder(const MotionPlan& plan, const AccelSensorSpec& acc_spec,
                const GyroSensorSpec& gyro_spec, Random& rng, Recording& rec,
                const std::function<void(const MotionSample&)>* sink = nullptr)
      : plan_(plan),
        acc_spec_(acc_spec),
        gyro_spec_(gyro_spec),
        rng_(rng),
        rec_(rec),
        sink_(sink) {}

  // Sample 0 at t = 0, at rest with attitude r0.
  void start(const Matrix3<double>& r0) {
    r_ = r0;
    t_ = 0.0;
    push(Vector3<double>::Zero(), Vector3<double>::Zero(), true);
  }

  // Up (gravity direction) in the body frame.
  Vector3<double> up() const { return r_.row(2).transpose(); }

  // Still samples until `duration` has elapsed (at least one); held in the hand if the plan
  // says so (the body turns and accelerates a little, see MotionPlan::hand_tremor).
  void rest(double duration, bool in_hand = true) {
    const double t0 = t_;
    if (!in_hand ||
        (plan_.hand_tremor <= 0.0 && plan_.hand_accel <= 0.0 && plan_.hand_drift == 0.0)) {
      do {
        t_ = next_time(t_);
        push(Vector3<double>::Zero(), Vector3<double>::Zero(), true);
      } while (t_ - t0 < duration);
      return;
    }
    std::array<Vector3<double>, 3> axis{};
    std::array<double, 3> omega{}, phase{};
    const double amplitude = plan_.hand_tremor / std::sqrt(1.5);  // three sinusoids: RMS
    for (std::size_t j = 0; j < 3; ++j) {
      axis[j] = random_direction(rng_) * amplitude;
      omega[j] = 2.0 * kPi * rng_.uniform(4.0, 11.0);
      phase[j] = rng_.uniform(0.0, 2.0 * kPi);
    }
    const Vector3<double> drift = random_direction(rng_) * (plan_.hand_drift / duration);
    const Vector3<double> push_dir = random_direction(rng_) * (plan_.hand_accel * std::sqrt(2.0));
    const double push_omega = 2.0 * kPi * rng_.uniform(2.0, 8.0);
    const double push_phase = rng_.uniform(0.0, 2.0 * kPi);
    do {
      const double t = next_time(t_);
      const double tau = 0.5 * ((t_ - t0) + (t - t0));  // the interval's middle
      Vector3<double> w = drift;
      for (std::size_t j = 0; j < 3; ++j) w += axis[j] * std::sin(omega[j] * tau + phase[j]);
      advance(t, w);
      push(w, push_dir * std::sin(push_omega * (t - t0) + push_phase), true);
    } while (t_ - t0 < duration);
  }

  // A hand rotation of net rotation q_des (R_after = R_before q_des). The rate magnitude follows
  // sin^2(pi tau/T) about a coning axis a0 + coning (cos(2 pi f tau) a1 + sin(2 pi f tau) a2),
  // f in [1/T, 2/T]. The profile's parameter phi = |phi| a0 (|phi| = the path angle, integral of
  // |w| dt) is solved on the actual jittered sample steps so that the ZOH product lands on q_des
  // exactly, and the rest that follows has the planned gravity direction.
  void move(const Matrix3<double>& q_des) {
    const std::vector<double> times = phase_times(rng_.uniform(plan_.move_min_s, plan_.move_max_s));
    const std::size_t n = times.size();
    const double t0 = t_, period = times.back() - t0;
    std::vector<double> dt(n), mid(n);
    for (std::size_t j = 0; j < n; ++j) {
      const double prev = j == 0 ? t0 : times[j - 1];
      dt[j] = times[j] - prev;
      mid[j] = 0.5 * ((prev - t0) + (times[j] - t0));
    }
    const double kappa = plan_.coning;
    const double wobble = 2.0 * kPi * rng_.uniform(1.0, 2.0) / period;
    const Vector3<double> reference = random_direction(rng_);
    const HandAccel hand = HandAccel::draw(plan_.linear_accel, period, rng_);

    std::vector<Vector3<double>> w(n);
    auto fill = [&](const Vector3<double>& phi) {
      const double angle = std::max(phi.norm(), 1e-300);
      const Vector3<double> a0 = phi / angle;
      Vector3<double> a1 = reference - reference.dot(a0) * a0;
      a1 = a1.norm() > 1e-6 ? a1.normalized() : a0.unitOrthogonal();
      const Vector3<double> a2 = a0.cross(a1);
      const double peak = 2.0 * angle / period / std::sqrt(1.0 + kappa * kappa);
      for (std::size_t j = 0; j < n; ++j) {
        const double s = std::sin(kPi * mid[j] / period);
        const double c = wobble * mid[j];
        w[j] = (peak * s * s) * (a0 + kappa * (std::cos(c) * a1 + std::sin(c) * a2));
      }
    };
    auto integrate = [&]() {
      Matrix3<double> q = Matrix3<double>::Identity();
      for (std::size_t j = 0; j < n; ++j) q = q * rotation_exp<double>(w[j] * dt[j]);
      return q;
    };

    // Damped Newton on r(phi) = log(q_des^T Q(phi)) with a forward-difference Jacobian: the wobble
    // tilts and shortens the net rotation, strongly at large coning, so plain fixed-point steps
    // are not enough. A few passes over ~300 steps each; if it ever stalls the move is still a
    // valid truth, only off target.
    auto residual = [&](const Vector3<double>& phi) {
      fill(phi);
      return Vector3<double>(so3_log(q_des.transpose() * integrate()));
    };
    Vector3<double> phi = so3_log(q_des) * std::sqrt(1.0 + kappa * kappa);
    Vector3<double> r = residual(phi);
    for (int iter = 0; iter < 30 && r.norm() > 1e-13; ++iter) {
      const double h = 1e-7 * std::max(1.0, phi.norm());
      Matrix3<double> jac;
      for (int c = 0; c < 3; ++c) {
        Vector3<double> d = Vector3<double>::Zero();
        d(c) = h;
        jac.col(c) = (residual(phi + d) - r) / h;
      }
      const Vector3<double> step = -jac.partialPivLu().solve(r);
      if (!step.allFinite()) break;
      bool improved = false;
      double lambda = 1.0;
      for (int halving = 0; halving < 12 && !improved; ++halving, lambda *= 0.5) {
        const Vector3<double> candidate = phi + lambda * step;
        const Vector3<double> rc = residual(candidate);
        if (rc.norm() < r.norm()) {
          phi = candidate;
          r = rc;
          improved = true;
        }
      }
      if (!improved) break;
    }
    fill(phi);
    for (std::size_t j = 0; j < n; ++j) {
      advance(times[j], w[j]);
      push(w[j], hand.at(times[j] - t0), false);
    }
  }

  // A knock in the middle of a rest: a back-and-forth turn about a fixed, nearly horizontal axis
  // leaving a net rotation of plan.bump_angle. On a fixed axis the ZOH steps commute, so scaling
  // the forward part by the actual step sums makes the net angle exact.
  void bump() {
    const std::vector<double> times = phase_times(plan_.bump_s);
    const std::size_t n = times.size();
    const double t0 = t_, period = times.back() - t0;
    const Vector3<double> u = up();
    Vector3<double> axis = random_direction(rng_);
    axis -= axis.dot(u) * u;
    axis = (axis.norm() > 1e-6 ? axis.normalized() : u.unitOrthogonal());
    axis = (axis + rng_.uniform(-0.2, 0.2) * u).normalized();
    std::vector<double> dt(n), fwd(n), swing(n);
    double sum_fwd = 0.0, sum_swing = 0.0;
    for (std::size_t j = 0; j < n; ++j) {
      const double prev = j == 0 ? t0 : times[j - 1];
      dt[j] = times[j] - prev;
      const double x = kPi * 0.5 * ((prev - t0) + (times[j] - t0)) / period;
      fwd[j] = std::sin(x) * std::sin(x);
      swing[j] = std::sin(2.0 * x) * fwd[j];  // integrates to zero: the back-and-forth
      sum_fwd += fwd[j] * dt[j];
      sum_swing += swing[j] * dt[j];
    }
    const double size = std::max(std::abs(plan_.bump_angle), 0.05);
    const double c = (rng_.uniform() < 0.5 ? -4.0 : 4.0) * size / period;
    const double a = (plan_.bump_angle - c * sum_swing) / sum_fwd;
    const HandAccel hand = HandAccel::draw(plan_.linear_accel, period, rng_);
    for (std::size_t j = 0; j < n; ++j) {
      const Vector3<double> w = (a * fwd[j] + c * swing[j]) * axis;
      advance(times[j], w);
      push(w, hand.at(times[j] - t0), false);
    }
  }

 private:
  double next_time(double t) {
    const double j = std::clamp(plan_.jitter, 0.0, 0.9);
    return t + (1.0 + rng_.uniform(-j, j)) / plan_.rate_hz;
  }

  // Sample times after t_ until `duration` has elapsed (at least one sample).
  std::vector<double> phase_times(double duration) {
    std::vector<double> times;
    double t = t_;
    do {
      t = next_time(t);
      times.push_back(t);
    } while (t - t_ < duration);
    return times;
  }

  // Holds w over (t_, t] (dt taken from the stored times, as a consumer will).
  void advance(double t, const Vector3<double>& w) {
    const double dt = t - t_;
    r_ = r_ * rotation_exp<double>(w * dt);
    t_ = t;
  }

  void push(const Vector3<double>& w, const Vector3<double>& a_lin, bool still) {
    MotionSample s;
    s.t = t_;
    s.rate = w;
    s.still = still;
    const Vector3<double> f = r_.transpose() * (Vector3<double>(0.0, 0.0, plan_.gravity) + a_lin);
    s.acc = raw_from_calibrated(rec_.acc, f) + noise(acc_spec_.noise);
    if (plan_.accel_drift != 0.0)
      s.acc += Vector3<double>::Constant(accel_offset(plan_, t_) / std::sqrt(3.0));
    s.gyro = raw_gyro_from_rate(rec_.gyro, w) + noise(gyro_spec_.noise);
    // The maximal runs of still samples, in order.
    if (still) {
      if (!last_still_) rec_.rests.push_back({count_, count_});
      rec_.rests.back().end = count_ + 1;
    }
    last_still_ = still;
    ++count_;
    if (sink_ != nullptr && *sink_) {
      (*sink_)(s);
      return;
    }
    rec_.samples.push_back(s);
    if (plan_.record_attitude) rec_.attitude.push_back(r_);
  }

  Vector3<double> noise(double sd) { return rng_.normal3() * sd; }

  const MotionPlan& plan_;
  const AccelSensorSpec& acc_spec_;
  const GyroSensorSpec& gyro_spec_;
  Random& rng_;
  Recording& rec_;
  const std::function<void(const MotionSample&)>* sink_;
  std::size_t count_ = 0;  // samples pushed
  bool last_still_ = false;
  Matrix3<double> r_ = Matrix3<double>::Identity();
  double t_ = 0.0;
};

}  // namespace detail

// Draws the accelerometer and gyroscope truth, a random initial attitude, and the whole stream:
// initial rest, then plan.poses times (move, rest). Deterministic for a given rng state.
// With a sink, every sample goes to it as it is made and rec.samples stays empty (rec.rests still
// index the samples in the order the sink saw them).
inline Recording simulate_motion(const MotionPlan& plan, const AccelSensorSpec& acc_spec,
                                 const GyroSensorSpec& gyro_spec, Random& rng,
                                 const std::function<void(const MotionSample&)>& sink = {}) {
  Recording rec;
  rec.acc = draw_accel_truth(acc_spec, rng, plan.gravity);
  rec.gyro = draw_gyro_truth(gyro_spec, rng);
  const double poses = static_cast<double>(std::max(plan.poses, 0));
  // The expected length plus a margin (a vector that grows doubles: too much for a 2 MB board).
  const double seconds =
      plan.initial_rest_s +
      poses * 0.5 * (plan.rest_min_s + plan.rest_max_s + plan.move_min_s + plan.move_max_s) +
      std::max(plan.bump_s, 0.0);
  const double estimate = 1.25 * seconds * plan.rate_hz + 64.0;
  if (estimate > 0.0 && estimate < 1e8 && !sink) {
    rec.samples.reserve(static_cast<std::size_t>(estimate));
    if (plan.record_attitude) rec.attitude.reserve(static_cast<std::size_t>(estimate));
  }

  // Net move angles stay clear of pi, where the rotation vector (and so the move) is ambiguous.
  const double max_angle = std::clamp(plan.move_angle_max, 1e-3, detail::kPi - 0.05);
  const double min_angle = std::clamp(plan.move_angle_min, 1e-3, max_angle);
  detail::MotionBuilder builder(plan, acc_spec, gyro_spec, rng, rec, &sink);
  detail::TargetPlanner planner(max_angle);
  builder.start(random_rotation(rng));
  builder.rest(plan.initial_rest_s, plan.hand_initial_rest);
  planner.record_rest(builder.up());
  for (int i = 0; i < plan.poses; ++i) {
    const Vector3<double> up = builder.up();
    const Vector3<double> target = planner.target(i, up, rng);
    const double delta = detail::angle_between(up, target);
    const double theta = std::min(max_angle, std::max(rng.uniform(min_angle, max_angle), delta));
    builder.move(detail::turn_to(up, target, theta, rng));
    const double duration = rng.uniform(plan.rest_min_s, plan.rest_max_s);
    if (i == plan.bump_rest) {
      builder.rest(0.5 * duration);
      builder.bump();
      builder.rest(0.5 * duration);
    } else {
      builder.rest(duration);
    }
    planner.record_rest(builder.up());
  }
  return rec;
}

}  // namespace imucal::sim
