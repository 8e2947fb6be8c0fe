// SPDX-License-Identifier: MIT
// imucal/solve/pose_store.hpp: still poses (mean raw reading and sample count) in a fixed-capacity
// store. PoseSpan is the capacity-free view that the solvers take, so that algorithms are not
// templated on the capacity. Never allocates; a full store refuses new poses and keeps its own.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "imucal/models/accel_model.hpp"
#include "imucal/solve/normal_equations.hpp"
#include "imucal/status.hpp"

namespace imucal {

template <typename Scalar>
struct Pose {
  Vector3<Scalar> mean;   // mean raw accelerometer reading over the rest (sensor units)
  std::uint32_t samples;  // number of samples averaged
  // Variance of one sample on one axis about the rest's mean (sensor units^2), measured in the
  // rest; 0: not known. When every pose has it, the solver weights each pose by the noise of its
  // mean and takes sigma from that noise model (see accel_calibration.hpp); otherwise poses are
  // weighted by sample count and sigma comes from the scatter of the fit alone.
  Scalar noise = Scalar(0);
};

template <typename Scalar>
struct PoseSpan {
  const Pose<Scalar>* data = nullptr;
  int size = 0;
  const Pose<Scalar>& operator[](int i) const { return data[i]; }
};

template <typename Scalar, int Capacity>
class PoseStore {
 public:
  static_assert(Capacity > 0, "capacity must be positive");
  static constexpr int kCapacity = Capacity;

  // Adds a pose. Refuses (and keeps every stored pose) a non-finite mean or noise, a negative
  // noise, a zero sample count, or a full store.
  Status add(const Vector3<Scalar>& mean, std::uint32_t samples, Scalar noise = Scalar(0)) {
    if (!all_finite(mean) || !std::isfinite(noise)) return Status::kNonFiniteInput;
    if (samples == 0 || noise < Scalar(0)) return Status::kInvalidArgument;
    if (size_ >= Capacity) return Status::kCapacityExceeded;
    poses_[size_].mean = mean;
    poses_[size_].samples = samples;
    poses_[size_].noise = noise;
    ++size_;
    return Status::kOk;
  }

  void clear() { size_ = 0; }
  int size() const { return size_; }
  bool full() const { return size_ >= Capacity; }
  const Pose<Scalar>& operator[](int i) const { return poses_[i]; }
  PoseSpan<Scalar> span() const { return PoseSpan<Scalar>{poses_, size_}; }

 private:
  Pose<Scalar> poses_[static_cast<std::size_t>(Capacity)] = {};
  int size_ = 0;
};

}  // namespace imucal
