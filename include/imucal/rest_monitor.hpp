// imucal/rest_monitor.hpp: a small rest detector for the field, after calibration. It watches
// the raw stream (the same ImuSample the calibrator takes) and hands out a RestSummary (mean raw
// readings, mean temperature, length) for each rest it finds, to feed TemperatureFit::add_rest():
// the temperature model keeps improving while the device is in use. Fixed memory (a few hundred
// bytes), a handful of operations per sample, no allocation, no exceptions. Header-only.
//
// How it decides. Samples are grouped in windows of window_seconds. Per window: the sums and sums
// of squares of the accelerometer and gyro readings, re-centred on the window's first reading
// (so float keeps the noise's precision on raw counts ~33000). A window is still when the sum of
// the three per-axis variances is at most accel_var_max for the accelerometer and at most
// gyro_var_max for the gyro, and, if gyro_offset_max is set, its mean gyro reading lies within
// gyro_offset_max (per axis) of gyro_rest_reading: variance alone cannot see a steady turn.
// Consecutive still windows make a rest. Edges are trimmed causally: the first still window
// after motion is dropped (the motion's tail), and each still window joins the rest only when the
// next window is still too, so the window in which motion started is dropped as well. A rest
// therefore loses about two windows: with the defaults a still spell must last about 7 s to give
// a 5 s rest.
//
// A rest ends at motion, at a gap in the timestamps (a step above max_step_seconds), when it
// would exceed max_rest_seconds (a long rest on a slowly warming board yields several
// temperature points), or, if accel_shift_max is set, when a still window's mean accelerometer
// reading has moved from the rest's mean by more than accel_shift_max (a slow tilt that no
// window's variance shows; leave room for the bias's drift over max_rest_seconds: 1 mg/deg C on a
// board warming 2 deg C/min moves the mean by 2 mg in a minute). A rest of at least
// min_rest_seconds is handed out by take(), once.
//
// Setting the thresholds. accel_var_max and gyro_var_max are in raw units squared, the sum over
// the three axes of the per-axis variance of single samples. Take them from the calibration's
// measured noise, a few times over: accel_var_max = k * Calibrator::accel_noise_variance().sum()
// with k = 4 to 10 (the window variance of a still unit scatters by about sqrt(2/n) of itself, n
// samples per window, so k = 4 is safe from 25 samples per window), and gyro_var_max likewise
// from the gyro's per-axis variance at the initial rest (the calibrator does not expose it yet:
// measure it over a known rest, or take k times the square of the datasheet's noise density times
// sqrt(rate)). Real vibration (a running engine) raises the variance: such periods are simply not
// rests.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "imucal/calibrator.hpp"
#include "imucal/normal_equations.hpp"
#include "imucal/status.hpp"
#include "imucal/temperature_model.hpp"

namespace imucal {

template <typename Scalar>
struct RestMonitorSettings {
  Scalar window_seconds = Scalar(1);
  // Raw units squared, sum over the axes of the per-axis sample variance (see above). NaN: not
  // set, and add() refuses every sample with kInvalidArgument.
  Scalar accel_var_max = std::numeric_limits<Scalar>::quiet_NaN();
  Scalar gyro_var_max = std::numeric_limits<Scalar>::quiet_NaN();
  Scalar min_rest_seconds = Scalar(5);    // a shorter rest is not handed out
  Scalar max_rest_seconds = Scalar(60);   // a longer one is split
  Scalar max_step_seconds = Scalar(0.5);  // a larger timestamp step is a gap: the rest ends
  // Optional: largest distance (raw units) of a still window's mean accelerometer reading from
  // the rest's mean before the rest is ended and a new one begun. Infinity: not checked.
  Scalar accel_shift_max = std::numeric_limits<Scalar>::infinity();
  // Optional: the raw gyro reading at zero rate (minus the calibration's bias) and how far (per
  // axis, raw units) a still window's mean may be from it. Infinity: not checked. Leave room for
  // the bias's drift with temperature.
  Vector3<Scalar> gyro_rest_reading = Vector3<Scalar>::Zero();
  Scalar gyro_offset_max = std::numeric_limits<Scalar>::infinity();
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
      window_us_ = to_us(settings.window_seconds);
      step_us_ = to_us(settings.max_step_seconds);
    }
    have_prev_ = false;
    t_prev_ = 0;
    window_ = Window{};
    pending_ = Window{};
    have_pending_ = false;
    after_motion_ = false;
    rest_ = Rest{};
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
    if (have_prev_) {
      const std::int32_t d = static_cast<std::int32_t>(s.t_us - t_prev_);
      if (d == 0) return Status::kTimeRepeated;
      if (d < 0) return Status::kTimeBackwards;
      if (static_cast<std::uint32_t>(d) > step_us_) {
        // The spell before the gap is cut short: its partial window and the unconfirmed one go.
        window_ = Window{};
        have_pending_ = false;
        end_rest();
        result = Status::kTimestampGap;
      }
    }
    if (window_.n > 0 && s.t_us - window_.t_first >= window_us_) close_window();
    window_.add(s);
    t_prev_ = s.t_us;
    have_prev_ = true;
    return result;
  }

  // The stream ended (or the caller wants what is there now): the unconfirmed still window joins
  // the rest (no motion followed it), the partial window is dropped, and the rest in progress is
  // handed out if long enough.
  void finish() {
    window_ = Window{};
    if (have_pending_) commit(pending_);
    have_pending_ = false;
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

 private:
  // Sums of one window, re-centred on its first reading (and first temperature).
  struct Window {
    std::uint32_t n = 0, temp_n = 0;
    std::uint32_t t_first = 0, t_last = 0;
    Vector3<Scalar> acc_ref = Vector3<Scalar>::Zero(), acc_sum = Vector3<Scalar>::Zero(),
                    acc_sq = Vector3<Scalar>::Zero();
    Vector3<Scalar> gyro_ref = Vector3<Scalar>::Zero(), gyro_sum = Vector3<Scalar>::Zero(),
                    gyro_sq = Vector3<Scalar>::Zero();
    Scalar temp_ref = Scalar(0), temp_sum = Scalar(0);

    void add(const ImuSample<Scalar>& s) {
      if (n == 0) {
        t_first = s.t_us;
        acc_ref = s.acc;
        gyro_ref = s.gyro;
      }
      t_last = s.t_us;
      ++n;
      const Vector3<Scalar> da = s.acc - acc_ref, dg = s.gyro - gyro_ref;
      acc_sum += da;
      acc_sq += da.cwiseProduct(da);
      gyro_sum += dg;
      gyro_sq += dg.cwiseProduct(dg);
      if (!std::isnan(s.temperature)) {
        if (temp_n == 0) temp_ref = s.temperature;
        temp_sum += s.temperature - temp_ref;
        ++temp_n;
      }
    }
    Scalar count() const { return static_cast<Scalar>(n); }
    Vector3<Scalar> acc_mean() const { return acc_ref + acc_sum / count(); }
    Vector3<Scalar> gyro_mean() const { return gyro_ref + gyro_sum / count(); }
    static Scalar variance_sum(const Vector3<Scalar>& sum, const Vector3<Scalar>& sq, Scalar n) {
      const Vector3<Scalar> m = sum / n;
      return (sq / n - m.cwiseProduct(m)).cwiseMax(Scalar(0)).sum();
    }
  };

  // A rest in progress: sums relative to its first window's references.
  struct Rest {
    std::uint32_t n = 0, temp_n = 0;
    std::uint32_t t_first = 0, t_last = 0;
    Vector3<Scalar> acc_ref = Vector3<Scalar>::Zero(), acc_sum = Vector3<Scalar>::Zero();
    Vector3<Scalar> gyro_ref = Vector3<Scalar>::Zero(), gyro_sum = Vector3<Scalar>::Zero();
    Scalar temp_ref = Scalar(0), temp_sum = Scalar(0);
    Vector3<Scalar> acc_mean() const { return acc_ref + acc_sum / static_cast<Scalar>(n); }
  };

  static bool check(const RestMonitorSettings<Scalar>& s) {
    const auto positive = [](Scalar x) { return std::isfinite(x) && x > Scalar(0); };
    return positive(s.window_seconds) && s.window_seconds <= Scalar(600) &&
           positive(s.accel_var_max) && positive(s.gyro_var_max) &&
           std::isfinite(s.min_rest_seconds) && s.min_rest_seconds >= Scalar(0) &&
           std::isfinite(s.max_rest_seconds) && s.max_rest_seconds >= s.window_seconds &&
           positive(s.max_step_seconds) && s.max_step_seconds <= Scalar(600) &&
           all_finite(s.gyro_rest_reading) && !std::isnan(s.gyro_offset_max) &&
           s.gyro_offset_max > Scalar(0) && !std::isnan(s.accel_shift_max) &&
           s.accel_shift_max > Scalar(0);
  }

  static std::uint32_t to_us(Scalar seconds) {
    return static_cast<std::uint32_t>(std::lround(static_cast<double>(seconds) * 1e6));
  }

  // Seconds covered by n samples spanning first..last: the span plus one mean sample interval.
  static Scalar duration(std::uint32_t first, std::uint32_t last, std::uint32_t n) {
    const Scalar span = static_cast<Scalar>(last - first) * Scalar(1e-6);
    if (n < 2) return span;
    return span * static_cast<Scalar>(n) / static_cast<Scalar>(n - 1);
  }

  bool still(const Window& w) const {
    if (w.n < 2) return false;
    const Scalar n = w.count();
    if (!(Window::variance_sum(w.acc_sum, w.acc_sq, n) <= settings_.accel_var_max)) return false;
    if (!(Window::variance_sum(w.gyro_sum, w.gyro_sq, n) <= settings_.gyro_var_max)) return false;
    if (std::isfinite(settings_.gyro_offset_max)) {
      const Vector3<Scalar> off = w.gyro_mean() - settings_.gyro_rest_reading;
      if (!(off.cwiseAbs().maxCoeff() <= settings_.gyro_offset_max)) return false;
    }
    return true;
  }

  void close_window() {
    const Window w = window_;
    window_ = Window{};
    if (!still(w)) {
      have_pending_ = false;  // the window in which the motion began: trimmed
      end_rest();
      after_motion_ = true;
      return;
    }
    if (after_motion_) {  // the motion's tail: trimmed
      after_motion_ = false;
      return;
    }
    if (have_pending_) commit(pending_);
    pending_ = w;
    have_pending_ = true;
  }

  void commit(const Window& w) {
    if (rest_.n > 0) {
      const Vector3<Scalar> shift = w.acc_mean() - rest_.acc_mean();
      const bool tilted =
          std::isfinite(settings_.accel_shift_max) && !(shift.norm() <= settings_.accel_shift_max);
      const bool too_long =
          duration(rest_.t_first, w.t_last, rest_.n + w.n) > settings_.max_rest_seconds;
      if (tilted || too_long) end_rest();
    }
    if (rest_.n == 0) {
      rest_ = Rest{};
      rest_.t_first = w.t_first;
      rest_.acc_ref = w.acc_ref;
      rest_.gyro_ref = w.gyro_ref;
      rest_.temp_ref = w.temp_ref;
    }
    const Scalar n = w.count();
    rest_.acc_sum += w.acc_sum + n * (w.acc_ref - rest_.acc_ref);
    rest_.gyro_sum += w.gyro_sum + n * (w.gyro_ref - rest_.gyro_ref);
    if (w.temp_n > 0) {
      if (rest_.temp_n == 0) rest_.temp_ref = w.temp_ref;
      rest_.temp_sum += w.temp_sum + static_cast<Scalar>(w.temp_n) * (w.temp_ref - rest_.temp_ref);
      rest_.temp_n += w.temp_n;
    }
    rest_.n += w.n;
    rest_.t_last = w.t_last;
  }

  void end_rest() {
    if (rest_.n == 0) return;
    const Rest r = rest_;
    rest_ = Rest{};
    const Scalar d = duration(r.t_first, r.t_last, r.n);
    if (!(d >= settings_.min_rest_seconds)) return;
    RestSummary<Scalar> out;
    const Scalar n = static_cast<Scalar>(r.n);
    out.accel_mean = r.acc_ref + r.acc_sum / n;
    out.gyro_mean = r.gyro_ref + r.gyro_sum / n;
    out.has_temperature = r.temp_n > 0;
    out.temperature_c =
        r.temp_n > 0 ? r.temp_ref + r.temp_sum / static_cast<Scalar>(r.temp_n) : Scalar(0);
    out.samples = r.n;
    out.duration_s = d;
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
  bool valid_ = false;
  std::uint32_t window_us_ = 0, step_us_ = 0;
  bool have_prev_ = false;
  std::uint32_t t_prev_ = 0;
  Window window_{};
  Window pending_{};
  bool have_pending_ = false;
  bool after_motion_ = false;
  Rest rest_{};
  RestSummary<Scalar> queue_[static_cast<std::size_t>(Queue)] = {};
  int head_ = 0, count_ = 0;
  std::uint32_t dropped_ = 0, emitted_ = 0;
};

}  // namespace imucal
