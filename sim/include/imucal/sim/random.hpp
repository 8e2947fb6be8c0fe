// SPDX-License-Identifier: MIT
// imucal/sim/random.hpp: a small deterministic random source for the simulator. SplitMix64 and
// Box-Muller, so a seed draws the same numbers on the host and on every cross target (the C++
// standard library's distributions are implementation-defined). Not for device code.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>

namespace imucal::sim {

class Random {
 public:
  explicit Random(std::uint64_t seed) : state_(seed) {}

  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }

  // Uniform in [0, 1).
  double uniform() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

  // A vector of standard normal draws, drawn last coordinate first. The order is fixed here,
  // not left to the compiler: Eigen::Vector3d(normal(), normal(), normal()) draws in whichever
  // order the compiler evaluates arguments, and x86 GCC, Arm GCC and Clang differ.
  Eigen::Vector3d normal3() {
    const double z = normal(), y = normal(), x = normal();
    return {x, y, z};
  }
  // A quaternion (w, x, y, z) of standard normal draws, z first.
  Eigen::Quaterniond normal_quaternion() {
    const double z = normal(), y = normal(), x = normal(), w = normal();
    return {w, x, y, z};
  }

  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u1 = uniform();
    while (u1 <= 0.0) u1 = uniform();
    const double u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    const double t = 6.283185307179586 * u2;
    spare_ = r * std::sin(t);
    has_spare_ = true;
    return r * std::cos(t);
  }

 private:
  std::uint64_t state_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace imucal::sim
