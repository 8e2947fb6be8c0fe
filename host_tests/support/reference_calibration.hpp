// SPDX-License-Identifier: MIT
// Test support (host only): the double-precision REFERENCE calibration, the yardstick for the
// streaming float calibrator. It keeps every raw sample, finds the rests offline, calibrates the
// accelerometer with the library's AccelSolver<double>, then the gyroscope with its own dense
// Levenberg-Marquardt on Tedaldi's gravity-direction residual (math.md section 4), integrating
// every raw gyro sample with 4th-order Runge-Kutta on the unit quaternion as Tedaldi et al.
// (ICRA 2014) and imu_tk do. Deliberately shares no gyro code with the library (it builds its
// own M = T K and its own integrator), so that the two can check each other. Not library code:
// std::vector holds the samples; no exceptions, and no heap-sized Eigen objects (the library's
// EIGEN_NO_MALLOC reaches every test that links it).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "imucal/models/gyro_model.hpp"
#include "imucal/solve/accel_calibration.hpp"
#include "imucal/status.hpp"

namespace imucal::test {

struct RawSample {
  double t;              // s
  Vector3<double> acc;   // raw sensor units
  Vector3<double> gyro;  // raw sensor units
};

struct RestInterval {
  std::size_t begin;  // first sample
  std::size_t end;    // one past the last sample
};

struct ReferenceSettings {
  double gravity = 9.81;  // m/s^2: local gravity magnitude
  // The first init_seconds are taken as still: they give the gyro bias (bias = -mean raw rate,
  // since the bias is ADDED) and the accelerometer variance baseline of the still detector.
  double init_seconds = 40.0;
  double window_seconds = 0.5;  // centred window of the accelerometer variance (by timestamps)
  double k = 2.0;               // still when variance norm <= k * the initial rest's (imu_tk)
  // imu_tk's selection: with k_max > k, every integer k' in [k, k_max] is tried and the one whose
  // accelerometer fit has the lowest residual RMS is kept (the offline accelerometer-only rule
  // is sensitive to k: 40 to 44 rests on the xsens recording).
  double k_max = 0.0;
  // Also require the windowed mean of |w - w0|^2 below gyro_k times its initial-rest value (the
  // cue the streaming detector uses too); 0: accelerometer only, as imu_tk.
  double gyro_k = 0.0;
  // Rests given instead of detected (e.g. the streaming calibrator's own pose windows), to
  // compare the solvers on identical data.
  const std::vector<RestInterval>* given_rests = nullptr;
  double trim_seconds = 0.25;     // cut from both ends of each still run (not the start of rest 0)
  double min_rest_seconds = 1.0;  // still runs shorter than this after trimming are dropped
  double gyro_nominal_scale = 1.0;  // rad/s per raw unit: the LM starts from M = nominal * I
  bool refine_gyro_bias = false;    // false: 9 parameters, bias fixed at the initial-rest value
  // A timestamp step larger than this (or negative) splits a still run, and a move containing
  // one is not used for the gyro: the rotation across a dropout cannot be integrated.
  double max_gap_seconds = 0.1;
};

struct ReferenceResult {
  // The gyro LM's stop reason (kConvergedStep / kConvergedCost when usable: see succeeded()),
  // or the first failure: settings or input (kInvalidArgument, kNonFiniteInput), too few rests
  // (kTooFewPoses), the accelerometer solver's own status, too few usable moves
  // (kTooFewResiduals), or a singular gyro problem (kRankDeficient). On kMaxIterations and
  // kNoProgress the last estimate is still filled in, for diagnosis.
  Status status = Status::kNotStarted;
  std::vector<RestInterval> rests;  // the initial rest first
  AccelCalibration<double> acc;
  // 12: the 9 matrix parameters (gyro_model.hpp order), then the ADDED bias (absolute, raw units).
  GyroVector<double> gyro = GyroVector<double>::Zero();
  GyroVector<double> gyro_sigma = GyroVector<double>::Zero();  // bias sigmas 0 when not refined
  double gyro_rms_rad = 0;  // RMS over moves of the angle between R_k^T g_k and g_{k+1}
  int moves = 0;            // residual pairs (consecutive rests) used
  int iterations = 0;       // gyro LM iterations
  double k = 0;             // the detector threshold used
};

// Body-frame rotation from sample i0 to sample i1 (i0 < i1) for the model w_cal = M (w_raw + b):
// RK4 on the quaternion q' = 1/2 q (x) (0, w(t)), q(t_i0) = 1, w(t) linear between consecutive
// samples. The result maps vectors in the body frame at i1 into the body frame at i0, so a
// world-fixed direction seen as v0 at i0 is seen as R^T v0 at i1. Identity if i0 >= i1 or i1 is
// out of range.
Eigen::Matrix3d rk4_rotation(const std::vector<RawSample>& s, std::size_t i0, std::size_t i1,
                             const Eigen::Matrix3d& m, const Vector3<double>& b);

// Still intervals found offline (imu_tk's rule, windows in seconds). Empty on invalid settings
// or input shorter than two samples.
std::vector<RestInterval> detect_rests(const std::vector<RawSample>& s, const ReferenceSettings&);

// The whole reference calibration. Never crashes on short or bad input: see status.
ReferenceResult reference_calibrate(const std::vector<RawSample>& s, const ReferenceSettings&);

}  // namespace imucal::test
