// imucal/stream/segmenter.hpp: splits a checked sample stream (checks.hpp) into rests and moves.
// Every sample goes through the stillness detector (stillness.hpp) and into a short block
// (blocks.hpp: at most block_seconds, all still or all moving, each a valid gyro segment). Still
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
#include "imucal/stream/gyro_segment.hpp"
#include "imucal/stream/stillness.hpp"
#include "imucal/types.hpp"

namespace imucal {

// What the segmenter is set up with (seconds; accelerometer in raw units).
template <typename Scalar>
struct SegmenterSettings {
  Scalar block_seconds = Scalar(0.1);     // granularity of the trimming
  Scalar trim_seconds = Scalar(0.25);     // cut from a rest's end before the motion showed
  Scalar min_rest_seconds = Scalar(0.6);  // a shorter still spell is part of the move
  // Optional: a rest is ended (and a new one begun) once it has lasted this long, or once a
  // block's mean accelerometer reading is further than accel_shift_max from the rest's mean.
  // Infinity: never.
  Scalar max_rest_seconds = std::numeric_limits<Scalar>::infinity();
  Scalar accel_shift_max = std::numeric_limits<Scalar>::infinity();
};

template <typename Scalar, int DelayBlocks>
class Segmenter {
 public:
  static_assert(DelayBlocks >= 2, "delay line too short");
  using Block = SampleBlock<Scalar>;

  // Settings valid for this delay line (trim_seconds fits in it; durations far from 2^32 us).
  static bool valid(const SegmenterSettings<Scalar>& s) {
    return s.block_seconds > Scalar(0) && s.block_seconds <= Scalar(60) &&
           s.trim_seconds >= Scalar(0) && s.trim_seconds <= Scalar(60) &&
           s.trim_seconds <= s.block_seconds * Scalar(DelayBlocks - 1) &&
           s.min_rest_seconds > Scalar(0) && s.max_rest_seconds >= s.min_rest_seconds &&
           s.accel_shift_max > Scalar(0);
  }

  // Forgets everything and takes the settings (check them with valid() first).
  void reset(const SegmenterSettings<Scalar>& s) {
    block_us_ = static_cast<std::uint32_t>(s.block_seconds * Scalar(1e6));
    trim_us_ = static_cast<std::uint32_t>(s.trim_seconds * Scalar(1e6));
    min_rest_seconds_ = s.min_rest_seconds;
    max_rest_seconds_ = s.max_rest_seconds;
    accel_shift_max_ = s.accel_shift_max;
    clear();
    last_still_ = true;
    u_prev_.setZero();
  }

  // Starts the detector from a still period: the accelerometer's reference (sums and the
  // detector work relative to it), its mean relative to it and per-axis variance, the gyro's
  // energy with the bias removed (0: no gyro cue), and the bias added to every gyro reading.
  void start(const StillnessSettings<Scalar>& stillness, const Vector3<Scalar>& acc_ref,
             const Vector3<Scalar>& acc_mean, const Vector3<Scalar>& acc_var, Scalar gyro_energy,
             const Vector3<Scalar>& gyro_bias) {
    a_ref_ = acc_ref;
    b0_ = gyro_bias;
    u_prev_.setZero();  // the rate at the rest's end, bias removed
    stillness_seconds_ = stillness.seconds;
    detector_.start(stillness, acc_mean, acc_var, gyro_energy);
  }

  // Readings further than sqrt(limit2) from the detector's moving mean are glitches.
  void set_glitch_limit(Scalar limit2) { detector_.set_glitch_limit(limit2); }
  // The bias added to every gyro reading. The blocks and the rest held so far are moved to it
  // (their statistics are of the rate with the bias added: exact for the segments' alpha and
  // beta; a block's path angle keeps the old bias).
  void set_gyro_bias(const Vector3<Scalar>& b) {
    const Vector3<Scalar> db = b - b0_;
    block_.seg.add_bias(db);
    delay_.for_each([&db](Block& d) { d.seg.add_bias(db); });
    rest_.seg.add_bias(db);
    u_prev_ += db;
    b0_ = b;
  }

  // The stream (re)starts with a rest already open (the protocol's initial rest).
  void open_rest(const Block& rest) {
    rest_ = rest;
    rest_open_ = true;
    block_ = Block{};
  }

  // One checked sample (the temperature NaN if none; temp_ref what block temperatures are
  // relative to; moving: the accelerometer says nothing, e.g. saturated). False: a glitch,
  // nothing changed. Written per axis with the thresholds precomputed (bench_stream counts its
  // instructions).
  template <class Sink>
  __attribute__((always_inline)) bool add(const ImuSample<Scalar>& s, Scalar temperature,
                                          Scalar temp_ref, Scalar dt, bool moving, Sink& sink) {
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
    const SegmentBounds<Scalar>& bounds = sink.segment_bounds();
    if (block_.n > 0 && (still != block_.still || block_.path + step_path > bounds.max_angle))
      close_block(sink);
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
      block_.temp_sum += temperature - temp_ref;
      ++block_.temp_n;
    }
    ++block_.n;
    block_.t_end = s.t_us;
    if (s.t_us - block_.t_begin >= block_us_ ||
        (block_.path > bounds.error_free_path &&
         block_.seg.alpha.squaredNorm() * block_.seg.beta.squaredNorm() > bounds.max_error2))
      close_block(sink);
    return true;
  }

  // The stream is cut (a gap): the current block and the delay line are treated as if motion
  // followed, so the rest before the cut is trimmed like any other; what follows is a move.
  template <class Sink>
  void cut(Sink& sink) {
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
    block_ = Block{};
    delay_.clear();
    rest_open_ = false;
  }

  // End of the stream: if it ends still, the delay line belongs to the last rest (no motion
  // followed). True if a rest was open (and has ended); false if the stream ended in motion.
  template <class Sink>
  bool end(Sink& sink) {
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
  bool still() const { return last_still_; }
  const StillnessDetector<Scalar>& detector() const { return detector_; }
  const Vector3<Scalar>& gyro_bias() const { return b0_; }
  const Vector3<Scalar>& acc_ref() const { return a_ref_; }

 private:
  void clear() {
    block_ = Block{};
    delay_.clear();
    rest_ = Block{};
    rest_open_ = false;
  }

  // Routes the current block (by reference into the ring: no copies on the per-sample path).
  // Out of line: once per block, and inlined its registers would cost every sample.
  template <class Sink>
  __attribute__((noinline)) void close_block(Sink& sink) {
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
    delay_.drain([this, &sink](const Block& d) { to_move(d, sink); });
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
        accel_shift_max_ == std::numeric_limits<Scalar>::infinity())
      return false;
    const Scalar span = static_cast<Scalar>(b.t_end - rest_.t_begin) * Scalar(1e-6);
    if (span > max_rest_seconds_) return true;
    return !((b.acc_mean() - rest_.acc_mean()).norm() <= accel_shift_max_);
  }

  // The open rest ends (motion, gap, end of stream, a split).
  template <class Sink>
  void end_rest(bool with_delay_line, Sink& sink) {
    if (!rest_open_) return;
    rest_open_ = false;
    sink.rest_ended(rest_, rest_long_enough(with_delay_line));
  }

  // The per-sample path's members first (single-instruction offsets on Arm).
  StillnessDetector<Scalar> detector_{};
  Vector3<Scalar> a_ref_ = Vector3<Scalar>::Zero();   // acceleration sums are relative to this
  Vector3<Scalar> b0_ = Vector3<Scalar>::Zero();      // gyro bias, added
  Vector3<Scalar> u_prev_ = Vector3<Scalar>::Zero();  // previous bias-corrected rate
  bool last_still_ = true;
  bool rest_open_ = false;
  std::uint32_t block_us_ = 0, trim_us_ = 0;
  Block block_{};
  DelayLine<Scalar, DelayBlocks> delay_{};
  Block rest_{};
  Scalar min_rest_seconds_ = Scalar(0), stillness_seconds_ = Scalar(0.1);
  Scalar max_rest_seconds_ = std::numeric_limits<Scalar>::infinity();
  Scalar accel_shift_max_ = std::numeric_limits<Scalar>::infinity();
};

}  // namespace imucal
