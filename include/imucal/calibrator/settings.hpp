// SPDX-License-Identifier: MIT
// imucal/calibrator/settings.hpp: what the streaming calibrator (calibrator.hpp) takes and
// reports: one raw sample, the settings, the phase and the hint for the user, the stream's fault
// counts and the progress. Plain types, no code.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>

#include "imucal/solve/accel_calibration.hpp"
#include "imucal/solve/gyro_calibration.hpp"
#include "imucal/status.hpp"
#include "imucal/stream/checks.hpp"
#include "imucal/stream/stillness.hpp"
#include "imucal/types.hpp"

namespace imucal {

// The calibrator's settings: the stream checks' (StreamSettings, checks.hpp: gaps, frozen
// sensors, full scale, temperature range, nominal rate, whether there is a gyro) and its own.
template <typename Scalar>
struct CalibratorSettings : StreamSettings<Scalar> {
  // The initial rest is the first still period of at least this long (however long it then
  // lasts, until the first motion): the gyro bias to start from, the noise that sets the first
  // thresholds, the sample period.
  Scalar initial_rest_seconds = Scalar(2);
  // A still spell of at least this long (as the detector sees it, trimmed part included) is a
  // pose; a shorter one is part of the move around it.
  Scalar min_rest_seconds = Scalar(0.6);
  Scalar trim_seconds = Scalar(0.25);     // cut from a rest's end before the motion showed
  StillnessSettings<Scalar> stillness{};  // the detector (stillness.hpp)
  // The granularity of the trimming, and the detector's step: the per-sample path's float work
  // is done once a block (sooner at more than 32 samples a block, or in a fast turn).
  Scalar block_seconds = Scalar(0.25);
  // An accelerometer reading (not at full scale) further than this many noise sigmas (the
  // initial rest's, its noisiest axis) from the moving mean (the distance over the three axes) is
  // a glitch: refused and counted. During the initial rest, the sigma and the mean are the rest
  // window's (initial_rest.hpp).
  // 1e5 sigma is 100 g or more for any MEMS accelerometer's noise: a value no sensor reads (an
  // ADC's own limit is far inside for 16-bit counts).
  Scalar glitch_sigma = Scalar(1e5);
  // Segments (math.md section 4): path angle and |alpha||beta| (rad^3) bounds. The defaults keep
  // the second-order expansion within ~7e-5 rad on a 3 s coning move (test_gyro_segment); 3e-4
  // gives ~1e-5 rad for ~35 % more segments (on the xsens recording: 0.04 instead of 0.10 sigma
  // from the RK4 reference, test_xsens_reference).
  Scalar segment_max_angle = Scalar(0.6);
  Scalar segment_max_error = Scalar(1e-3);
  // Raw accelerometer reading at zero acceleration, if roughly known (e.g. 32768 for unsigned
  // 16-bit counts); only used to tell which face is up for the coverage report. NaN: estimated
  // from the poses' spread.
  Vector3<Scalar> accel_zero_hint =
      Vector3<Scalar>::Constant(std::numeric_limits<Scalar>::quiet_NaN());
  int target_poses = 24;  // ready when this many poses cover all six faces
  AccelSettings<Scalar> accel{};
  // gyro.nominal_scale (rad/s per unit), if given, also sizes the segments; otherwise they start
  // as for rad/s and the store coarsens as needed.
  GyroSettings<Scalar> gyro{};
};

enum class Phase : std::uint8_t {
  kInitialRest,  // hold still
  kCollecting,   // turning and resting
  kReady,        // enough poses and coverage: solve() may be called (more poses still help)
  kSolving,      // solve_step() until it returns something other than kRunning
  kDone,         // calibration() holds the result
  kFailed,       // calibration() says why (status fields); the collected data are kept
};

enum class Hint : std::uint8_t {
  kHoldStill,      // initial rest in progress
  kTurnToFace,     // put the face progress.next_face up and hold it
  kHoldLonger,     // the last rest was too short to count
  kTurnAboutAxis,  // turn more about body axis progress.next_axis
  kCheckSensor,    // frozen sensor or gaps in the stream
  kSolve,          // ready: call solve()
  kNone,
};

struct Progress {
  Phase phase = Phase::kInitialRest;
  Hint hint = Hint::kHoldStill;
  Status last_event = Status::kOk;  // the latest notable event of the stream
  float initial_rest_done = 0.0f;   // fraction of the initial rest completed
  int poses = 0;
  int moves = 0;
  int segments = 0;
  std::uint8_t faces = 0;  // bit i: face i up (+x, -x, +y, -y, +z, -z) has a pose
  int faces_covered = 0;
  int next_face = 0;             // for kTurnToFace
  std::uint8_t axes_turned = 0;  // bit i: enough rotation about body axis i
  int next_axis = 0;             // for kTurnAboutAxis
  int rests_too_short = 0;
  int moves_dropped = 0;  // across gaps, frozen spells, capacity, or the end
  int coarsenings = 0;    // times the segment store was merged pairwise
  std::uint32_t samples_refused = 0;
  StreamCounts stream{};  // bad samples and stream events, each by kind
};

}  // namespace imucal
