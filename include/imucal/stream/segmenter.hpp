// SPDX-License-Identifier: MIT
// imucal/stream/segmenter.hpp: splits a checked sample stream (checks.hpp) into rests and moves.
// Samples are summed into sub-blocks (sub_block.hpp: 16-bit counts in integers, or readings in
// the scalar type); each sub-block goes through the stillness detector (stillness.hpp) and into a
// short block (blocks.hpp: at most block_seconds, all still or all moving, each a valid gyro
// segment). Still
// blocks wait in a delay line of trim_seconds: a still block followed by trim_seconds of stillness
// joins the open rest; when motion comes, the blocks still in the line (the rest's last
// trim_seconds, which the moving averages saw only late) go to the move. A rest ends at motion, at
// a cut in the stream, at the end of the stream, or, if asked, when it has lasted
// max_rest_seconds or its accelerometer mean has moved by accel_shift_max (a slow tilt). The
// protocol calibrator, the rest monitor and the field calibrator all take their rests and moves
// from here, so they agree by construction.
//
// The consumer is a sink, passed to every call that can hand something out:
//   sink.move_block(block)        a block that belongs to the move in progress
//   sink.rest_ended(rest, long)   the open rest ended; long: it lasted min_rest_seconds of
//                                 stillness (the trimmed part included). The sink calls
//                                 learn_rest(rest) if the rest is one to set the thresholds by.
//   sink.segment_bounds()         the bounds a block must stay within to be one gyro segment
// Never allocates, throws or blocks. Header-only.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>

#include "imucal/stream/blocks.hpp"
#include "imucal/stream/checks.hpp"
#include "imucal/stream/gyro_segment.hpp"
#include "imucal/stream/stillness.hpp"
#include "imucal/stream/sub_block.hpp"
#include "imucal/types.hpp"

namespace imucal {

// What the segmenter is set up with (seconds; accelerometer in raw units).
template <typename Scalar>
struct SegmenterSettings {
  // A sub-block (the detector's step) lasts at most this long, and holds at most the segmenter's
  // SubBlockSamples samples, kStillSubBlockFactor times as many while still: the per-sample work
  // is integer sums (or float sums), the float work happens once a sub-block.
  Scalar sub_block_seconds = Scalar(0.1);
  Scalar block_seconds = Scalar(0.1);     // granularity of the trimming
  Scalar trim_seconds = Scalar(0.25);     // cut from a rest's end before the motion showed
  Scalar min_rest_seconds = Scalar(0.6);  // a shorter still spell is part of the move
  // Optional: a rest is ended (and a new one begun) once it has lasted this long, or once a
  // block's mean accelerometer reading is further than accel_shift_max from the rest's mean.
  // Infinity: never.
  Scalar max_rest_seconds = std::numeric_limits<Scalar>::infinity();
  Scalar accel_shift_max = std::numeric_limits<Scalar>::infinity();
};

template <typename Scalar, int DelayBlocks, int SubBlockSamples = kMaxSubBlockSamples>
class Segmenter {
 public:
  static_assert(DelayBlocks >= 2, "delay line too short");
  static_assert(SubBlockSamples >= 1 && SubBlockSamples <= kMaxSubBlockSamples,
                "sub-block of 1 to kMaxSubBlockSamples samples");
  // The most samples of a moving sub-block, and of a still one.
  static constexpr std::uint32_t kMovingSamples = SubBlockSamples;
  static constexpr std::uint32_t kStillSamples = kStillSubBlockFactor * SubBlockSamples;
  using Block = SampleBlock<Scalar>;

  // Settings valid for this delay line (trim_seconds fits in it; durations far from 2^32 us).
  static bool valid(const SegmenterSettings<Scalar>& s) {
    return s.sub_block_seconds > Scalar(0) && s.sub_block_seconds <= s.block_seconds &&
           s.block_seconds > Scalar(0) && s.block_seconds <= Scalar(60) &&
           s.trim_seconds >= Scalar(0) && s.trim_seconds <= Scalar(60) &&
           s.trim_seconds <= s.block_seconds * Scalar(DelayBlocks - 1) &&
           s.min_rest_seconds > Scalar(0) && s.max_rest_seconds >= s.min_rest_seconds &&
           s.accel_shift_max > Scalar(0);
  }

  // Forgets everything and takes the settings (check them with valid() first).
  void reset(const SegmenterSettings<Scalar>& s) {
    sub_us_ = detail::seconds_to_us(s.sub_block_seconds);
    block_us_ = detail::seconds_to_us(s.block_seconds);
    trim_us_ = detail::seconds_to_us(s.trim_seconds);
    min_rest_seconds_ = s.min_rest_seconds;
    max_rest_seconds_ = s.max_rest_seconds;
    accel_shift_max2_ = s.accel_shift_max * s.accel_shift_max;
    clear();
    sub_.forget_kind();
    mean_follows_ = false;
    open_sub_block();
    sub_.forget_rate();
  }

  // Starts the detector from a still period: the accelerometer's mean (raw) and per-axis
  // variance, the gyro's energy with the bias removed (0: no gyro cue), and the bias added to
  // every gyro reading.
  // Readings further than sqrt(glitch_limit2) from the detector's moving mean are glitches;
  // interval: the sample period if known (0: learned from the first sub-block).
  void start(const StillnessSettings<Scalar>& stillness, const Vector3<Scalar>& acc_mean,
             const Vector3<Scalar>& acc_var, Scalar gyro_energy, const Vector3<Scalar>& gyro_bias,
             Scalar glitch_limit2 = std::numeric_limits<Scalar>::infinity(),
             Scalar interval = Scalar(0)) {
    b0_ = gyro_bias;
    interval_ = interval > Scalar(0) ? interval : Scalar(0);
    interval_us_ = 0;
    bias_pending_ = false;
    stillness_seconds_ = stillness.seconds;
    weight_ = interval_ / (stillness_seconds_ + interval_);
    mean_follows_ = false;
    detector_.start(stillness, acc_mean, acc_var, gyro_energy);
    detector_.set_glitch_limit(glitch_limit2);
    open_sub_block();
    sub_.forget_rate();
    sub_.set_averages(acc_mean, detector_.start_accel(), detector_.start_energy());
  }

  // The bias added to every gyro reading. The blocks and the rest held so far are moved to it
  // (their statistics are of the rate with the bias added: exact for the segments' alpha and
  // beta; a block's path angle keeps the old bias).
  // It takes effect at the end of the open sub-block (it may be called from the sink).
  void set_gyro_bias(const Vector3<Scalar>& b) {
    pending_bias_ = b;
    bias_pending_ = true;
  }

  // The stream (re)starts with a rest already open (the protocol's initial rest).
  void open_rest(const Block& rest) {
    rest_ = rest;
    rest_open_ = true;
    block_ = Block{};
    if (sub_.size() > 0) set_sub_span();
  }

  // One checked sample: a reading in the scalar type or a frame of 16-bit counts (integer work
  // only, but once a sub-block). c: what the front end made of it: the step after the previous
  // one, 0 if the stream starts here; whether the accelerometer says nothing; the temperature.
  // A stream is readings or frames, one kind at a time: a sample of the other kind drops the open
  // sub-block and goes on in its own arithmetic (SubBlock::add()). False: a glitch, nothing else
  // changed.
  template <class Input, class Sink>
  __attribute__((always_inline)) bool add(const Input& x, const CheckedSample<Scalar>& c,
                                          Sink& sink) {
    if (!sub_.add(x, c.step_us, c.acc_saturated)) return false;
    if (c.has_temperature()) sub_.add_temperature(c.temperature_q);
    if (const SubBlockStats<Scalar>* done = sub_.done()) {
      sub_block_done(*done, sink);
      sub_.release_done();
    }
    if (sub_.size() == 1) set_sub_span();
    // A still sub-block may hold kStillSubBlockFactor times as many samples (its rotation bound
    // that many times tighter past kMovingSamples).
    const std::uint32_t n = sub_.size();
    const bool full =
        n < kMovingSamples
            ? x.t_us - sub_.t_begin() >= sub_span_us_ || sub_.template energy_full<Input>(false)
            : !sub_.still() || n >= kStillSamples || x.t_us - sub_.t_begin() >= sub_span_us_ ||
                  sub_.template energy_full<Input>(true);
    if (full) close_sub_block(sink);
    return true;
  }

  // The open sub-block goes through the detector into the blocks now (before a cut, at the end).
  template <class Sink>
  void close_sub_block(Sink& sink) {
    if (sub_.size() == 0) return;
    sub_block_done(sub_.finish(), sink);
    open_sub_block();
  }

  // The stream is cut (a gap): the current block and the delay line are treated as if motion
  // followed, so the rest before the cut is trimmed like any other; what follows is a move.
  template <class Sink>
  void cut(Sink& sink) {
    close_sub_block(sink);
    sub_.forget_rate();
    if (block_.still && block_.n > 0) {
      delay_.add(block_);
      block_.clear();
    }
    motion_after(block_, sink);
    block_.clear();
  }

  // A sensor froze: the samples since it froze may already sit in the rest, so the block, the
  // delay line and the open rest are discarded.
  void discard() {
    mean_follows_ = false;
    open_sub_block();  // what the open sub-block held goes too
    sub_.forget_rate();
    block_ = Block{};
    delay_.clear();
    rest_open_ = false;
  }

  // End of the stream: if it ends still, the delay line belongs to the last rest (no motion
  // followed). True if a rest was open (and has ended); false if the stream ended in motion.
  template <class Sink>
  bool end(Sink& sink) {
    close_sub_block(sink);
    if (block_.n > 0) {
      if (block_.still)
        delay_.add(block_);
      else
        motion_after(block_, sink);
      block_.clear();
    }
    if (delay_.empty() && !rest_open_) return false;
    delay_.drain([this, &sink](const Block& d) { rest_add(d, sink); });
    end_rest(false, sink);
    return true;
  }

  // Whether the open rest has lasted min_rest_seconds; with_delay_line: the still blocks in the
  // delay line count towards it. Timestamps wrap after 71.6 min: a rest that lasted
  // min_rest_seconds stays long enough (the flag is set while the span is still short).
  bool rest_long_enough(bool with_delay_line) const {
    if (rest_.long_enough) return true;
    std::uint32_t end = rest_.t_end;
    if (with_delay_line && !delay_.empty()) end = delay_.newest().t_end;
    return static_cast<Scalar>(end - rest_.t_begin) * Scalar(1e-6) >= min_rest_seconds_;
  }

  // The detector learns the noise of a rest (called by the sink from rest_ended()).
  void learn_rest(const Block& rest) {
    const Scalar inv_n = Scalar(1) / static_cast<Scalar>(rest.n);
    detector_.learn_rest(rest.accel_cue * inv_n, rest.energy_cue * inv_n);
  }

  // As a pose's noise (SampleBlock::noise_variance with the detector's time constant).
  Scalar noise_variance(const Block& rest) const { return rest.noise_variance(stillness_seconds_); }

  bool rest_open() const { return rest_open_; }
  const Block& rest() const { return rest_; }
  // Whether the latest sample was classified still.
  bool still() const { return sub_.still(); }
  const StillnessDetector<Scalar>& detector() const { return detector_; }
  const Vector3<Scalar>& gyro_bias() const { return b0_; }

 private:
  // When the block the open sub-block joins began (a block closes once it lasted block_seconds).
  std::uint32_t block_begin(std::uint32_t sub_begin) const {
    return block_.n > 0 ? block_.t_begin : sub_begin;
  }

  // How long the open sub-block may last from its first sample: sub_block_seconds, and no
  // further than the block's end (block_seconds from the block's first sample). Worked out at
  // its first sample and wherever the block changes under it, not at every sample.
  void set_sub_span() {
    const std::uint32_t into = sub_.t_begin() - block_begin(sub_.t_begin());
    const std::uint32_t left = into < block_us_ ? block_us_ - into : 0u;
    sub_span_us_ = left < sub_us_ ? left : sub_us_;
  }

  // The accumulator starts a sub-block with the detector's limits and the rotation bound. A new
  // bias moves what is held first.
  void open_sub_block() {
    if (bias_pending_) {
      bias_pending_ = false;
      const Vector3<Scalar> db = pending_bias_ - b0_;
      block_.seg.add_bias(db);
      delay_.for_each([&db](Block& d) { d.seg.add_bias(db); });
      rest_.seg.add_bias(db);
      b0_ = pending_bias_;
    }
    SubBlockLimits<Scalar> l;
    detector_.limits(l);
    l.gyro_bias = b0_;
    l.energy_max = energy_max_;
    l.weight = weight_;
    l.acc_ref_is_mean = mean_follows_;
    sub_.start(l);
  }

  // A sub-block's sums into the detector and the blocks: close the block before it if it
  // changes state or would exceed the segment's path bound; after it once the block lasted
  // block_seconds or its segment reached the error bound.
  template <class Sink>
  __attribute__((noinline)) void sub_block_done(const SubBlockStats<Scalar>& s, Sink& sink) {
    const bool still = detector_.update(s);
    mean_follows_ = true;
    const SegmentBounds<Scalar>& bounds = sink.segment_bounds();
    // Rotation bound of the next sub-block: its path duration * rms|u| at most a quarter of a
    // segment's: sum |u|^2 <= (max_angle / 4)^2 / (n h^2), with n the most samples it holds
    // (moving or still) and h the mean interval (to the microsecond: it and the moving averages'
    // weight are worked out again only when that changes).
    if (s.intervals > 0) {
      const std::uint32_t us = (s.duration_us + s.intervals / 2) / s.intervals;
      if (us != interval_us_ || detail::bits_differ(bounds.max_angle, bound_angle_)) {
        interval_us_ = us;
        bound_angle_ = bounds.max_angle;
        interval_ = static_cast<Scalar>(us) * Scalar(1e-6);
        const Scalar a = Scalar(0.25) * bounds.max_angle / interval_;
        energy_max_ = a * a / static_cast<Scalar>(kMovingSamples);
        weight_ = interval_ / (stillness_seconds_ + interval_);
      }
    }
    if (block_.n > 0 && (still != block_.still || block_.path + s.path > bounds.max_angle))
      close_block(sink);
    if (block_.n == 0) block_.still = still;
    block_.add(s);
    if (block_.t_end - block_.t_begin >= block_us_ ||
        (block_.path > bounds.error_free_path &&
         block_.seg.alpha.squaredNorm() * block_.seg.beta.squaredNorm() > bounds.max_error2))
      close_block(sink);
  }

  void clear() {
    block_ = Block{};
    delay_.clear();
    rest_ = Block{};
    rest_open_ = false;
  }

  // Routes the current block (by reference into the ring: no copies on the per-sample path).
  // Out of line: once per block, and inlined its registers would cost every sample.
  template <class Sink>
  void close_block(Sink& sink) {
    if (block_.n == 0) return;
    if (block_.still) {
      delay_.add(block_);
      block_.clear();
      // A still block is part of the rest once trim_seconds of stillness follow it.
      while (!delay_.empty() && delay_.span_after_oldest() >= trim_us_) {
        rest_add(delay_.oldest(), sink);
        delay_.drop_oldest();
      }
      return;
    }
    detector_.learn_motion(block_.energy_cue / static_cast<Scalar>(block_.n));
    motion_after(block_, sink);
    block_.clear();
  }

  // Motion has come: the rest (if any) ends, the trimmed blocks and then b (if any) belong to
  // the move.
  template <class Sink>
  void motion_after(const Block& b, Sink& sink) {
    end_rest(true, sink);
    delay_.drain([&sink](const Block& d) { to_move(d, sink); });
    to_move(b, sink);  // an empty block adds nothing
  }

  template <class Sink>
  static void to_move(const Block& b, Sink& sink) {
    if (b.n > 0) sink.move_block(b);
  }

  template <class Sink>
  void rest_add(const Block& b, Sink& sink) {
    if (!rest_open_) {
      rest_ = b;
      rest_open_ = true;
    } else {
      if (split_before(b)) {
        end_rest(false, sink);
        rest_ = b;
        rest_open_ = true;
      } else {
        rest_.append(b);
      }
    }
    if (!rest_.long_enough) rest_.long_enough = rest_long_enough(false);
  }

  // A rest that has lasted max_rest_seconds, or tilted by accel_shift_max, ends before b.
  bool split_before(const Block& b) const {
    if (max_rest_seconds_ == std::numeric_limits<Scalar>::infinity() &&
        accel_shift_max2_ == std::numeric_limits<Scalar>::infinity())
      return false;
    const Scalar span = static_cast<Scalar>(b.t_end - rest_.t_begin) * Scalar(1e-6);
    if (span > max_rest_seconds_) return true;
    // Squared: no square root (a NaN still splits).
    return !((b.acc_mean() - rest_.acc_mean()).squaredNorm() <= accel_shift_max2_);
  }

  // The open rest ends (motion, gap, end of stream, a split).
  template <class Sink>
  void end_rest(bool with_delay_line, Sink& sink) {
    if (!rest_open_) return;
    rest_open_ = false;
    sink.rest_ended(rest_, rest_long_enough(with_delay_line));
  }

  // The per-sample path's members first (single-instruction offsets on Arm).
  SubBlock<Scalar> sub_{};
  std::uint32_t sub_us_ = 0;
  std::uint32_t sub_span_us_ = 0;  // the open sub-block's (set_sub_span())
  bool rest_open_ = false;
  bool bias_pending_ = false;
  bool mean_follows_ = false;  // the detector's mean is the accumulator's moving mean
  StillnessDetector<Scalar> detector_{};
  Vector3<Scalar> b0_ = Vector3<Scalar>::Zero();  // gyro bias, added
  Vector3<Scalar> pending_bias_ = Vector3<Scalar>::Zero();
  Scalar energy_max_ = std::numeric_limits<Scalar>::infinity();  // a sub-block's rotation bound
  Scalar interval_ = Scalar(0);     // the latest sub-block's mean sample interval
  std::uint32_t interval_us_ = 0;   // the same, to the microsecond (0: none yet)
  Scalar bound_angle_ = Scalar(0);  // the segment bound energy_max_ was worked out for
  Scalar weight_ = Scalar(0);       // one sample's weight in the moving averages at interval_
  std::uint32_t block_us_ = 0, trim_us_ = 0;
  Block block_{};
  DelayLine<Scalar, DelayBlocks> delay_{};
  Block rest_{};
  Scalar min_rest_seconds_ = Scalar(0), stillness_seconds_ = Scalar(0.1);
  Scalar max_rest_seconds_ = std::numeric_limits<Scalar>::infinity();
  Scalar accel_shift_max2_ = std::numeric_limits<Scalar>::infinity();  // squared
};

}  // namespace imucal
