// SPDX-License-Identifier: MIT
// imucal/calibrator/pose_collection.hpp: the poses a stream gave, and what they say about the
// protocol so far: which faces have been up (coverage), about which axes the board has turned,
// what the user should do next (the hint), and the gyro bias from the mean rates of the rests.
// Header-only, no allocation.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "imucal/calibrator/settings.hpp"
#include "imucal/models/accel_model.hpp"
#include "imucal/solve/pose_store.hpp"
#include "imucal/status.hpp"

namespace imucal {

template <typename Scalar, int MaxPoses>
class PoseCollection {
 public:
  void clear() {
    poses_.clear();
    rate_sum_.setZero();
    rate_sq_.setZero();
    rate_time_ = Scalar(0);
    rate_rests_ = 0;
  }

  // A rest as a pose: its mean raw reading, samples, noise (Pose::noise) and time span. Refused
  // as PoseStore::add() refuses (kCapacityExceeded when full), nothing changed.
  Status add(const Vector3<Scalar>& mean, std::uint32_t samples, Scalar noise,
             std::uint32_t t_begin, std::uint32_t t_end) {
    const Status s = poses_.add(mean, samples, noise);
    if (s != Status::kOk) return s;
    time_[poses_.size() - 1][0] = t_begin;
    time_[poses_.size() - 1][1] = t_end;
    return s;
  }

  int size() const { return poses_.size(); }
  bool full() const { return poses_.full(); }
  const Pose<Scalar>& operator[](int i) const { return poses_[i]; }
  PoseSpan<Scalar> span() const { return poses_.span(); }
  // Pose i's first and last sample's timestamps.
  std::uint32_t begin_us(int i) const { return time_[i][0]; }
  std::uint32_t end_us(int i) const { return time_[i][1]; }

  // A rest's mean rate u = w + b0 over its length: at rest w = -b, so their time-weighted mean
  // gives the bias from every rest, and their scatter its uncertainty.
  void add_rest_rate(const Vector3<Scalar>& u_mean, Scalar duration) {
    if (!(duration > Scalar(0))) return;
    rate_sum_ += duration * u_mean;
    rate_sq_ += duration * u_mean.cwiseProduct(u_mean);
    rate_time_ += duration;
    ++rate_rests_;
  }
  // The rests' mean rate u (sensor units); false without rests.
  bool mean_rest_rate(Vector3<Scalar>& u) const {
    if (!(rate_time_ > Scalar(0))) return false;
    u = rate_sum_ / rate_time_;
    return true;
  }
  // The sigma of the rests' mean rate as the bias: white noise of variance `noise_var` (per
  // axis, one sample every `period` s) over the rests' total length, or the scatter of the rests'
  // means (bias instability, a hand-held rest's slow turn) if larger. Without rests: `fallback`.
  Vector3<Scalar> rest_rate_sigma(const Vector3<Scalar>& noise_var, Scalar period,
                                  const Vector3<Scalar>& fallback) const {
    if (!(rate_time_ > Scalar(0))) return fallback;
    Vector3<Scalar> var = noise_var * (period / rate_time_);
    if (rate_rests_ >= 2) {
      const Vector3<Scalar> mean = rate_sum_ / rate_time_;
      const Vector3<Scalar> scatter =
          (rate_sq_ / rate_time_ - mean.cwiseProduct(mean)).cwiseMax(Scalar(0)) /
          static_cast<Scalar>(rate_rests_ - 1);
      var = var.cwiseMax(scatter);
    }
    return var.cwiseSqrt();
  }

  // Bit i: face i up (+x, -x, +y, -y, +z, -z) in some pose: the axis of the largest component
  // of the pose's mean about `zero` (the raw reading at zero acceleration). A zero that is not
  // finite is estimated as the middle of the poses' spread (with one pose: 0).
  std::uint8_t faces(const Vector3<Scalar>& zero_hint) const {
    const int n = poses_.size();
    if (n == 0) return 0;
    Vector3<Scalar> zero = zero_hint;
    if (!all_finite(zero)) {
      Vector3<Scalar> lo = poses_[0].mean, hi = poses_[0].mean;
      for (int k = 1; k < n; ++k) {
        lo = lo.cwiseMin(poses_[k].mean);
        hi = hi.cwiseMax(poses_[k].mean);
      }
      zero = Scalar(0.5) * (lo + hi);
      // One side seen only: the spread says nothing yet, the first pose counts as its face.
      if (n < 2) zero = Vector3<Scalar>::Zero();
    }
    std::uint8_t bits = 0;
    for (int k = 0; k < n; ++k) {
      const Vector3<Scalar> d = poses_[k].mean - zero;
      int axis = 0;
      for (int i = 1; i < 3; ++i)
        if (std::abs(d(i)) > std::abs(d(axis))) axis = i;
      bits = static_cast<std::uint8_t>(bits | (1u << (2 * axis + (d(axis) < Scalar(0) ? 1 : 0))));
    }
    return bits;
  }

 private:
  PoseStore<Scalar, MaxPoses> poses_{};
  std::uint32_t time_[static_cast<std::size_t>(MaxPoses)][2] = {};
  // The rests' mean rates (add_rest_rate): duration-weighted sums.
  Vector3<Scalar> rate_sum_ = Vector3<Scalar>::Zero(), rate_sq_ = Vector3<Scalar>::Zero();
  Scalar rate_time_ = Scalar(0);
  int rate_rests_ = 0;
};

// The coverage fields of a progress report: faces up, axes turned about (bit i: |alpha| about
// axis i at least a fifth of the most-turned axis's, `rotation` summed over the moves), and the
// next face and axis to ask for.
template <typename Scalar>
void set_coverage(Progress& p, std::uint8_t faces, const Vector3<Scalar>& rotation) {
  p.faces = faces;
  p.faces_covered = 0;
  for (int i = 0; i < 6; ++i) p.faces_covered += (faces >> i) & 1;
  p.next_face = 0;
  while (p.next_face < 5 && ((faces >> p.next_face) & 1)) ++p.next_face;
  const Scalar most = rotation.maxCoeff();
  p.axes_turned = 0;
  for (int i = 0; i < 3; ++i)
    if (most > Scalar(0) && rotation(i) >= Scalar(0.2) * most)
      p.axes_turned = static_cast<std::uint8_t>(p.axes_turned | (1u << i));
  p.next_axis = 0;
  while (p.next_axis < 2 && ((p.axes_turned >> p.next_axis) & 1)) ++p.next_axis;
}

// What the user should do next, from a progress report with its phase and coverage set: hold
// still, check the sensor (frozen), hold longer (the last rest was too short), a face not yet
// up, an axis not yet turned about (with a gyro), or solve.
inline Hint coverage_hint(const Progress& p, bool frozen, bool last_rest_short, bool has_gyro) {
  switch (p.phase) {
    case Phase::kInitialRest:
      return frozen ? Hint::kCheckSensor : Hint::kHoldStill;
    case Phase::kSolving:
    case Phase::kDone:
    case Phase::kFailed:
      return Hint::kNone;
    case Phase::kReady:
      return Hint::kSolve;
    case Phase::kCollecting:
      break;
  }
  if (frozen) return Hint::kCheckSensor;
  if (last_rest_short) return Hint::kHoldLonger;
  if (p.faces_covered < 6) return Hint::kTurnToFace;
  if (has_gyro && p.axes_turned != 0x7) return Hint::kTurnAboutAxis;
  return Hint::kTurnToFace;  // all faces seen: more poses, anywhere new
}

}  // namespace imucal
