// SPDX-License-Identifier: MIT
// imucal/calibrator/solve_sequence.hpp: the solve after the collection, in bounded slices: the
// accelerometer's Levenberg-Marquardt on the poses, then the gyro's on the moves between them
// (the gravity directions from the calibrated accelerometer), then the pass that carries the
// accelerometer's uncertainty into the gyro's sigma. One memory holds the accelerometer's solver
// and then that pass (they never run together), one the gyro solver.
// Also the verdict on the result (judge_quality). Header-only, no allocation.
#pragma once

#include <cstddef>
#include <cstdint>
#include <new>
#include <type_traits>

#include "imucal/models/calibration.hpp"
#include "imucal/solve/accel_calibration.hpp"
#include "imucal/solve/gyro_calibration.hpp"
#include "imucal/solve/pose_store.hpp"
#include "imucal/status.hpp"
#include "imucal/stream/gyro_segment.hpp"

namespace imucal {

// What the collection hands the solve; the memory stays the caller's.
template <typename Scalar>
struct SolveInputs {
  PoseSpan<Scalar> poses{};
  const GyroSegment<Scalar>* segments = nullptr;
  const GyroMove* moves = nullptr;
  int move_count = 0;
  bool has_gyro = true;
  Vector3<Scalar> gyro_bias0 = Vector3<Scalar>::Zero();  // the initial rest's bias (added)
  // Added to gyro_bias0 before anything is fitted (GyroData::bias_shift): the rests' mean rate.
  Vector3<Scalar> bias_shift = Vector3<Scalar>::Zero();
  // The bias's sigma when it is not refined (the rests' mean rate's).
  Vector3<Scalar> bias_sigma = Vector3<Scalar>::Zero();
};

template <typename Scalar, int MaxPoses>
class SolveSequence {
 public:
  static_assert(std::is_trivially_destructible<AccelSolver<Scalar>>::value &&
                    std::is_trivially_destructible<GyroInputUncertainty<Scalar>>::value &&
                    std::is_trivially_destructible<GyroSolver<Scalar>>::value,
                "the solve memory is rebuilt in place without a destructor call");

  SolveSequence() = default;
  // The solvers for these settings from the start, as configure() (no default ones built first).
  SolveSequence(const AccelSettings<Scalar>& accel, const GyroSettings<Scalar>& gyro)
      : memory_(accel), gyro_(gyro) {}

  // The solvers for these settings (the gyro's: refine_bias picks 9 or 12 parameters).
  void configure(const AccelSettings<Scalar>& accel, const GyroSettings<Scalar>& gyro) {
    memory_.make_accel(accel);
    new (&gyro_) GyroSolver<Scalar>(gyro);  // in place: no solver-sized temporary on the stack
    stage_ = Stage::kAccel;
  }

  // Starts the accelerometer's solve on the poses. kRunning: call step() until it returns
  // something else. Otherwise the start failed: cal.accel says why, and that status is returned.
  Status start(const AccelSettings<Scalar>& accel, PoseSpan<Scalar> poses,
               Calibration<Scalar>& cal) {
    stage_ = Stage::kAccel;
    memory_.make_accel(accel);
    const Status s = memory_.accel().start(poses);
    if (s != Status::kRunning && s != Status::kOk && !succeeded(s)) {
      memory_.accel().finish(cal.accel);
      return cal.accel.status;
    }
    return Status::kRunning;
  }

  // One bounded slice: one accelerometer LM iteration, or at most gyro.segments_per_step
  // segments of the gyro's run. kRunning: more to do. Otherwise the solve has ended: cal holds
  // the accelerometer's result and (with a gyro, once the accelerometer's succeeded) the gyro's,
  // and the status returned is the last part's.
  Status step(const SolveInputs<Scalar>& in, const GyroSettings<Scalar>& gyro,
              Calibration<Scalar>& cal) {
    if (stage_ == Stage::kAccel) {
      AccelSolver<Scalar>& solver = memory_.accel();
      const Status s = solver.status() == Status::kRunning ? solver.step() : solver.status();
      if (s == Status::kRunning) return s;
      if (!succeeded(solver.finish(cal.accel))) return cal.accel.status;
      if (!in.has_gyro) return cal.accel.status;  // the accelerometer alone: done
      return start_gyro(in, cal);
    }
    if (stage_ == Stage::kGyro) {
      const Status s = gyro_.step();
      if (s == Status::kRunning) return s;
      gyro_.finish(cal.gyro);
      if (!cal.gyro.bias_refined && succeeded(cal.gyro.status))
        cal.gyro.sigma.template tail<3>() = in.bias_sigma;  // the bias is the rests' mean rate
      if (succeeded(cal.gyro.status) && start_input_uncertainty(in, cal)) return Status::kRunning;
    } else {  // Stage::kGyroSigma
      const AccelVector<Scalar>& pa = cal.accel.params;
      GyroInputUncertainty<Scalar>& u = memory_.input_uncertainty();
      const int slice = gyro.segments_per_step;
      Status s = u.step(gyro_, pa, in.poses, slice);
      if (s == Status::kOk) s = u.finish(gyro_, cal.gyro);
      if (s == Status::kRunning) return s;
      if (s != Status::kOk) fail_gyro(s, in, cal);
    }
    return cal.gyro.status;
  }

  // Past the accelerometer's part (in the gyro's run or its sigma pass).
  bool in_gyro() const { return stage_ != Stage::kAccel; }

 private:
  // The accelerometer's LM, the gyro's, then the pass that carries the inputs the gyro's held
  // fixed into its sigma.
  enum class Stage : std::uint8_t { kAccel, kGyro, kGyroSigma };

  // The gravity direction of every pose from the calibrated accelerometer, and the gyro's start.
  // kRunning, or its failure (in cal.gyro).
  Status start_gyro(const SolveInputs<Scalar>& in, Calibration<Scalar>& cal) {
    stage_ = Stage::kGyro;
    const AccelVector<Scalar>& pa = cal.accel.params;
    for (int k = 0; k < in.poses.size; ++k) up_[k] = accel_apply(pa, in.poses[k].mean).normalized();
    GyroData<Scalar> data;
    data.segments = in.segments;
    data.moves = in.moves;
    data.move_count = in.move_count;
    data.up = up_;
    data.pose_count = in.poses.size;
    data.bias_shift = in.bias_shift;
    const Status s = gyro_.start(data, in.gyro_bias0);
    if (s != Status::kRunning) fail_gyro(s, in, cal);
    return s == Status::kRunning ? s : cal.gyro.status;
  }

  // After a usable gyro solve: the accelerometer's covariance (while its solver's memory is still
  // there) and the start of the pass that widens the gyro's sigma by it (GyroInputUncertainty).
  // False, and the gyro failed with the reason, if that covariance cannot be had.
  bool start_input_uncertainty(const SolveInputs<Scalar>& in, Calibration<Scalar>& cal) {
    Eigen::Matrix<Scalar, kAccelParams, kAccelParams> cov_a;
    const Status s = memory_.accel().covariance(cov_a);
    if (s != Status::kOk) {
      fail_gyro(s, in, cal);
      return false;
    }
    GyroInputUncertainty<Scalar>& u = memory_.make_input_uncertainty();
    u.start(gyro_, cov_a);
    stage_ = Stage::kGyroSigma;
    return true;
  }

  // The gyro's result refused for `why` (nothing of it is kept).
  static void fail_gyro(Status why, const SolveInputs<Scalar>& in, Calibration<Scalar>& cal) {
    cal.gyro = GyroCalibration<Scalar>{};
    cal.gyro.status = why;
    cal.gyro.moves = in.move_count;
  }

  // The accelerometer's solver, then the input-uncertainty pass: one memory.
  class Memory {
   public:
    Memory() { new (&u_.accel) AccelSolver<Scalar>(); }
    explicit Memory(const AccelSettings<Scalar>& s) { new (&u_.accel) AccelSolver<Scalar>(s); }
    Memory(const Memory& o) { copy_from(o); }
    Memory& operator=(const Memory& o) {
      if (this != &o) copy_from(o);
      return *this;
    }
    void make_accel(const AccelSettings<Scalar>& s) {
      accel_ = true;
      new (&u_.accel) AccelSolver<Scalar>(s);
    }
    GyroInputUncertainty<Scalar>& make_input_uncertainty() {
      accel_ = false;
      return *new (&u_.input) GyroInputUncertainty<Scalar>();
    }
    AccelSolver<Scalar>& accel() { return u_.accel; }
    GyroInputUncertainty<Scalar>& input_uncertainty() { return u_.input; }

   private:
    void copy_from(const Memory& o) {
      accel_ = o.accel_;
      if (accel_)
        new (&u_.accel) AccelSolver<Scalar>(o.u_.accel);
      else
        new (&u_.input) GyroInputUncertainty<Scalar>(o.u_.input);
    }
    union U {
      U() {}
      AccelSolver<Scalar> accel;
      GyroInputUncertainty<Scalar> input;
    } u_;
    bool accel_ = true;
  };

  Vector3<Scalar> up_[static_cast<std::size_t>(MaxPoses)] = {};
  Memory memory_;
  GyroSolver<Scalar> gyro_;
  Stage stage_ = Stage::kAccel;
};

// The verdict on a calibration, and in *why (static text) the check that set it.
// Good: both calibrated, all six faces (bit i of `faces`, as PoseCollection::faces()), no
// accelerometer parameter held or weak, pose residuals within 3x what the noise explains
// (accel_noise_var: one raw sample's variance per axis), every gyro matrix sigma within a quarter
// of its bound. Fair: both calibrated. Poor: the accelerometer only. None: not even that.
// Without a gyro the accelerometer's part of the same rule decides.
template <typename Scalar>
Quality judge_quality(const Calibration<Scalar>& cal, bool has_gyro, std::uint8_t faces,
                      const Vector3<Scalar>& accel_noise_var, PoseSpan<Scalar> poses,
                      Scalar max_normalised_sigma, const char** why = nullptr) {
  const char* unused = nullptr;
  const char*& reason = why != nullptr ? *why : unused;
  reason = "the accelerometer was not calibrated";
  if (!succeeded(cal.accel.status)) return Quality::kNone;
  reason = "the gyroscope was not calibrated";
  if (has_gyro && !succeeded(cal.gyro.status)) return Quality::kPoor;
  reason = "not every face was up in a pose";
  if (faces != 0x3f) return Quality::kFair;
  // A parameter held at 0 or barely determined (named in the calibration, with the hint).
  reason = "an accelerometer parameter is held at 0 or weak";
  if (cal.accel.held != 0 || cal.accel.weak != 0) return Quality::kFair;
  // Noise of a pose mean in m/s^2: the per-sample noise (initial rest) over sqrt(samples).
  const AccelVector<Scalar>& p = cal.accel.params;
  const Vector3<Scalar> sd(std::sqrt(accel_noise_var(0)) * p(kScaleX),
                           std::sqrt(accel_noise_var(1)) * p(kScaleY),
                           std::sqrt(accel_noise_var(2)) * p(kScaleZ));
  Scalar mean_n = Scalar(0);
  for (int k = 0; k < poses.size; ++k) mean_n += static_cast<Scalar>(poses[k].samples);
  mean_n /= static_cast<Scalar>(poses.size);
  const Scalar expected = sd.norm() / std::sqrt(Scalar(3) * mean_n);
  reason =
      "the pose residual is over 3 times the noise of a pose mean (drift between poses, or "
      "rests that were not still)";
  if (cal.accel.residual_rms > Scalar(3) * expected) return Quality::kFair;
  reason = "every check passed";
  if (!has_gyro) return Quality::kGood;
  const GyroCalibration<Scalar>& g = cal.gyro;
  const Scalar quarter = max_normalised_sigma / Scalar(4);
  reason = "a gyroscope misalignment or scale has a sigma over a quarter of its bound";
  for (int k = 0; k < kGyroMatrixParams; ++k)
    if (!(gyro_normalised_sigma<Scalar>(g.params, g.sigma, k) <= quarter)) return Quality::kFair;
  reason = "every check passed";
  return Quality::kGood;
}

}  // namespace imucal
