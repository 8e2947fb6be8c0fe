// SPDX-License-Identifier: MIT
// imucal/calibrator/calibrator.hpp: the streaming calibrator. The firmware hands it every raw
// sample (timestamp, accelerometer, gyroscope) and follows the progress it reports; at the end it
// solves, in bounded slices, for the accelerometer and the gyroscope calibration. No raw sample
// is stored: rests become pose means, moves become second-order segment statistics
// (math.md sections 4 and 5), all in fixed stores sized at compile time.
//
// This file routes the stream; each job is a part of its own. From the stream layer
// (imucal/stream/), shared with the rest monitor:
//   checks.hpp           the front end: every sample's status (timestamps, gaps, clock resets,
//                        frozen, full scale, rate, temperature)
//   initial_rest.hpp     the first still period: gyro bias, noise, sample period
//   segmenter.hpp        still or moving (stillness.hpp), blocks, the delay line that trims
//                        rests, rests and moves
// and its own, in imucal/calibrator/:
//   settings.hpp         the settings, the progress report
//   move_store.hpp       the moves between poses as gyro segments, coarsened when full
//   pose_collection.hpp  the poses, coverage and hints, the bias from the rests' rates
//   solve_sequence.hpp   accelerometer, gyro, the gyro's sigma; the quality verdict
//
// The stream, per sample: the front end's checks; until the initial rest is found, the initial
// rest window (the first still period of at least initial_rest_seconds: the gyro bias to start
// from, the noise levels that set the first stillness thresholds, the sample period; it goes on
// as pose 0 until the first motion); then the segmenter, whose rests become poses when long
// enough and whose moves go to the move store (merged segments, coarsened when full). Each
// part's header says how it decides.
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

#include "imucal/calibrator/pose_collection.hpp"
#include "imucal/calibrator/settings.hpp"
#include "imucal/calibrator/solve_sequence.hpp"
#include "imucal/models/calibration.hpp"
#include "imucal/solve/move_store.hpp"
#include "imucal/status.hpp"
#include "imucal/stream/blocks.hpp"
#include "imucal/stream/checks.hpp"
#include "imucal/stream/fifo.hpp"
#include "imucal/stream/initial_rest.hpp"
#include "imucal/stream/rest_summary.hpp"
#include "imucal/stream/segmenter.hpp"
#include "imucal/types.hpp"

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
    checks_.reset(settings_);
    segmenter_.reset(segmenter_settings());
    poses_.clear();
    rests_too_short_ = 0;
    last_rest_short_ = false;
    pose_store_full_reported_ = false;
    capacity_reported_ = false;
    last_rest_ = RestSummary<Scalar>{};
    calibration_ = Calibration<Scalar>{};
    restart_initial_rest();
    const Scalar scale =
        settings_.gyro.nominal_scale > Scalar(0) ? settings_.gyro.nominal_scale : Scalar(1);
    moves_.reset(settings_.segment_max_angle / scale,
                 settings_.segment_max_error / (scale * scale * scale));
    settings_ok_ = check_settings();
  }

  // One raw sample. kOk: taken. Refused (nothing collected is lost): kNonFiniteInput,
  // kTimeRepeated, kTimeBackwards, kSensorFrozen, kBusy, kGlitch, kInvalidArgument (settings),
  // and kGyroSaturated (the move in progress is dropped as across a gap). Taken with a note:
  // kAccelSaturated (the sample counts as motion), kTimestampGap, kClockReset, kSampleRateOff,
  // kTemperatureImplausible, kInitialRestDisturbed, kCapacityExceeded (pose store full). Every
  // case is counted in progress().stream.
  Status add(const ImuSample<Scalar>& sample) {
    if (!settings_ok_) return checks_.refuse(Status::kInvalidArgument);
    if (settings_.has_gyro) return take(sample);
    ImuSample<Scalar> s = sample;
    s.gyro.setZero();  // ignored, whatever it reads
    return take(s);
  }

  // One frame of 16-bit counts (a sensor's data registers), with the temperature if one was
  // read with it (NaN: none; one reading a second is enough, the rests' temperatures are means).
  // The same statuses as add(); after the initial rest its per-sample work is integer sums only.
  // A stream is frames or samples: one kind from the start (or a reset()).
  Status add_raw(const RawFrame& frame,
                 Scalar temperature = std::numeric_limits<Scalar>::quiet_NaN()) {
    if (!settings_ok_) return checks_.refuse(Status::kInvalidArgument);
    if (settings_.has_gyro) return take_raw(frame, temperature);
    RawFrame f = frame;
    f.gyro[0] = f.gyro[1] = f.gyro[2] = 0;  // ignored, whatever it reads
    return take_raw(f, temperature);
  }

  // A batch of frames as the sensor's FIFO delivers them (fifo.hpp: where the readings are in
  // each frame, when each was taken), and the temperature read with the batch (NaN: none).
  // Each frame gets the status add_raw() would give it: counted in the result, and written to
  // statuses[k] if given (count entries). An invalid layout or a null buffer refuses every frame
  // with kInvalidArgument.
  FifoResult add_fifo(const std::uint8_t* data, std::uint32_t count, const FifoLayout& layout,
                      const FifoTiming& timing,
                      Scalar temperature = std::numeric_limits<Scalar>::quiet_NaN(),
                      Status* statuses = nullptr) {
    return feed_fifo(
        data, count, layout, timing, temperature, statuses,
        [this](const RawFrame& f, Scalar t) { return add_raw(f, t); },
        [](Status s) {
          return sample_taken(s) || s == Status::kInitialRestDisturbed ||
                 s == Status::kCapacityExceeded;
        },
        [this] { return checks_.refuse(Status::kInvalidArgument); },
        [this] { return checks_.temperatures_read(); });
  }

  Progress progress() const {
    Progress p;
    p.phase = phase_;
    p.last_event = checks_.last_event();
    p.initial_rest_done = phase_ == Phase::kInitialRest
                              ? static_cast<float>(init_.elapsed() / settings_.initial_rest_seconds)
                              : 1.0f;
    p.poses = poses_.size();
    p.moves = moves_.move_count();
    p.segments = moves_.segment_count();
    p.rests_too_short = rests_too_short_;
    p.moves_dropped = moves_.moves_dropped();
    p.coarsenings = moves_.coarsenings();
    p.samples_refused = checks_.refused();
    p.stream = checks_.counts();
    set_coverage(p, faces(), moves_.rotation());
    p.hint = coverage_hint(p, checks_.frozen(), last_rest_short_, settings_.has_gyro);
    return p;
  }

  // The stream has ended (a recording's last sample): a rest still open becomes a pose if long
  // enough, a move in progress is dropped (it has no pose to end at). solve() does this itself;
  // call it to see every pose before solving, or when there are too few to solve. A sample added
  // afterwards starts the stream again as after a gap.
  void end_stream() {
    if (phase_ != Phase::kCollecting && phase_ != Phase::kReady) return;
    end_of_stream();
    checks_.restart();
  }

  // Ends the collection and starts the solve. kRunning: call solve_step() until it returns
  // something else. kTooFewPoses: nothing is changed, collection may go on.
  Status solve() {
    if (phase_ == Phase::kSolving) return Status::kRunning;
    if (phase_ == Phase::kDone || phase_ == Phase::kFailed) return calibration_status();
    if (phase_ == Phase::kInitialRest) return Status::kTooFewPoses;
    const bool pending_pose =
        segmenter_.rest_open() && segmenter_.rest_long_enough(true) && !poses_.full();
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
  bool still() const { return segmenter_.still(); }
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
  const Vector3<Scalar>& gyro_bias0() const { return segmenter_.gyro_bias(); }
  const Vector3<Scalar>& accel_noise_variance() const { return v0_; }
  // The gyro's per-axis noise variance over the initial rest (sensor units^2).
  Vector3<Scalar> gyro_noise_variance() const { return gv0_; }
  Scalar mean_period() const { return period_; }
  // The mean temperature of the samples taken so far; false if none carried one.
  bool mean_temperature(Scalar& out) const { return checks_.temperature().mean(out); }
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
  template <typename, int, int>
  friend class Segmenter;
  template <typename>
  friend class StreamChecks;

  // The segmenter: a sub-block (the detector's step, its float work) as long as a block, and as
  // many samples as the integer sums hold, so that the float work is done as seldom as the
  // trimming's granularity allows.
  using StreamSegmenter = Segmenter<Scalar, DelayBlocks, kMaxSubBlockSamples>;
  SegmenterSettings<Scalar> segmenter_settings() const {
    SegmenterSettings<Scalar> s;
    s.block_seconds = settings_.block_seconds;
    s.sub_block_seconds = settings_.block_seconds;
    s.trim_seconds = settings_.trim_seconds;
    s.min_rest_seconds = settings_.min_rest_seconds;
    return s;
  }

  // add() of a sample whose gyro reading is to be used.
  Status take(const ImuSample<Scalar>& in) {
    // A copy the compiler knows no store to the calibrator changes: each reading is loaded
    // once, not again after every store (the caller's sample could alias this object).
    const ImuSample<Scalar> s = in;
    if (phase_ == Phase::kSolving || phase_ == Phase::kDone || phase_ == Phase::kFailed)
      return checks_.refuse_busy();
    CheckedSample<Scalar> c;
    Status result = checks_.check(s, *this, c);
    if (result != Status::kOk && !sample_taken(result)) return result;
    if (phase_ == Phase::kInitialRest) {
      // A reading far outside the window's noise: refused as after the initial rest (the
      // previous sample stays the reference).
      if (!c.acc_saturated && init_.glitch(s.acc, settings_.glitch_sigma))
        return checks_.refuse_glitch(c, s.t_us);
      checks_.accept(s);
      // A saturated accelerometer cannot be at rest: the initial rest starts again.
      if (c.acc_saturated) {
        restart_initial_rest();
        return result;
      }
      return initial_rest_sample(in, c.dt(), result);
    }
    if (!segmenter_.add(s, c, *this)) {
      // Not taken: a reading this far off is no acceleration a hand makes. The previous
      // sample stays the reference, so the interval spans the refused one.
      return checks_.refuse_glitch(c, s.t_us);
    }
    checks_.accept(s);
    if (pose_store_full_reported_ && result == Status::kOk) {
      pose_store_full_reported_ = false;
      return Status::kCapacityExceeded;
    }
    return result;
  }

  // add_raw() of a frame whose gyro reading is to be used.
  Status take_raw(const RawFrame& f, Scalar temperature) {
    if (phase_ == Phase::kSolving || phase_ == Phase::kDone || phase_ == Phase::kFailed)
      return checks_.refuse_busy();
    CheckedSample<Scalar> c;
    Status result = checks_.check(f, temperature, *this, c);
    if (result != Status::kOk && !sample_taken(result)) return result;
    if (phase_ == Phase::kInitialRest) {
      const ImuSample<Scalar> s = to_sample(f, c.temperature);
      if (!c.acc_saturated && init_.glitch(s.acc, settings_.glitch_sigma))
        return checks_.refuse_glitch(c, f.t_us);
      checks_.accept(f);
      if (c.acc_saturated) {
        restart_initial_rest();
        return result;
      }
      return initial_rest_sample(s, c.dt(), result);
    }
    if (!segmenter_.add(f, c, *this)) return checks_.refuse_glitch(c, f.t_us);
    checks_.accept(f);
    if (pose_store_full_reported_ && result == Status::kOk) {
      pose_store_full_reported_ = false;
      return Status::kCapacityExceeded;
    }
    return result;
  }

  static ImuSample<Scalar> to_sample(const RawFrame& f, Scalar temperature) {
    ImuSample<Scalar> s;
    s.t_us = f.t_us;
    for (int i = 0; i < 3; ++i) {
      s.acc(i) = static_cast<Scalar>(f.acc[i]);
      s.gyro(i) = static_cast<Scalar>(f.gyro[i]);
    }
    s.temperature = temperature;
    return s;
  }

  bool check_settings() const {
    const CalibratorSettings<Scalar>& c = settings_;
    return c.initial_rest_seconds > Scalar(0) && c.stillness.valid() &&
           StreamSegmenter::valid(segmenter_settings()) && c.glitch_sigma > Scalar(1) &&
           c.segment_max_angle > Scalar(0) && c.segment_max_error > Scalar(0) &&
           c.gyro.nominal_scale >= Scalar(0) &&
           // Durations become microseconds in uint32: keep them far from 2^32 us (71 min).
           c.max_step_seconds <= Scalar(60) && c.StreamSettings<Scalar>::valid();
  }

  // The largest step that is not a gap, in microseconds.
  void update_gap_limit() {
    const Scalar period = phase_ != Phase::kInitialRest ? period_ : Scalar(0);
    checks_.set_gap_limit(detail::seconds_to_us(settings_.gap_seconds(period)));
  }

  // ---- The front end's sink (checks.hpp) -----------------------------------------------------

  // A gap, a clock reset, a gyro at full scale: the rest before it still counts (trimmed as
  // before motion); the move across it is dropped.
  __attribute__((noinline)) void stream_cut() {
    if (phase_ == Phase::kInitialRest) {
      restart_initial_rest();
      return;
    }
    segmenter_.cut(*this);
    moves_.drop();
  }

  // A frozen sensor: the samples since it froze may already sit in the rest, so the rest in
  // progress is discarded with the move.
  __attribute__((noinline)) void sensor_froze() {
    if (phase_ == Phase::kInitialRest) {
      restart_initial_rest();
      return;
    }
    segmenter_.discard();
    moves_.drop();
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
    if (r != Status::kOk) return checks_.note(r);
    start_collecting(init_.found());
    return result;
  }

  // The initial rest's statistics set the bias, the noise, the period and the detector; the
  // rest goes on as the first rest, to become pose 0 when the first move starts.
  void start_collecting(const typename InitialRestWindow<Scalar>::Found& f) {
    const Scalar n = f.samples;
    v0_ = f.acc_variance;
    gv0_ = settings_.has_gyro ? f.gyro_variance : Vector3<Scalar>::Zero();
    const Vector3<Scalar> b0 =
        settings_.has_gyro ? Vector3<Scalar>(-f.gyro_mean) : Vector3<Scalar>::Zero();
    b0_sigma_ = (gv0_ / n).cwiseSqrt();  // of the mean rate
    period_ = f.period;
    // The detector starts from the rest's own statistics.
    segmenter_.start(settings_.stillness, Vector3<Scalar>(f.acc_ref + f.acc_sum / n), v0_,
                     gv0_.sum(), b0,
                     settings_.glitch_sigma * settings_.glitch_sigma * v0_.maxCoeff(), f.period);
    Block rest{};
    rest.acc_ref = f.acc_ref;
    rest.acc_sum = f.acc_sum;
    rest.long_enough = false;  // decided by its length, as every rest
    rest.n = static_cast<std::uint32_t>(n);
    rest.accel_cue = n * v0_.sum();
    rest.energy_cue = n * gv0_.sum();
    // The temperatures so far (those before the window too: close enough for a mean).
    rest.temp_sum = checks_.temperature().sum();
    rest.temp_n = checks_.temperature().count();
    rest.t_begin = f.t_begin;
    rest.t_end = f.t_end;
    segmenter_.open_rest(rest);
    phase_ = Phase::kCollecting;
    init_.restart();
    update_gap_limit();
  }

  // ---- The segmenter's sink (segmenter.hpp) --------------------------------------------------

  const SegmentBounds<Scalar>& segment_bounds() const { return moves_.bounds(); }

  // A block's rotation into the move in progress.
  void move_block(const Block& b) {
    if (settings_.has_gyro) moves_.add(b.seg, b.path);
  }

  // The open rest ended (motion, gap, end of stream): a pose if long enough, else part of the
  // move in progress.
  void rest_ended(const Block& rest, bool long_enough) {
    if (!long_enough) {
      ++rests_too_short_;
      last_rest_short_ = true;
      checks_.note(Status::kRestTooShort);
      move_block(rest);
      return;
    }
    last_rest_short_ = false;
    if (poses_.full()) {
      // Not stored (see the top of this file); the chain cannot continue past it.
      if (!capacity_reported_) pose_store_full_reported_ = capacity_reported_ = true;
      checks_.note(Status::kCapacityExceeded);
      moves_.drop();
      return;
    }
    if (poses_.add(rest.acc_mean(), rest.n, segmenter_.noise_variance(rest), rest.t_begin,
                   rest.t_end) != Status::kOk) {
      moves_.drop();
      return;
    }
    const int index = poses_.size() - 1;
    const Vector3<Scalar>& b0 = segmenter_.gyro_bias();
    last_rest_ = rest.summary(b0, checks_.temperature().ref());
    segmenter_.learn_rest(rest);
    // The rest's own rotation: held in the hand (its gyro energy well above the quietest rest's),
    // a board turns a little, and the pose's gravity direction, a mean over the rest, stands for
    // its time centroid: the move into the pose ends there and the move out of it starts there.
    // On a table a rest does not turn, and integrating through it would only add the bias's
    // drift (on the Xsens recording: 1.08 instead of 0.44 deg per move).
    GyroSegment<Scalar> head{}, tail{};
    const Scalar inv_n = Scalar(1) / static_cast<Scalar>(rest.n);
    const bool shaky =
        rest.energy_cue * inv_n > Scalar(4) * segmenter_.detector().first_rest_energy();
    const bool halves = settings_.has_gyro && shaky && split_rest_rotation(rest.seg, head, tail);
    if (settings_.has_gyro) poses_.add_rest_rate(last_rest_.gyro_mean + b0, last_rest_.duration_s);
    moves_.arrive(index, halves ? &head : nullptr, halves ? &tail : nullptr);
    if (phase_ == Phase::kCollecting && poses_.size() >= settings_.target_poses && faces() == 0x3f)
      phase_ = Phase::kReady;
    if (poses_.full()) phase_ = Phase::kReady;
  }

  // End of the stream: the last rest ends (a pose if long enough), or a move in progress has no
  // pose to end at.
  void end_of_stream() {
    if (!segmenter_.end(*this) && moves_.in_move()) checks_.note(Status::kEndedInMotion);
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
    in.gyro_bias0 = segmenter_.gyro_bias();
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

  // The per-sample path: the front end and the segmenter first (single-instruction offsets from
  // `this` on Arm).
  StreamChecks<Scalar> checks_{};
  StreamSegmenter segmenter_{};
  bool last_rest_short_ = false;
  bool pose_store_full_reported_ = false;  // to be returned by the next add()
  bool capacity_reported_ = false;         // once per run

  // What the initial rest set.
  Vector3<Scalar> b0_sigma_ = Vector3<Scalar>::Zero();
  Vector3<Scalar> v0_ = Vector3<Scalar>::Zero();   // accelerometer variance per axis
  Vector3<Scalar> gv0_ = Vector3<Scalar>::Zero();  // gyro variance per axis
  Scalar period_ = Scalar(0);                      // mean sample period

  // Used before the first rest and once a pose.
  InitialRestWindow<Scalar> init_{};
  RestSummary<Scalar> last_rest_{};

  // Stores.
  MoveStore<Scalar, MaxPoses, MaxSegments> moves_{};
  PoseCollection<Scalar, MaxPoses> poses_{};

  // Counters.
  int rests_too_short_ = 0;

  // Solving.
  SolveSequence<Scalar, MaxPoses> solver_{};
  Calibration<Scalar> calibration_{};
};

}  // namespace imucal
