// imucal/stream/rest_monitor.hpp: a small rest detector for the field, after calibration. It
// watches the raw stream (the same ImuSample the calibrator takes) and hands out a RestSummary
// (mean raw readings, mean temperature, length) for each rest it finds, to feed
// TemperatureFit::add_rest(): the temperature model keeps improving while the device is in use.
// Fixed memory (a few hundred bytes), a handful of operations per sample, no allocation, no
// exceptions. Header-only.
//
// How it decides: with the calibrator's own detector (stillness.hpp), sample by sample, started
// from the noise the calibration measured (accel_noise, gyro_noise: what the calibrator's
// accel_noise_variance() and gyro_noise_variance() return, summed over the axes) and the raw gyro
// reading at zero rate (gyro_rest_reading: minus the calibration's gyro bias). From there its
// thresholds follow the rests and moves it sees, as in the calibrator: a rest held in the hand
// counts, a steady slow turn does not (the gyro cue is the rate with the bias removed). The
// zero-rate reading follows the gyro's mean over each rest handed out, so a bias that drifts with
// temperature does not read as a turn.
//
// Trimming: still samples are summed in blocks of trim_seconds; a block joins the rest once the
// next block has been still throughout, so the moments before motion (which the moving averages
// see only after a few samples) are cut: between trim_seconds and twice that at the end of each
// rest. The start is cut by the averages' decay after the motion.
//
// A rest ends at motion, at a gap in the timestamps (a step above max_step_seconds), when it
// would exceed max_rest_seconds (a long rest on a slowly warming board yields several
// temperature points), or, if accel_shift_max is set, when a block's mean accelerometer reading
// has moved from the rest's mean by more than accel_shift_max (a slow tilt too gentle for the
// detector; leave room for the bias's drift over max_rest_seconds: 1 mg/deg C on a board warming
// 2 deg C/min moves the mean by 2 mg in a minute). A rest of at least min_rest_seconds of
// stillness (the part trimmed before motion included) is handed out by take(), once. Real vibration
// (a running engine) raises the accelerometer's variance: such periods are simply not rests.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "imucal/calibrator/settings.hpp"
#include "imucal/models/temperature_model.hpp"
#include "imucal/solve/normal_equations.hpp"
#include "imucal/status.hpp"
#include "imucal/stream/stillness.hpp"

namespace imucal {

template <typename Scalar>
struct RestMonitorSettings {
  // The noise at rest, raw units squared: the variance of one sample, summed over the three axes
  // (Calibrator::accel_noise_variance().sum(), gyro_noise_variance().sum()). NaN: not set, and
  // add() refuses every sample with kInvalidArgument. gyro_noise = 0: no gyro cue (stillness
  // from the accelerometer alone).
  Scalar accel_noise = std::numeric_limits<Scalar>::quiet_NaN();
  Scalar gyro_noise = std::numeric_limits<Scalar>::quiet_NaN();
  // The raw gyro reading at zero rate (minus the calibration's bias) when the monitor starts.
  Vector3<Scalar> gyro_rest_reading = Vector3<Scalar>::Zero();
  StillnessSettings<Scalar> stillness{};  // the detector's settings, as in the calibrator
  Scalar trim_seconds = Scalar(0.25);     // block length: what is cut before motion
  Scalar min_rest_seconds = Scalar(5);    // a shorter rest is not handed out
  Scalar max_rest_seconds = Scalar(60);   // a longer one is split
  Scalar max_step_seconds = Scalar(0.5);  // a larger timestamp step is a gap: the rest ends
  // Optional: largest distance (raw units) of a block's mean accelerometer reading from the
  // rest's mean before the rest is ended and a new one begun. Infinity: not checked.
  Scalar accel_shift_max = std::numeric_limits<Scalar>::infinity();
};

template <typename Scalar, int Queue = 4>
class RestMonitor {
 public:
  static_assert(Queue >= 1, "room for at least one finished rest");

  explicit RestMonitor(
      const RestMonitorSettings<Scalar>& settings = RestMonitorSettings<Scalar>()) {
    reset(settings);
  }

  // Starts again with new settings. kInvalidArgument for settings out of range (then add()
  // refuses every sample until a valid reset).
  Status reset(const RestMonitorSettings<Scalar>& settings) {
    settings_ = settings;
    valid_ = check(settings);
    if (valid_) {
      block_us_ = to_us(settings.trim_seconds);
      step_us_ = to_us(settings.max_step_seconds);
    }
    started_ = have_prev_ = false;
    t_prev_ = 0;
    gyro_zero_ = settings.gyro_rest_reading;
    block_ = pending_ = rest_ = Sums{};
    moving_energy_ = Scalar(0);
    moving_n_ = 0;
    head_ = count_ = 0;
    dropped_ = 0;
    emitted_ = 0;
    return valid_ ? Status::kOk : Status::kInvalidArgument;
  }

  // One raw sample. Refused, nothing changed: kInvalidArgument (settings not valid),
  // kNonFiniteInput (a NaN or infinity in a reading; a NaN temperature means "none" and is
  // taken, an infinite one is refused), kTimeRepeated, kTimeBackwards (timestamps are wrapping
  // microseconds: differences modulo 2^32, read as signed). Taken: kOk, or kTimestampGap (a step
  // above max_step_seconds: the rest in progress ended there).
  Status add(const ImuSample<Scalar>& s) {
    if (!valid_) return Status::kInvalidArgument;
    if (!all_finite(s.acc) || !all_finite(s.gyro) || std::isinf(s.temperature))
      return Status::kNonFiniteInput;
    Status result = Status::kOk;
    Scalar dt = Scalar(0);
    if (have_prev_) {
      const std::int32_t d = static_cast<std::int32_t>(s.t_us - t_prev_);
      if (d == 0) return Status::kTimeRepeated;
      if (d < 0) return Status::kTimeBackwards;
      if (static_cast<std::uint32_t>(d) > step_us_) {
        // The spell before the gap is cut short: its unconfirmed blocks go.
        drop_unconfirmed_and_end_rest();
        result = Status::kTimestampGap;
      } else {
        dt = static_cast<Scalar>(d) * Scalar(1e-6);
      }
    }
    if (!started_) {
      detector_.start(settings_.stillness, Vector3<Scalar>::Zero(),
                      Vector3<Scalar>::Constant(settings_.accel_noise / Scalar(3)),
                      settings_.gyro_noise);
      a_ref_ = s.acc;
      started_ = true;
    }
    const bool still =
        detector_.update(s.acc - a_ref_, s.gyro - gyro_zero_, dt, false) == Stillness::kStill;
    if (!still) {
      if (moving_n_ == 0) drop_unconfirmed_and_end_rest();  // motion began
      moving_energy_ += detector_.sample_energy();
      ++moving_n_;
    } else {
      if (moving_n_ > 0) {
        detector_.learn_motion(moving_energy_ / static_cast<Scalar>(moving_n_));
        moving_energy_ = Scalar(0);
        moving_n_ = 0;
      }
      if (block_.n > 0 && s.t_us - block_.t_first >= block_us_) close_block();
      if (!spell_.set) {
        spell_.acc = s.acc;
        spell_.gyro = s.gyro;
        spell_.set = true;
      }
      block_.add(s, detector_.sample_accel(), detector_.sample_energy(), spell_);
    }
    t_prev_ = s.t_us;
    have_prev_ = true;
    return result;
  }

  // The stream ended (or the caller wants what is there now): the unconfirmed blocks join the
  // rest (no motion followed them), and the rest in progress is handed out if long enough.
  void finish() {
    if (pending_.n > 0) rest_add(pending_);
    if (block_.n > 0) rest_add(block_);
    block_ = pending_ = Sums{};
    end_rest();
  }

  // The oldest finished rest not taken yet; false if none. Call it after every add() or at least
  // once per min_rest_seconds: Queue rests wait, beyond that the oldest is overwritten
  // (dropped()).
  bool take(RestSummary<Scalar>& out) {
    if (count_ == 0) return false;
    out = queue_[static_cast<std::size_t>(head_)];
    head_ = (head_ + 1) % Queue;
    --count_;
    return true;
  }

  bool resting() const { return rest_.n > 0; }            // a rest is in progress
  std::uint32_t rests_found() const { return emitted_; }  // handed to the queue so far
  std::uint32_t dropped() const { return dropped_; }      // overwritten before take()
  const RestMonitorSettings<Scalar>& settings() const { return settings_; }
  // The raw gyro reading at zero rate now: the latest rest's mean, or the setting before any.
  const Vector3<Scalar>& gyro_rest_reading() const { return gyro_zero_; }

 private:
  // References of a still spell: its first sample's readings. Every sum of the spell (blocks and
  // the rest) is relative to them, so float keeps the noise's precision on raw counts ~33000.
  struct Spell {
    Vector3<Scalar> acc = Vector3<Scalar>::Zero(), gyro = Vector3<Scalar>::Zero();
    Scalar temp = Scalar(0);
    bool set = false, temp_set = false;
  };

  // Sums over a block, a rest, or a motion spell (cues only).
  struct Sums {
    std::uint32_t n = 0, temp_n = 0;
    std::uint32_t t_first = 0, t_last = 0;
    Vector3<Scalar> acc = Vector3<Scalar>::Zero(), gyro = Vector3<Scalar>::Zero();
    Scalar temp = Scalar(0), accel_cue = Scalar(0), energy_cue = Scalar(0);

    void add(const ImuSample<Scalar>& s, Scalar a_cue, Scalar e_cue, Spell& ref) {
      if (n == 0) t_first = s.t_us;
      t_last = s.t_us;
      ++n;
      acc += s.acc - ref.acc;
      gyro += s.gyro - ref.gyro;
      accel_cue += a_cue;
      energy_cue += e_cue;
      if (!std::isnan(s.temperature)) {
        if (!ref.temp_set) {
          ref.temp = s.temperature;
          ref.temp_set = true;
        }
        temp += s.temperature - ref.temp;
        ++temp_n;
      }
    }
    void append(const Sums& b) {
      if (n == 0) t_first = b.t_first;
      t_last = b.t_last;
      n += b.n;
      temp_n += b.temp_n;
      acc += b.acc;
      gyro += b.gyro;
      temp += b.temp;
      accel_cue += b.accel_cue;
      energy_cue += b.energy_cue;
    }
    Vector3<Scalar> acc_mean() const { return acc / static_cast<Scalar>(n); }
  };

  static bool check(const RestMonitorSettings<Scalar>& s) {
    const auto positive = [](Scalar x) { return std::isfinite(x) && x > Scalar(0); };
    return positive(s.accel_noise) && std::isfinite(s.gyro_noise) && s.gyro_noise >= Scalar(0) &&
           all_finite(s.gyro_rest_reading) && s.stillness.valid() && positive(s.trim_seconds) &&
           s.trim_seconds <= Scalar(60) && std::isfinite(s.min_rest_seconds) &&
           s.min_rest_seconds >= Scalar(0) && std::isfinite(s.max_rest_seconds) &&
           s.max_rest_seconds >= s.min_rest_seconds && s.max_rest_seconds >= s.trim_seconds &&
           positive(s.max_step_seconds) && s.max_step_seconds <= Scalar(600) &&
           !std::isnan(s.accel_shift_max) && s.accel_shift_max > Scalar(0);
  }

  // In the scalar type: in double on a single-precision FPU it would link the soft-double
  // routines. check() keeps seconds at most 600: float rounds 6e8 us to within 32 us.
  static std::uint32_t to_us(Scalar seconds) {
    return static_cast<std::uint32_t>(std::lround(seconds * Scalar(1e6)));
  }

  // Seconds covered by n samples spanning first..last: the span plus one mean sample interval.
  static Scalar duration(std::uint32_t first, std::uint32_t last, std::uint32_t n) {
    const Scalar span = static_cast<Scalar>(last - first) * Scalar(1e-6);
    if (n < 2) return span;
    return span * static_cast<Scalar>(n) / static_cast<Scalar>(n - 1);
  }

  // A full block: the one before it (still throughout, and followed by a whole still block)
  // joins the rest; this one waits.
  void close_block() {
    if (pending_.n > 0) rest_add(pending_);
    pending_ = block_;
    block_ = Sums{};
  }

  void rest_add(const Sums& b) {
    if (rest_.n > 0) {
      const Vector3<Scalar> shift = b.acc_mean() - rest_.acc_mean();
      const bool tilted =
          std::isfinite(settings_.accel_shift_max) && !(shift.norm() <= settings_.accel_shift_max);
      const bool too_long =
          duration(rest_.t_first, b.t_last, rest_.n + b.n) > settings_.max_rest_seconds;
      if (tilted || too_long) end_rest();
    }
    rest_.append(b);
  }

  // Motion or a gap: the unconfirmed blocks go, but they were still, and count towards the
  // rest's length: the shortest rest handed out is min_rest_seconds of stillness, as in the
  // calibrator.
  void drop_unconfirmed_and_end_rest() {
    const std::uint32_t still_end =
        block_.n > 0 ? block_.t_last : (pending_.n > 0 ? pending_.t_last : rest_.t_last);
    block_ = pending_ = Sums{};
    end_rest(still_end);
  }

  void end_rest() { end_rest(rest_.t_last); }
  void end_rest(std::uint32_t still_end) {
    if (rest_.n == 0) {
      spell_ = Spell{};
      return;
    }
    const Sums r = rest_;
    const Spell ref = spell_;
    rest_ = Sums{};
    if (block_.n == 0 && pending_.n == 0) spell_ = Spell{};  // else a split: the spell goes on
    const Scalar n = static_cast<Scalar>(r.n);
    detector_.learn_rest(r.accel_cue / n, r.energy_cue / n);
    const Scalar d = duration(r.t_first, r.t_last, r.n);
    const Scalar still = static_cast<Scalar>(still_end - r.t_first) * Scalar(1e-6) +
                         (r.n > 1 ? d / n : Scalar(0));  // plus one sample interval
    if (!(still >= settings_.min_rest_seconds)) return;
    RestSummary<Scalar> out;
    out.accel_mean = ref.acc + r.acc / n;
    out.gyro_mean = ref.gyro + r.gyro / n;
    gyro_zero_ = out.gyro_mean;
    out.has_temperature = r.temp_n > 0;
    out.temperature_c =
        r.temp_n > 0 ? ref.temp + r.temp / static_cast<Scalar>(r.temp_n) : Scalar(0);
    out.samples = r.n;
    out.duration_s = d;
    out.begin_us = r.t_first;
    out.end_us = r.t_last;
    if (count_ == Queue) {  // full: the oldest goes
      head_ = (head_ + 1) % Queue;
      --count_;
      ++dropped_;
    }
    queue_[static_cast<std::size_t>((head_ + count_) % Queue)] = out;
    ++count_;
    ++emitted_;
  }

  RestMonitorSettings<Scalar> settings_{};
  bool valid_ = false, started_ = false, have_prev_ = false;
  std::uint32_t block_us_ = 0, step_us_ = 0, t_prev_ = 0;
  StillnessDetector<Scalar> detector_{};
  Vector3<Scalar> a_ref_ = Vector3<Scalar>::Zero();
  Vector3<Scalar> gyro_zero_ = Vector3<Scalar>::Zero();
  Spell spell_{};
  Sums block_{}, pending_{}, rest_{};
  Scalar moving_energy_ = Scalar(0);  // the gyro cue summed over the move so far
  std::uint32_t moving_n_ = 0;
  RestSummary<Scalar> queue_[static_cast<std::size_t>(Queue)] = {};
  int head_ = 0, count_ = 0;
  std::uint32_t dropped_ = 0, emitted_ = 0;
};

}  // namespace imucal
