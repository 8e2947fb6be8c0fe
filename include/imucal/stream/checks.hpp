// SPDX-License-Identifier: MIT
// imucal/stream/checks.hpp: the checks every raw sample passes before anything uses it, and the
// front end that runs them (StreamChecks): readings finite and inside the full scale, timestamps
// in order, a clock that went back and stayed back, gaps, a frozen sensor, the sample rate
// against the nominal one, the temperature's range and running mean. Each check is a few bytes
// of state and a few instructions a sample. Every calibrator and the rest monitor take their
// samples through it, so every bad sample gets the same status and count everywhere.
// Header-only, no allocation.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "imucal/status.hpp"
#include "imucal/types.hpp"

namespace imucal {

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

// Each count's key (JSON, Python) and label (a person's summary), in the struct's order: the one
// place these names are written.
struct StreamCountName {
  const char* key;
  const char* label;
  std::uint32_t StreamCounts::*count;
};
inline constexpr StreamCountName kStreamCountNames[] = {
    {"non_finite", "non-finite", &StreamCounts::non_finite},
    {"accel_saturated", "accel saturated", &StreamCounts::accel_saturated},
    {"gyro_saturated", "gyro saturated", &StreamCounts::gyro_saturated},
    {"frozen", "frozen", &StreamCounts::frozen},
    {"time_repeated", "repeated time", &StreamCounts::time_repeated},
    {"time_backwards", "backwards time", &StreamCounts::time_backwards},
    {"clock_resets", "clock resets", &StreamCounts::clock_resets},
    {"gaps", "gaps", &StreamCounts::gaps},
    {"rate_off", "rate off", &StreamCounts::rate_off},
    {"busy", "busy", &StreamCounts::busy},
    {"glitches", "accelerometer glitches (refused)", &StreamCounts::glitches},
    {"temperature_bad", "temperatures ignored", &StreamCounts::temperature_bad},
};

// A sensor's full-scale limits [lo, hi] on every axis, tested first as a ball: centred in the
// box, a radius a little inside its half-width, so that a reading in it is inside the limits on
// every axis despite rounding (and NaN is never in it). Only a reading outside the ball is
// tested exactly.
template <typename Scalar>
struct FullScale {
  Scalar lo = -std::numeric_limits<Scalar>::infinity();
  Scalar hi = std::numeric_limits<Scalar>::infinity();
  Scalar centre = Scalar(0);
  Scalar radius2 = Scalar(-1);  // < 0: an empty ball (every reading tested exactly)

  void set(Scalar lo_in, Scalar hi_in) {
    lo = lo_in;
    hi = hi_in;
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

  // Surely finite and inside the limits (false: test exactly).
  bool in_ball(const Vector3<Scalar>& v) const {
    return (v.array() - centre).matrix().squaredNorm() < radius2;
  }

  // Any axis at or beyond the limits (for a finite reading).
  bool outside(const Vector3<Scalar>& v) const {
    return v(0) <= lo || v(0) >= hi || v(1) <= lo || v(1) >= hi || v(2) <= lo || v(2) >= hi;
  }
};

// The same reading on every axis (finite readings). Compared axis by axis, the first that
// differs ends it: on a live sensor that is nearly always the first.
template <typename Scalar>
bool same_reading(const Vector3<Scalar>& a, const Vector3<Scalar>& b) {
  return a(0) == b(0) && a(1) == b(1) && a(2) == b(2);
}

// Timestamps behind the clock: a reset once `needed` of them came in order with normal steps
// between them, a stray timestamp otherwise.
class ClockResetWatch {
 public:
  void reset() {
    run_ = 0;
    t_ = 0;
  }
  // A sample in order: the run behind the clock is over.
  void in_order() { run_ = 0; }
  // A sample at t, behind the clock. True: the clock was reset (the run starts again).
  bool went_back(std::uint32_t t, std::uint32_t max_step_us, int needed) {
    const std::int32_t since = static_cast<std::int32_t>(t - t_);
    if (run_ > 0 && since > 0 && static_cast<std::uint32_t>(since) <= max_step_us)
      ++run_;
    else
      run_ = 1;
    t_ = t;
    if (run_ < needed) return false;
    run_ = 0;
    return true;
  }

 private:
  int run_ = 0;          // consecutive samples behind the clock
  std::uint32_t t_ = 0;  // the latest of them
};

// The rate over each second of the stream against the nominal one.
class RateWatch {
 public:
  // The stream starts (again): no window open.
  void restart() {
    us_ = 0;
    n_ = 0;
  }
  // One sample, step_us after the previous one. True when a window just closed with a rate
  // further than `tolerance` (relative) from `nominal_hz`.
  template <typename Scalar>
  bool off(std::uint32_t step_us, Scalar nominal_hz, Scalar tolerance) {
    us_ += step_us;
    ++n_;
    if (us_ < 1000000u) return false;
    const Scalar rate = static_cast<Scalar>(n_ - 1) * Scalar(1e6) /
                        static_cast<Scalar>(us_);  // intervals over their span
    us_ = 0;
    n_ = 1;  // this sample opens the next window
    return !(std::abs(rate / nominal_hz - Scalar(1)) <= tolerance);
  }

 private:
  std::uint32_t us_ = 0;  // the open window's span
  std::uint32_t n_ = 0;   // and its samples
};

// Running mean of the temperature: re-centred on the first reading, summed exactly in fixed point
// (1/4096 deg C).
template <typename Scalar>
class TemperatureMean {
 public:
  void reset() { *this = TemperatureMean{}; }
  void add(Scalar t) { add_q(detail::to_temperature_q(t)); }
  // A reading in 1/4096 deg C (detail::to_temperature_q()).
  void add_q(std::int32_t q) {
    if (!has_ref_) {  // the first reading ever: the count wraps, the reference stays
      ref_q_ = q;
      has_ref_ = true;
    }
    sum_q_ += q - ref_q_;
    ++n_;
  }
  // The first reading: sums elsewhere (a block's, a rest's) are relative to it.
  Scalar ref() const { return detail::from_temperature_q<Scalar>(ref_q_); }
  std::int32_t ref_q() const { return ref_q_; }
  // The readings so far, relative to ref(), summed.
  Scalar sum() const {
    return detail::to_scalar<Scalar>(sum_q_) * Scalar(1.0 / detail::kTemperatureQ);
  }
  // How many readings came (a new one changes it).
  std::uint32_t count() const { return n_; }
  // The readings so far, relative to ref_q(), summed (1/4096 deg C).
  std::int64_t sum_q() const { return sum_q_; }
  // False if no reading came.
  bool mean(Scalar& out) const {
    if (n_ == 0) return false;
    out = ref() + sum() / static_cast<Scalar>(n_);
    return true;
  }

 private:
  std::int32_t ref_q_ = 0;
  std::int64_t sum_q_ = 0;
  bool has_ref_ = false;
  std::uint32_t n_ = 0;
};

// The front end's settings: what a sample must be to be taken. Every limit in raw units or
// seconds.
template <typename Scalar>
struct StreamSettings {
  // false: the stream carries no gyro (its readings are ignored).
  bool has_gyro = true;
  // A step above gap_factor x the period is a gap (the calibrator's period is the mean it
  // measured at its initial rest, the rest monitor's the nominal one, 1 / nominal_rate_hz); a step
  // above max_step_seconds is one whatever the period.
  Scalar gap_factor = Scalar(5);
  Scalar max_step_seconds = Scalar(0.5);
  Scalar frozen_seconds = Scalar(0.5);  // identical readings this long: sensor frozen
  // Temperature readings outside this range (deg C; compared in 1/4096 deg C, limits beyond
  // +-4096 deg C taken as +-4096), or not finite (NaN means "no sensor"), are ignored and counted;
  // the sample is taken.
  Scalar temperature_min_c = Scalar(-60), temperature_max_c = Scalar(150);
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

  // The largest step that is not a gap, in seconds, for a stream of this period (0: unknown).
  Scalar gap_seconds(Scalar period) const {
    return period > Scalar(0) && gap_factor * period < max_step_seconds ? gap_factor * period
                                                                        : max_step_seconds;
  }

  bool valid() const {
    return gap_factor > Scalar(1) && max_step_seconds > Scalar(0) &&
           // Durations become microseconds in uint32: keep them far from 2^32 us (71 min).
           max_step_seconds <= Scalar(600) && frozen_seconds > Scalar(0) &&
           frozen_seconds <= Scalar(600) && temperature_min_c < temperature_max_c &&
           clock_reset_samples >= 1 && !(accel_min != accel_min) && !(accel_max != accel_max) &&
           !(gyro_min != gyro_min) && !(gyro_max != gyro_max) && nominal_rate_hz >= Scalar(0) &&
           rate_tolerance > Scalar(0);
  }
};

// Whether the front end let a sample through: kOk, or one of its notes (the sample is taken
// with it). Every other status it returns is a refusal.
constexpr bool sample_taken(Status s) {
  return s == Status::kOk || s == Status::kTimestampGap || s == Status::kClockReset ||
         s == Status::kAccelSaturated || s == Status::kSampleRateOff ||
         s == Status::kTemperatureImplausible;
}

// What the front end made of a sample it let through.
template <typename Scalar>
struct CheckedSample {
  std::uint32_t step_us = 0;       // since the previous sample taken (0: the stream starts here)
  Scalar temperature = Scalar(0);  // deg C; NaN: none, or ignored as implausible
  // The same relative to the running mean's first reading, in 1/4096 deg C (if not NaN).
  std::int32_t temperature_q = 0;
  bool acc_saturated = false;  // the accelerometer at full scale: the sample says no rest

  bool has_temperature() const { return !detail::is_nan(temperature); }

  Scalar dt() const { return static_cast<Scalar>(step_us) * Scalar(1e-6); }  // step_us in s
};

// The front end. check() passes or refuses each sample and tells the consumer (a sink with two
// calls) when the stream was cut: sink.stream_cut() before a sample that cannot be joined to the
// one before it (a gap, a clock reset, a gyro at full scale: nothing may be integrated across),
// sink.sensor_froze() when a sensor starts repeating itself (what came since it froze is
// suspect). A sample the consumer then takes is remembered with accept(); one it refuses
// (a glitch) with refuse().
template <typename Scalar>
class StreamChecks {
 public:
  // Starts again with new settings. The consumer checks them (StreamSettings::valid()) and
  // refuses every sample while they are not valid: check() assumes they are.
  void reset(const StreamSettings<Scalar>& s) {
    has_gyro_ = s.has_gyro;
    frozen_limit_us_ = detail::seconds_to_us(s.frozen_seconds);
    // Limits within +-4096 deg C: a reading that saturated the conversion (infinity) is outside
    // them, and two readings inside differ by at most 2^25 (a 48-bit sum, SubBlockTemperature).
    temperature_min_q_ = clamp_temperature_limit(detail::to_temperature_q(s.temperature_min_c));
    temperature_max_q_ = clamp_temperature_limit(detail::to_temperature_q(s.temperature_max_c));
    nominal_rate_ = s.nominal_rate_hz;
    check_rate_ = s.nominal_rate_hz > Scalar(0);
    rate_tolerance_ = s.rate_tolerance;
    clock_reset_samples_ = s.clock_reset_samples;
    acc_scale_.set(s.accel_min, s.accel_max);
    set_counts_range(int_floor(s.accel_min), int_ceil(s.accel_max), acc_lo1_, acc_span_);
    if (s.has_gyro) {
      gyro_scale_.set(s.gyro_min, s.gyro_max);
      set_counts_range(int_floor(s.gyro_min), int_ceil(s.gyro_max), gyro_lo1_, gyro_span_);
    } else {  // no gyro: the zeros that stand for its readings are never at a limit
      gyro_scale_.set(-std::numeric_limits<Scalar>::infinity(),
                      std::numeric_limits<Scalar>::infinity());
      set_counts_range(-65536, 65536, gyro_lo1_, gyro_span_);
    }
    have_prev_ = false;
    restart_ = true;
    frozen_ = false;
    frozen_us_ = 0;
    t_prev_ = 0;
    raw_prev_ = RawFrame{};
    acc_prev_.setZero();
    gyro_prev_.setZero();
    clock_.reset();
    rate_.restart();
    temperature_.reset();
    counts_ = StreamCounts{};
    refused_ = 0;
    last_event_ = Status::kOk;
  }

  // The largest step that is not a gap, in microseconds (the consumer sets it from the period).
  void set_gap_limit(std::uint32_t us) { gap_us_ = us; }
  std::uint32_t gap_limit() const { return gap_us_; }

  // One sample. Taken (out filled; the consumer then accepts or refuses it): kOk, or a note:
  // kTimestampGap, kClockReset, kAccelSaturated, kSampleRateOff, kTemperatureImplausible.
  // Refused (nothing of the consumer's changes, but the sink calls): kNonFiniteInput,
  // kTimeRepeated, kTimeBackwards, kSensorFrozen, kGyroSaturated. Inlined into the consumer's
  // per-sample path (out of line it would pass the sample and its result through memory); the rare
  // paths are out of line.
  template <class Sink>
  __attribute__((always_inline)) Status check(const ImuSample<Scalar>& s, Sink& sink,
                                              CheckedSample<Scalar>& out) {
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
    return check_stream(s, s.temperature, gyro_saturated, acc_saturated, sink, out);
  }

  // One frame of 16-bit counts and the temperature with it (NaN: none): as check().
  template <class Sink>
  __attribute__((always_inline)) Status check(const RawFrame& f, Scalar temperature, Sink& sink,
                                              CheckedSample<Scalar>& out) {
    // Saturated: at or beyond a limit, lo < x < hi failing as one unsigned compare per axis.
    const bool acc_saturated =
        (outside(f.acc[0], acc_lo1_, acc_span_) | outside(f.acc[1], acc_lo1_, acc_span_) |
         outside(f.acc[2], acc_lo1_, acc_span_)) != 0;
    const bool gyro_saturated =
        (outside(f.gyro[0], gyro_lo1_, gyro_span_) | outside(f.gyro[1], gyro_lo1_, gyro_span_) |
         outside(f.gyro[2], gyro_lo1_, gyro_span_)) != 0;
    return check_stream(f, temperature, gyro_saturated, acc_saturated, sink, out);
  }

  // The sample check() let through was taken: the next is ordered against it.
  void accept(const ImuSample<Scalar>& s) {
    acc_prev_ = s.acc;
    gyro_prev_ = s.gyro;
    t_prev_ = s.t_us;
    have_prev_ = true;
  }
  void accept(const RawFrame& f) {
    raw_prev_ = f;
    t_prev_ = f.t_us;
    have_prev_ = true;
  }

 private:
  // Whether either sensor repeats its previous reading exactly.
  bool repeats(const ImuSample<Scalar>& s) const {
    return same_reading(s.acc, acc_prev_) || (has_gyro_ && same_reading(s.gyro, gyro_prev_));
  }
  bool repeats(const RawFrame& f) const {
    const RawFrame& p = raw_prev_;
    // Short-circuit: a live sensor differs at the first axis almost always.
    return (f.acc[0] == p.acc[0] && f.acc[1] == p.acc[1] && f.acc[2] == p.acc[2]) ||
           (has_gyro_ && f.gyro[0] == p.gyro[0] && f.gyro[1] == p.gyro[1] &&
            f.gyro[2] == p.gyro[2]);
  }

  static std::int32_t clamp_temperature_limit(std::int32_t q) {
    constexpr std::int32_t kLimit = 4096 * detail::kTemperatureQ;
    return q > kLimit ? kLimit : (q < -kLimit ? -kLimit : q);
  }

  // The counts strictly between lo and hi, as x - lo1 < span in unsigned arithmetic.
  static void set_counts_range(std::int32_t lo, std::int32_t hi, std::int32_t& lo1,
                               std::uint32_t& span) {
    lo1 = lo + 1;
    span = hi - lo > 1 ? static_cast<std::uint32_t>(hi - lo - 1) : 0u;
  }
  static int outside(std::int32_t x, std::int32_t lo1, std::uint32_t span) {
    return static_cast<std::uint32_t>(x - lo1) >= span ? 1 : 0;
  }

  // The checks of the stream itself, after the readings' own.
  template <class Sink, class Frame>
  __attribute__((always_inline)) Status check_stream(const Frame& s, Scalar temperature,
                                                     bool gyro_saturated, bool acc_saturated,
                                                     Sink& sink, CheckedSample<Scalar>& out) {
    std::int32_t step = 0;
    Status result = Status::kOk;
    if (have_prev_) {
      step = static_cast<std::int32_t>(s.t_us - t_prev_);
      if (step == 0) {
        ++counts_.time_repeated;
        return refuse(Status::kTimeRepeated);
      }
      if (step < 0) {
        result = behind_clock(s.t_us, sink);
        if (result != Status::kClockReset) return result;
      }
    }
    clock_.in_order();
    // Frozen: either sensor's reading the same as its previous one for frozen_seconds. A gap's
    // step is not time the sensor was seen repeating itself (one repeat across a stall is a
    // quantised reading, and the gap is what the sample says); a spell already frozen goes on.
    if (have_prev_ && !restart_ && repeats(s)) {
      // Saturating: a spell longer than the clock's 71.6 minutes stays frozen.
      const std::uint32_t room = 0xFFFFFFFFu - frozen_us_;
      const std::uint32_t seen =
          static_cast<std::uint32_t>(step) <= gap_us_ ? static_cast<std::uint32_t>(step) : 0u;
      frozen_us_ += seen < room ? seen : room;
      t_prev_ = s.t_us;
      if (frozen_us_ >= frozen_limit_us_) {
        if (!frozen_) {
          last_event_ = Status::kSensorFrozen;
          sink.sensor_froze();
        }
        frozen_ = true;
        ++counts_.frozen;
        ++refused_;
        return Status::kSensorFrozen;
      }
    } else if (frozen_us_ > 0) {
      frozen_us_ = 0;
      if (frozen_) {
        frozen_ = false;
        restart_ = true;  // the stream starts again after the frozen spell
      }
    }
    if (gyro_saturated) return gyro_at_full_scale(s, sink);
    if (!restart_ && static_cast<std::uint32_t>(step) > gap_us_) {
      ++counts_.gaps;
      sink.stream_cut();
      result = last_event_ = Status::kTimestampGap;
      restart_ = true;
    }
    if (restart_) {  // first sample after a start, a gap or a reset: no interval
      step = 0;
      restart_ = false;
      rate_.restart();
    }
    std::int32_t temperature_q = 0;
    if (!detail::is_nan(temperature)) {  // NaN: no temperature sensor
      const std::int32_t q = detail::to_temperature_q(temperature);
      if (q >= temperature_min_q_ && q <= temperature_max_q_) {
        temperature_.add_q(q);
        temperature_q = q - temperature_.ref_q();
      } else {
        ++counts_.temperature_bad;
        temperature = std::numeric_limits<Scalar>::quiet_NaN();
        if (result == Status::kOk) result = last_event_ = Status::kTemperatureImplausible;
      }
    }
    if (acc_saturated) {  // a note: a gap or a clock reset with it is what the status says
      ++counts_.accel_saturated;
      if (result == Status::kOk) result = last_event_ = Status::kAccelSaturated;
    }
    if (check_rate_ &&
        rate_.off(static_cast<std::uint32_t>(step), nominal_rate_, rate_tolerance_)) {
      ++counts_.rate_off;
      last_event_ = Status::kSampleRateOff;
      if (result == Status::kOk) result = Status::kSampleRateOff;
    }
    out.step_us = static_cast<std::uint32_t>(step);
    out.temperature = temperature;
    out.temperature_q = temperature_q;
    out.acc_saturated = acc_saturated;
    return result;
  }

 public:
  // A sample refused by the consumer (counted in refused()); returns s.
  Status refuse(Status s) {
    ++refused_;
    return s;
  }
  // The consumer's own refusals that the counts name. A glitch refused where the stream started
  // again (c.step_us 0: after a gap, a clock reset, a saturated gyro) leaves it to start again at
  // the next sample, which is ordered against this one's time t_us (a reset clock's).
  Status refuse_glitch(const CheckedSample<Scalar>& c, std::uint32_t t_us) {
    if (c.step_us == 0) {
      restart_ = true;
      t_prev_ = t_us;
    }
    ++counts_.glitches;
    last_event_ = Status::kGlitch;
    return refuse(Status::kGlitch);
  }
  Status refuse_busy() {
    ++counts_.busy;
    return refuse(Status::kBusy);
  }

  // The next sample starts the stream again (no interval to the one before).
  void restart() { restart_ = true; }
  // As reset(), within one stream (new settings mid-stream): the next sample is still ordered
  // against the latest one seen, so one behind it is refused or makes a clock reset; it starts
  // the stream again. The counts (counts(), refused()) are the whole stream's and go on.
  void reset_in_stream(const StreamSettings<Scalar>& s) {
    const bool had = have_prev_;
    const std::uint32_t t = t_prev_;
    const StreamCounts counts = counts_;
    const std::uint32_t refused = refused_;
    reset(s);
    have_prev_ = had;
    t_prev_ = t;
    counts_ = counts;
    refused_ = refused;
  }
  // The latest notable event of the stream (the consumer's own too, through note()).
  Status last_event() const { return last_event_; }
  Status note(Status s) { return last_event_ = s; }

  const StreamCounts& counts() const { return counts_; }
  // The temperatures read so far, usable or not (a change: the latest sample's was read).
  std::uint32_t temperatures_read() const { return temperature_.count() + counts_.temperature_bad; }
  std::uint32_t refused() const { return refused_; }
  bool frozen() const { return frozen_; }
  // The running mean of the temperatures taken (TemperatureMean: sums elsewhere are relative
  // to its ref()).
  const TemperatureMean<Scalar>& temperature() const { return temperature_; }

 private:
  // A limit as a count: x <= floor(lo) and x >= ceil(hi) for an integer x are x <= lo and
  // x >= hi; limits outside the 16-bit range are out of reach.
  static std::int32_t int_floor(Scalar lo) {
    if (!(lo > Scalar(-65536))) return -65536;
    if (!(lo < Scalar(65536))) return 65536;
    const std::int32_t i = static_cast<std::int32_t>(lo);
    return static_cast<Scalar>(i) > lo ? i - 1 : i;
  }
  static std::int32_t int_ceil(Scalar hi) { return -int_floor(-hi); }

  // A timestamp behind the clock: refused (kTimeBackwards), or the clock was reset (kClockReset:
  // the sample starts the stream again, as after a gap). Out of line, as every rare path.
  template <class Sink>
  __attribute__((noinline)) Status behind_clock(std::uint32_t t_us, Sink& sink) {
    if (!clock_.went_back(t_us, gap_us_, clock_reset_samples_)) {
      ++counts_.time_backwards;
      return refuse(Status::kTimeBackwards);
    }
    ++counts_.clock_resets;
    sink.stream_cut();
    restart_ = true;
    return last_event_ = Status::kClockReset;
  }

  // A gyro at full scale: the rotation over this interval is unknown, nothing can be integrated
  // across it. Refused; it is the sample the next is ordered against.
  template <class Sink, class Frame>
  __attribute__((noinline)) Status gyro_at_full_scale(const Frame& s, Sink& sink) {
    accept(s);
    ++counts_.gyro_saturated;
    if (!restart_) sink.stream_cut();
    restart_ = true;
    last_event_ = Status::kGyroSaturated;
    return refuse(Status::kGyroSaturated);
  }

  bool has_gyro_ = true;
  bool have_prev_ = false;  // t_prev_ holds a time to order against
  bool restart_ = true;     // the next sample taken starts the stream (no interval)
  bool frozen_ = false;
  std::uint32_t t_prev_ = 0, gap_us_ = 0;
  Vector3<Scalar> acc_prev_ = Vector3<Scalar>::Zero(), gyro_prev_ = Vector3<Scalar>::Zero();
  FullScale<Scalar> acc_scale_{}, gyro_scale_{};
  std::uint32_t frozen_us_ = 0, frozen_limit_us_ = 0;
  RawFrame raw_prev_{};
  // The full scale for 16-bit counts: a count at or beyond a limit (lo, hi) is saturated; kept as
  // lo + 1 and the span hi - lo - 1 of the counts that are not.
  std::int32_t acc_lo1_ = -65535, gyro_lo1_ = -65535;
  std::uint32_t acc_span_ = 131071, gyro_span_ = 131071;
  std::int32_t temperature_min_q_ = 0, temperature_max_q_ = 0;  // the range, 1/4096 deg C
  Scalar nominal_rate_ = Scalar(0), rate_tolerance_ = Scalar(0);
  bool check_rate_ = false;  // nominal_rate_ > 0 (a flag: no float compare per sample)
  int clock_reset_samples_ = 3;
  ClockResetWatch clock_{};
  RateWatch rate_{};
  TemperatureMean<Scalar> temperature_{};
  StreamCounts counts_{};
  std::uint32_t refused_ = 0;
  Status last_event_ = Status::kOk;
};

}  // namespace imucal
