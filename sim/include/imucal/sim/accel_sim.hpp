// SPDX-License-Identifier: MIT
// imucal/sim/accel_sim.hpp: simulated multi-position accelerometer recordings with known truth.
// Draws T, K, b near realistic values, pose directions over the sphere (or a chosen geometry),
// and white noise on every sample, and returns the pose means the calibrator sees. Double
// precision, host and test code only.
#pragma once

#include <Eigen/LU>
#include <cmath>
#include <cstdint>

#include "imucal/models/accel_model.hpp"
#include "imucal/sim/random.hpp"

namespace imucal::sim {

struct AccelSensorSpec {
  double nominal_scale;  // sensor-to-m/s^2 factor (1 for SI, 1/415 for xsens-like counts)
  double nominal_bias;   // added to the raw reading (-32768 for unsigned 16-bit counts)
  double scale_spread;   // relative, uniform +-
  double bias_spread;    // sensor units, uniform +-
  double misalignment;   // rad, uniform +-
  double noise;          // per-sample white noise, sensor units
  static AccelSensorSpec si() { return {1.0, 0.0, 0.05, 0.3, 0.02, 0.015}; }
  static AccelSensorSpec raw_counts() { return {1.0 / 415.0, -32768.0, 0.05, 300.0, 0.02, 3.3}; }
};

struct AccelTruth {
  AccelVector<double> params;
  double gravity;
};

inline AccelTruth draw_accel_truth(const AccelSensorSpec& spec, Random& rng,
                                   double gravity = 9.80665) {
  AccelTruth t{};
  t.gravity = gravity;
  for (int i = 0; i < 3; ++i) t.params(kAlphaYz + i) = rng.uniform(-1, 1) * spec.misalignment;
  for (int i = 0; i < 3; ++i)
    t.params(kScaleX + i) = spec.nominal_scale * (1.0 + rng.uniform(-1, 1) * spec.scale_spread);
  for (int i = 0; i < 3; ++i)
    t.params(kBiasX + i) = spec.nominal_bias + rng.uniform(-1, 1) * spec.bias_spread;
  return t;
}

inline Vector3<double> random_direction(Random& rng) {
  for (;;) {
    const Vector3<double> v = rng.normal3();
    const double n = v.norm();
    if (n > 1e-6) return v / n;
  }
}

// The raw reading that calibrates to the specific force f: a = (T K)^-1 f - b.
inline Vector3<double> raw_from_calibrated(const AccelTruth& t, const Vector3<double>& f) {
  const Matrix3<double> m = accel_matrix(t.params);
  const Vector3<double> b(t.params(kBiasX), t.params(kBiasY), t.params(kBiasZ));
  return m.inverse() * f - b;
}

// Mean of n samples with white noise at gravity direction `up` (unit). The mean of n white
// samples is exactly normal with sigma/sqrt(n), so it is drawn directly.
inline Vector3<double> noisy_pose_mean(const AccelTruth& t, const AccelSensorSpec& spec,
                                       const Vector3<double>& up, std::uint32_t n, Random& rng) {
  const Vector3<double> clean = raw_from_calibrated(t, t.gravity * up);
  const double sd = spec.noise / std::sqrt(static_cast<double>(n));
  return clean + rng.normal3() * sd;
}

}  // namespace imucal::sim
