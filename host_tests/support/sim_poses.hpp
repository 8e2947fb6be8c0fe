// SPDX-License-Identifier: MIT
// Test helper: simulated pose sets with known truth, in double and rounded to float.
#pragma once

#include <cstddef>
#include <cstdint>

#include "imucal/sim/accel_sim.hpp"
#include "imucal/solve/pose_store.hpp"

namespace imucal::test {

constexpr int kTestCapacity = 64;
using DoubleStore = PoseStore<double, kTestCapacity>;
using FloatStore = PoseStore<float, kTestCapacity>;

struct SimulatedPoses {
  sim::AccelTruth truth;
  DoubleStore poses;  // already rounded through float, so float and double see the same data
};

// `count` poses with directions uniform on the sphere and 150..400 samples each.
inline SimulatedPoses simulate_poses(const sim::AccelSensorSpec& spec, std::uint64_t seed,
                                     int count = 30) {
  sim::Random rng(seed);
  SimulatedPoses out{sim::draw_accel_truth(spec, rng), {}};
  for (int i = 0; i < count; ++i) {
    const auto n = static_cast<std::uint32_t>(150 + rng.next() % 251);
    const Vector3<double> m =
        sim::noisy_pose_mean(out.truth, spec, sim::random_direction(rng), n, rng);
    out.poses.add(m.cast<float>().cast<double>(), n);
  }
  return out;
}

inline FloatStore to_float(const DoubleStore& in) {
  FloatStore out;
  for (int i = 0; i < in.size(); ++i) out.add(in[i].mean.cast<float>(), in[i].samples);
  return out;
}

// Poses whose gravity directions come from a caller's list (unit vectors).
template <std::size_t M>
DoubleStore poses_from_directions(const sim::AccelTruth& truth, const sim::AccelSensorSpec& spec,
                                  const Vector3<double> (&dirs)[M], std::uint64_t seed) {
  sim::Random rng(seed);
  DoubleStore out;
  for (const Vector3<double>& d : dirs)
    out.add(sim::noisy_pose_mean(truth, spec, d, 200, rng), 200);
  return out;
}

}  // namespace imucal::test
