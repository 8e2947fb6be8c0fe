// imucal/calibrator.hpp: the streaming calibrator. The firmware hands it every raw sample
// (timestamp, accelerometer, gyroscope) and follows the progress it reports; at the end it
// solves, in bounded slices, for the accelerometer and the gyroscope calibration. No raw sample
// is stored: rests become pose means, moves become second-order segment statistics
// (math.md sections 4 and 5), all in fixed stores sized at compile time.
//
// The stream, per sample:
//   1. Initial rest: the first still period of at least initial_rest_seconds, found by a window
//      of four quarters sliding over the stream (quarter means that agree within the noise and
//      the quarter variances alike). It gives the gyro bias to start from, the noise levels that
//      set the first stillness thresholds and the sample period, and it goes on as pose 0 until
//      the first motion, however long it lasts.
//   2. Stillness (stillness.hpp): causal moving averages of the accelerometer variance and of the
//      gyro energy |w + b0|^2, against thresholds that follow the noise of the rests and the
//      level of the moves, so that rests held in the hand count as well as table-top ones.
//   3. Samples are folded into short blocks (at most block_seconds, all still or all moving,
//      each a valid gyro segment). Still blocks wait in a delay line of trim_seconds: a still
//      block that is followed by trim_seconds of stillness joins the current rest; when motion
//      comes, the blocks still in the line (the rest's last trim_seconds) go to the move. A rest
//      becomes a pose when motion ends it, if it lasted min_rest_seconds; a shorter one is part
//      of the move. A lone outlier cannot end a rest (each sample's weight in the averages is
//      clipped); a real disturbance ends it, and then everything between the two
//      poses is integrated as a move: nothing is lost in between.
//   4. Moves: every non-pose block's gyro statistics go to the segment store, merged with the
//      previous segment while the merged one stays a small, nearly single-axis rotation
//      (segment_max_angle, segment_max_error). When the store is full, the adjacent segments
//      whose merge costs least are merged (exact algebra) until an eighth of it is free:
//      accuracy degrades gracefully instead of data being lost.
//
// Full pose store: new rests are not stored (kCapacityExceeded is reported once, the phase is
// ready, the hint says solve). Poses are chained by the moves between them, so replacing a pose
// would break two gyro residuals; the capacity is sized for the protocol instead (Tedaldi uses
// 36-50 poses), and the coverage report tells the user which faces are still missing.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <new>
#include <type_traits>

#include "imucal/accel_calibration.hpp"
#include "imucal/calibration.hpp"
#include "imucal/compensated_sum.hpp"
#include "imucal/gyro_calibration.hpp"
#include "imucal/gyro_segment.hpp"
#include "imucal/pose_store.hpp"
#include "imucal/status.hpp"
#include "imucal/stillness.hpp"
#include "imucal/temperature_model.hpp"

namespace imucal {

template <typename Scalar>
struct ImuSample {
  std::uint32_t t_us = 0;  // microseconds, wrapping (differences are taken modulo 2^32)
  Vector3<Scalar> acc = Vector3<Scalar>::Zero();   // raw accelerometer (counts or m/s^2)
  Vector3<Scalar> gyro = Vector3<Scalar>::Zero();  // raw gyroscope (counts or rad/s)
  // deg C, NaN if the sensor has none: its mean goes into the calibration (and its record).
  Scalar temperature = std::numeric_limits<Scalar>::quiet_NaN();
};

template <typename Scalar>
struct CalibratorSettings {
  // The initial rest is the first still period of at least this long (however long it then
  // lasts, until the first motion): the gyro bias to start from, the noise that sets the first
  // thresholds, the sample period.
  Scalar initial_rest_seconds = Scalar(2);
  // A still spell of at least this long (as the detector sees it, trimmed part included) is a
  // pose; a shorter one is part of the move around it.
  Scalar min_rest_seconds = Scalar(0.6);
  Scalar trim_seconds = Scalar(0.25);     // cut from a rest's end before the motion showed
  StillnessSettings<Scalar> stillness{};  // the detector (stillness.hpp)
  // false: the stream carries no gyro (its readings are ignored): stillness from the
  // accelerometer alone, the solve ends after the accelerometer.
  bool has_gyro = true;
  Scalar block_seconds = Scalar(0.1);     // granularity of the trimming
  Scalar gap_factor = Scalar(5);          // a step above this x the mean period is a gap
  Scalar max_step_seconds = Scalar(0.5);  // a gap whatever the period (initial rest too)
  Scalar frozen_seconds = Scalar(0.5);    // identical readings this long: sensor frozen
  // Temperature readings outside this range (deg C), or not finite (NaN means "no sensor"), are
  // ignored and counted; the sample is taken.
  Scalar temperature_min_c = Scalar(-60), temperature_max_c = Scalar(150);
  // After the initial rest, an accelerometer reading (not at full scale) further than this many
  // noise sigmas (the initial rest's, its noisiest axis) from the moving mean (the distance over
  // the three axes) is a glitch: refused and counted.
  // 1e5 sigma is 100 g or more for any MEMS accelerometer's noise: a value no sensor reads (an
  // ADC's own limit is far inside for 16-bit counts).
  Scalar glitch_sigma = Scalar(1e5);
  // Full scale, raw units: a reading at or beyond a limit is saturated. Set them to the ADC's
  // clip values (0 and 65535 for unsigned 16-bit counts, -32768 and 32767 for signed ones, or
  // the range in SI units). The defaults only refuse readings too large for the float sums.
  Scalar accel_min = Scalar(-1e15), accel_max = Scalar(1e15);
  Scalar gyro_min = Scalar(-1e15), gyro_max = Scalar(1e15);
  // The sample rate the sensor is configured for (0: not checked). Over every second of the
  // stream, a measured rate further than rate_tolerance (relative) from it is reported.
  Scalar nominal_rate_hz = Scalar(0);
  Scalar rate_tolerance = Scalar(0.1);
  // This many consecutive samples behind the clock, in order among themselves: the clock was
  // reset (the stream restarts as after a gap) rather than a few bad timestamps.
  int clock_reset_samples = 3;
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

// What the stream did wrong, each counted by kind (Progress::stream). Samples refused are also
// in Progress::samples_refused; what was collected before any of these is kept.
struct StreamCounts {
  std::uint32_t non_finite = 0;       // samples with a NaN or infinity: refused
  std::uint32_t accel_saturated = 0;  // accelerometer at full scale: taken as motion
  std::uint32_t gyro_saturated = 0;   // gyro at full scale: refused, the move in progress dropped
  std::uint32_t frozen = 0;           // samples refused while a sensor repeated itself
  std::uint32_t time_repeated = 0;    // same timestamp as the previous sample: refused
  std::uint32_t time_backwards = 0;   // timestamp before the previous one: refused
  std::uint32_t clock_resets = 0;     // the clock went back and stayed back: resynchronised
  std::uint32_t gaps = 0;             // steps above the gap limit
  std::uint32_t rate_off = 0;         // one-second windows with a rate far from nominal
  std::uint32_t busy = 0;             // samples offered while solving or solved: refused
  std::uint32_t glitches = 0;         // accelerometer readings far outside the running range
  std::uint32_t temperature_bad = 0;  // temperatures not finite or out of range: ignored
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

// The defaults fit Tedaldi's protocol (the xsens recording: 41 poses, one partial coarsening of
// the segment store in the motion after its last rest) in about 31.7 KiB of float
// (bench/footprint).
template <typename Scalar, int MaxPoses = 48, int MaxSegments = 630, int DelayBlocks = 8>
class Calibrator {
 public:
  static_assert(MaxPoses >= kAccelMinPoses, "too few poses for the accelerometer model");
  static_assert(MaxSegments >= 2 * MaxPoses, "segment store too small for the poses");
  static_assert(DelayBlocks >= 2, "delay line too short");
  static constexpr int kMaxPoses = MaxPoses;
  static constexpr int kMaxSegments = MaxSegments;

  explicit Calibrator(const CalibratorSettings<Scalar>& settings = CalibratorSettings<Scalar>())
      : settings_(settings) {
    solve_memory_.make_accel(settings.accel);
    make_gyro_solver();
    reset();
  }

  // Starts again with new settings, in place (assigning a new Calibrator would build a 32 KB
  // temporary on the stack).
  void reset(const CalibratorSettings<Scalar>& settings) {
    settings_ = settings;
    solve_memory_.make_accel(settings.accel);
    make_gyro_solver();
    reset();
  }

  // Forgets everything collected and starts again with the initial rest.
  void reset() {
    phase_ = Phase::kInitialRest;
    last_event_ = Status::kOk;
    have_prev_ = false;
    restart_stream_ = true;
    back_run_ = 0;
    t_back_ = 0;
    rate_us_ = 0;
    rate_n_ = 0;
    counts_ = StreamCounts{};
    temp_ref_ = temp_sum_ = temp_comp_ = Scalar(0);
    temp_n_ = 0;
    last_rest_ = RestSummary<Scalar>{};
    frozen_time_ = Scalar(0);
    frozen_ = false;
    poses_.clear();
    move_count_ = 0;
    seg_count_ = 0;
    chain_from_ = -1;
    move_first_ = 0;
    last_mergeable_ = false;
    tail_only_ = false;
    rate_sum_.setZero();
    rate_sq_.setZero();
    rate_time_ = Scalar(0);
    rate_rests_ = 0;
    rest_open_ = false;
    block_ = Block{};
    delay_count_ = 0;
    delay_head_ = 0;
    rests_too_short_ = moves_dropped_ = coarsenings_ = 0;
    samples_refused_ = 0;
    last_rest_short_ = false;
    pose_store_full_reported_ = false;
    capacity_reported_ = false;
    last_still_ = true;
    u_prev_.setZero();
    rotation_ = Vector3<Scalar>::Zero();
    calibration_ = Calibration<Scalar>{};
    restart_initial_rest();
    const Scalar scale =
        settings_.gyro.nominal_scale > Scalar(0) ? settings_.gyro.nominal_scale : Scalar(1);
    seg_angle_ = settings_.segment_max_angle / scale;
    seg_error_ = settings_.segment_max_error / (scale * scale * scale);
    set_segment_error(seg_error_);
    block_us_ = static_cast<std::uint32_t>(settings_.block_seconds * Scalar(1e6));
    trim_us_ = static_cast<std::uint32_t>(settings_.trim_seconds * Scalar(1e6));
    inside_ball(settings_.accel_min, settings_.accel_max, acc_centre_, acc_radius2_);
    inside_ball(settings_.gyro_min, settings_.gyro_max, gyro_centre_, gyro_radius2_);
    settings_ok_ = check_settings();
  }

  // One raw sample. kOk: taken. Refused (nothing collected is lost): kNonFiniteInput,
  // kTimeRepeated, kTimeBackwards, kSensorFrozen, kBusy, kInvalidArgument (settings), and
  // kSaturated for a gyro at full scale (the move in progress is dropped as across a gap).
  // Taken with a note: kSaturated for an accelerometer at full scale (the sample counts as
  // motion), kTimestampGap, kClockReset, kSampleRateOff, kInitialRestDisturbed,
  // kCapacityExceeded (pose store full). Every case is counted in progress().stream.
  Status add(const ImuSample<Scalar>& sample) {
    if (!settings_ok_) return refuse(Status::kInvalidArgument);
    if (settings_.has_gyro) return take(sample);
    ImuSample<Scalar> s = sample;
    s.gyro.setZero();  // ignored, whatever it reads
    return take(s);
  }

  Progress progress() const {
    Progress p;
    p.phase = phase_;
    p.last_event = last_event_;
    p.initial_rest_done = phase_ == Phase::kInitialRest
                              ? static_cast<float>(init_.elapsed() / settings_.initial_rest_seconds)
                              : 1.0f;
    p.poses = poses_.size();
    p.moves = move_count_;
    p.segments = seg_count_;
    p.rests_too_short = rests_too_short_;
    p.moves_dropped = moves_dropped_;
    p.coarsenings = coarsenings_;
    p.samples_refused = samples_refused_;
    p.stream = counts_;
    p.faces = faces();
    for (int i = 0; i < 6; ++i) p.faces_covered += (p.faces >> i) & 1;
    p.next_face = 0;
    while (p.next_face < 5 && ((p.faces >> p.next_face) & 1)) ++p.next_face;
    const Scalar most = rotation_.maxCoeff();
    for (int i = 0; i < 3; ++i)
      if (most > Scalar(0) && rotation_(i) >= Scalar(0.2) * most)
        p.axes_turned = static_cast<std::uint8_t>(p.axes_turned | (1u << i));
    p.next_axis = 0;
    while (p.next_axis < 2 && ((p.axes_turned >> p.next_axis) & 1)) ++p.next_axis;
    p.hint = hint(p);
    return p;
  }

  // The stream has ended (a recording's last sample): a rest still open becomes a pose if long
  // enough, a move in progress is dropped (it has no pose to end at). solve() does this itself;
  // call it to see every pose before solving, or when there are too few to solve. A sample added
  // afterwards starts the stream again as after a gap.
  void end_stream() {
    if (phase_ != Phase::kCollecting && phase_ != Phase::kReady) return;
    end_of_stream();
    restart_stream_ = true;
  }

  // Ends the collection and starts the solve. kRunning: call solve_step() until it returns
  // something else. kTooFewPoses: nothing is changed, collection may go on.
  Status solve() {
    if (phase_ == Phase::kSolving) return Status::kRunning;
    if (phase_ == Phase::kDone || phase_ == Phase::kFailed) return calibration_status();
    if (phase_ == Phase::kInitialRest) return Status::kTooFewPoses;
    const bool pending_pose = rest_open_ && rest_long_enough(true) && !poses_.full();
    if (poses_.size() + (pending_pose ? 1 : 0) < kAccelMinPoses) return Status::kTooFewPoses;
    end_of_stream();
    calibration_.sample_rate_hz = period_ > Scalar(0) ? Scalar(1) / period_ : Scalar(0);
    calibration_.has_temperature = mean_temperature(calibration_.temperature_c);
    phase_ = Phase::kSolving;
    stage_ = SolveStage::kAccel;
    solve_memory_.make_accel(settings_.accel);
    const Status s = solve_memory_.accel().start(poses_.span());
    if (s != Status::kRunning && s != Status::kOk && !succeeded(s)) return fail_accel();
    return Status::kRunning;
  }

  // One bounded slice of the solve: one accelerometer LM iteration, or at most
  // gyro.segments_per_step segments of the gyro run.
  Status solve_step() {
    if (phase_ != Phase::kSolving)
      return phase_ == Phase::kDone     ? Status::kOk
             : phase_ == Phase::kFailed ? calibration_status()
                                        : Status::kNotStarted;
    if (stage_ == SolveStage::kAccel) {
      AccelSolver<Scalar>& solver = solve_memory_.accel();
      const Status s = solver.status() == Status::kRunning ? solver.step() : solver.status();
      if (s == Status::kRunning) return s;
      if (!succeeded(solver.finish(calibration_.accel))) return fail_accel();
      if (!settings_.has_gyro) {  // the accelerometer alone: done
        calibration_.quality = quality();
        phase_ = Phase::kDone;
        return calibration_.accel.status;
      }
      start_gyro();
      return phase_ == Phase::kFailed ? calibration_status() : Status::kRunning;
    }
    if (stage_ == SolveStage::kGyro) {
      const Status s = gyro_.visit([](auto& g) { return g.step(); });
      if (s == Status::kRunning) return s;
      if (settings_.gyro.refine_bias) {
        gyro_.twelve().finish(calibration_.gyro);
      } else {
        gyro_.nine().finish(calibration_.gyro);
        if (succeeded(calibration_.gyro.status))  // the bias is the rests' mean rate
          calibration_.gyro.sigma.template tail<3>() = rest_bias_sigma();
      }
      if (succeeded(calibration_.gyro.status) && start_input_uncertainty()) return Status::kRunning;
    } else {  // SolveStage::kGyroSigma
      const AccelVector<Scalar>& pa = calibration_.accel.params;
      GyroInputUncertainty<Scalar>& u = solve_memory_.input_uncertainty();
      const int slice = settings_.gyro.segments_per_step;
      const Status s = gyro_.visit([&](auto& g) {
        const Status st = u.step(g, pa, poses_.span(), slice);
        return st == Status::kOk ? u.finish(g, calibration_.gyro) : st;
      });
      if (s == Status::kRunning) return s;
      if (s != Status::kOk) fail_gyro(s);
    }
    calibration_.quality = quality();
    phase_ = succeeded(calibration_.gyro.status) ? Phase::kDone : Phase::kFailed;
    return calibration_.gyro.status;
  }

  // Both in one call (host tools, tests): solve() then solve_step() to the end.
  Status solve_all() {
    Status s = solve();
    while (s == Status::kRunning) s = solve_step();
    return s;
  }

  // Whether the latest sample taken was classified still (e.g. for a status LED).
  bool still() const { return last_still_; }
  // Whether solve_step() is in the gyro run (after the accelerometer's).
  bool solving_gyro() const { return phase_ == Phase::kSolving && stage_ != SolveStage::kAccel; }

  const Calibration<Scalar>& calibration() const { return calibration_; }
  PoseSpan<Scalar> poses() const { return poses_.span(); }
  // Time span of pose i: first and last sample's timestamps.
  std::uint32_t pose_begin_us(int i) const { return pose_time_[i][0]; }
  std::uint32_t pose_end_us(int i) const { return pose_time_[i][1]; }
  int move_count() const { return move_count_; }
  const GyroMove& move(int i) const { return moves_[i]; }
  int segment_count() const { return seg_count_; }
  const GyroSegment<Scalar>& segment(int i) const { return segments_[i]; }
  // The initial-rest gyro bias (added, sensor units) and the per-axis noise variances.
  const Vector3<Scalar>& gyro_bias0() const { return b0_; }
  const Vector3<Scalar>& accel_noise_variance() const { return v0_; }
  // The gyro's per-axis noise variance over the initial rest (sensor units^2).
  Vector3<Scalar> gyro_noise_variance() const { return gv0_; }
  Scalar mean_period() const { return period_; }
  // The mean temperature of the samples taken so far; false if none carried one.
  bool mean_temperature(Scalar& out) const {
    if (temp_n_ == 0) return false;
    out = temp_ref_ + (temp_sum_ + temp_comp_) / static_cast<Scalar>(temp_n_);
    return true;
  }
  const CalibratorSettings<Scalar>& settings() const { return settings_; }
  // Why the calibration's quality is what it is (static text; after a solve).
  const char* quality_reason() const {
    const char* why = "";
    quality(&why);
    return why;
  }
  // The latest pose (progress().poses counts them) as a rest: mean raw readings, temperature,
  // length. Feed it to a TemperatureFit (temperature_fit.hpp) for a bias-vs-temperature model.
  const RestSummary<Scalar>& last_rest() const { return last_rest_; }

 private:
  // add() of a sample whose gyro reading is to be used.
  Status take(const ImuSample<Scalar>& s) {
    if (phase_ == Phase::kSolving || phase_ == Phase::kDone || phase_ == Phase::kFailed) {
      ++counts_.busy;
      return refuse(Status::kBusy);
    }
    // Every reading finite and inside its full scale: one test per sensor on the usual path
    // (inside a ball within the box of the limits; NaN fails it), exact tests only outside it.
    bool gyro_saturated = false, acc_saturated = false;
    if (!((s.acc.array() - acc_centre_).matrix().squaredNorm() < acc_radius2_ &&
          (s.gyro.array() - gyro_centre_).matrix().squaredNorm() < gyro_radius2_)) {
      // x - x is 0 for a finite x and NaN otherwise.
      const Scalar nan_if_any = (s.acc - s.acc).sum() + (s.gyro - s.gyro).sum();
      if (!(nan_if_any == Scalar(0))) {
        ++counts_.non_finite;
        return refuse(Status::kNonFiniteInput);
      }
      gyro_saturated = outside(s.gyro, settings_.gyro_min, settings_.gyro_max);
      acc_saturated = outside(s.acc, settings_.accel_min, settings_.accel_max);
    }
    std::int32_t step = 0;
    Status result = Status::kOk;
    if (have_prev_) {
      step = static_cast<std::int32_t>(s.t_us - t_prev_);
      if (step == 0) {
        ++counts_.time_repeated;
        return refuse(Status::kTimeRepeated);
      }
      if (step < 0) {
        if (!clock_went_back(s.t_us)) {
          ++counts_.time_backwards;
          return refuse(Status::kTimeBackwards);
        }
        // Reset: this sample starts the stream again, as after a gap.
        ++counts_.clock_resets;
        on_gap();
        result = last_event_ = Status::kClockReset;
        restart_stream_ = true;
      }
    }
    back_run_ = 0;
    Scalar dt = static_cast<Scalar>(step) * Scalar(1e-6);
    // Frozen: either sensor's reading the same as its previous one for frozen_seconds.
    if (have_prev_ && !restart_stream_ &&
        (same_reading(s.acc, acc_prev_) ||
         (settings_.has_gyro && same_reading(s.gyro, gyro_prev_)))) {
      frozen_time_ += dt;
      t_prev_ = s.t_us;
      if (frozen_time_ >= settings_.frozen_seconds) {
        if (!frozen_) on_frozen();
        frozen_ = true;
        ++counts_.frozen;
        ++samples_refused_;
        return Status::kSensorFrozen;
      }
    } else if (frozen_time_ > Scalar(0)) {
      frozen_time_ = Scalar(0);
      if (frozen_) {
        frozen_ = false;
        restart_stream_ = true;  // the stream starts again after the frozen spell
      }
    }
    if (gyro_saturated) {
      remember(s);
      // The rotation over this interval is unknown: nothing can be integrated across it.
      ++counts_.gyro_saturated;
      if (!restart_stream_) on_gap();
      restart_stream_ = true;
      last_event_ = Status::kSaturated;
      return refuse(Status::kSaturated);
    }
    if (!restart_stream_ && static_cast<std::uint32_t>(step) > gap_us_) {
      ++counts_.gaps;
      on_gap();
      result = last_event_ = Status::kTimestampGap;
      restart_stream_ = true;
    }
    if (restart_stream_) {  // first sample after a start, a gap or a reset: no interval
      dt = Scalar(0);
      step = 0;
      restart_stream_ = false;
      rate_us_ = 0;
      rate_n_ = 0;
    }
    Scalar temperature = s.temperature;
    if (temperature == temperature) {  // NaN: no temperature sensor
      if (temperature >= settings_.temperature_min_c &&
          temperature <= settings_.temperature_max_c) {
        add_temperature(temperature);
      } else {
        ++counts_.temperature_bad;
        temperature = std::numeric_limits<Scalar>::quiet_NaN();
        if (result == Status::kOk) result = last_event_ = Status::kTemperatureImplausible;
      }
    }
    if (acc_saturated) {
      ++counts_.accel_saturated;
      result = last_event_ = Status::kSaturated;
    }
    if (settings_.nominal_rate_hz > Scalar(0) && rate_window(static_cast<std::uint32_t>(step)) &&
        result == Status::kOk)
      result = Status::kSampleRateOff;
    if (phase_ == Phase::kInitialRest) {
      remember(s);
      // A saturated accelerometer cannot be at rest: the initial rest starts again.
      if (acc_saturated) restart_initial_rest();
      const Status r = acc_saturated ? Status::kOk : initial_rest_sample(s, dt);
      return r == Status::kOk ? result : r;
    }
    if (!collect_sample(s, temperature, dt, acc_saturated)) {
      // Not taken: a reading this far off is no acceleration a hand makes. The previous
      // sample stays the reference, so the interval spans the refused one.
      ++counts_.glitches;
      last_event_ = Status::kGlitch;
      return refuse(Status::kGlitch);
    }
    remember(s);
    if (pose_store_full_reported_ && result == Status::kOk) {
      pose_store_full_reported_ = false;
      return Status::kCapacityExceeded;
    }
    return result;
  }

  void make_gyro_solver() { gyro_.make(settings_.gyro); }

  // The accelerometer's LM, the gyro's, then the pass that carries the inputs the gyro's held
  // fixed into its sigma.
  enum class SolveStage : std::uint8_t { kAccel, kGyro, kGyroSigma };

  // A run of consecutive samples, all still or all moving: gyro statistics (of u = w + b0),
  // path angle sum |u| dt, time span, and the acceleration sum, re-centred: relative to acc_ref
  // (the block's first raw reading), so that the summands are noise-sized, and blocks are added
  // into a rest compensated (compensated_add): a rest of hours keeps its mean exact (the 24-hour
  // test in test_stream_faults.cpp holds float to double).
  struct Block {
    GyroSegment<Scalar> seg{};
    Vector3<Scalar> acc_ref = Vector3<Scalar>::Zero();
    Vector3<Scalar> acc_sum = Vector3<Scalar>::Zero();
    Vector3<Scalar> acc_comp = Vector3<Scalar>::Zero();  // low part: the sum is sum + comp
    Scalar path = Scalar(0);
    Scalar accel_cue = Scalar(0), energy_cue = Scalar(0);  // the detector's sample cues, summed
    Scalar temp_sum = Scalar(0);  // temperatures relative to the stream's first one
    std::uint32_t temp_n = 0;     // samples that carried a temperature
    std::uint32_t n = 0;
    std::uint32_t t_begin = 0;
    std::uint32_t t_end = 0;
    bool still = true;
    bool long_enough = false;  // rests: lasted min_rest_seconds (sticky: the clock wraps)

    void clear() {
      seg = GyroSegment<Scalar>{};
      acc_sum.setZero();
      acc_comp.setZero();
      path = Scalar(0);
      accel_cue = energy_cue = Scalar(0);
      temp_sum = Scalar(0);
      temp_n = 0;
      n = 0;
      long_enough = false;
    }

    Vector3<Scalar> acc_mean() const {
      return acc_ref + (acc_sum + acc_comp) / static_cast<Scalar>(n);
    }

    void append(const Block& later) {
      seg.append(later.seg);
      if (n == 0) {
        acc_ref = later.acc_ref;
        acc_sum = later.acc_sum;
        acc_comp = later.acc_comp;
      } else {
        // The later block's sum moved to this reference (n (ref' - ref): exact for raw counts),
        // added compensated.
        const Vector3<Scalar> add = later.acc_sum + later.acc_comp +
                                    static_cast<Scalar>(later.n) * (later.acc_ref - acc_ref);
        for (int i = 0; i < 3; ++i) compensated_add(acc_sum(i), acc_comp(i), add(i));
      }
      path += later.path;
      accel_cue += later.accel_cue;
      energy_cue += later.energy_cue;
      temp_sum += later.temp_sum;
      temp_n += later.temp_n;
      if (n == 0) t_begin = later.t_begin;
      n += later.n;
      t_end = later.t_end;
    }
  };

  // A quarter of the initial-rest window while it fills: sums re-centred on its own first
  // reading (float keeps the noise's precision on raw counts ~33000 even after the board moved).
  struct QuarterSums {
    Vector3<Scalar> acc_ref = Vector3<Scalar>::Zero(), gyro_ref = Vector3<Scalar>::Zero();
    Vector3<Scalar> acc_sum = Vector3<Scalar>::Zero(), acc_sq = Vector3<Scalar>::Zero();
    Vector3<Scalar> gyro_sum = Vector3<Scalar>::Zero(), gyro_sq = Vector3<Scalar>::Zero();
    Scalar elapsed = Scalar(0);
    std::uint32_t n = 0;
    std::uint32_t t_begin = 0, t_end = 0;
  };
  // A complete quarter: means and per-axis variances.
  struct Quarter {
    Vector3<Scalar> acc_mean = Vector3<Scalar>::Zero(), acc_var = Vector3<Scalar>::Zero();
    Vector3<Scalar> gyro_mean = Vector3<Scalar>::Zero(), gyro_var = Vector3<Scalar>::Zero();
    Scalar elapsed = Scalar(0);
    std::uint32_t n = 0;
    std::uint32_t t_begin = 0, t_end = 0;

    Quarter() = default;
    explicit Quarter(const QuarterSums& q)
        : elapsed(q.elapsed), n(q.n), t_begin(q.t_begin), t_end(q.t_end) {
      if (n == 0) return;
      const Scalar k = Scalar(1) / static_cast<Scalar>(n);
      const Vector3<Scalar> ma = k * q.acc_sum, mg = k * q.gyro_sum;
      acc_mean = q.acc_ref + ma;
      gyro_mean = q.gyro_ref + mg;
      acc_var = (k * q.acc_sq - ma.cwiseProduct(ma)).cwiseMax(Scalar(0));
      gyro_var = (k * q.gyro_sq - mg.cwiseProduct(mg)).cwiseMax(Scalar(0));
    }
  };

  // The window sliding over the stream until it is still: the last four complete quarters (a
  // ring) and the one filling.
  struct InitialRest {
    Quarter q[4] = {};
    QuarterSums cur{};
    int head = 0, count = 0;
    Scalar elapsed() const {
      Scalar e = cur.elapsed;
      for (int k = 0; k < count; ++k) e += q[(head + k) % 4].elapsed;
      return e;
    }
    const Quarter& at(int k) const { return q[(head + k) % 4]; }
  };

  bool check_settings() const {
    const CalibratorSettings<Scalar>& c = settings_;
    return c.initial_rest_seconds > Scalar(0) && c.min_rest_seconds > Scalar(0) &&
           c.trim_seconds >= Scalar(0) && c.stillness.valid() && c.block_seconds > Scalar(0) &&
           c.glitch_sigma > Scalar(1) && c.temperature_min_c < c.temperature_max_c &&
           c.trim_seconds <= c.block_seconds * Scalar(DelayBlocks - 1) &&
           c.gap_factor > Scalar(1) && c.max_step_seconds > Scalar(0) &&
           c.frozen_seconds > Scalar(0) && c.segment_max_angle > Scalar(0) &&
           c.segment_max_error > Scalar(0) && c.gyro.nominal_scale >= Scalar(0) &&
           // Durations become microseconds in uint32: keep them far from 2^32 us (71 min).
           c.block_seconds <= Scalar(60) && c.trim_seconds <= Scalar(60) &&
           c.max_step_seconds <= Scalar(60);
  }

  // The same reading on every axis (finite readings only: NaN was refused before). Compared
  // axis by axis, the first that differs ends it: on a live sensor that is nearly always the
  // first.
  static bool same_reading(const Vector3<Scalar>& a, const Vector3<Scalar>& b) {
    return a(0) == b(0) && a(1) == b(1) && a(2) == b(2);
  }

  // The largest step that is not a gap, in microseconds.
  void update_gap_limit() {
    Scalar limit = settings_.max_step_seconds;
    if (phase_ != Phase::kInitialRest && period_ > Scalar(0) &&
        settings_.gap_factor * period_ < limit)
      limit = settings_.gap_factor * period_;
    gap_us_ = static_cast<std::uint32_t>(limit * Scalar(1e6));
  }

  // The error bound |alpha| |beta| of a new segment, and the path angle below which a segment
  // cannot reach it: |alpha| <= path and |beta| <= path^2 / 2, so |alpha| |beta| <= path^3 / 2
  // (with a margin for rounding: 0.9^3 of the bound).
  void set_segment_error(Scalar e) {
    seg_error_ = e;
    seg_error2_ = e * e;
    seg_error_path_ = Scalar(0.9) * std::cbrt(Scalar(2) * e);
  }

  // The sample taken (or refused for its gyro) is the one the next is ordered against.
  void remember(const ImuSample<Scalar>& s) {
    acc_prev_ = s.acc;
    gyro_prev_ = s.gyro;
    t_prev_ = s.t_us;
    have_prev_ = true;
  }

  Status refuse(Status s) {
    ++samples_refused_;
    return s;
  }

  // The ball that add() tests a reading against first: centred in the box [lo, hi]^3, a radius
  // a little inside its half-width, so a reading in it is inside the limits on every axis despite
  // rounding. Limits that give no finite centre: an empty ball (every reading tested exactly).
  static void inside_ball(Scalar lo, Scalar hi, Scalar& centre, Scalar& radius2) {
    const Scalar c = Scalar(0.5) * lo + Scalar(0.5) * hi;
    const Scalar r = (Scalar(0.5) * hi - Scalar(0.5) * lo) * (Scalar(1) - Scalar(1) / Scalar(1024));
    if (lo == -std::numeric_limits<Scalar>::infinity() &&
        hi == std::numeric_limits<Scalar>::infinity()) {  // no limits: finite is inside
      centre = Scalar(0);
      radius2 = std::numeric_limits<Scalar>::infinity();
      return;
    }
    const bool usable = std::isfinite(c) && std::isfinite(r) && r > Scalar(0);
    centre = usable ? c : Scalar(0);
    radius2 = usable ? r * r : Scalar(-1);  // r * r may be +inf: then every finite norm is in
  }

  // Any axis at or beyond the full-scale limits (NaN was refused before).
  static bool outside(const Vector3<Scalar>& v, Scalar lo, Scalar hi) {
    return v(0) <= lo || v(0) >= hi || v(1) <= lo || v(1) >= hi || v(2) <= lo || v(2) >= hi;
  }

  // A timestamp behind the clock: true once clock_reset_samples of them came in order with
  // normal steps between them (the clock was reset), false for a stray one (refused).
  bool clock_went_back(std::uint32_t t) {
    const std::int32_t since = static_cast<std::int32_t>(t - t_back_);
    if (back_run_ > 0 && since > 0 && static_cast<std::uint32_t>(since) <= gap_us_)
      ++back_run_;
    else
      back_run_ = 1;
    t_back_ = t;
    if (back_run_ < settings_.clock_reset_samples) return false;
    back_run_ = 0;
    return true;
  }

  // The rate over each second of the stream against the nominal one; true when a window just
  // closed off-rate (counted, and the stream's latest event).
  bool rate_window(std::uint32_t step_us) {
    rate_us_ += step_us;
    ++rate_n_;
    if (rate_us_ < 1000000u) return false;
    const Scalar rate = static_cast<Scalar>(rate_n_ - 1) * Scalar(1e6) /
                        static_cast<Scalar>(rate_us_);  // intervals over their span
    rate_us_ = 0;
    rate_n_ = 1;  // this sample opens the next window
    if (std::abs(rate / settings_.nominal_rate_hz - Scalar(1)) <= settings_.rate_tolerance)
      return false;
    ++counts_.rate_off;
    last_event_ = Status::kSampleRateOff;
    return true;
  }

  // Running mean of the temperature: re-centred on the first reading, compensated.
  void add_temperature(Scalar t) {
    if (temp_n_ == 0) temp_ref_ = t;
    compensated_add(temp_sum_, temp_comp_, t - temp_ref_);
    ++temp_n_;
  }

  // ---- Initial rest --------------------------------------------------------------------------

  void restart_initial_rest() {
    phase_ = Phase::kInitialRest;
    init_ = InitialRest{};
    update_gap_limit();
  }

  Status initial_rest_sample(const ImuSample<Scalar>& s, Scalar dt) {
    QuarterSums& c = init_.cur;
    if (c.n == 0) {
      c.acc_ref = s.acc;
      c.gyro_ref = s.gyro;
      c.t_begin = s.t_us;
      dt = init_.count == 0 ? Scalar(0) : dt;  // the window's span starts at its first sample
    }
    c.elapsed += dt;
    const Vector3<Scalar> a = s.acc - c.acc_ref, g = s.gyro - c.gyro_ref;
    c.acc_sum += a;
    c.acc_sq += a.cwiseProduct(a);
    c.gyro_sum += g;
    c.gyro_sq += g.cwiseProduct(g);
    ++c.n;
    c.t_end = s.t_us;
    if (c.elapsed < Scalar(0.25) * settings_.initial_rest_seconds) return Status::kOk;
    // The quarter is complete: into the ring (the oldest slides out), then the window's test.
    if (init_.count == 4) {
      init_.head = (init_.head + 1) % 4;
      --init_.count;
    }
    init_.q[(init_.head + init_.count) % 4] = Quarter(c);
    ++init_.count;
    init_.cur = QuarterSums{};
    if (init_.count < 4) return Status::kOk;
    return finish_initial_rest();
  }

  // Still: every quarter's variance within 9x the smallest (motion raises it by orders of
  // magnitude), and every quarter mean within (8 sigma of a quarter mean) + (1 sigma of a
  // sample) of the window's mean. The second term keeps the test from growing stricter with the
  // sample rate: a warming board's slow drift is not motion, a tilt of a fraction of a degree is.
  Status finish_initial_rest() {
    Vector3<Scalar> va_min = init_.at(0).acc_var, va_max = va_min;
    Vector3<Scalar> vg_min = init_.at(0).gyro_var, vg_max = vg_min;
    Scalar n = Scalar(0);
    Vector3<Scalar> va = Vector3<Scalar>::Zero(), vg = Vector3<Scalar>::Zero();
    Vector3<Scalar> acc_sum = Vector3<Scalar>::Zero(), gyro_sum = Vector3<Scalar>::Zero();
    const Quarter& first = init_.at(0);
    for (int k = 0; k < 4; ++k) {
      const Quarter& q = init_.at(k);
      const Scalar nq = static_cast<Scalar>(q.n);
      va_min = va_min.cwiseMin(q.acc_var);
      va_max = va_max.cwiseMax(q.acc_var);
      vg_min = vg_min.cwiseMin(q.gyro_var);
      vg_max = vg_max.cwiseMax(q.gyro_var);
      va += nq * q.acc_var;
      vg += nq * q.gyro_var;
      acc_sum += nq * (q.acc_mean - first.acc_mean);  // relative to the first quarter's mean
      gyro_sum += nq * (q.gyro_mean - first.gyro_mean);
      n += nq;
    }
    va /= n;
    vg /= n;
    const Vector3<Scalar> acc_mean = acc_sum / n, gyro_mean = gyro_sum / n;
    // No noise on an axis: a frozen or disconnected sensor, no threshold can be set from it.
    if (!(va_min.minCoeff() > Scalar(0)) ||
        (settings_.has_gyro && !(vg_min.minCoeff() > Scalar(0))))
      return last_event_ = Status::kSensorFrozen;
    for (int i = 0; i < 3; ++i) {
      if (va_max(i) > Scalar(9) * va_min(i) ||
          (settings_.has_gyro && vg_max(i) > Scalar(9) * vg_min(i)))
        return last_event_ = Status::kInitialRestDisturbed;
    }
    for (int k = 0; k < 4; ++k) {
      const Quarter& q = init_.at(k);
      const Scalar nq = static_cast<Scalar>(q.n);
      const Vector3<Scalar> da = q.acc_mean - (first.acc_mean + acc_mean);
      const Vector3<Scalar> dg = q.gyro_mean - (first.gyro_mean + gyro_mean);
      const Scalar limit = Scalar(64) / nq + Scalar(1);
      for (int i = 0; i < 3; ++i) {
        if (da(i) * da(i) > limit * va(i) || (settings_.has_gyro && dg(i) * dg(i) > limit * vg(i)))
          return last_event_ = Status::kInitialRestDisturbed;
      }
    }
    a_ref_ = first.acc_mean;
    v0_ = va;
    gv0_ = settings_.has_gyro ? vg : Vector3<Scalar>::Zero();
    b0_ = settings_.has_gyro ? Vector3<Scalar>(-(first.gyro_mean + gyro_mean))
                             : Vector3<Scalar>::Zero();
    b0_sigma_ = (gv0_ / n).cwiseSqrt();  // of the mean rate
    u_prev_.setZero();                   // the rate at the rest's end, bias removed
    const std::uint32_t t_begin = first.t_begin, t_end = init_.at(3).t_end;
    period_ = static_cast<Scalar>(t_end - t_begin) * Scalar(1e-6) / (n - Scalar(1));
    // The detector starts from the rest's own statistics.
    detector_.start(settings_.stillness, acc_mean, v0_, gv0_.sum());
    detector_.set_glitch_limit(settings_.glitch_sigma * settings_.glitch_sigma * v0_.maxCoeff());
    // The initial rest is the first rest: it becomes pose 0 when the first move starts.
    rest_ = Block{};
    rest_.acc_ref = a_ref_;
    rest_.acc_sum = acc_sum;
    rest_.long_enough = false;  // decided by its length, as every rest
    rest_.n = static_cast<std::uint32_t>(n);
    rest_.accel_cue = n * v0_.sum();
    rest_.energy_cue = n * gv0_.sum();
    // The temperatures so far (those before the window too: close enough for a mean).
    rest_.temp_sum = temp_sum_ + temp_comp_;
    rest_.temp_n = temp_n_;
    rest_.t_begin = t_begin;
    rest_.t_end = t_end;
    rest_open_ = true;
    block_ = Block{};
    phase_ = Phase::kCollecting;
    init_ = InitialRest{};
    update_gap_limit();
    return Status::kOk;
  }

  // ---- Collection ----------------------------------------------------------------------------

  // The per-sample path, written per axis with the thresholds precomputed (bench_stream counts
  // its instructions): the detector, then the sample folded into the current block. False: a
  // glitch (nothing changed).
  bool collect_sample(const ImuSample<Scalar>& s, Scalar temperature, Scalar dt, bool moving) {
    // The rate over the interval is the mean of its two end samples (trapezoid, as the RK4
    // reference interpolates linearly between samples): holding the newer sample instead
    // differs by ~1e-4 rad per move on the xsens recording, 0.16 sigma of the gyro scale. (A
    // first sample has dt = 0: whatever u_prev_ holds then adds nothing.)
    const Vector3<Scalar> u = s.gyro + b0_;
    const Stillness step = detector_.update(s.acc - a_ref_, u, dt, moving);
    if (step == Stillness::kGlitch) return false;
    const bool still = step == Stillness::kStill;
    last_still_ = still;
    Vector3<Scalar> u_mid;
    Scalar path2 = Scalar(0);
#pragma GCC unroll 3
    for (int i = 0; i < 3; ++i) {
      const Scalar mi = Scalar(0.5) * (u(i) + u_prev_(i));
      u_prev_(i) = u(i);
      path2 += mi * mi;
      u_mid(i) = mi;
    }
    // Blocks are homogeneous, short, and valid segments: close before a change of state or
    // a path angle above the segment bound, after the duration or the error bound.
    const Scalar step_path = std::sqrt(path2) * dt;
    if (block_.n > 0 && (still != block_.still || block_.path + step_path > seg_angle_))
      close_block();
    if (block_.n == 0) {
      block_.still = still;
      block_.t_begin = s.t_us;
      block_.acc_ref = s.acc;
    }
    block_.seg.add(u_mid, dt);
    block_.acc_sum += s.acc - block_.acc_ref;
    block_.path += step_path;
    block_.accel_cue += detector_.sample_accel();
    block_.energy_cue += detector_.sample_energy();
    if (temperature == temperature) {
      block_.temp_sum += temperature - temp_ref_;
      ++block_.temp_n;
    }
    ++block_.n;
    block_.t_end = s.t_us;
    if (s.t_us - block_.t_begin >= block_us_ ||
        (block_.path > seg_error_path_ &&
         block_.seg.alpha.squaredNorm() * block_.seg.beta.squaredNorm() > seg_error2_))
      close_block();
    return true;
  }

  // Routes the current block (by reference into the ring: no copies on the per-sample path).
  void close_block() {
    if (block_.n == 0) return;
    if (block_.still) {
      delay_add(block_);
      block_.clear();
      // A still block is part of the rest once trim_seconds of stillness follow it.
      while (delay_count_ > 0 && delay_span_after_oldest() >= trim_us_) {
        rest_add(delay_[delay_head_]);
        delay_drop_oldest();
      }
      return;
    }
    detector_.learn_motion(block_.energy_cue / static_cast<Scalar>(block_.n));
    motion_after(block_);
    block_.clear();
  }

  // Motion has come: the rest (if any) ends, the trimmed blocks and then b (if any) belong to
  // the move.
  void motion_after(const Block& b) {
    end_rest(true);
    flush_delay_to_move();
    push_segment(b);  // an empty block adds nothing
  }

  // A full line (blocks cut short by the segment bounds) grows its newest block instead of
  // letting a block into the rest before trim_seconds of stillness followed it.
  void delay_add(const Block& b) {
    if (delay_count_ == DelayBlocks) {
      delay_[(delay_head_ + delay_count_ - 1) % DelayBlocks].append(b);
      return;
    }
    delay_[(delay_head_ + delay_count_) % DelayBlocks] = b;
    ++delay_count_;
  }
  void delay_drop_oldest() {
    delay_head_ = (delay_head_ + 1) % DelayBlocks;
    --delay_count_;
  }
  void flush_delay_to_move() {
    while (delay_count_ > 0) {
      push_segment(delay_[delay_head_]);
      delay_drop_oldest();
    }
  }
  void flush_delay_to_rest() {
    while (delay_count_ > 0) {
      rest_add(delay_[delay_head_]);
      delay_drop_oldest();
    }
  }
  std::uint32_t delay_span_after_oldest() const {
    if (delay_count_ < 2) return 0;
    const Block& oldest = delay_[delay_head_];
    const Block& newest = delay_[(delay_head_ + delay_count_ - 1) % DelayBlocks];
    return newest.t_end - oldest.t_end;
  }

  void rest_add(const Block& b) {
    if (!rest_open_) {
      rest_ = b;
      rest_open_ = true;
    } else {
      rest_.append(b);
    }
    if (!rest_.long_enough) rest_.long_enough = rest_long_enough(false);
  }

  // Timestamps wrap after 71.6 min: a rest that lasted min_rest_seconds stays long enough (the
  // flag is set while the span is still short).
  bool rest_long_enough(bool with_delay_line) const {
    if (rest_.long_enough) return true;
    std::uint32_t end = rest_.t_end;
    if (with_delay_line && delay_count_ > 0)
      end = delay_[(delay_head_ + delay_count_ - 1) % DelayBlocks].t_end;
    return static_cast<Scalar>(end - rest_.t_begin) * Scalar(1e-6) >= settings_.min_rest_seconds;
  }

  // The open rest ends (motion, gap, end of stream): a pose if long enough, else part of the
  // move in progress.
  // with_delay_line: the still blocks in the delay line (about to be trimmed into the move) count
  // towards the rest's length: the shortest usable rest is min_rest_seconds of stillness.
  void end_rest(bool with_delay_line) {
    if (!rest_open_) return;
    rest_open_ = false;
    if (!rest_long_enough(with_delay_line)) {
      ++rests_too_short_;
      last_rest_short_ = true;
      last_event_ = Status::kRestTooShort;
      push_segment(rest_);
      return;
    }
    last_rest_short_ = false;
    if (poses_.full()) {
      // Not stored (see the top of this file); the chain cannot continue past it.
      if (!capacity_reported_) pose_store_full_reported_ = capacity_reported_ = true;
      last_event_ = Status::kCapacityExceeded;
      drop_move();
      return;
    }
    if (poses_.add(rest_.acc_mean(), rest_.n, rest_noise()) != Status::kOk) {
      drop_move();
      return;
    }
    const int index = poses_.size() - 1;
    summarise_rest();
    pose_time_[index][0] = rest_.t_begin;
    pose_time_[index][1] = rest_.t_end;
    const Scalar inv_n = Scalar(1) / static_cast<Scalar>(rest_.n);
    detector_.learn_rest(rest_.accel_cue * inv_n, rest_.energy_cue * inv_n);
    // The rest's own rotation: held in the hand (its gyro energy well above the quietest rest's),
    // a board turns a little, and the pose's gravity direction, a mean over the rest, stands for
    // its time centroid: the move into the pose ends there and the move out of it starts there.
    // On a table a rest does not turn, and integrating through it would only add the bias's
    // drift (on the Xsens recording: 1.08 instead of 0.44 deg per move).
    GyroSegment<Scalar> head{}, tail{};
    const bool shaky = rest_.energy_cue * inv_n > Scalar(4) * detector_.first_rest_energy();
    const bool halves = settings_.has_gyro && shaky && rest_halves(rest_.seg, head, tail);
    if (halves && chain_from_ >= 0 && seg_count_ > move_first_) store_segment(head);
    if (settings_.has_gyro) add_rest_rate(last_rest_.gyro_mean + b0_, last_rest_.duration_s);
    if (chain_from_ >= 0 && seg_count_ > move_first_) {
      GyroMove& m = moves_[move_count_++];
      m.first_segment = move_first_;
      m.segments = seg_count_ - move_first_;
      m.from_pose = chain_from_;
      m.to_pose = index;
      for (int k = m.first_segment; k < seg_count_; ++k) rotation_ += segments_[k].alpha.cwiseAbs();
    }
    chain_from_ = index;
    move_first_ = seg_count_;
    last_mergeable_ = false;
    if (halves) {
      store_segment(tail);
      tail_only_ = true;
    }
    if (phase_ == Phase::kCollecting && poses_.size() >= settings_.target_poses && faces() == 0x3f)
      phase_ = Phase::kReady;
    if (poses_.full()) phase_ = Phase::kReady;
  }

  // The rest's noise for the accelerometer solver (Pose::noise): the variance of one sample on
  // one axis, from the detector's cue summed over the rest (each sample's squared deviation from
  // the moving mean, over the three axes). With white noise of variance s^2 that deviation has
  // variance s^2 (1 + w / (2 - w)) per axis, w = dt / (seconds + dt) the moving mean's weight.
  Scalar rest_noise() const {
    const Scalar n = static_cast<Scalar>(rest_.n);
    const Scalar dt = static_cast<Scalar>(rest_.t_end - rest_.t_begin) * Scalar(1e-6) / n;
    const Scalar w = dt / (settings_.stillness.seconds + dt);
    const Scalar noise = rest_.accel_cue / (Scalar(3) * n) * (Scalar(1) - w / Scalar(2));
    return std::isfinite(noise) && noise > Scalar(0) ? noise : Scalar(0);
  }

  // The latest pose as a RestSummary (for the temperature fit): the gyro mean from the rest's
  // segment statistics (alpha / duration is the time-weighted mean of u = w + b0). The initial
  // rest's samples are not in the segment but their u averages 0 by definition of b0: dividing
  // by the whole span counts them. (The span wraps after 71.6 min; the segment's duration not.)
  void summarise_rest() {
    RestSummary<Scalar>& r = last_rest_;
    r.accel_mean = rest_.acc_mean();
    const Scalar span = static_cast<Scalar>(rest_.t_end - rest_.t_begin) * Scalar(1e-6);
    const Scalar d = rest_.seg.duration > span ? rest_.seg.duration : span;
    r.gyro_mean =
        d > Scalar(0) ? Vector3<Scalar>(rest_.seg.alpha / d - b0_) : Vector3<Scalar>(-b0_);
    r.has_temperature = rest_.temp_n > 0;
    r.temperature_c = r.has_temperature
                          ? temp_ref_ + rest_.temp_sum / static_cast<Scalar>(rest_.temp_n)
                          : Scalar(0);
    r.samples = rest_.n;
    r.duration_s = d;
    r.begin_us = rest_.t_begin;
    r.end_us = rest_.t_end;
  }

  // Appends a block's gyro statistics to the move in progress, merged into the last segment
  // while the merged segment stays within the bounds.
  void push_segment(const Block& b) {
    if (chain_from_ < 0 || b.n == 0 || !settings_.has_gyro) return;  // nothing to integrate
    tail_only_ = false;
    if (last_mergeable_ && seg_count_ > move_first_ && last_path_ + b.path <= seg_angle_) {
      GyroSegment<Scalar> merged = segments_[seg_count_ - 1];
      merged.append(b.seg);
      if (merged.alpha.squaredNorm() * merged.beta.squaredNorm() <= seg_error2_) {
        segments_[seg_count_ - 1] = merged;
        last_path_ += b.path;
        return;
      }
    }
    if (!store_segment(b.seg)) return;
    last_path_ = b.path;
    last_mergeable_ = true;
  }

  // A new segment at the end of the store, coarsening it when full; false (the move dropped)
  // when nothing is left to merge (one segment per move everywhere).
  bool store_segment(const GyroSegment<Scalar>& seg) {
    if (seg_count_ == MaxSegments) coarsen();
    if (seg_count_ == MaxSegments) {
      drop_move();
      return false;
    }
    segments_[seg_count_++] = seg;
    last_mergeable_ = false;
    return true;
  }

  // A rest's rotation split at its time centroid (first order: the rotation within a rest is a
  // fraction of a degree). With gamma = sum_{k<l} dt_k dt_l (u_k - u_l) = sum u_k dt_k (T - 2 m_k)
  // (m_k the middle of interval k), the centroid's attitude is reached after alpha/2 + gamma/2T
  // and the rest of alpha follows; each half holds T/2 of the bias (alpha_b = alpha + T/2 b).
  static bool rest_halves(const GyroSegment<Scalar>& r, GyroSegment<Scalar>& head,
                          GyroSegment<Scalar>& tail) {
    if (!(r.duration > Scalar(0))) return false;
    const Vector3<Scalar> half = Scalar(0.5) * r.alpha, skew = r.gamma / (Scalar(2) * r.duration);
    head = GyroSegment<Scalar>{};
    tail = GyroSegment<Scalar>{};
    head.alpha = half + skew;
    tail.alpha = half - skew;
    head.duration = tail.duration = Scalar(0.5) * r.duration;
    return true;
  }

  // Each pose's mean rate u = w + b0 over its length: at rest w = -b, so their time-weighted
  // mean gives the bias from every rest, and their scatter its uncertainty.
  void add_rest_rate(const Vector3<Scalar>& u_mean, Scalar duration) {
    if (!(duration > Scalar(0))) return;
    rate_sum_ += duration * u_mean;
    rate_sq_ += duration * u_mean.cwiseProduct(u_mean);
    rate_time_ += duration;
    ++rate_rests_;
  }

  // Frees at least an eighth of the store by merging adjacent segments of the same move (exact
  // algebra), those whose merged error bound is smallest first: the bound tau starts at the
  // current one and doubles until enough merges qualify. The new-segment bounds double too, so
  // that a long protocol (or an unknown gyro scale) settles at a coarser resolution instead of
  // coarsening often.
  void coarsen() {
    const int wanted = MaxSegments / 8 > 0 ? MaxSegments / 8 : 1;
    Scalar tau = seg_error_;
    for (int attempt = 0; attempt < 40 && merge_pass(tau, false) < wanted; ++attempt)
      tau *= Scalar(2);
    merge_pass(tau, true);
    seg_angle_ *= Scalar(2);
    set_segment_error(Scalar(2) * seg_error_);
    last_mergeable_ = false;
    ++coarsenings_;
  }

  // Greedy left-to-right merging within each move (the recorded ones and the open one) while
  // |alpha||beta| of the merged segment stays within tau. Returns the number of merges; with
  // apply, also performs them and compacts the store.
  int merge_pass(Scalar tau, bool apply) {
    int merges = 0, write = 0;
    auto range = [&](int first, int count) {
      const int new_first = write;
      if (count == 0) return new_first;
      GyroSegment<Scalar> cur = segments_[first];
      for (int k = 1; k < count; ++k) {
        GyroSegment<Scalar> trial = cur;
        trial.append(segments_[first + k]);
        if (trial.alpha.squaredNorm() * trial.beta.squaredNorm() <= tau * tau) {
          cur = trial;
          ++merges;
          continue;
        }
        if (apply) segments_[write] = cur;
        ++write;
        cur = segments_[first + k];
      }
      if (apply) segments_[write] = cur;
      ++write;
      return new_first;
    };
    for (int m = 0; m < move_count_; ++m) {
      const int first = range(moves_[m].first_segment, moves_[m].segments);
      if (apply) {
        moves_[m].first_segment = first;
        moves_[m].segments = write - first;
      }
    }
    const int open_first = range(move_first_, seg_count_ - move_first_);
    if (apply) {
      move_first_ = open_first;
      seg_count_ = write;
    }
    return merges;
  }

  // The move in progress cannot be used: its segments are freed, the chain restarts at the
  // next pose.
  void drop_move() {
    if (chain_from_ >= 0 && seg_count_ > move_first_ && !tail_only_) ++moves_dropped_;
    tail_only_ = false;
    seg_count_ = move_first_;
    chain_from_ = -1;
    last_mergeable_ = false;
  }

  // A gap: the rest before it still counts (trimmed as before motion); the move across it is
  // dropped.
  void on_gap() {
    if (phase_ == Phase::kInitialRest) {
      restart_initial_rest();
      return;
    }
    flush_blocks_as_motion();
    drop_move();
  }

  // A frozen sensor: the samples since it froze may already sit in the rest, so the rest in
  // progress is discarded with the move.
  void on_frozen() {
    last_event_ = Status::kSensorFrozen;
    if (phase_ == Phase::kInitialRest) {
      restart_initial_rest();
      return;
    }
    block_ = Block{};
    delay_count_ = 0;
    rest_open_ = false;
    drop_move();
  }

  // The stream is cut (gap): the current block and the delay line are treated as if motion
  // followed, so the rest before the cut is trimmed like any other.
  void flush_blocks_as_motion() {
    if (block_.still && block_.n > 0) {
      delay_add(block_);
      block_.clear();
    }
    motion_after(block_);
    block_.clear();
  }

  // End of the stream: if it ends still, the delay line belongs to the last rest (no motion
  // followed); if it ends in motion, the move in progress has no pose to end at.
  void end_of_stream() {
    if (block_.n > 0) {
      if (block_.still)
        delay_add(block_);
      else
        motion_after(block_);
      block_.clear();
    }
    if (delay_count_ > 0 || rest_open_) {
      flush_delay_to_rest();
      end_rest(false);
    } else if (chain_from_ >= 0 && seg_count_ > move_first_) {
      last_event_ = Status::kEndedInMotion;
    }
    drop_move();  // whatever is still open after the last pose
  }

  // ---- Solving -------------------------------------------------------------------------------

  void start_gyro() {
    stage_ = SolveStage::kGyro;
    const AccelVector<Scalar>& pa = calibration_.accel.params;
    for (int k = 0; k < poses_.size(); ++k) up_[k] = accel_apply(pa, poses_[k].mean).normalized();
    GyroData<Scalar> data;
    data.segments = segments_;
    data.moves = moves_;
    data.move_count = move_count_;
    data.up = up_;
    data.pose_count = poses_.size();
    if (rate_time_ > Scalar(0)) data.bias_shift = -rate_sum_ / rate_time_;
    const Status s = gyro_.visit([&](auto& g) { return g.start(data, b0_); });
    if (s != Status::kRunning) {
      fail_gyro(s);
      calibration_.quality = quality();
      phase_ = Phase::kFailed;
    }
  }

  // After a usable gyro solve: the accelerometer's covariance (while its solver's memory is still
  // there) and the start of the pass that widens the gyro's sigma by it (GyroInputUncertainty).
  // False, and the gyro failed with the reason, if that covariance cannot be had.
  bool start_input_uncertainty() {
    Eigen::Matrix<Scalar, kAccelParams, kAccelParams> cov_a;
    const Status s = solve_memory_.accel().covariance(cov_a);
    if (s != Status::kOk) {
      fail_gyro(s);
      return false;
    }
    GyroInputUncertainty<Scalar>& u = solve_memory_.make_input_uncertainty();
    gyro_.visit([&](const auto& g) { u.start(g, cov_a); });
    stage_ = SolveStage::kGyroSigma;
    return true;
  }

  // The gyro's result refused for `why` (nothing of it is kept).
  void fail_gyro(Status why) {
    calibration_.gyro = GyroCalibration<Scalar>{};
    calibration_.gyro.status = why;
    calibration_.gyro.moves = move_count_;
  }

  Status fail_accel() {
    solve_memory_.accel().finish(calibration_.accel);
    calibration_.quality = Quality::kNone;
    phase_ = Phase::kFailed;
    return calibration_.accel.status;
  }

  // The sigma of the rests' mean rate as the bias: white noise over the rests' total length, or
  // the scatter of the rests' means (bias instability, a hand-held rest's slow turn) if larger.
  Vector3<Scalar> rest_bias_sigma() const {
    if (!(rate_time_ > Scalar(0))) return b0_sigma_;
    Vector3<Scalar> var = gv0_ * (period_ / rate_time_);
    if (rate_rests_ >= 2) {
      const Vector3<Scalar> mean = rate_sum_ / rate_time_;
      const Vector3<Scalar> scatter =
          (rate_sq_ / rate_time_ - mean.cwiseProduct(mean)).cwiseMax(Scalar(0)) /
          static_cast<Scalar>(rate_rests_ - 1);
      var = var.cwiseMax(scatter);
    }
    return var.cwiseSqrt();
  }

  Status calibration_status() const {
    if (!succeeded(calibration_.accel.status)) return calibration_.accel.status;
    if (!settings_.has_gyro) return calibration_.accel.status;
    return calibration_.gyro.status;
  }

  // Good: both calibrated, all six faces, pose residuals within 3x what the noise explains, every
  // sigma within a quarter of its bound. Fair: both calibrated. Poor: the accelerometer only.
  // Without a gyro (has_gyro false) the accelerometer's part of the same rule decides.
  // The quality and, in *why (static text), the check that set it.
  Quality quality(const char** why = nullptr) const {
    const char* unused = nullptr;
    const char*& reason = why != nullptr ? *why : unused;
    reason = "the accelerometer was not calibrated";
    if (!succeeded(calibration_.accel.status)) return Quality::kNone;
    reason = "the gyroscope was not calibrated";
    if (settings_.has_gyro && !succeeded(calibration_.gyro.status)) return Quality::kPoor;
    reason = "not every face was up in a pose";
    if (faces() != 0x3f) return Quality::kFair;
    // A parameter held at 0 or barely determined (named in the calibration, with the hint).
    reason = "an accelerometer parameter is held at 0 or weak";
    if (calibration_.accel.held != 0 || calibration_.accel.weak != 0) return Quality::kFair;
    // Noise of a pose mean in m/s^2: the per-sample noise (initial rest) over sqrt(samples).
    const AccelVector<Scalar>& p = calibration_.accel.params;
    const Vector3<Scalar> sd(std::sqrt(v0_(0)) * p(kScaleX), std::sqrt(v0_(1)) * p(kScaleY),
                             std::sqrt(v0_(2)) * p(kScaleZ));
    Scalar mean_n = Scalar(0);
    for (int k = 0; k < poses_.size(); ++k) mean_n += static_cast<Scalar>(poses_[k].samples);
    mean_n /= static_cast<Scalar>(poses_.size());
    const Scalar expected = sd.norm() / std::sqrt(Scalar(3) * mean_n);
    reason =
        "the pose residual is over 3 times the noise of a pose mean (drift between poses, or "
        "rests that were not still)";
    if (calibration_.accel.residual_rms > Scalar(3) * expected) return Quality::kFair;
    reason = "every check passed";
    if (!settings_.has_gyro) return Quality::kGood;
    const GyroCalibration<Scalar>& g = calibration_.gyro;
    const Scalar quarter = settings_.gyro.max_normalised_sigma / Scalar(4);
    reason = "a gyroscope misalignment or scale has a sigma over a quarter of its bound";
    for (int k = 0; k < kGyroMatrixParams; ++k)
      if (!(gyro_normalised_sigma<Scalar>(g.params, g.sigma, k) <= quarter)) return Quality::kFair;
    reason = "every check passed";
    return Quality::kGood;
  }

  // ---- Coverage ------------------------------------------------------------------------------

  std::uint8_t faces() const {
    const int n = poses_.size();
    if (n == 0) return 0;
    Vector3<Scalar> zero = settings_.accel_zero_hint;
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

  Hint hint(const Progress& p) const {
    switch (phase_) {
      case Phase::kInitialRest:
        return frozen_ ? Hint::kCheckSensor : Hint::kHoldStill;
      case Phase::kSolving:
      case Phase::kDone:
      case Phase::kFailed:
        return Hint::kNone;
      case Phase::kReady:
        return Hint::kSolve;
      case Phase::kCollecting:
        break;
    }
    if (frozen_) return Hint::kCheckSensor;
    if (last_rest_short_) return Hint::kHoldLonger;
    if (p.faces_covered < 6) return Hint::kTurnToFace;
    if (settings_.has_gyro && p.axes_turned != 0x7) return Hint::kTurnAboutAxis;
    return Hint::kTurnToFace;  // all faces seen: more poses, anywhere new
  }

  CalibratorSettings<Scalar> settings_;
  bool settings_ok_ = false;
  Phase phase_ = Phase::kInitialRest;
  SolveStage stage_ = SolveStage::kAccel;
  Status last_event_ = Status::kOk;

  // Stream state.
  bool have_prev_ = false;      // t_prev_ holds a time to order against
  bool restart_stream_ = true;  // the next sample taken starts the stream (no interval)
  int back_run_ = 0;            // consecutive samples behind the clock
  std::uint32_t t_back_ = 0;    // the latest of them
  std::uint32_t rate_us_ = 0;   // the open one-second rate window: its span
  std::uint32_t rate_n_ = 0;    // and its samples
  StreamCounts counts_{};
  Scalar temp_ref_ = Scalar(0), temp_sum_ = Scalar(0), temp_comp_ = Scalar(0);
  RestSummary<Scalar> last_rest_{};
  std::uint32_t temp_n_ = 0;
  std::uint32_t t_prev_ = 0;
  Vector3<Scalar> acc_prev_ = Vector3<Scalar>::Zero(), gyro_prev_ = Vector3<Scalar>::Zero();
  // The full-scale limits as balls (inside_ball(): the centre's coordinate on every axis).
  Scalar acc_centre_ = Scalar(0), gyro_centre_ = Scalar(0);
  Scalar acc_radius2_ = Scalar(-1), gyro_radius2_ = Scalar(-1);
  Scalar frozen_time_ = Scalar(0);
  bool frozen_ = false;
  InitialRest init_{};

  // What the initial rest set.
  Vector3<Scalar> a_ref_ = Vector3<Scalar>::Zero();  // acceleration sums are relative to this
  Vector3<Scalar> g_ref_ = Vector3<Scalar>::Zero();
  Vector3<Scalar> b0_ = Vector3<Scalar>::Zero();  // gyro bias, added
  Vector3<Scalar> b0_sigma_ = Vector3<Scalar>::Zero();
  Vector3<Scalar> v0_ = Vector3<Scalar>::Zero();   // accelerometer variance per axis
  Vector3<Scalar> gv0_ = Vector3<Scalar>::Zero();  // gyro variance per axis
  Scalar period_ = Scalar(0);                      // mean sample period

  // Detector.
  StillnessDetector<Scalar> detector_{};
  bool last_still_ = true;
  Vector3<Scalar> u_prev_ = Vector3<Scalar>::Zero();  // previous bias-corrected rate

  // Blocks, delay line, the open rest.
  Block block_{};
  Block delay_[static_cast<std::size_t>(DelayBlocks)] = {};
  int delay_head_ = 0, delay_count_ = 0;
  Block rest_{};
  bool rest_open_ = false;
  bool last_rest_short_ = false;
  bool pose_store_full_reported_ = false;  // to be returned by the next add()
  bool capacity_reported_ = false;         // once per run

  // Stores.
  PoseStore<Scalar, MaxPoses> poses_{};
  std::uint32_t pose_time_[static_cast<std::size_t>(MaxPoses)][2] = {};
  GyroMove moves_[static_cast<std::size_t>(MaxPoses)] = {};
  int move_count_ = 0;
  GyroSegment<Scalar> segments_[static_cast<std::size_t>(MaxSegments)] = {};
  int seg_count_ = 0;
  int chain_from_ = -1;  // pose the move in progress starts from (-1: none)
  int move_first_ = 0;   // its first segment
  bool last_mergeable_ = false;
  bool tail_only_ = false;  // the move in progress holds only its pose's rest half so far
  Scalar last_path_ = Scalar(0);
  // The poses' mean rates (add_rest_rate): duration-weighted sums.
  Vector3<Scalar> rate_sum_ = Vector3<Scalar>::Zero(), rate_sq_ = Vector3<Scalar>::Zero();
  Scalar rate_time_ = Scalar(0);
  int rate_rests_ = 0;
  Scalar seg_angle_ = Scalar(0), seg_error_ = Scalar(0), seg_error2_ = Scalar(0);  // raw units
  Scalar seg_error_path_ = Scalar(0);  // set_segment_error()
  std::uint32_t block_us_ = 0, trim_us_ = 0, gap_us_ = 0;
  Vector3<Scalar> rotation_ = Vector3<Scalar>::Zero();  // |alpha| per axis over the moves

  // Counters.
  int rests_too_short_ = 0, moves_dropped_ = 0, coarsenings_ = 0;
  std::uint32_t samples_refused_ = 0;

  // Solving.
  Vector3<Scalar> up_[static_cast<std::size_t>(MaxPoses)] = {};
  // The accelerometer's solver, then (once its result and covariance are out) the pass that
  // carries them into the gyro's sigma: one memory, as the two never run together.
  static_assert(std::is_trivially_destructible<AccelSolver<Scalar>>::value &&
                    std::is_trivially_destructible<GyroInputUncertainty<Scalar>>::value,
                "the solve memory is rebuilt in place without a destructor call");
  class SolveMemory {
   public:
    SolveMemory() { new (&u_.accel) AccelSolver<Scalar>(); }
    SolveMemory(const SolveMemory& o) { copy_from(o); }
    SolveMemory& operator=(const SolveMemory& o) {
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
    void copy_from(const SolveMemory& o) {
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
  } solve_memory_;
  // The gyro solver that settings.gyro.refine_bias picks. Only one is ever used per run, so they
  // share memory (920 B saved); built in place, copied as the one that is there.
  using Gyro9 = GyroSolver<Scalar, kGyroMatrixParams>;
  using Gyro12 = GyroSolver<Scalar, kGyroParams>;
  static_assert(std::is_trivially_destructible<Gyro9>::value &&
                    std::is_trivially_destructible<Gyro12>::value,
                "the gyro solvers are rebuilt in place without a destructor call");
  class GyroSolvers {
   public:
    GyroSolvers() { new (&u_.nine) Gyro9(GyroSettings<Scalar>{}); }
    GyroSolvers(const GyroSolvers& o) { copy_from(o); }
    GyroSolvers& operator=(const GyroSolvers& o) {
      if (this != &o) copy_from(o);
      return *this;
    }
    void make(const GyroSettings<Scalar>& s) {
      twelve_ = s.refine_bias;
      if (twelve_)
        new (&u_.twelve) Gyro12(s);
      else
        new (&u_.nine) Gyro9(s);
    }
    Gyro9& nine() { return u_.nine; }
    Gyro12& twelve() { return u_.twelve; }
    // f(the solver that is there).
    template <class F>
    decltype(auto) visit(const F& f) {
      return twelve_ ? f(u_.twelve) : f(u_.nine);
    }

   private:
    void copy_from(const GyroSolvers& o) {
      twelve_ = o.twelve_;
      if (twelve_)
        new (&u_.twelve) Gyro12(o.u_.twelve);
      else
        new (&u_.nine) Gyro9(o.u_.nine);
    }
    union U {
      U() {}
      Gyro9 nine;
      Gyro12 twelve;
    } u_;
    bool twelve_ = false;
  } gyro_;
  Calibration<Scalar> calibration_{};
};

}  // namespace imucal
