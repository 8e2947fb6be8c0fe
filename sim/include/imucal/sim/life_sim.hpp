// SPDX-License-Identifier: MIT
// imucal/sim/life_sim.hpp: days of a device's life in normal use, with known truth, for the field
// calibrators' bench (bench/field/): raw 16-bit accelerometer, gyroscope, magnetometer and
// temperature readings generated one sample at a time (never the whole life in memory), while
// the biases follow temperature and a random walk, and events (a knock, a magnetisation change,
// a passing magnet) happen when the plan says. Six lives (desk, handheld, vehicle, drone, fixed,
// turntable) each make a plan from a seed and a length. Double precision, host only (it
// allocates a little per phase).
//
// Conventions (imucal's, math.md section 1): the biases are ADDED to the raw readings in raw
// units, a_cal = T K (a_raw + b(T)), w_cal = T K (w_raw + b(T)). A calibrator that works in SI
// and SUBTRACTS an offset from the nominally scaled reading (Android's CHRE does) sees the offset
// -s b, with s the nominal scale (m/s^2, rad/s or uT per count): LifeTruth carries both. The
// attitude R is body to world, world z up, x north; the accelerometer reads R^T (g e_z + a_lin).
// The body rate of sample k is held over (t_{k-1}, t_k], R_k = R_{k-1} exp([w_k dt]x), as in
// motion_sim.hpp, whose hand moves, knocks and hand-held rests this reuses.
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
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "imucal/models/accel_model.hpp"
#include "imucal/models/gyro_model.hpp"
#include "imucal/sim/accel_sim.hpp"
#include "imucal/sim/mag_sim.hpp"
#include "imucal/sim/motion_sim.hpp"
#include "imucal/sim/random.hpp"
#include "imucal/sim/temperature_sim.hpp"
#include "imucal/types.hpp"

namespace imucal::sim {

// The parts, as their datasheets state them (defaults: a consumer 6-axis IMU at +-2000 deg/s and
// +-8 g, a phone magnetometer at 0.15 uT per count, a temperature sensor at 1/512 deg C).
struct LifeSensors {
  double rate_hz = 100.0;  // IMU output rate
  // Gyroscope.
  double gyro_lsb_per_dps = 16.4;       // counts per deg/s (+-2000 deg/s)
  double gyro_noise_dps_rthz = 0.01;    // white noise density, deg/s/sqrt(Hz)
  double gyro_bias_dps = 3.0;           // bias at the reference temperature, uniform +- per axis
  double gyro_scale_spread = 0.02;      // relative, uniform +-
  double gyro_misalignment = 0.01;      // rad, uniform +-
  double gyro_slope_min_dps_c = 0.002;  // |bias slope| uniform in [min, max], deg/s per deg C
  double gyro_slope_max_dps_c = 0.02;   //
  double gyro_rrw_dps_rts = 1e-4;       // rate random walk density, deg/s/sqrt(s)
  // Accelerometer.
  double accel_lsb_per_g = 4096.0;     // counts per g (+-8 g)
  double accel_noise_ug_rthz = 150.0;  // white noise density, micro-g/sqrt(Hz)
  double accel_bias_mg = 40.0;         // bias at the reference temperature, uniform +- per axis
  double accel_scale_spread = 0.02;    // relative, uniform +-
  double accel_misalignment = 0.01;    // rad, uniform +-
  double accel_slope_min_mg_c = 0.1;   // |bias slope| uniform in [min, max], mg per deg C
  double accel_slope_max_mg_c = 1.0;   //
  double accel_rrw_mg_rts = 2e-3;      // bias random walk density, mg/sqrt(s)
  // Both: the curvature of the bias against temperature (DriftSpec::quad_min, quad_max) and the
  // temperature at which the drawn bias holds.
  double quad_min = 0.3, quad_max = 1.0;
  double reference_c = 25.0;
  // Magnetometer (optional, at its own rate).
  bool has_mag = true;
  double mag_rate_hz = 50.0;
  double mag_ut_per_lsb = 0.15;
  double mag_field_ut = 48.0;      // local field
  double mag_dip_deg = 62.0;       // inclination
  double mag_hard_iron_ut = 50.0;  // uniform +- per axis
  double mag_scale_spread = 0.03;  // soft iron: relative, uniform +- on the diagonal
  double mag_off_diagonal = 0.02;  // soft iron: uniform +- off the diagonal
  double mag_noise_ut = 0.3;       // per sample
  // Temperature sensor (optional, at its own rate; 0: with every IMU sample).
  bool has_temperature = true;
  double temperature_rate_hz = 0.0;
  double temperature_noise_c = 0.05;
  double temperature_lsb_c = 1.0 / 512.0;
  double gravity = 9.80665;
  // The device timer: microseconds, wrapping; the first sample's value (near 2^32: the timer
  // wraps 30 s into the life).
  std::uint32_t t0_us = 4294967295u - 29999999u;
};

// What a device knows of its parts: the nominal scales (SI per count) and the rates. An
// estimator is given this, never the truth.
struct DeviceSheet {
  double rate_hz;
  double gyro_rad_s_per_count;
  double accel_m_s2_per_count;
  double gyro_noise_rad_s_rthz;  // datasheet white noise densities
  double accel_noise_m_s2_rthz;
  bool has_mag;
  double mag_rate_hz;
  double mag_ut_per_count;
  bool has_temperature;
  double gravity;
  // The accelerometer's datasheet tolerances (bounds, as a datasheet states them): the zero-g
  // offset (m/s^2), the scale (relative), the axes' misalignment (rad), the offset's drift with
  // temperature (m/s^2 per deg C).
  double accel_offset_m_s2;
  double accel_scale_tolerance;
  double accel_misalignment_rad;
  double accel_offset_drift_m_s2_c;
};

enum class PhaseKind : std::uint8_t {
  kRest,       // truly still (on a surface, bolted, parked)
  kMove,       // a hand move to an attitude (motion_sim's move)
  kHand,       // held in the hand and used: free rotation, hand accelerations
  kHandRest,   // held still in the hand: tremor (motion_sim's rest in the hand); not still
  kPocket,     // walking with the device in a pocket
  kTurn,       // a steady turn about the vertical (a vehicle's bend, a turntable): not still
  kVibration,  // zero-mean vibration (an idling engine, machinery): not still
  kDrive,      // driving: yaw rate, speed changes, road vibration
  kFlight,     // a drone flight: tilts, yaw, thrust, propeller vibration
  kKnock,      // a knock (motion_sim's bump) with a step in the biases
};

inline const char* phase_name(PhaseKind k) {
  switch (k) {
    case PhaseKind::kRest:
      return "rest";
    case PhaseKind::kMove:
      return "move";
    case PhaseKind::kHand:
      return "hand";
    case PhaseKind::kHandRest:
      return "hand_rest";
    case PhaseKind::kPocket:
      return "pocket";
    case PhaseKind::kTurn:
      return "turn";
    case PhaseKind::kVibration:
      return "vibration";
    case PhaseKind::kDrive:
      return "drive";
    case PhaseKind::kFlight:
      return "flight";
    case PhaseKind::kKnock:
      return "knock";
  }
  return "?";
}

struct LifePhase {
  PhaseKind kind = PhaseKind::kRest;
  double duration_s = 1.0;
  // kMove: the attitude reached, absolute (body to world) or, when relative, R_after = R_before
  // * target.
  Eigen::Quaterniond target = Eigen::Quaterniond::Identity();
  bool relative = false;
  double turn_dps = 0.0;        // kTurn: the steady rate about the vertical (signed)
  double speed_m_s = 0.0;       // kTurn, kDrive: the vehicle's speed (centripetal acceleration)
  double vib_gyro_dps = 0.0;    // kVibration, kDrive, kFlight: vibration RMS, rate
  double vib_accel_m_s2 = 0.0;  //   and acceleration
  double vib_min_hz = 20.0, vib_max_hz = 35.0;
  double heat_c = 0.0;  // self-heating: the temperature approached above the ambient
  Vector3<double> gyro_step_dps = Vector3<double>::Zero();  // kKnock: bias steps (added to the
  Vector3<double> accel_step_mg = Vector3<double>::Zero();  //   raw reading's bias)
  double knock_angle = 0.05;  // kKnock: net rotation left by the knock, rad
  // kHand: the rotation rate's standard deviation per axis (rad/s) and correlation time (s);
  // 0: a calm hand (0.3 rad/s, 0.8 s).
  double hand_rate_rad_s = 0.0, hand_tau_s = 0.0;
};

struct HardIronStep {
  double t_s;
  Vector3<double> step_ut;  // added to the true hard iron (in uT; the raw units' hard iron
                            // moves by step / mag_ut_per_lsb)
};

struct MagnetPass {
  double t_s, duration_s;
  Vector3<double> peak_ut;  // in the magnetometer's frame, sin^2 envelope over the duration
};

struct LifePlan {
  std::string name;
  std::uint64_t seed = 0;
  LifeSensors sensors{};
  // Ambient temperature: a daily cycle between min and max (period, phase in cycles at t = 0).
  double ambient_min_c = 15.0, ambient_max_c = 45.0;
  double ambient_period_s = 86400.0, ambient_phase = 0.0;
  double heat_tau_s = 150.0;  // first-order self-heating time constant
  Eigen::Quaterniond start = Eigen::Quaterniond::Identity();  // attitude at t = 0
  std::vector<LifePhase> phases;
  std::vector<HardIronStep> hard_iron_steps;  // in time order
  std::vector<MagnetPass> magnet_passes;      // in time order
  // The planned length (moves and knocks may end a few samples later than planned).
  double duration_s() const {
    double d = 0.0;
    for (const LifePhase& p : phases) d += p.duration_s;
    return d;
  }
};

// Which events a life has; the sensors it runs with.
struct LifeOptions {
  LifeSensors sensors{};
  bool knock = true;           // a sudden bias shift with a knock, mid-life
  bool hard_iron_step = true;  // a magnetisation change, late in the life
  bool magnet_pass = true;     // a magnet passing, early in the life
  bool magnetometer = true;    // false: the magnetometer-free variant
};

// One sample as the device reads it.
struct LifeSample {
  double t_s = 0.0;        // seconds since the life began (for the harness)
  std::uint32_t t_us = 0;  // the device timer, microseconds, wrapping
  std::array<std::int16_t, 3> acc_counts{}, gyro_counts{}, mag_counts{};
  ImuSample<float> imu;  // t_us, acc and gyro as floats (the counts), the latest temperature
  Vector3<float> mag = Vector3<float>::Zero();  // the counts as floats (the latest reading)
  bool mag_new = false;                         // a magnetometer reading arrived with this sample
  bool temperature_new = false;                 // a temperature reading arrived with this sample
};

// The truth at one sample.
struct LifeTruth {
  std::size_t phase_index = 0;
  PhaseKind phase = PhaseKind::kRest;
  double phase_time_s = 0.0;                       // since the phase began
  bool still = false;                              // the body does not move at all (true rate zero)
  Vector3<double> rate = Vector3<double>::Zero();  // body rate, rad/s, held over (t_{k-1}, t_k]
  Eigen::Quaterniond attitude = Eigen::Quaterniond::Identity();  // body to world
  Vector3<double> specific_force = Vector3<double>::Zero();      // body frame, m/s^2
  double temperature_c = 0.0;
  // Biases ADDED to the raw reading (counts), and their random-walk part (the rest follows the
  // temperature curve; knocks step the walk).
  Vector3<double> gyro_bias = Vector3<double>::Zero(), accel_bias = Vector3<double>::Zero();
  Vector3<double> gyro_walk = Vector3<double>::Zero(), accel_walk = Vector3<double>::Zero();
  // The same as an SI offset SUBTRACTED from the nominally scaled reading: -s b.
  Vector3<double> gyro_offset_si = Vector3<double>::Zero();   // rad/s
  Vector3<double> accel_offset_si = Vector3<double>::Zero();  // m/s^2
  GyroVector<double> gyro = GyroVector<double>::Zero();       // full models, bias = the above
  AccelVector<double> accel = AccelVector<double>::Zero();
  Vector3<double> hard_iron = Vector3<double>::Zero();     // added, counts
  Vector3<double> hard_iron_ut = Vector3<double>::Zero();  // subtracted from the uT reading
  bool magnet_near = false;                                // a passing magnet adds its field
  bool saturated = false;  // an accelerometer or gyro count was clipped at the int16 range
};

namespace life_detail {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kDeg = kPi / 180.0;

// A sum of three sinusoids along random directions, of total RMS (vector norm) `rms`, at
// frequencies uniform in [f_min, f_max]: zero mean (vibration, a walking gait).
struct Sinusoids {
  std::array<Vector3<double>, 3> amplitude{};
  std::array<double, 3> omega{}, phase{};

  static Sinusoids draw(double rms, double f_min, double f_max, Random& rng) {
    Sinusoids s;
    const double each = rms * std::sqrt(2.0 / 3.0);
    for (std::size_t j = 0; j < 3; ++j) {
      s.amplitude[j] = random_direction(rng) * each;
      s.omega[j] = 2.0 * kPi * rng.uniform(f_min, f_max);
      s.phase[j] = rng.uniform(0.0, 2.0 * kPi);
    }
    return s;
  }

  Vector3<double> at(double t) const {
    Vector3<double> v = Vector3<double>::Zero();
    for (std::size_t j = 0; j < 3; ++j) v += amplitude[j] * std::sin(omega[j] * t + phase[j]);
    return v;
  }
  // An integral of at() over t.
  Vector3<double> integral(double t) const {
    Vector3<double> v = Vector3<double>::Zero();
    for (std::size_t j = 0; j < 3; ++j)
      v -= amplitude[j] * (std::cos(omega[j] * t + phase[j]) / omega[j]);
    return v;
  }
};

// A scalar Ornstein-Uhlenbeck process of standard deviation sd and correlation time tau.
struct OrnsteinUhlenbeck {
  double x = 0.0, a = 0.0, b = 0.0;
  void init(double sd, double tau, double dt, double x0) {
    a = std::exp(-dt / tau);
    b = sd * std::sqrt(1.0 - a * a);
    x = x0;
  }
  double step(Random& rng) { return x = a * x + b * rng.normal(); }
};

inline Matrix3<double> rot_z(double a) {
  return Eigen::AngleAxisd(a, Vector3<double>::UnitZ()).toRotationMatrix();
}
inline Matrix3<double> rot_x(double a) {
  return Eigen::AngleAxisd(a, Vector3<double>::UnitX()).toRotationMatrix();
}

// 0 -> 1 over [0, ramp] (sin^2), 1 -> 0 over [d - ramp, d].
inline double ramp_envelope(double tau, double d, double ramp) {
  if (ramp <= 0.0) return 1.0;
  const double edge = std::min(tau, d - tau);
  if (edge >= ramp) return 1.0;
  if (edge <= 0.0) return 0.0;
  const double s = std::sin(0.5 * kPi * edge / ramp);
  return s * s;
}

inline std::int16_t to_count(double v, bool& clipped) {
  const double r = std::nearbyint(v);
  if (r > 32767.0) {
    clipped = true;
    return 32767;
  }
  if (r < -32768.0) {
    clipped = true;
    return -32768;
  }
  return static_cast<std::int16_t>(r);
}

}  // namespace life_detail

// Generates a life sample by sample: next() until it returns false. The truth (the sensors'
// models, the bias curves, the magnetometer) is drawn from the plan's seed; the same plan gives
// the same stream.
class LifeSimulator {
 public:
  explicit LifeSimulator(const LifePlan& plan)
      : plan_(plan), rng_(plan.seed ^ 0x5DEECE66DA3B1F27ull) {
    using life_detail::kDeg;
    const LifeSensors& s = plan_.sensors;
    dt_ = 1.0 / s.rate_hz;
    const double bw = std::sqrt(0.5 * s.rate_hz);  // white noise over the Nyquist band
    gyro_spec_ =
        GyroSensorSpec{kDeg / s.gyro_lsb_per_dps, 0.0,
                       s.gyro_scale_spread,       s.gyro_bias_dps * s.gyro_lsb_per_dps,
                       s.gyro_misalignment,       s.gyro_noise_dps_rthz * bw * s.gyro_lsb_per_dps};
    accel_spec_ = AccelSensorSpec{
        s.gravity / s.accel_lsb_per_g, 0.0,
        s.accel_scale_spread,          s.accel_bias_mg * 1e-3 * s.accel_lsb_per_g,
        s.accel_misalignment,          s.accel_noise_ug_rthz * 1e-6 * bw * s.accel_lsb_per_g};
    DriftSpec drift;
    drift.accel_slope_min = s.accel_slope_min_mg_c * 1e-3;
    drift.accel_slope_max = s.accel_slope_max_mg_c * 1e-3;
    drift.gyro_slope_min = s.gyro_slope_min_dps_c;
    drift.gyro_slope_max = s.gyro_slope_max_dps_c;
    drift.quad_min = s.quad_min;
    drift.quad_max = s.quad_max;
    // DriftSpec's slopes are in g per deg C; draw_temperature_truth converts with 9.80665.
    imu_ =
        draw_temperature_truth(accel_spec_, gyro_spec_, 2, s.reference_c, rng_, drift, s.gravity);
    gyro_inv_ = gyro_matrix<double>(imu_.gyro.params).inverse();
    accel_inv_ = accel_matrix(imu_.acc.params).inverse();
    // The random walks step at about 10 Hz (a day at 100 Hz draws 6 normals a sample less).
    walk_every_ = static_cast<std::uint64_t>(std::max(1.0, std::floor(0.1 * s.rate_hz)));
    const double walk_dt = static_cast<double>(walk_every_) * dt_;
    gyro_walk_sd_ = s.gyro_rrw_dps_rts * s.gyro_lsb_per_dps * std::sqrt(walk_dt);
    accel_walk_sd_ = s.accel_rrw_mg_rts * 1e-3 * s.accel_lsb_per_g * std::sqrt(walk_dt);
    const MagSensorSpec mag_spec{s.mag_ut_per_lsb,
                                 s.mag_field_ut,
                                 s.mag_dip_deg,
                                 s.mag_scale_spread,
                                 s.mag_off_diagonal,
                                 s.mag_hard_iron_ut / s.mag_ut_per_lsb,
                                 s.mag_noise_ut / s.mag_ut_per_lsb,
                                 0.0};
    mag_ = draw_mag_truth(mag_spec, rng_);
    mag_noise_ = mag_spec.noise;
    mag_s_inv_ = mag_.S_true.inverse();
    r_ = plan_.start.normalized().toRotationMatrix();
    // A vehicle's forward axis, fixed in the body: the world's x at the start.
    forward_body_ = r_.transpose() * Vector3<double>::UnitX();
    // The motion parts of motion_sim.hpp generate kinematics only: an identity sensor without
    // noise, so their "raw" readings are the specific force and the body rate.
    kin_.acc.gravity = s.gravity;
    kin_.acc.params << 0, 0, 0, 1, 1, 1, 0, 0, 0;
    kin_.gyro.params << 0, 0, 0, 0, 0, 0, 1, 1, 1, 0, 0, 0;
    kin_acc_spec_ = AccelSensorSpec{1.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    kin_gyro_spec_ = GyroSensorSpec{1.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    motion_.rate_hz = s.rate_hz;
    motion_.jitter = 0.0;
    motion_.gravity = s.gravity;
    motion_.hand_tremor = 0.02;
    motion_.hand_drift = 0.03;
    motion_.hand_accel = 0.1;
    sink_ = [this](const MotionSample& m) { buffer_.push_back(m); };
    ambient_amplitude_ = 0.5 * (plan_.ambient_max_c - plan_.ambient_min_c);
    heat_alpha_ = 1.0 - std::exp(-dt_ / plan_.heat_tau_s);
  }

  LifeSimulator(const LifeSimulator&) = delete;
  LifeSimulator& operator=(const LifeSimulator&) = delete;

  const LifePlan& plan() const { return plan_; }
  // The IMU's truth: T, K, and the bias curves against temperature (raw units, added).
  const TemperatureTruth& imu_truth() const { return imu_; }
  // The magnetometer's truth at the start (hard iron before any step).
  const MagTruth& mag_truth() const { return mag_start_ ? *mag_start_ : mag_; }
  // The per-sample white noise of the raw readings (counts, before rounding).
  double gyro_noise_counts() const { return gyro_spec_.noise; }
  double accel_noise_counts() const { return accel_spec_.noise; }
  double mag_noise_counts() const { return mag_noise_; }
  DeviceSheet sheet() const {
    using life_detail::kDeg;
    const LifeSensors& s = plan_.sensors;
    return {s.rate_hz,
            gyro_spec_.nominal_scale,
            accel_spec_.nominal_scale,
            s.gyro_noise_dps_rthz * kDeg,
            s.accel_noise_ug_rthz * 1e-6 * s.gravity,
            s.has_mag,
            s.mag_rate_hz,
            s.mag_ut_per_lsb,
            s.has_temperature,
            s.gravity,
            s.accel_bias_mg * 1e-3 * s.gravity,
            s.accel_scale_spread,
            s.accel_misalignment,
            s.accel_slope_max_mg_c * 1e-3 * s.gravity};
  }
  // The true ambient temperature (without self-heating) at time t.
  double ambient_c(double t) const {
    const double c = 2.0 * life_detail::kPi * (t / plan_.ambient_period_s + plan_.ambient_phase);
    return plan_.ambient_min_c + ambient_amplitude_ * (1.0 - std::cos(c));
  }

  // The next sample and its truth; false once every phase is done.
  bool next(LifeSample& out, LifeTruth& truth) {
    using namespace life_detail;
    const LifeSensors& s = plan_.sensors;
    Vector3<double> w = Vector3<double>::Zero();
    Vector3<double> f;
    if (k_ == 0) {
      if (plan_.phases.empty()) return false;
      begin_phase(0);
      f = r_.transpose() * Vector3<double>(0.0, 0.0, s.gravity);
    } else {
      t_ = static_cast<double>(k_) * dt_;
      while (phase_done()) {
        if (phase_ + 1 >= plan_.phases.size()) return false;
        begin_phase(phase_ + 1);
      }
      motion_step(w, f);
    }
    const LifePhase& ph = plan_.phases[phase_];

    // Temperature: the ambient cycle plus first-order self-heating.
    heat_ += (ph.heat_c - heat_) * (k_ == 0 ? 0.0 : heat_alpha_);
    const double temp = ambient_c(t_) + heat_;

    // Biases: the curve at the temperature, plus the walk (knocks step the walk), which steps
    // every walk_every_ samples.
    if (k_ > 0 && k_ % walk_every_ == 0) {
      if (gyro_walk_sd_ > 0.0) gyro_walk_ += rng_.normal3() * gyro_walk_sd_;
      if (accel_walk_sd_ > 0.0) accel_walk_ += rng_.normal3() * accel_walk_sd_;
    }
    const Vector3<double> bg = imu_.gyro_bias(temp) + gyro_walk_;
    const Vector3<double> ba = imu_.accel_bias(temp) + accel_walk_;
    const Vector3<double> gyro_raw = gyro_inv_ * w - bg + rng_.normal3() * gyro_spec_.noise;
    const Vector3<double> acc_raw = accel_inv_ * f - ba + rng_.normal3() * accel_spec_.noise;

    bool clipped = false;
    out.t_s = t_;
    out.t_us = s.t0_us + static_cast<std::uint32_t>(
                             static_cast<std::uint64_t>(std::llround(t_ * 1e6)) & 0xFFFFFFFFull);
    for (int i = 0; i < 3; ++i) {
      const auto u = static_cast<std::size_t>(i);
      out.gyro_counts[u] = to_count(gyro_raw(i), clipped);
      out.acc_counts[u] = to_count(acc_raw(i), clipped);
      out.imu.gyro(i) = static_cast<float>(out.gyro_counts[u]);
      out.imu.acc(i) = static_cast<float>(out.acc_counts[u]);
    }
    out.imu.t_us = out.t_us;

    // Temperature sensor.
    out.temperature_new = false;
    if (s.has_temperature) {
      if (due(s.temperature_rate_hz, temperature_readings_)) {
        const double reading = temp + s.temperature_noise_c * rng_.normal();
        temperature_reading_ =
            s.temperature_lsb_c > 0.0
                ? std::nearbyint(reading / s.temperature_lsb_c) * s.temperature_lsb_c
                : reading;
        out.temperature_new = true;
      }
      out.imu.temperature = static_cast<float>(temperature_reading_);
    } else {
      out.imu.temperature = std::numeric_limits<float>::quiet_NaN();
    }

    // Magnetometer: hard-iron steps, passing magnets, its own rate.
    while (next_hard_iron_ < plan_.hard_iron_steps.size() &&
           plan_.hard_iron_steps[next_hard_iron_].t_s <= t_) {
      if (!mag_start_) mag_start_ = mag_;
      mag_.h_true += plan_.hard_iron_steps[next_hard_iron_].step_ut / s.mag_ut_per_lsb;
      ++next_hard_iron_;
    }
    Vector3<double> magnet = Vector3<double>::Zero();
    bool magnet_near = false;
    for (const MagnetPass& m : plan_.magnet_passes) {
      if (t_ >= m.t_s && t_ < m.t_s + m.duration_s) {
        const double e = std::sin(kPi * (t_ - m.t_s) / m.duration_s);
        magnet += m.peak_ut * (e * e);
        magnet_near = true;
      }
    }
    out.mag_new = false;
    if (s.has_mag && due(s.mag_rate_hz, mag_readings_)) {
      const Vector3<double> m = raw_mag(mag_, r_, mag_noise_, rng_) + mag_s_inv_ * magnet;
      bool mag_clipped = false;
      for (int i = 0; i < 3; ++i) {
        const auto u = static_cast<std::size_t>(i);
        out.mag_counts[u] = to_count(m(i), mag_clipped);
        out.mag(i) = static_cast<float>(out.mag_counts[u]);
      }
      out.mag_new = true;
    }

    truth.phase_index = phase_;
    truth.phase = ph.kind;
    truth.phase_time_s = t_ - phase_start_;
    truth.still = w.squaredNorm() == 0.0 && ph.kind == PhaseKind::kRest;
    truth.rate = w;
    truth.attitude = Eigen::Quaterniond(r_);
    truth.specific_force = f;
    truth.temperature_c = temp;
    truth.gyro_bias = bg;
    truth.accel_bias = ba;
    truth.gyro_walk = gyro_walk_;
    truth.accel_walk = accel_walk_;
    truth.gyro_offset_si = -gyro_spec_.nominal_scale * bg;
    truth.accel_offset_si = -accel_spec_.nominal_scale * ba;
    truth.gyro = imu_.gyro.params;
    truth.gyro.tail<3>() = bg;
    truth.accel = imu_.acc.params;
    truth.accel.tail<3>() = ba;
    truth.hard_iron = mag_.h_true;
    truth.hard_iron_ut = -s.mag_ut_per_lsb * mag_.h_true;
    truth.magnet_near = magnet_near;
    truth.saturated = clipped;
    ++k_;
    if (k_ % 1024 == 0) r_ = Eigen::Quaterniond(r_).normalized().toRotationMatrix();
    return true;
  }

 private:
  // A sensor at its own rate (0: with every sample) reads at this sample when its next reading
  // time has come; `count` is its readings so far.
  bool due(double rate_hz, std::uint64_t& count) const {
    if (rate_hz <= 0.0) return true;
    if (t_ + 1e-9 < static_cast<double>(count) / rate_hz) return false;
    ++count;
    return true;
  }

  bool phase_done() const {
    const LifePhase& p = plan_.phases[phase_];
    if (buffered_) return next_buffered_ >= buffer_.size();
    return t_ >= phase_start_ + p.duration_s - 1e-9;
  }

  void begin_phase(std::size_t i) {
    using namespace life_detail;
    phase_ = i;
    phase_start_ = t_;
    const LifePhase& p = plan_.phases[i];
    buffered_ = false;
    buffer_.clear();
    next_buffered_ = 0;
    hand_.reset();
    switch (p.kind) {
      case PhaseKind::kMove: {
        const Matrix3<double> target = p.target.normalized().toRotationMatrix();
        const Matrix3<double> q = p.relative ? target : Matrix3<double>(r_.transpose() * target);
        // Two halves when the turn is near pi, where the rotation vector is ambiguous.
        const double angle = so3_log(q).norm();
        if (angle > 2.6) {
          const Eigen::Quaterniond half =
              Eigen::Quaterniond::Identity().slerp(0.5, Eigen::Quaterniond(q));
          buffer_moves({half.toRotationMatrix(), half.toRotationMatrix()}, 0.5 * p.duration_s);
        } else {
          buffer_moves({q}, p.duration_s);
        }
        break;
      }
      case PhaseKind::kKnock: {
        gyro_walk_ += p.gyro_step_dps * plan_.sensors.gyro_lsb_per_dps;
        accel_walk_ += p.accel_step_mg * 1e-3 * plan_.sensors.accel_lsb_per_g;
        motion_.bump_angle = p.knock_angle;
        motion_.bump_s = p.duration_s;
        run_builder([](detail::MotionBuilder& b) { b.bump(); });
        break;
      }
      case PhaseKind::kHandRest: {
        const double d = p.duration_s;
        run_builder([d](detail::MotionBuilder& b) { b.rest(d, true); });
        break;
      }
      case PhaseKind::kHand:
      case PhaseKind::kPocket: {
        HandRotation::Options o;
        o.rate_hz = plan_.sensors.rate_hz;
        o.rate_rad_s = p.kind == PhaseKind::kPocket ? 0.15
                       : p.hand_rate_rad_s > 0.0    ? p.hand_rate_rad_s
                                                    : 0.3;
        o.tau_s = p.kind == PhaseKind::kPocket ? 2.0 : p.hand_tau_s > 0.0 ? p.hand_tau_s : 0.8;
        hand_.emplace(o, mag_world(mag_), rng_);
        hand_prev_ = hand_->attitude();
        if (p.kind == PhaseKind::kHand) {
          lin_ = Sinusoids::draw(0.3, 0.3, 2.0, rng_);
          sway_ = Sinusoids::draw(0.05, 0.5, 2.0, rng_);
        } else {
          const double step_hz = rng_.uniform(1.7, 2.2);
          lin_ = Sinusoids::draw(2.5, step_hz, 2.0 * step_hz, rng_);
          sway_ = Sinusoids::draw(0.4, 0.5 * step_hz, step_hz, rng_);
        }
        break;
      }
      case PhaseKind::kVibration:
      case PhaseKind::kDrive:
      case PhaseKind::kFlight: {
        const double nyquist = 0.45 * plan_.sensors.rate_hz;
        const double hi = std::min(p.vib_max_hz, nyquist);
        const double lo = std::min(p.vib_min_hz, hi);
        sway_ = Sinusoids::draw(p.vib_gyro_dps * kDeg, lo, hi, rng_);
        lin_ = Sinusoids::draw(p.vib_accel_m_s2, lo, hi, rng_);
        if (p.kind == PhaseKind::kDrive) {
          yaw_rate_.init(3.0 * kDeg, 5.0, dt_, 0.0);
          long_accel_.init(0.8, 4.0, dt_, 0.0);
          speed_ = p.speed_m_s;
        }
        if (p.kind == PhaseKind::kFlight) {
          roll_.init(6.0 * kDeg, 1.5, dt_, 0.0);
          pitch_.init(6.0 * kDeg, 1.5, dt_, 0.0);
          yaw_rate_.init(15.0 * kDeg, 3.0, dt_, 0.0);
          yaw_ = 0.0;
          flight_start_ = r_;
          thrust_body_ = r_.transpose() * Vector3<double>::UnitZ();  // level at take-off
        }
        break;
      }
      case PhaseKind::kTurn:
      case PhaseKind::kRest:
        break;
    }
  }

  // motion_sim's builder from the current attitude; its samples (kinematics) into the buffer.
  template <class Run>
  void run_builder(Run run) {
    buffered_ = true;
    detail::MotionBuilder b(motion_, kin_acc_spec_, kin_gyro_spec_, rng_, kin_, &sink_);
    kin_.rests.clear();
    b.start(r_);
    buffer_.clear();  // the start sample is the previous sample's instant
    run(b);
  }

  void buffer_moves(const std::vector<Matrix3<double>>& moves, double duration) {
    motion_.move_min_s = motion_.move_max_s = duration;
    run_builder([&moves](detail::MotionBuilder& b) {
      for (const Matrix3<double>& q : moves) b.move(q);
    });
  }

  // The body rate held over (t - dt, t] and the specific force at t; advances the attitude.
  void motion_step(Vector3<double>& w, Vector3<double>& f) {
    using namespace life_detail;
    const LifePhase& p = plan_.phases[phase_];
    const double g = plan_.sensors.gravity;
    const double tau = t_ - phase_start_;
    Vector3<double> a_world = Vector3<double>::Zero();  // linear acceleration, world frame
    Vector3<double> a_body = Vector3<double>::Zero();   // vibration, body frame
    w.setZero();
    switch (p.kind) {
      case PhaseKind::kRest:
        break;
      case PhaseKind::kMove:
      case PhaseKind::kKnock:
      case PhaseKind::kHandRest: {
        const MotionSample& m = buffer_[next_buffered_++];
        w = m.rate;
        advance(w);
        f = m.acc;  // identity sensor: the specific force
        return;
      }
      case PhaseKind::kHand:
      case PhaseKind::kPocket: {
        const Matrix3<double> c = hand_->next();
        w = so3_log(hand_prev_.transpose() * c) / dt_ + sway_.at(tau);
        hand_prev_ = c;
        a_world = lin_.at(tau);
        break;
      }
      case PhaseKind::kTurn: {
        const double ramp = std::min(2.0, 0.25 * p.duration_s);
        const double omega = p.turn_dps * kDeg * ramp_envelope(tau, p.duration_s, ramp);
        w = r_.transpose() * Vector3<double>::UnitZ() * omega;
        const Vector3<double> fwd = r_ * forward_body_;
        a_world = p.speed_m_s * omega * Vector3<double>::UnitZ().cross(fwd);
        break;
      }
      case PhaseKind::kVibration: {
        // The rotation angle is the rate's integral faded in and out over 0.5 s: the rate is its
        // increment over the sample, so the attitude ends where it began (a bolted node keeps
        // its one orientation).
        auto angle = [&](double x) {
          return Vector3<double>(ramp_envelope(x, p.duration_s, 0.5) * sway_.integral(x));
        };
        w = (angle(tau) - angle(std::max(0.0, tau - dt_))) / dt_;
        a_body = lin_.at(tau);
        break;
      }
      case PhaseKind::kDrive: {
        const double ramp = std::min(3.0, 0.25 * p.duration_s);
        const double env = ramp_envelope(tau, p.duration_s, ramp);
        const double r = env * yaw_rate_.step(rng_);
        double a = env * long_accel_.step(rng_) - 0.02 * (speed_ - p.speed_m_s);
        speed_ = std::max(0.0, speed_ + a * dt_);
        if (speed_ == 0.0) a = 0.0;
        w = r_.transpose() * Vector3<double>::UnitZ() * r + sway_.at(tau);
        const Vector3<double> fwd = r_ * forward_body_;
        a_world = a * fwd + speed_ * r * Vector3<double>::UnitZ().cross(fwd);
        a_body = lin_.at(tau);
        break;
      }
      case PhaseKind::kFlight: {
        const double env = ramp_envelope(tau, p.duration_s, std::min(4.0, 0.25 * p.duration_s));
        yaw_ += yaw_rate_.step(rng_) * dt_;
        const Vector3<double> tilt(env * roll_.step(rng_), env * pitch_.step(rng_), 0.0);
        const Matrix3<double> target = rot_z(yaw_) * rotation_exp<double>(tilt) * flight_start_;
        w = so3_log(r_.transpose() * target) / dt_ + sway_.at(tau);
        const Vector3<double> thrust = r_ * thrust_body_;
        a_world = thrust * (g / std::max(thrust.z(), 0.5)) - Vector3<double>(0.0, 0.0, g);
        a_body = lin_.at(tau);
        break;
      }
    }
    advance(w);
    f = r_.transpose() * (Vector3<double>(0.0, 0.0, g) + a_world) + a_body;
  }

  void advance(const Vector3<double>& w) {
    if (w.squaredNorm() > 0.0) r_ = r_ * rotation_exp<double>(Vector3<double>(w * dt_));
  }

  LifePlan plan_;
  Random rng_;
  double dt_ = 0.01;
  GyroSensorSpec gyro_spec_{};
  AccelSensorSpec accel_spec_{};
  TemperatureTruth imu_{};
  Matrix3<double> gyro_inv_, accel_inv_;
  double gyro_walk_sd_ = 0.0, accel_walk_sd_ = 0.0;
  std::uint64_t walk_every_ = 1, mag_readings_ = 0, temperature_readings_ = 0;
  Vector3<double> gyro_walk_ = Vector3<double>::Zero(), accel_walk_ = Vector3<double>::Zero();
  MagTruth mag_{};
  std::optional<MagTruth> mag_start_;
  double mag_noise_ = 0.0;
  Matrix3<double> mag_s_inv_;
  std::size_t next_hard_iron_ = 0;
  double temperature_reading_ = std::numeric_limits<double>::quiet_NaN();
  double ambient_amplitude_ = 0.0, heat_alpha_ = 0.0, heat_ = 0.0;

  // Motion state.
  std::uint64_t k_ = 0;
  double t_ = 0.0, phase_start_ = 0.0;
  std::size_t phase_ = 0;
  Matrix3<double> r_ = Matrix3<double>::Identity();
  MotionPlan motion_{};
  Recording kin_{};
  AccelSensorSpec kin_acc_spec_{};
  GyroSensorSpec kin_gyro_spec_{};
  std::function<void(const MotionSample&)> sink_;
  std::vector<MotionSample> buffer_;
  std::size_t next_buffered_ = 0;
  bool buffered_ = false;
  std::optional<HandRotation> hand_;
  Matrix3<double> hand_prev_ = Matrix3<double>::Identity();
  life_detail::Sinusoids sway_{}, lin_{};
  life_detail::OrnsteinUhlenbeck yaw_rate_{}, long_accel_{}, roll_{}, pitch_{};
  double speed_ = 0.0, yaw_ = 0.0;
  Vector3<double> forward_body_ = Vector3<double>::UnitX();
  Vector3<double> thrust_body_ = Vector3<double>::UnitZ();
  Matrix3<double> flight_start_ = Matrix3<double>::Identity();
};

// ---------------------------------------------------------------------------------------------
// The lives. Each makes a plan from a seed and a length; the options choose the events and the
// sensors.

namespace life_detail {

// A uniform draw in [lo, hi].
struct Span {
  double lo, hi;
};

// Appends phases until the planned length is reached (the last time phase is cut to fit). Its
// methods draw their random values in a fixed order (never two draws in one argument list, whose
// order of evaluation C++ leaves open).
class PlanBuilder {
 public:
  PlanBuilder(LifePlan& plan, double length_s, Random& rng)
      : plan_(plan), end_(length_s), rng_(rng) {}
  bool full() const { return t_ >= end_ - 1e-9; }
  double time() const { return t_; }

  double uniform(Span s) { return rng_.uniform(s.lo, s.hi); }
  double log_uniform(Span s) { return std::exp(rng_.uniform(std::log(s.lo), std::log(s.hi))); }

  void add(LifePhase p) {
    if (full()) return;
    const bool cuttable = p.kind != PhaseKind::kMove && p.kind != PhaseKind::kKnock;
    if (cuttable && t_ + p.duration_s > end_) p.duration_s = end_ - t_;
    if (p.duration_s <= 0.0) return;
    t_ += p.duration_s;
    plan_.phases.push_back(p);
  }
  void rest(double d, double heat = 0.0) {
    LifePhase p;
    p.duration_s = d;
    p.heat_c = heat;
    add(p);
  }
  void move_to(const Matrix3<double>& target, Span d) {
    LifePhase p;
    p.kind = PhaseKind::kMove;
    p.duration_s = uniform(d);
    p.target = Eigen::Quaterniond(target);
    add(p);
  }
  // A turn of an angle in `angle` (rad) about a random axis, from wherever the body is.
  void move_by(Span angle, Span d) {
    LifePhase p;
    p.kind = PhaseKind::kMove;
    p.relative = true;
    const double a = uniform(angle);
    p.duration_s = uniform(d);
    const Vector3<double> axis = random_direction(rng_);
    p.target = Eigen::Quaterniond(rotation_exp<double>(Vector3<double>(axis * a)));
    add(p);
  }
  void simple(PhaseKind kind, double d) {
    LifePhase p;
    p.kind = kind;
    p.duration_s = d;
    add(p);
  }
  // A brisk gesture in the hand (turning the phone over, a figure eight): a fast tumble.
  void gesture(double d) {
    LifePhase p;
    p.kind = PhaseKind::kHand;
    p.duration_s = d;
    p.hand_rate_rad_s = 2.0;
    p.hand_tau_s = 0.3;
    add(p);
  }
  // A steady turn about the vertical at a rate of either sign, |rate| in `dps`.
  void turn(Span dps, double d, double speed = 0.0) {
    LifePhase p;
    p.kind = PhaseKind::kTurn;
    p.turn_dps = signed_uniform(rng_, dps.lo, dps.hi);
    p.duration_s = d;
    p.speed_m_s = speed;
    add(p);
  }
  void vibration(PhaseKind kind, double d, Span gyro_dps, Span accel_m_s2, Span hz,
                 double speed = 0.0, double heat = 0.0) {
    LifePhase p;
    p.kind = kind;
    p.duration_s = d;
    p.vib_gyro_dps = uniform(gyro_dps);
    p.vib_accel_m_s2 = uniform(accel_m_s2);
    p.vib_min_hz = hz.lo;
    p.vib_max_hz = hz.hi;
    p.speed_m_s = speed;
    p.heat_c = heat;
    add(p);
  }

 private:
  LifePlan& plan_;
  double end_;
  Random& rng_;
  double t_ = 0.0;
};

// A random direction times a magnitude in [lo, hi].
inline Vector3<double> random_vector(Random& rng, double lo, double hi) {
  const Vector3<double> d = random_direction(rng);
  return d * rng.uniform(lo, hi);
}

// Face up (a desk, a nightstand): a yaw, then a tilt of `tilt` about a random horizontal axis.
inline Matrix3<double> lying(double tilt, Random& rng) {
  const double yaw = rng.uniform(0.0, 2.0 * kPi);
  const double a = rng.uniform(0.0, 2.0 * kPi);
  const Vector3<double> axis(std::cos(a), std::sin(a), 0.0);
  return rotation_exp<double>(Vector3<double>(axis * tilt)) * rot_z(yaw);
}

// A random yaw, then a tilt of `tilt` about the body x axis (a stand, a cradle, face down).
inline Matrix3<double> tilted(double tilt, Random& rng) {
  const double yaw = rng.uniform(0.0, 2.0 * kPi);
  return rot_z(yaw) * rot_x(tilt);
}

// The plan's common part: seed, sensors, the ambient cycle.
inline LifePlan begin_plan(const char* name, std::uint64_t seed, const LifeOptions& o,
                           Random& rng) {
  LifePlan plan;
  plan.name = name;
  plan.seed = seed;
  plan.sensors = o.sensors;
  plan.sensors.has_mag = o.sensors.has_mag && o.magnetometer;
  plan.ambient_min_c = rng.uniform(15.0, 18.0);
  plan.ambient_max_c = rng.uniform(40.0, 45.0);
  plan.ambient_phase = rng.uniform();
  return plan;
}

// A knock inside the first rest (of 20 s or more) that covers or follows `at_s`, else the last
// one before it: the rest is split around the knock.
inline void insert_knock(LifePlan& plan, double at_s, double angle, Random& rng) {
  std::size_t best = plan.phases.size();
  double t = 0.0, best_start = 0.0;
  for (std::size_t i = 0; i < plan.phases.size(); ++i) {
    const LifePhase& p = plan.phases[i];
    const double start = t;
    t += p.duration_s;
    if (p.kind != PhaseKind::kRest || p.duration_s < 20.0) continue;
    best = i;
    best_start = start;
    if (t > at_s) break;
  }
  if (best == plan.phases.size()) return;
  const LifePhase rest = plan.phases[best];
  const double split = std::clamp(at_s - best_start, 0.3 * rest.duration_s, 0.7 * rest.duration_s);
  LifePhase first = rest, second = rest, knock;
  first.duration_s = split;
  second.duration_s = rest.duration_s - split - 0.3;
  knock.kind = PhaseKind::kKnock;
  knock.duration_s = 0.3;
  knock.knock_angle = angle;
  knock.heat_c = rest.heat_c;
  knock.gyro_step_dps = random_vector(rng, 0.2, 0.5);
  knock.accel_step_mg = random_vector(rng, 10.0, 30.0);
  plan.phases[best] = first;
  plan.phases.insert(plan.phases.begin() + static_cast<std::ptrdiff_t>(best) + 1, {knock, second});
}

inline void add_events(LifePlan& plan, const LifeOptions& o, double knock_angle, Random& rng) {
  const double length = plan.duration_s();
  if (o.magnet_pass && plan.sensors.has_mag) {
    MagnetPass m;
    m.t_s = rng.uniform(0.2, 0.35) * length;
    m.duration_s = rng.uniform(5.0, 20.0);
    m.peak_ut = random_vector(rng, 100.0, 400.0);
    plan.magnet_passes.push_back(m);
  }
  if (o.knock) insert_knock(plan, rng.uniform(0.4, 0.6) * length, knock_angle, rng);
  if (o.hard_iron_step && plan.sensors.has_mag) {
    HardIronStep h;
    h.t_s = rng.uniform(0.6, 0.8) * length;
    h.step_ut = random_vector(rng, 15.0, 40.0);
    plan.hard_iron_steps.push_back(h);
  }
}

}  // namespace life_detail

// A phone on a desk: long rests in a few places (desk face up, nightstand, a stand, face
// down), picked up, used in the hand and put down now and then.
inline LifePlan desk_life(std::uint64_t seed, double hours, const LifeOptions& o = {}) {
  using namespace life_detail;
  Random rng(seed ^ 0xD35Cull);
  LifePlan plan = begin_plan("desk", seed, o, rng);
  std::array<Matrix3<double>, 4> stations;
  stations[0] = lying(1.0 * kDeg, rng);
  stations[1] = lying(2.0 * kDeg, rng);
  stations[2] = tilted(rng.uniform(60.0, 75.0) * kDeg, rng);
  stations[3] = tilted(kPi - 1.0 * kDeg, rng);
  plan.start = Eigen::Quaterniond(stations[0]);
  PlanBuilder b(plan, hours * 3600.0, rng);
  std::size_t at = 0;
  while (!b.full()) {
    b.rest(b.log_uniform({600.0, 3.0 * 3600.0}));
    if (b.full()) break;
    if (rng.uniform() < 0.3) {  // a touch: picked up and put back
      b.move_by({0.4, 1.0}, {1.0, 2.0});
      b.move_to(stations[at], {1.0, 2.0});
      continue;
    }
    b.move_by({0.7, 1.6}, {1.5, 2.5});
    b.simple(PhaseKind::kHand, b.log_uniform({10.0, 300.0}));
    const double v = rng.uniform();
    at = v < 0.5 ? 0 : v < 0.75 ? 1 : v < 0.9 ? 2 : 3;
    b.move_to(stations[at], {1.5, 3.0});
  }
  add_events(plan, o, 0.05, rng);
  return plan;
}

// A phone carried: hand-held use and walking with it in a pocket for long spells, held still in
// the hand now and then (tremor), turned briskly now and then, put on a table sometimes, on a
// nightstand at night.
inline LifePlan handheld_life(std::uint64_t seed, double hours, const LifeOptions& o = {}) {
  using namespace life_detail;
  Random rng(seed ^ 0x4A4Dull);
  LifePlan plan = begin_plan("handheld", seed, o, rng);
  const Matrix3<double> table = lying(1.5 * kDeg, rng);
  const Matrix3<double> nightstand = lying(1.0 * kDeg, rng);
  plan.start = Eigen::Quaterniond(table);
  PlanBuilder b(plan, hours * 3600.0, rng);
  // The life starts at 08:00; nights from 23:00 to 07:00.
  const double day_start = 8.0 * 3600.0;
  b.rest(b.uniform({60.0, 300.0}));
  b.move_by({0.7, 1.6}, {1.5, 2.5});
  while (!b.full()) {
    const double clock = std::fmod(day_start + b.time(), 86400.0);
    if (clock >= 23.0 * 3600.0 || clock < 7.0 * 3600.0) {
      b.move_to(nightstand, {1.5, 3.0});
      b.rest(std::fmod(7.0 * 3600.0 - clock + 86400.0, 86400.0));
      b.move_by({0.7, 1.6}, {1.5, 2.5});
      continue;
    }
    const double u = rng.uniform();
    if (u < 0.4) {
      b.simple(PhaseKind::kHand, b.log_uniform({60.0, 1200.0}));
      if (rng.uniform() < 0.2) b.gesture(b.uniform({3.0, 15.0}));
      const int holds = 1 + static_cast<int>(rng.uniform(0.0, 3.0));
      for (int i = 0; i < holds; ++i) {
        b.simple(PhaseKind::kHandRest, b.uniform({5.0, 60.0}));
        b.simple(PhaseKind::kHand, b.uniform({5.0, 30.0}));
      }
    } else if (u < 0.85) {
      b.move_by({1.0, 2.0}, {1.0, 2.0});
      b.simple(PhaseKind::kPocket, b.log_uniform({300.0, 2700.0}));
      b.move_by({1.0, 2.0}, {1.0, 2.0});
    } else {
      b.move_to(table, {1.5, 3.0});
      b.rest(b.log_uniform({60.0, 1200.0}));
      b.move_by({0.7, 1.6}, {1.5, 2.5});
    }
  }
  add_events(plan, o, 0.05, rng);
  return plan;
}

// A phone in a car's cradle: parked (engine off), the engine idling (zero-mean vibration),
// driving, steady bends (a constant slow turn about the vertical for tens of seconds to minutes:
// not a rest, though the accelerometer is steady), stops at lights.
inline LifePlan vehicle_life(std::uint64_t seed, double hours, const LifeOptions& o = {}) {
  using namespace life_detail;
  Random rng(seed ^ 0xCA5ull);
  LifePlan plan = begin_plan("vehicle", seed, o, rng);
  const double mount_yaw = rng.uniform(-0.3, 0.3) + kPi;
  const double mount_tilt = rng.uniform(60.0, 80.0) * kDeg;
  plan.start = Eigen::Quaterniond(rot_z(mount_yaw) * rot_x(mount_tilt));
  PlanBuilder b(plan, hours * 3600.0, rng);
  const Span idle_gyro{0.2, 0.6}, idle_accel{0.05, 0.3}, idle_hz{20.0, 35.0};
  b.rest(b.uniform({60.0, 600.0}));  // parked, then the first trip
  while (!b.full()) {
    b.vibration(PhaseKind::kVibration, b.uniform({20.0, 120.0}), idle_gyro, idle_accel, idle_hz);
    const double trip_end = b.time() + b.uniform({600.0, 3600.0});
    while (!b.full() && b.time() < trip_end) {
      const double u = rng.uniform();
      const double speed = b.uniform({8.0, 30.0});
      if (u < 0.45) {
        b.vibration(PhaseKind::kDrive, b.uniform({30.0, 300.0}), {0.3, 0.3}, {0.3, 0.3},
                    {8.0, 20.0}, speed);
      } else if (u < 0.7) {
        b.turn({0.2, 2.0}, b.uniform({20.0, 300.0}), speed);
      } else {
        b.vibration(PhaseKind::kVibration, b.uniform({10.0, 90.0}), idle_gyro, idle_accel, idle_hz);
      }
    }
    b.vibration(PhaseKind::kVibration, b.uniform({10.0, 30.0}), idle_gyro, idle_accel, idle_hz);
    b.rest(b.log_uniform({600.0, 4.0 * 3600.0}));  // parked, engine off
  }
  add_events(plan, o, 0.05, rng);
  return plan;
}

// A drone: stored on a shelf, carried to the pad, warmed up at rest before each flight (the
// temperature rises 10 to 17 deg C in minutes), flights, landings (cooling at rest).
inline LifePlan drone_life(std::uint64_t seed, double hours, const LifeOptions& o = {}) {
  using namespace life_detail;
  Random rng(seed ^ 0xD2011Eull);
  LifePlan plan = begin_plan("drone", seed, o, rng);
  plan.ambient_max_c = rng.uniform(26.0, 28.0);
  const Matrix3<double> shelf = random_rotation(rng);
  const Matrix3<double> pad = lying(0.5 * kDeg, rng);
  plan.start = Eigen::Quaterniond(shelf);
  PlanBuilder b(plan, hours * 3600.0, rng);
  b.rest(b.uniform({300.0, 1800.0}));  // on the shelf, then the first session
  while (!b.full()) {
    b.move_by({0.7, 1.6}, {1.5, 2.5});
    b.simple(PhaseKind::kHand, b.uniform({30.0, 180.0}));
    b.move_to(pad, {1.5, 3.0});
    const int flights = 1 + static_cast<int>(rng.uniform(0.0, 3.0));
    for (int i = 0; i < flights; ++i) {
      const double heat = b.uniform({10.0, 17.0});
      b.rest(b.uniform({180.0, 360.0}), heat);  // warming up at rest
      b.vibration(PhaseKind::kFlight, b.uniform({300.0, 900.0}), {1.0, 1.0}, {1.5, 1.5},
                  {30.0, 45.0}, 0.0, heat);
      b.rest(b.uniform({120.0, 600.0}));  // landed, cooling
    }
    b.move_by({0.7, 1.6}, {1.5, 2.5});
    b.simple(PhaseKind::kHand, b.uniform({30.0, 180.0}));
    b.move_to(shelf, {1.5, 3.0});
    b.rest(b.log_uniform({1800.0, 4.0 * 3600.0}));
  }
  add_events(plan, o, 0.05, rng);
  return plan;
}

// A node bolted in one orientation for days: rests and spells of machinery vibration nearby;
// the knock leaves the orientation as it was.
inline LifePlan fixed_life(std::uint64_t seed, double hours, const LifeOptions& o = {}) {
  using namespace life_detail;
  Random rng(seed ^ 0xF1ull);
  LifePlan plan = begin_plan("fixed", seed, o, rng);
  plan.start = Eigen::Quaterniond(random_rotation(rng));
  PlanBuilder b(plan, hours * 3600.0, rng);
  while (!b.full()) {
    b.rest(b.log_uniform({1200.0, 6.0 * 3600.0}));
    b.vibration(PhaseKind::kVibration, b.uniform({60.0, 1200.0}), {0.05, 0.2}, {0.02, 0.1},
                {10.0, 40.0});
  }
  add_events(plan, o, 0.0, rng);
  return plan;
}

// A platform turning slowly and steadily (0.2 to 2 deg/s about the vertical) for long spells
// between true rests.
inline LifePlan turntable_life(std::uint64_t seed, double hours, const LifeOptions& o = {}) {
  using namespace life_detail;
  Random rng(seed ^ 0x7AB1Eull);
  LifePlan plan = begin_plan("turntable", seed, o, rng);
  plan.start = Eigen::Quaterniond(random_rotation(rng));
  PlanBuilder b(plan, hours * 3600.0, rng);
  while (!b.full()) {
    b.rest(b.log_uniform({60.0, 1800.0}));
    b.turn({0.2, 2.0}, b.log_uniform({300.0, 7200.0}));
  }
  add_events(plan, o, 0.05, rng);
  return plan;
}

inline const std::array<const char*, 6>& life_names() {
  static const std::array<const char*, 6> names = {"desk",  "handheld", "vehicle",
                                                   "drone", "fixed",    "turntable"};
  return names;
}

// The life of that name (one of life_names()); false if there is none.
inline bool make_life(const std::string& name, std::uint64_t seed, double hours,
                      const LifeOptions& o, LifePlan& out) {
  if (name == "desk") {
    out = desk_life(seed, hours, o);
  } else if (name == "handheld") {
    out = handheld_life(seed, hours, o);
  } else if (name == "vehicle") {
    out = vehicle_life(seed, hours, o);
  } else if (name == "drone") {
    out = drone_life(seed, hours, o);
  } else if (name == "fixed") {
    out = fixed_life(seed, hours, o);
  } else if (name == "turntable") {
    out = turntable_life(seed, hours, o);
  } else {
    return false;
  }
  return true;
}

}  // namespace imucal::sim
