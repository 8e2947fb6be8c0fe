// imucal/stream/checks.hpp: the checks every raw sample passes before the calibrator
// uses it: readings inside the full scale, a clock that went back and stayed back, the sample
// rate against the nominal one, and the running mean of the temperature. Each is a few bytes of
// state and a few instructions a sample. Header-only, no allocation.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>

#include "imucal/models/accel_model.hpp"
#include "imucal/stream/compensated_sum.hpp"

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

// Running mean of the temperature: re-centred on the first reading, compensated.
template <typename Scalar>
class TemperatureMean {
 public:
  void reset() { *this = TemperatureMean{}; }
  void add(Scalar t) {
    if (n_ == 0) ref_ = t;
    compensated_add(sum_, comp_, t - ref_);
    ++n_;
  }
  // The first reading: sums elsewhere (a block's, a rest's) are relative to it.
  Scalar ref() const { return ref_; }
  // The readings so far, relative to ref(), summed.
  Scalar sum() const { return sum_ + comp_; }
  std::uint32_t count() const { return n_; }
  // False if no reading came.
  bool mean(Scalar& out) const {
    if (n_ == 0) return false;
    out = ref_ + (sum_ + comp_) / static_cast<Scalar>(n_);
    return true;
  }

 private:
  Scalar ref_ = Scalar(0), sum_ = Scalar(0), comp_ = Scalar(0);
  std::uint32_t n_ = 0;
};

}  // namespace imucal
