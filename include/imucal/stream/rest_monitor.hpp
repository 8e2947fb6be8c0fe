// SPDX-License-Identifier: MIT
// imucal/stream/rest_monitor.hpp: a small rest finder for the field, after calibration. It
// watches the raw stream (the same ImuSample the calibrator takes) and hands out a RestSummary
// (mean raw readings, mean temperature, length) for each rest it finds, to feed
// TemperatureFit::add_rest(): the temperature model keeps improving while the device is in use.
// It is the stream layer and nothing else: the front end's checks (checks.hpp: every bad sample
// gets the calibrator's status and count), and the calibrator's segmenter (segmenter.hpp: the
// same detector, blocks, trimming and rests), started from the noise the calibration measured
// (accel_noise, gyro_noise: what the calibrator's accel_noise_variance() and
// gyro_noise_variance() return, summed over the axes) and the raw gyro reading at zero rate
// (gyro_rest_reading: minus the calibration's gyro bias). The zero-rate reading follows the gyro's
// mean over each rest handed out, so a bias that drifts with temperature does not read as a
// turn; a steady slow turn does.
//
// A rest ends at motion, at a cut in the stream (a gap, a clock reset, a gyro at full scale),
// when it would exceed max_rest_seconds (a long rest on a slowly warming board yields several
// temperature points), or, if accel_shift_max is set, when a block's mean accelerometer reading
// has moved from the rest's mean by more than accel_shift_max (a slow tilt too gentle for the
// detector; leave room for the bias's drift over max_rest_seconds: 1 mg/deg C on a board warming
// 2 deg C/min moves the mean by 2 mg in a minute). A rest of at least min_rest_seconds of
// stillness (the part trimmed before motion included) is handed out by take(), once. Real
// vibration (a running engine) raises the accelerometer's variance: such periods are not rests.
//
// With MoveSegments > 0 and move bounds set (RestMonitorSettings::move_max_angle, _error), it also
// hands on the moves between the rests as gyro segments, as they come (a move of any length in
// fixed memory): a move begins at the end of each rest handed out and ends at the next one, over
// the blocks between them, shorter rests included. Its segments are merged while small in the
// protocol's store (solve/move_store.hpp), and taken one by one (take_move_segment()), each with
// the move's number; the owner walks them. move_from() says which rest a move began at and with
// which zero-rate reading, move_complete() that it ended whole at a rest: not across a cut in the
// stream (a gap, a clock reset, a frozen or saturated sensor), and never coarsened (its segments
// not taken in time). A move's segments all include the bias of its start: blocks that come
// after the zero-rate reading changed are moved back to it (exactly: GyroSegment::add_bias()).
// Fixed memory, no allocation, no exceptions. Header-only.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "imucal/solve/move_store.hpp"
#include "imucal/status.hpp"
#include "imucal/stream/blocks.hpp"
#include "imucal/stream/checks.hpp"
#include "imucal/stream/rest_summary.hpp"
#include "imucal/stream/ring.hpp"
#include "imucal/stream/segmenter.hpp"
#include "imucal/stream/stillness.hpp"
#include "imucal/types.hpp"

namespace imucal {

// The monitor's settings: the stream checks' (StreamSettings: gaps, frozen sensors, full scale,
// temperature range), the segmenter's (SegmenterSettings: blocks, trimming, the shortest rest
// handed out, the optional splits; here 5 s at least, split after 60 s) and its own.
template <typename Scalar>
struct RestMonitorSettings : StreamSettings<Scalar>, SegmenterSettings<Scalar> {
  RestMonitorSettings() {
    this->min_rest_seconds = Scalar(5);   // a shorter rest is not handed out
    this->max_rest_seconds = Scalar(60);  // a longer one is split
  }

  // The noise at rest, raw units squared: the variance of one sample, summed over the three axes
  // (Calibrator::accel_noise_variance().sum(), gyro_noise_variance().sum()). NaN: not set, and
  // add() refuses every sample with kInvalidArgument. gyro_noise = 0: no gyro cue (stillness
  // from the accelerometer alone).
  Scalar accel_noise = std::numeric_limits<Scalar>::quiet_NaN();
  Scalar gyro_noise = std::numeric_limits<Scalar>::quiet_NaN();
  // The raw gyro reading at zero rate (minus the calibration's bias) when the monitor starts.
  Vector3<Scalar> gyro_rest_reading = Vector3<Scalar>::Zero();
  // True: the zero-rate reading follows the gyro's mean over each rest handed out. False: it
  // stays at what set_gyro_rest_reading() sets (an owner that judges the rests first, such as
  // the field calibrator: a slow steady turn taken for a rest must not become the zero rate).
  bool follow_rests = true;
  StillnessSettings<Scalar> stillness{};  // the detector's settings, as in the calibrator
  // An accelerometer reading further than this many noise sigmas (sqrt(accel_noise)) from the
  // detector's moving mean is a glitch: refused and counted (as CalibratorSettings::glitch_sigma).
  Scalar glitch_sigma = Scalar(1e5);
  // The bounds a block must stay within to be one gyro segment of a move (raw units: path angle,
  // and |alpha||beta|; as CalibratorSettings::segment_max_angle and _error over the gyro's scale
  // and its cube). Infinite: no moves are kept.
  Scalar move_max_angle = std::numeric_limits<Scalar>::infinity();
  Scalar move_max_error = std::numeric_limits<Scalar>::infinity();
};

// Queue rests wait to be taken; DelayBlocks blocks wait to be confirmed still (the delay line:
// at least trim_seconds plus one block); a move under way keeps at most MoveSegments segments; a
// sub-block holds at most SubBlockSamples samples (the segmenter's, segmenter.hpp).
template <typename Scalar, int Queue = 4, int DelayBlocks = 8, int MoveSegments = 0,
          int SubBlockSamples = kMaxSubBlockSamples>
class RestMonitor {
 public:
  static_assert(Queue >= 1, "room for at least one finished rest");
  static_assert(MoveSegments >= 0, "no room for a negative number of segments");
  // The move under way (MoveSegments > 0): at most MoveSegments segments not taken yet.
  using Moves = MoveStore<Scalar, 1, (MoveSegments > 0 ? MoveSegments : 1)>;

  explicit RestMonitor(
      const RestMonitorSettings<Scalar>& settings = RestMonitorSettings<Scalar>()) {
    reset(settings);
  }

  // Starts again with new settings. kInvalidArgument for settings out of range (then add()
  // refuses every sample until a valid reset).
  Status reset(const RestMonitorSettings<Scalar>& settings) { return reset(settings, false); }
  // As reset(), within one stream (new settings mid-stream): the next sample is still ordered
  // against the latest one, so one behind it is refused (kTimeBackwards) or makes a clock reset.
  // The stream's counts (stream_counts(), samples_refused(), dropped()) go on; rests found and
  // not yet taken are counted in dropped().
  Status reset_in_stream(const RestMonitorSettings<Scalar>& settings) {
    return reset(settings, true);
  }

 private:
  Status reset(const RestMonitorSettings<Scalar>& settings, bool in_stream) {
    settings_ = settings;
    valid_ = check(settings);
    if (in_stream)
      checks_.reset_in_stream(settings);
    else
      checks_.reset(settings);
    const Scalar period =
        settings.nominal_rate_hz > Scalar(0) ? Scalar(1) / settings.nominal_rate_hz : Scalar(0);
    checks_.set_gap_limit(valid_ ? detail::seconds_to_us(settings.gap_seconds(period)) : 0u);
    segmenter_.reset(settings);
    started_ = false;
    after_motion_ = true;
    // Within the stream, rests found and not yet taken are lost to the new settings: dropped.
    if (in_stream)
      dropped_ += static_cast<std::uint32_t>(queue_.size());
    else
      dropped_ = 0;
    queue_.clear();
    emitted_ = 0;
    if constexpr (MoveSegments > 0) {
      can_keep_moves_ = valid_ && std::isfinite(settings.move_max_angle) &&
                        std::isfinite(settings.move_max_error) &&
                        settings.move_max_angle > Scalar(0) && settings.move_max_error > Scalar(0);
      keep_moves_ = can_keep_moves_;
      moves_ = KeptMoves{};
      moves_.building.reset(settings.move_max_angle, settings.move_max_error);
    }
    return valid_ ? Status::kOk : Status::kInvalidArgument;
  }

 public:
  // Moves are kept (true, the default when the settings bound them) or not: then blocks close by
  // duration and stillness only, as without moves, and nothing is handed on (an owner that cannot
  // use them yet saves their cost). A move under way is dropped either way; the next begins at
  // the end of the next rest handed out.
  void keep_moves(bool on) {
    if constexpr (MoveSegments > 0) {
      keep_moves_ = on && can_keep_moves_;
      moves_.building.drop();
      moves_.moved = false;
      if (!keep_moves_) moves_.ended.move = 0;
    } else {
      (void)on;
    }
  }
  bool keeps_moves() const { return keep_moves_; }

  // One raw sample: the front end's statuses (checks.hpp), as the calibrator's add(). Refused,
  // nothing changed: kInvalidArgument (settings not valid), kNonFiniteInput, kTimeRepeated,
  // kTimeBackwards, kSensorFrozen, kGyroSaturated, kGlitch. Taken: kOk, or a note:
  // kTimestampGap and kClockReset (the rest in progress ended there), kAccelSaturated,
  // kTemperatureImplausible (the temperature ignored), kSampleRateOff.
  Status add(const ImuSample<Scalar>& in) {
    if (!valid_) return checks_.refuse(Status::kInvalidArgument);
    ImuSample<Scalar> s = in;
    if (!settings_.has_gyro) s.gyro.setZero();
    CheckedSample<Scalar> c;
    const Status result = checks_.check(s, *this, c);
    if (result != Status::kOk && !sample_taken(result)) return result;
    if (!started_) start(s.acc);
    if (!segmenter_.add(s, c, *this)) return checks_.refuse_glitch(c, s.t_us);
    checks_.accept(s);
    return result;
  }

  // One frame of 16-bit counts, with the temperature if one was read with it (NaN: none): as
  // add(), with integer work only per sample. A stream is frames or samples: one kind.
  Status add_raw(const RawFrame& in,
                 Scalar temperature = std::numeric_limits<Scalar>::quiet_NaN()) {
    if (!valid_) return checks_.refuse(Status::kInvalidArgument);
    RawFrame f = in;
    if (!settings_.has_gyro) f.gyro[0] = f.gyro[1] = f.gyro[2] = 0;
    CheckedSample<Scalar> c;
    const Status result = checks_.check(f, temperature, *this, c);
    if (result != Status::kOk && !sample_taken(result)) return result;
    if (!started_)
      start(Vector3<Scalar>(static_cast<Scalar>(f.acc[0]), static_cast<Scalar>(f.acc[1]),
                            static_cast<Scalar>(f.acc[2])));
    if (!segmenter_.add(f, c, *this)) return checks_.refuse_glitch(c, f.t_us);
    checks_.accept(f);
    return result;
  }

  // A frame its caller could not read (a FIFO batch with an invalid layout or no buffer):
  // refused with kInvalidArgument and counted in samples_refused().
  Status refuse_unreadable() { return checks_.refuse(Status::kInvalidArgument); }

  // The stream ended (or the caller wants what is there now): the unconfirmed blocks join the
  // rest (no motion followed them), and the rest in progress is handed out if long enough. The
  // next sample starts the stream again, as after a gap.
  void finish() {
    segmenter_.end(*this);
    checks_.restart();
    after_motion_ = true;
  }

  // The oldest finished rest not taken yet; false if none. Call it after every add() or at least
  // once per min_rest_seconds: Queue rests wait, beyond that the oldest is overwritten
  // (dropped()).
  bool take(RestSummary<Scalar>& out) {
    if (queue_.empty()) return false;
    out = queue_.oldest();
    queue_.pop();
    return true;
  }

  bool resting() const { return segmenter_.rest_open(); }  // a rest is in progress
  std::uint32_t rests_found() const { return emitted_; }   // handed to the queue so far
  std::uint32_t dropped() const { return dropped_; }       // overwritten before take()
  const RestMonitorSettings<Scalar>& settings() const { return settings_; }
  // What the stream did wrong, by kind, and the samples refused.
  const StreamCounts& stream_counts() const { return checks_.counts(); }
  std::uint32_t temperatures_read() const { return checks_.temperatures_read(); }
  // The temperatures the front end took (in range), since reset().
  const TemperatureMean<Scalar>& temperatures() const { return checks_.temperature(); }
  std::uint32_t samples_refused() const { return checks_.refused(); }
  // The raw gyro reading at zero rate now: the latest rest's mean, or the setting before any.
  Vector3<Scalar> gyro_rest_reading() const { return -segmenter_.gyro_bias(); }
  // The accelerometer's moving mean (raw), as the last sub-block left it: gravity, at rest.
  const Vector3<Scalar>& accel_now() const { return segmenter_.detector().moving_mean(); }
  // Sets the zero-rate reading the detector removes from the gyro (from the end of the sub-block
  // in progress). kNonFiniteInput, nothing changed, for a NaN or infinity.
  Status set_gyro_rest_reading(const Vector3<Scalar>& reading) {
    if (!all_finite(reading)) return Status::kNonFiniteInput;
    segmenter_.set_gyro_bias(-reading);
    return Status::kOk;
  }

  // ---- Moves (MoveSegments > 0, move bounds set) ----
  // The oldest segment not taken yet, and the number of its move (from 1, in order): the rest of
  // the move that ended at the latest rest handed out comes first, then the move under way's
  // (all but its newest segment, which may still grow). False if none is ready.
  bool take_move_segment(GyroSegment<Scalar>& out, std::uint32_t& move) {
    if constexpr (MoveSegments > 0) {
      if (moves_.ended.move != 0 && moves_.ended.store.pop_oldest(out, true)) {
        move = moves_.ended.move;
        return true;
      }
      if (moves_.under_way.move != 0 && moves_.building.pop_oldest(out, false)) {
        move = moves_.under_way.move;
        return true;
      }
    } else {
      (void)out;
      (void)move;
    }
    return false;
  }
  bool move_segment_ready() const {
    if constexpr (MoveSegments > 0) {
      return (moves_.ended.move != 0 && moves_.ended.store.ready(true) > 0) ||
             (moves_.under_way.move != 0 && moves_.building.ready(false) > 0);
    } else {
      return false;
    }
  }
  // Where move `move` began: the rest's first and last sample's timestamps
  // (RestSummary::begin_us, end_us), and the bias (added) its segments include. False if it is
  // neither the move under way nor the one that ended last.
  bool move_from(std::uint32_t move, std::uint32_t& begin_us, std::uint32_t& end_us,
                 Vector3<Scalar>& bias) const {
    if constexpr (MoveSegments > 0) {
      const MoveInfo* m = move == moves_.under_way.move ? &moves_.under_way
                          : move == moves_.ended.move   ? &moves_.ended.info
                                                        : nullptr;
      if (move == 0 || m == nullptr) return false;
      begin_us = m->from_begin;
      end_us = m->from_end;
      bias = m->bias;
      return true;
    } else {
      (void)move, (void)begin_us, (void)end_us, (void)bias;
      return false;
    }
  }
  // Move `move` ended whole at the rest with these timestamps, and every segment of it was taken.
  bool move_complete(std::uint32_t move, std::uint32_t begin_us, std::uint32_t end_us) const {
    if constexpr (MoveSegments > 0) {
      const EndedMove& e = moves_.ended;
      return move != 0 && e.move == move && e.to_begin == begin_us && e.to_end == end_us &&
             e.store.ready(true) == 0 && e.store.coarsenings() == 0;
    } else {
      (void)move, (void)begin_us, (void)end_us;
      return false;
    }
  }

 private:
  using Block = SampleBlock<Scalar>;
  template <typename, int, int>
  friend class Segmenter;
  template <typename>
  friend class StreamChecks;

  // The detector starts from the first reading and the noise the settings give.
  void start(const Vector3<Scalar>& acc) {
    segmenter_.start(settings_.stillness, acc,
                     Vector3<Scalar>::Constant(settings_.accel_noise / Scalar(3)),
                     settings_.has_gyro ? settings_.gyro_noise : Scalar(0),
                     Vector3<Scalar>(-settings_.gyro_rest_reading),
                     settings_.glitch_sigma * settings_.glitch_sigma * settings_.accel_noise);
    started_ = true;
  }

  static bool check(const RestMonitorSettings<Scalar>& s) {
    const auto positive = [](Scalar x) { return std::isfinite(x) && x > Scalar(0); };
    return positive(s.accel_noise) && std::isfinite(s.gyro_noise) && s.gyro_noise >= Scalar(0) &&
           all_finite(s.gyro_rest_reading) && s.stillness.valid() && positive(s.trim_seconds) &&
           std::isfinite(s.max_rest_seconds) && s.max_rest_seconds <= Scalar(3600) &&
           s.max_rest_seconds >= s.trim_seconds && !std::isnan(s.accel_shift_max) &&
           s.glitch_sigma > Scalar(1) &&
           Segmenter<Scalar, DelayBlocks, SubBlockSamples>::valid(s) &&
           s.StreamSettings<Scalar>::valid();
  }

  // ---- The front end's sink ----
  void stream_cut() {
    segmenter_.cut(*this);
    after_motion_ = true;
    if constexpr (MoveSegments > 0) drop_move();
  }
  void sensor_froze() {
    segmenter_.discard();
    after_motion_ = true;
    if constexpr (MoveSegments > 0) drop_move();
  }

  // ---- The segmenter's sink ----
  const SegmentBounds<Scalar>& segment_bounds() const {
    if constexpr (MoveSegments > 0) {
      if (keep_moves_) return moves_.building.bounds();
    }
    return bounds_;
  }
  void move_block(const Block& b) {
    after_motion_ = true;
    if constexpr (MoveSegments > 0) add_to_move(b);
  }
  void rest_ended(const Block& rest, bool long_enough) {
    const bool after_motion = after_motion_;
    after_motion_ = false;
    if (!long_enough) {
      if constexpr (MoveSegments > 0) add_to_move(rest);  // a pause within the move
      return;
    }
    if constexpr (MoveSegments > 0) {
      if (keep_moves_) {
        // The move under way, if it moved and was not dropped, ends at this rest (the rest of its
        // segments wait to be taken); the next starts from it.
        KeptMoves& k = moves_;
        if (k.moved && k.building.chained()) {
          k.ended.store = k.building;
          k.ended.move = k.under_way.move;
          k.ended.info = k.under_way;
          k.ended.to_begin = rest.t_begin;
          k.ended.to_end = rest.t_end;
        }
        k.building.reset(settings_.move_max_angle, settings_.move_max_error);
        k.building.arrive(0, nullptr, nullptr);
        k.moved = false;
        k.under_way.move = ++k.count != 0 ? k.count : ++k.count;  // 0 stays "none"
        k.under_way.from_begin = rest.t_begin;
        k.under_way.from_end = rest.t_end;
        k.under_way.bias = segmenter_.gyro_bias();
      }
    }
    segmenter_.learn_rest(rest);
    RestSummary<Scalar> out = rest.summary(segmenter_.gyro_bias(), checks_.temperature().ref());
    out.after_motion = after_motion;
    if (settings_.follow_rests)
      segmenter_.set_gyro_bias(-out.gyro_mean);  // the zero-rate reading follows the rests
    if (queue_.push(out)) ++dropped_;            // full: the oldest went
    ++emitted_;
  }

  RestMonitorSettings<Scalar> settings_{};
  bool valid_ = false, started_ = false;
  bool after_motion_ = true;  // since the last rest ended: motion, a cut or the start
  StreamChecks<Scalar> checks_{};
  Segmenter<Scalar, DelayBlocks, SubBlockSamples> segmenter_{};
  // Blocks close by duration and stillness only: the monitor keeps no gyro segments.
  SegmentBounds<Scalar> bounds_{
      std::numeric_limits<Scalar>::infinity(), std::numeric_limits<Scalar>::infinity(),
      std::numeric_limits<Scalar>::infinity(), std::numeric_limits<Scalar>::infinity()};
  Ring<RestSummary<Scalar>, Queue> queue_{};
  std::uint32_t dropped_ = 0, emitted_ = 0;
  // A move: its number, the rest it began at (first and last sample's timestamps), the bias
  // (added) its segments include.
  struct MoveInfo {
    std::uint32_t move = 0;  // 0: none
    std::uint32_t from_begin = 0, from_end = 0;
    Vector3<Scalar> bias = Vector3<Scalar>::Zero();
  };
  // The latest move that ended at a rest: its segments not taken yet, and that rest.
  struct EndedMove {
    Moves store{};
    std::uint32_t move = 0;
    MoveInfo info{};
    std::uint32_t to_begin = 0, to_end = 0;
  };
  struct KeptMoves {
    Moves building{};  // the move under way's segments not taken yet
    MoveInfo under_way{};
    bool moved = false;  // it holds or held a segment
    EndedMove ended{};
    std::uint32_t count = 0;  // moves begun
  };
  void add_to_move(const Block& b) {
    if constexpr (MoveSegments > 0) {
      if (!keep_moves_ || !moves_.building.chained()) return;
      // The block's segment includes the segmenter's bias now; the move's, the one at its start.
      const Vector3<Scalar> back = moves_.under_way.bias - segmenter_.gyro_bias();
      if (back.isZero(Scalar(0))) {
        moves_.building.add(b.seg, b.path);
      } else {
        GyroSegment<Scalar> g = b.seg;
        g.add_bias(back);
        moves_.building.add(g, b.path);
      }
      moves_.moved = true;
    }
  }
  void drop_move() {
    if constexpr (MoveSegments > 0) moves_.building.drop();
  }
  struct NoMoves {};
  std::conditional_t<(MoveSegments > 0), KeptMoves, NoMoves> moves_{};
  bool keep_moves_ = false, can_keep_moves_ = false;
};

}  // namespace imucal
