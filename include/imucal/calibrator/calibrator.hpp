// imucal/calibrator/calibrator.hpp: the streaming calibrator. The firmware hands it every raw
// sample (timestamp, accelerometer, gyroscope) and follows the progress it reports; at the end it
// solves, in bounded slices, for the accelerometer and the gyroscope calibration. No raw sample
// is stored: rests become pose means, moves become second-order segment statistics
// (math.md sections 4 and 5), all in fixed stores sized at compile time.
//
// This file routes the stream; each job is a part of its own, in imucal/calibrator/:
//   settings.hpp         the sample, the settings, the progress report
//   stream_checks.hpp    full scale, clock resets, sample rate, the temperature's mean
//   initial_rest.hpp     the first still period: gyro bias, noise, sample period
//   stillness.hpp        (in imucal/) still or moving, sample by sample
//   blocks.hpp           runs of samples, the delay line that trims rests, a rest as a pose
//   move_store.hpp       the moves between poses as gyro segments, coarsened when full
//   pose_collection.hpp  the poses, coverage and hints, the bias from the rests' rates
//   solve_sequence.hpp   accelerometer, gyro, the gyro's sigma; the quality verdict
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
//   4. Moves: every non-pose block's gyro statistics go to the move store (move_store.hpp),
//      merged with the previous segment while the merged one stays a small, nearly single-axis
//      rotation (segment_max_angle, segment_max_error), coarsened when the store is full.
//
// Full pose store: new rests are not stored (kCapacityExceeded is reported once, the phase is
// ready, the hint says solve). Poses are chained by the moves between them, so replacing a pose
// would break two gyro residuals; the capacity is sized for the protocol instead (Tedaldi uses
// 36-50 poses), and the coverage report tells the user which faces are still missing.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <limits>

#include "imucal/calibrator/move_store.hpp"
#include "imucal/calibrator/pose_collection.hpp"
#include "imucal/calibrator/settings.hpp"
#include "imucal/calibrator/solve_sequence.hpp"
#include "imucal/models/calibration.hpp"
#include "imucal/models/temperature_model.hpp"
#include "imucal/status.hpp"
#include "imucal/stream/blocks.hpp"
#include "imucal/stream/checks.hpp"
#include "imucal/stream/initial_rest.hpp"
#include "imucal/stream/stillness.hpp"

namespace imucal {

// The defaults fit Tedaldi's protocol (the xsens recording: 41 poses, one partial coarsening of
// the segment store in the motion after its last rest) in 32,752 bytes of float
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
      : settings_(settings), solver_(settings.accel, settings.gyro) {
    reset();
  }

  // Starts again with new settings, in place (assigning a new Calibrator would build a 32 KB
  // temporary on the stack).
  void reset(const CalibratorSettings<Scalar>& settings) {
    settings_ = settings;
    solver_.configure(settings.accel, settings.gyro);
    reset();
  }

  // Forgets everything collected and starts again with the initial rest.
  void reset() {
    phase_ = Phase::kInitialRest;
    last_event_ = Status::kOk;
    have_prev_ = false;
    restart_stream_ = true;
    clock_.reset();
    rate_.restart();
    counts_ = StreamCounts{};
    temperature_.reset();
    last_rest_ = RestSummary<Scalar>{};
    frozen_time_ = Scalar(0);
    frozen_ = false;
    poses_.clear();
    rest_open_ = false;
    block_ = Block{};
    delay_.clear();
    rests_too_short_ = 0;
    samples_refused_ = 0;
    last_rest_short_ = false;
    pose_store_full_reported_ = false;
    capacity_reported_ = false;
    last_still_ = true;
    u_prev_.setZero();
    calibration_ = Calibration<Scalar>{};
    restart_initial_rest();
    const Scalar scale =
        settings_.gyro.nominal_scale > Scalar(0) ? settings_.gyro.nominal_scale : Scalar(1);
    moves_.reset(settings_.segment_max_angle / scale,
                 settings_.segment_max_error / (scale * scale * scale));
    block_us_ = static_cast<std::uint32_t>(settings_.block_seconds * Scalar(1e6));
    trim_us_ = static_cast<std::uint32_t>(settings_.trim_seconds * Scalar(1e6));
    acc_scale_.set(settings_.accel_min, settings_.accel_max);
    gyro_scale_.set(settings_.gyro_min, settings_.gyro_max);
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
    p.moves = moves_.move_count();
    p.segments = moves_.segment_count();
    p.rests_too_short = rests_too_short_;
    p.moves_dropped = moves_.moves_dropped();
    p.coarsenings = moves_.coarsenings();
    p.samples_refused = samples_refused_;
    p.stream = counts_;
    set_coverage(p, faces(), moves_.rotation());
    p.hint = coverage_hint(p, frozen_, last_rest_short_, settings_.has_gyro);
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
    if (solver_.start(settings_.accel, poses_.span(), calibration_) != Status::kRunning)
      return end_solve();
    return Status::kRunning;
  }

  // One bounded slice of the solve: one accelerometer LM iteration, or at most
  // gyro.segments_per_step segments of the gyro run.
  Status solve_step() {
    if (phase_ != Phase::kSolving)
      return phase_ == Phase::kDone     ? Status::kOk
             : phase_ == Phase::kFailed ? calibration_status()
                                        : Status::kNotStarted;
    const Status s = solver_.step(solve_inputs(), settings_.gyro, calibration_);
    return s == Status::kRunning ? s : end_solve();
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
  bool solving_gyro() const { return phase_ == Phase::kSolving && solver_.in_gyro(); }

  const Calibration<Scalar>& calibration() const { return calibration_; }
  PoseSpan<Scalar> poses() const { return poses_.span(); }
  // Time span of pose i: first and last sample's timestamps.
  std::uint32_t pose_begin_us(int i) const { return poses_.begin_us(i); }
  std::uint32_t pose_end_us(int i) const { return poses_.end_us(i); }
  int move_count() const { return moves_.move_count(); }
  const GyroMove& move(int i) const { return moves_.move(i); }
  int segment_count() const { return moves_.segment_count(); }
  const GyroSegment<Scalar>& segment(int i) const { return moves_.segment(i); }
  // The initial-rest gyro bias (added, sensor units) and the per-axis noise variances.
  const Vector3<Scalar>& gyro_bias0() const { return b0_; }
  const Vector3<Scalar>& accel_noise_variance() const { return v0_; }
  // The gyro's per-axis noise variance over the initial rest (sensor units^2).
  Vector3<Scalar> gyro_noise_variance() const { return gv0_; }
  Scalar mean_period() const { return period_; }
  // The mean temperature of the samples taken so far; false if none carried one.
  bool mean_temperature(Scalar& out) const { return temperature_.mean(out); }
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
  using Block = SampleBlock<Scalar>;

  // add() of a sample whose gyro reading is to be used.
  Status take(const ImuSample<Scalar>& in) {
    // A copy the compiler knows no store to the calibrator changes: each reading is loaded
    // once, not again after every store (the caller's sample could alias this object).
    const ImuSample<Scalar> s = in;
    if (phase_ == Phase::kSolving || phase_ == Phase::kDone || phase_ == Phase::kFailed) {
      ++counts_.busy;
      return refuse(Status::kBusy);
    }
    // Every reading finite and inside its full scale: one test per sensor on the usual path
    // (inside a ball within the box of the limits; NaN fails it), exact tests only outside it.
    bool gyro_saturated = false, acc_saturated = false;
    if (!(acc_scale_.in_ball(s.acc) && gyro_scale_.in_ball(s.gyro))) {
      // x - x is 0 for a finite x and NaN otherwise.
      const Scalar nan_if_any = (s.acc - s.acc).sum() + (s.gyro - s.gyro).sum();
      if (!(nan_if_any == Scalar(0))) {
        ++counts_.non_finite;
        return refuse(Status::kNonFiniteInput);
      }
      gyro_saturated = gyro_scale_.outside(s.gyro);
      acc_saturated = acc_scale_.outside(s.acc);
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
        result = behind_clock(s.t_us);
        if (result != Status::kClockReset) return result;
      }
    }
    clock_.in_order();
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
    if (gyro_saturated) return gyro_at_full_scale(in);
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
      rate_.restart();
    }
    Scalar temperature = s.temperature;
    if (temperature == temperature) {  // NaN: no temperature sensor
      if (temperature >= settings_.temperature_min_c &&
          temperature <= settings_.temperature_max_c) {
        temperature_.add(temperature);
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
    if (settings_.nominal_rate_hz > Scalar(0) &&
        rate_.off(static_cast<std::uint32_t>(step), settings_.nominal_rate_hz,
                  settings_.rate_tolerance)) {
      ++counts_.rate_off;
      last_event_ = Status::kSampleRateOff;
      if (result == Status::kOk) result = Status::kSampleRateOff;
    }
    if (phase_ == Phase::kInitialRest) {
      remember(s);
      // A saturated accelerometer cannot be at rest: the initial rest starts again.
      if (acc_saturated) {
        restart_initial_rest();
        return result;
      }
      return initial_rest_sample(in, dt, result);
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

  // A timestamp behind the clock: refused (kTimeBackwards), or the clock was reset (kClockReset:
  // the sample starts the stream again, as after a gap). Out of line, as every rare path of take().
  __attribute__((noinline)) Status behind_clock(std::uint32_t t_us) {
    if (!clock_.went_back(t_us, gap_us_, settings_.clock_reset_samples)) {
      ++counts_.time_backwards;
      return refuse(Status::kTimeBackwards);
    }
    ++counts_.clock_resets;
    on_gap();
    restart_stream_ = true;
    return last_event_ = Status::kClockReset;
  }

  // A gyro at full scale: the rotation over this interval is unknown, nothing can be integrated
  // across it. Refused; it is the sample the next is ordered against.
  __attribute__((noinline)) Status gyro_at_full_scale(const ImuSample<Scalar>& s) {
    remember(s);
    ++counts_.gyro_saturated;
    if (!restart_stream_) on_gap();
    restart_stream_ = true;
    last_event_ = Status::kSaturated;
    return refuse(Status::kSaturated);
  }

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

  // The largest step that is not a gap, in microseconds.
  void update_gap_limit() {
    Scalar limit = settings_.max_step_seconds;
    if (phase_ != Phase::kInitialRest && period_ > Scalar(0) &&
        settings_.gap_factor * period_ < limit)
      limit = settings_.gap_factor * period_;
    gap_us_ = static_cast<std::uint32_t>(limit * Scalar(1e6));
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

  // ---- Initial rest (initial_rest.hpp) -------------------------------------------------------

  void restart_initial_rest() {
    phase_ = Phase::kInitialRest;
    init_.restart();
    update_gap_limit();
  }

  // A sample into the window; once it is still, the collection starts from it. `result`: the
  // sample's status so far, returned unless the window was found disturbed or frozen. Out of
  // line: inlined, its registers would cost add() instructions on every later sample.
  __attribute__((noinline)) Status initial_rest_sample(const ImuSample<Scalar>& s, Scalar dt,
                                                       Status result) {
    const Status r =
        init_.add(s.acc, s.gyro, s.t_us, dt, settings_.initial_rest_seconds, settings_.has_gyro);
    if (r == Status::kRunning) return result;
    if (r != Status::kOk) return last_event_ = r;
    start_collecting(init_.found());
    return result;
  }

  // The initial rest's statistics set the bias, the noise, the period and the detector; the
  // rest goes on as the first rest, to become pose 0 when the first move starts.
  void start_collecting(const typename InitialRestWindow<Scalar>::Found& f) {
    const Scalar n = f.samples;
    a_ref_ = f.acc_ref;
    v0_ = f.acc_variance;
    gv0_ = settings_.has_gyro ? f.gyro_variance : Vector3<Scalar>::Zero();
    b0_ = settings_.has_gyro ? Vector3<Scalar>(-f.gyro_mean) : Vector3<Scalar>::Zero();
    b0_sigma_ = (gv0_ / n).cwiseSqrt();  // of the mean rate
    u_prev_.setZero();                   // the rate at the rest's end, bias removed
    period_ = f.period;
    // The detector starts from the rest's own statistics.
    detector_.start(settings_.stillness, Vector3<Scalar>(f.acc_sum / n), v0_, gv0_.sum());
    detector_.set_glitch_limit(settings_.glitch_sigma * settings_.glitch_sigma * v0_.maxCoeff());
    rest_ = Block{};
    rest_.acc_ref = a_ref_;
    rest_.acc_sum = f.acc_sum;
    rest_.long_enough = false;  // decided by its length, as every rest
    rest_.n = static_cast<std::uint32_t>(n);
    rest_.accel_cue = n * v0_.sum();
    rest_.energy_cue = n * gv0_.sum();
    // The temperatures so far (those before the window too: close enough for a mean).
    rest_.temp_sum = temperature_.sum();
    rest_.temp_n = temperature_.count();
    rest_.t_begin = f.t_begin;
    rest_.t_end = f.t_end;
    rest_open_ = true;
    block_ = Block{};
    phase_ = Phase::kCollecting;
    init_.restart();
    update_gap_limit();
  }

  // ---- Collection ----------------------------------------------------------------------------

  // The per-sample path, written per axis with the thresholds precomputed (bench_stream counts
  // its instructions): the detector, then the sample folded into the current block. False: a
  // glitch (nothing changed).
  __attribute__((always_inline)) bool collect_sample(const ImuSample<Scalar>& s, Scalar temperature,
                                                     Scalar dt, bool moving) {
    // The rate over the interval is the mean of its two end samples (trapezoid, as the RK4
    // reference interpolates linearly between samples): holding the newer sample instead
    // differs by ~1e-4 rad per move on the xsens recording, 0.16 sigma of the gyro scale. (A
    // first sample has dt = 0: whatever u_prev_ holds then adds nothing.)
    const Vector3<Scalar> u = s.gyro + b0_;
    const Stillness step = detector_.update(s.acc - a_ref_, u, dt, moving);
    if (step == Stillness::kGlitch) return false;
    const bool still = step == Stillness::kStill;
    last_still_ = still;
    // Read before close_block() may run: after that call they would be loaded again.
    const Scalar accel_cue = detector_.sample_accel(), energy_cue = detector_.sample_energy();
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
    // path2 >= 0: the absolute value only tells the compiler so (no errno branch around the
    // square root, two instructions fewer on an Arm FPU; the value is the same).
    const Scalar step_path = std::sqrt(std::abs(path2)) * dt;
    if (block_.n > 0 && (still != block_.still || block_.path + step_path > moves_.max_angle()))
      close_block();
    if (block_.n == 0) {
      block_.still = still;
      block_.t_begin = s.t_us;
      block_.acc_ref = s.acc;
    }
    block_.seg.add(u_mid, dt);
    block_.acc_sum += s.acc - block_.acc_ref;
    block_.path += step_path;
    block_.accel_cue += accel_cue;
    block_.energy_cue += energy_cue;
    if (temperature == temperature) {
      block_.temp_sum += temperature - temperature_.ref();
      ++block_.temp_n;
    }
    ++block_.n;
    block_.t_end = s.t_us;
    if (s.t_us - block_.t_begin >= block_us_ ||
        (block_.path > moves_.error_free_path() &&
         block_.seg.alpha.squaredNorm() * block_.seg.beta.squaredNorm() > moves_.max_error2()))
      close_block();
    return true;
  }

  // Routes the current block (by reference into the ring: no copies on the per-sample path).
  // Out of line: once per block, and inlined its registers would cost every sample.
  __attribute__((noinline)) void close_block() {
    if (block_.n == 0) return;
    if (block_.still) {
      delay_.add(block_);
      block_.clear();
      // A still block is part of the rest once trim_seconds of stillness follow it.
      while (!delay_.empty() && delay_.span_after_oldest() >= trim_us_) {
        rest_add(delay_.oldest());
        delay_.drop_oldest();
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
    delay_.drain([this](const Block& d) { to_move(d); });
    to_move(b);  // an empty block adds nothing
  }

  // A block's rotation into the move in progress.
  void to_move(const Block& b) {
    if (b.n == 0 || !settings_.has_gyro) return;  // nothing to integrate
    moves_.add(b.seg, b.path);
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
    if (with_delay_line && !delay_.empty()) end = delay_.newest().t_end;
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
      to_move(rest_);
      return;
    }
    last_rest_short_ = false;
    if (poses_.full()) {
      // Not stored (see the top of this file); the chain cannot continue past it.
      if (!capacity_reported_) pose_store_full_reported_ = capacity_reported_ = true;
      last_event_ = Status::kCapacityExceeded;
      moves_.drop();
      return;
    }
    if (poses_.add(rest_.acc_mean(), rest_.n, rest_.noise_variance(settings_.stillness.seconds),
                   rest_.t_begin, rest_.t_end) != Status::kOk) {
      moves_.drop();
      return;
    }
    const int index = poses_.size() - 1;
    last_rest_ = rest_.summary(b0_, temperature_.ref());
    const Scalar inv_n = Scalar(1) / static_cast<Scalar>(rest_.n);
    detector_.learn_rest(rest_.accel_cue * inv_n, rest_.energy_cue * inv_n);
    // The rest's own rotation: held in the hand (its gyro energy well above the quietest rest's),
    // a board turns a little, and the pose's gravity direction, a mean over the rest, stands for
    // its time centroid: the move into the pose ends there and the move out of it starts there.
    // On a table a rest does not turn, and integrating through it would only add the bias's
    // drift (on the Xsens recording: 1.08 instead of 0.44 deg per move).
    GyroSegment<Scalar> head{}, tail{};
    const bool shaky = rest_.energy_cue * inv_n > Scalar(4) * detector_.first_rest_energy();
    const bool halves = settings_.has_gyro && shaky && split_rest_rotation(rest_.seg, head, tail);
    if (settings_.has_gyro) poses_.add_rest_rate(last_rest_.gyro_mean + b0_, last_rest_.duration_s);
    moves_.arrive(index, halves ? &head : nullptr, halves ? &tail : nullptr);
    if (phase_ == Phase::kCollecting && poses_.size() >= settings_.target_poses && faces() == 0x3f)
      phase_ = Phase::kReady;
    if (poses_.full()) phase_ = Phase::kReady;
  }

  // A gap: the rest before it still counts (trimmed as before motion); the move across it is
  // dropped.
  void on_gap() {
    if (phase_ == Phase::kInitialRest) {
      restart_initial_rest();
      return;
    }
    flush_blocks_as_motion();
    moves_.drop();
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
    delay_.clear();
    rest_open_ = false;
    moves_.drop();
  }

  // The stream is cut (gap): the current block and the delay line are treated as if motion
  // followed, so the rest before the cut is trimmed like any other.
  void flush_blocks_as_motion() {
    if (block_.still && block_.n > 0) {
      delay_.add(block_);
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
        delay_.add(block_);
      else
        motion_after(block_);
      block_.clear();
    }
    if (!delay_.empty() || rest_open_) {
      delay_.drain([this](const Block& d) { rest_add(d); });
      end_rest(false);
    } else if (moves_.in_move()) {
      last_event_ = Status::kEndedInMotion;
    }
    moves_.drop();  // whatever is still open after the last pose
  }

  // ---- Solving (solve_sequence.hpp) ----------------------------------------------------------

  SolveInputs<Scalar> solve_inputs() const {
    SolveInputs<Scalar> in;
    in.poses = poses_.span();
    in.segments = moves_.segments();
    in.moves = moves_.moves();
    in.move_count = moves_.move_count();
    in.has_gyro = settings_.has_gyro;
    in.gyro_bias0 = b0_;
    Vector3<Scalar> rest_rate;
    if (poses_.mean_rest_rate(rest_rate)) in.bias_shift = -rest_rate;
    in.bias_sigma = poses_.rest_rate_sigma(gv0_, period_, b0_sigma_);
    return in;
  }

  // The solve has ended: the quality, and the phase by the status of each part.
  Status end_solve() {
    if (!succeeded(calibration_.accel.status)) {
      calibration_.quality = Quality::kNone;
      phase_ = Phase::kFailed;
    } else {
      calibration_.quality = quality();
      phase_ = !settings_.has_gyro || succeeded(calibration_.gyro.status) ? Phase::kDone
                                                                          : Phase::kFailed;
    }
    return calibration_status();
  }

  Status calibration_status() const {
    if (!succeeded(calibration_.accel.status)) return calibration_.accel.status;
    if (!settings_.has_gyro) return calibration_.accel.status;
    return calibration_.gyro.status;
  }

  Quality quality(const char** why = nullptr) const {
    return judge_quality(calibration_, settings_.has_gyro, faces(), v0_, poses_.span(),
                         settings_.gyro.max_normalised_sigma, why);
  }

  std::uint8_t faces() const { return poses_.faces(settings_.accel_zero_hint); }

  CalibratorSettings<Scalar> settings_;
  bool settings_ok_ = false;
  Phase phase_ = Phase::kInitialRest;
  Status last_event_ = Status::kOk;

  // Stream state.
  bool have_prev_ = false;      // t_prev_ holds a time to order against
  bool restart_stream_ = true;  // the next sample taken starts the stream (no interval)
  ClockResetWatch clock_{};
  RateWatch rate_{};
  StreamCounts counts_{};
  TemperatureMean<Scalar> temperature_{};
  std::uint32_t t_prev_ = 0;
  Vector3<Scalar> acc_prev_ = Vector3<Scalar>::Zero(), gyro_prev_ = Vector3<Scalar>::Zero();
  FullScale<Scalar> acc_scale_{}, gyro_scale_{};
  Scalar frozen_time_ = Scalar(0);
  bool frozen_ = false;

  // What the initial rest set.
  Vector3<Scalar> a_ref_ = Vector3<Scalar>::Zero();  // acceleration sums are relative to this
  Vector3<Scalar> b0_ = Vector3<Scalar>::Zero();     // gyro bias, added
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
  DelayLine<Scalar, DelayBlocks> delay_{};
  Block rest_{};
  bool rest_open_ = false;
  bool last_rest_short_ = false;
  bool pose_store_full_reported_ = false;  // to be returned by the next add()
  bool capacity_reported_ = false;         // once per run
  std::uint32_t block_us_ = 0, trim_us_ = 0, gap_us_ = 0;
  // Past the per-sample path's members (single-instruction offsets from `this` on Arm): used
  // before the first rest and once a pose.
  InitialRestWindow<Scalar> init_{};
  RestSummary<Scalar> last_rest_{};

  // Stores.
  MoveStore<Scalar, MaxPoses, MaxSegments> moves_{};
  PoseCollection<Scalar, MaxPoses> poses_{};

  // Counters.
  int rests_too_short_ = 0;
  std::uint32_t samples_refused_ = 0;

  // Solving.
  SolveSequence<Scalar, MaxPoses> solver_{};
  Calibration<Scalar> calibration_{};
};

}  // namespace imucal
