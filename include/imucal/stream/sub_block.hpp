// SPDX-License-Identifier: MIT
// imucal/stream/sub_block.hpp: the per-sample work of the stream layer. Each sample updates the
// stillness detector's two moving averages (stillness.hpp) and is summed into a sub-block, all
// still or all moving (a sample whose state differs starts a new one); a sub-block also ends at
// sub_block_seconds, a rotation bound, or SubBlockSamples samples (kStillSubBlockFactor times as
// many while still, so that a still sub-block lasts a block at any rate). The rest of the detector,
// the blocks and the segment statistics then work once per sub-block on its sums (the strapdown
// two-rate design: a cheap fast loop, the float work at a lower rate).
//
// One accumulator (SubBlock) takes the samples in either of two arithmetics, one per stream, both
// through the same per-sample steps into the same SubBlockStats:
//   16-bit counts   integer arithmetic only per sample (the moving averages in fixed point): the
//                   accelerometer's deviations from the detector's reference (their sum exact,
//                   their squares summed; clipped at the detector's clip, the squares feed only
//                   its moving average), the gyro's energy, and the rotation statistics of the
//                   trapezoid rate (alpha, and the second-order terms beta and gamma exactly, in 64
//                   and 32 bits) with an integer part of the bias removed; the fractional part of
//                   the bias is added exactly once per sub-block (detail::RawSums).
//   readings        in any unit, the same sums in the scalar type (the segment statistics sample
//                   by sample, with each sample's own interval; detail::FloatSums).
// The integer path takes the sub-block's mean interval for beta and gamma (second order; alpha
// and the duration are exact whatever the steps).
//
// A still sub-block's rotation statistics are first order in both: alpha and the duration, with
// beta and gamma zero. Within a sub-block beta is at most half its path angle squared and gamma
// vanishes for a steady rate; a still sub-block turns by little (its gyro energy is below the
// detector's threshold) and steadily, so what is left out is far below a move's noise, while
// the cross terms between sub-blocks, which carry a move's second order, are kept
// (GyroSegment::append()). The per-sample cost at rest, most of a device's life, drops by the
// three cross products. Never allocates, throws or blocks. Header-only.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "imucal/stream/gyro_segment.hpp"
#include "imucal/types.hpp"

namespace imucal {

// Most samples in one moving sub-block: the integer sums' bounds (the second-order terms'
// included) hold for this many 16-bit samples.
constexpr int kMaxSubBlockSamples = 32;
// A still sub-block (first order: no second-order terms) may hold this many times as many: its
// sums' bounds hold for kStillSubBlockFactor * kMaxSubBlockSamples (512) 16-bit samples, so that
// at any rate up to 2 kHz a still sub-block lasts a block (0.25 s), as it does at 100 Hz.
constexpr int kStillSubBlockFactor = 16;

// What the detector sets for each sub-block.
template <typename Scalar>
struct SubBlockLimits {
  // The moving averages' thresholds (the accelerometer's variance summed over the axes, the
  // gyro's energy; raw units^2), whether the gyro counts, and one sample's weight for a raw frame
  // (from the expected interval; readings in the scalar type use their own intervals).
  Scalar accel_threshold = std::numeric_limits<Scalar>::infinity();
  Scalar energy_threshold = std::numeric_limits<Scalar>::infinity();
  bool use_gyro = true;
  Scalar seconds = Scalar(0.1);  // the averages' time constant
  Scalar weight = Scalar(0);     // dt / (seconds + dt) at the expected interval
  Vector3<Scalar> acc_ref = Vector3<Scalar>::Zero();             // accelerometer reference (raw)
  Vector3<Scalar> gyro_bias = Vector3<Scalar>::Zero();           // added to every gyro reading (b0)
  Scalar dev_clip = std::numeric_limits<Scalar>::infinity();     // clip of one axis's square
  Scalar energy_clip = std::numeric_limits<Scalar>::infinity();  // clip of one |u|^2
  Scalar glitch2 = std::numeric_limits<Scalar>::infinity();      // a deviation beyond: a glitch
  // sum |u|^2 that closes it (kStillSubBlockFactor times less while still: it may hold that
  // many times as many samples)
  Scalar energy_max = std::numeric_limits<Scalar>::infinity();
  // acc_ref is the accumulator's own moving mean (where its last sample left it): the integer
  // accumulator takes its reference from its fixed-point mean, without a conversion.
  bool acc_ref_is_mean = false;
};

// One sub-block, summed: what the detector and the blocks take.
template <typename Scalar>
struct SubBlockStats {
  bool still = true;              // every sample still (else every sample moving)
  std::uint32_t n = 0;            // samples
  std::uint32_t n_acc = 0;        // of which with a usable accelerometer reading (not saturated)
  std::uint32_t intervals = 0;    // sample intervals (a sample that starts the stream has none)
  std::uint32_t duration_us = 0;  // their sum
  std::uint32_t t_begin = 0, t_end = 0;
  Vector3<Scalar> acc_ref = Vector3<Scalar>::Zero();      // the sums' reference (raw)
  Vector3<Scalar> moving_mean = Vector3<Scalar>::Zero();  // the detector's, after the last sample
  // sum of (a - acc_ref) over the usable readings, scaled to all n samples
  Vector3<Scalar> acc_sum = Vector3<Scalar>::Zero();
  Scalar dev = Scalar(0);       // sum |a - limits.acc_ref|^2 over the usable readings
  Scalar energy = Scalar(0);    // sum |w + b0|^2
  GyroSegment<Scalar> seg{};    // of the trapezoid rate u = w + b0 over the intervals
  Scalar path = Scalar(0);      // a bound on its path angle: duration * rms |u|
  Scalar temp_sum = Scalar(0);  // temperatures relative to the caller's reference
  std::uint32_t temp_n = 0;

  Scalar mean_interval() const {
    return intervals > 0 ? seg.duration / static_cast<Scalar>(intervals) : Scalar(0);
  }
};

// A sub-block's temperatures, in 1/4096 deg C relative to the stream's reference: summed exactly
// in 48 bits (the front end's range check keeps each within 2^25 of the reference, so at most
// kStillSubBlockFactor * kMaxSubBlockSamples of them within 2^34), in the 8 bytes of a 32-bit sum
// and count; converted once a sub-block.
class SubBlockTemperature {
 public:
  void clear() { low_ = 0, high_ = 0, n_ = 0; }
  void add(std::int32_t q) {
    const std::int64_t sum = value() + q;
    low_ = static_cast<std::uint32_t>(sum);
    high_ = static_cast<std::int16_t>(sum >> 32);
    ++n_;
  }
  template <typename Scalar>
  void finish(SubBlockStats<Scalar>& s) const {
    s.temp_sum = detail::from_temperature_q_sum<Scalar>(value());
    s.temp_n = n_;
  }

 private:
  std::int64_t value() const {
    return static_cast<std::int64_t>(high_) * (std::int64_t{1} << 32) +
           static_cast<std::int64_t>(low_);
  }

  std::uint32_t low_ = 0;  // the sum's low 32 bits
  std::int16_t high_ = 0;  // and its high 16
  std::uint16_t n_ = 0;
};

// A sub-block that ended because a sample's state differed (the sample began the next one): the
// accumulator keeps it here until the segmenter takes it, once.
template <typename Scalar>
struct FinishedSubBlock {
  SubBlockStats<Scalar> stats{};
  bool full = false;

  bool take(SubBlockStats<Scalar>& out) {
    if (!full) return false;
    full = false;
    out = stats;
    return true;
  }
  // The sums if held (nullptr if not), without a copy; release() once they were used.
  const SubBlockStats<Scalar>* held() const { return full ? &stats : nullptr; }
  void release() { full = false; }
};

namespace detail {

// Whether a 32 x 32 -> 64-bit multiply is a call into the runtime (ARMv6-M, ARMv8-M Baseline:
// no long multiply instruction). There, products of operands that fit 16 bits take 32 bits.
#if defined(__ARM_ARCH_6M__) || defined(__ARM_ARCH_8M_BASE__)
constexpr bool kLongMultiplyIsACall = true;
#else
constexpr bool kLongMultiplyIsACall = false;
#endif

// acc += a * b - c * d, exact (in 32 bits when the operands allow and a long multiply is a call;
// else two multiply-accumulates: |c| < 2^31 in every use, so -c does not overflow).
inline void cross_add(std::int64_t& acc, std::int32_t a, std::int32_t b, std::int32_t c,
                      std::int32_t d) {
  // All four within 16 bits: one test on the four offset by 2^15.
  const std::uint32_t offset = 0x8000u;
  if (kLongMultiplyIsACall &&
      (((static_cast<std::uint32_t>(a) + offset) | (static_cast<std::uint32_t>(b) + offset) |
        (static_cast<std::uint32_t>(c) + offset) | (static_cast<std::uint32_t>(d) + offset)) >>
       16) == 0u) {
    acc += static_cast<std::int64_t>(a * b) - static_cast<std::int64_t>(c * d);
    return;
  }
  acc += static_cast<std::int64_t>(a) * b;
  acc += static_cast<std::int64_t>(-c) * d;
}

// x as an unsigned 64-bit limit (NaN and values past 2^64: the largest), without the runtime's
// float-to-64-bit conversion (a double-precision routine on cores without an FPU).
template <typename Scalar>
std::uint64_t to_u64_limit(Scalar x) {
  if (!(x < Scalar(1.8e19))) return ~std::uint64_t{0};
  if (!(x > Scalar(0))) return 0;
  const Scalar two32 = Scalar(4294967296.0);
  const std::uint32_t hi = static_cast<std::uint32_t>(x * Scalar(1.0 / 4294967296.0));
  const Scalar rest = x - static_cast<Scalar>(hi) * two32;
  const std::uint32_t lo = rest > Scalar(0) ? static_cast<std::uint32_t>(rest) : 0u;
  return (static_cast<std::uint64_t>(hi) << 32) | lo;
}

inline std::int32_t clamp16(std::int32_t x) {
#if defined(__ARM_FEATURE_SAT)
  // One instruction. The builtin, not arm_acle.h's __ssat: GCC 12's macro converts its unsigned
  // result to int32_t, a -Wsign-conversion warning in every includer.
  return static_cast<std::int32_t>(__builtin_arm_ssat(x, 16));
#else
  return x > 32767 ? 32767 : (x < -32768 ? -32768 : x);
#endif
}

// x limited to +-2^16 counts (NaN: -2^16), twice a 16-bit reading's range, before it is rounded
// to an integer: a bias, a reference or a mean beyond that comes only from readings no frame
// carries (a stream of readings in other units, or hostile ones); the integer sums stay exact
// and the conversion defined.
template <typename Scalar>
Scalar clamp_counts(Scalar x) {
  constexpr Scalar kMax = Scalar(65536);
  return !(x > -kMax) ? -kMax : (x < kMax ? x : kMax);
}

inline std::int32_t round_to_int(double x) {
  return static_cast<std::int32_t>(x < 0 ? x - 0.5 : x + 0.5);
}
inline std::int32_t round_to_int(float x) {
  return static_cast<std::int32_t>(x < 0 ? x - 0.5f : x + 0.5f);
}
// round_to_int(q / 256), in integers.
inline std::int32_t round_q8(std::int32_t q) { return q < 0 ? -((128 - q) >> 8) : (q + 128) >> 8; }

// Whether a and b differ in any bit: integer compares (no soft-float call), for values that
// are copied, never computed, between the compares. On the values' bits in registers: memcmp()
// is a library call on some cores, once for every limit of every sub-block.
inline bool bits_differ(float a, float b) { return bits_of(a) != bits_of(b); }
inline bool bits_differ(double a, double b) { return bits_of(a) != bits_of(b); }
template <typename Scalar>
bool bits_differ(const Vector3<Scalar>& a, const Vector3<Scalar>& b) {
  return bits_differ(a(0), b(0)) || bits_differ(a(1), b(1)) || bits_differ(a(2), b(2));
}

// The arithmetic of readings in the scalar type: the sums and the moving averages sample by
// sample, each sample with its own interval. SubBlock's per-sample steps call it (see there).
template <typename Scalar>
class FloatSums {
 public:
  using Input = ImuSample<Scalar>;
  struct Step {  // the sample's interval and the averages' weight for it
    Scalar dt, w;
  };
  struct Cue {  // the deviations from the moving mean, their squares, their sum and clipped sum
    Scalar d0, d1, d2, q0, q1, q2, dev, clipped;
  };
  struct Rate {  // u = w + b0, |u|^2 (and clipped), the trapezoid's mean rate
    Vector3<Scalar> u, m;
    Scalar e, e_clipped;
  };

  // The previous sample's rate (the trapezoid's other end) moves to the new bias.
  void start(const SubBlockLimits<Scalar>& l, const SubBlockLimits<Scalar>& old) {
    if (bits_differ(l.gyro_bias, old.gyro_bias)) u_prev_ += l.gyro_bias - old.gyro_bias;
  }
  void forget_rate() { u_prev_.setZero(); }
  void set_averages(const Vector3<Scalar>& mean, Scalar accel, Scalar energy) {
    mean_ = mean;
    va_ = accel;
    ee_ = energy;
  }
  void averages(Vector3<Scalar>& mean, Scalar& accel, Scalar& energy,
                const SubBlockLimits<Scalar>& /*l*/) const {
    mean = mean_;
    accel = va_;
    energy = ee_;
  }
  void clear(const SubBlockLimits<Scalar>& l) {
    sums_ = Sums{};
    acc_ref_ = l.acc_ref;
  }

  Step step(std::uint32_t step_us, const SubBlockLimits<Scalar>& l) const {
    const Scalar dt = static_cast<Scalar>(step_us) * Scalar(1e-6);
    return {dt, dt / (l.seconds + dt)};
  }
  void cue(const Input& x, const SubBlockLimits<Scalar>& l, Cue& c) const {
    c.d0 = x.acc(0) - mean_(0), c.d1 = x.acc(1) - mean_(1), c.d2 = x.acc(2) - mean_(2);
    c.q0 = c.d0 * c.d0, c.q1 = c.d1 * c.d1, c.q2 = c.d2 * c.d2;
    c.dev = c.q0 + c.q1 + c.q2;
    const Scalar k = l.dev_clip;
    c.clipped = (c.q0 < k ? c.q0 : k) + (c.q1 < k ? c.q1 : k) + (c.q2 < k ? c.q2 : k);
  }
  static bool glitch(const Cue& c, const SubBlockLimits<Scalar>& l) { return c.dev > l.glitch2; }
  void rate(const Input& x, const SubBlockLimits<Scalar>& l, Rate& r) const {
    r.e = Scalar(0);
#pragma GCC unroll 3
    for (int i = 0; i < 3; ++i) {
      r.u(i) = x.gyro(i) + l.gyro_bias(i);
      r.e += r.u(i) * r.u(i);
      r.m(i) = Scalar(0.5) * (r.u(i) + u_prev_(i));
    }
    r.e_clipped = r.e < l.energy_clip ? r.e : l.energy_clip;
  }
  // The accelerometer's average keeps (1 - w) of itself and the sample's share, the gyro's
  // moves w of the way.
  void follow_accel(const Input& /*x*/, const Cue& c, const Step& h) {
    va_ = (Scalar(1) - h.w) * (va_ + h.w * c.clipped);
    mean_(0) += h.w * c.d0;
    mean_(1) += h.w * c.d1;
    mean_(2) += h.w * c.d2;
  }
  void follow_energy(const Rate& r, const Step& h) { ee_ += h.w * (r.e_clipped - ee_); }
  bool accel_still(const SubBlockLimits<Scalar>& l) const { return va_ <= l.accel_threshold; }
  bool energy_still(const SubBlockLimits<Scalar>& l) const { return ee_ <= l.energy_threshold; }
  void sum_accel(const Input& x, const Cue& c) {
    sums_.acc += x.acc - acc_ref_;
    sums_.dev += c.dev;
  }
  void sum_rate(const Rate& r) { sums_.energy += r.e; }
  void rotate(const Rate& r, const Step& h, bool still, std::uint32_t /*intervals*/) {
    if (still)
      sums_.seg.add_first_order(r.m, h.dt);
    else
      sums_.seg.add(r.m, h.dt);
  }
  void keep_rate(const Rate& r) { u_prev_ = r.u; }
  bool energy_full(const SubBlockLimits<Scalar>& l, bool long_still) const {
    return sums_.energy >
           (long_still ? l.energy_max * Scalar(1.0 / kStillSubBlockFactor) : l.energy_max);
  }

  // The sums into s (whose counts are set).
  void finish(SubBlockStats<Scalar>& s, const SubBlockLimits<Scalar>& /*l*/) const {
    s.acc_ref = acc_ref_;
    s.acc_sum = sums_.acc;
    s.dev = sums_.dev;
    s.energy = sums_.energy;
    s.seg = sums_.seg;
    s.moving_mean = mean_;
  }

 private:
  struct Sums {
    Vector3<Scalar> acc = Vector3<Scalar>::Zero();
    Scalar dev = Scalar(0), energy = Scalar(0);
    GyroSegment<Scalar> seg{};
  };
  Sums sums_{};
  Vector3<Scalar> acc_ref_ = Vector3<Scalar>::Zero();
  Vector3<Scalar> u_prev_ = Vector3<Scalar>::Zero();
  Vector3<Scalar> mean_ = Vector3<Scalar>::Zero();  // the moving mean, sample by sample
  Scalar va_ = Scalar(0), ee_ = Scalar(0);
};

// The arithmetic of 16-bit counts. Every sum is exact in integers: for at most
// kStillSubBlockFactor * kMaxSubBlockSamples samples the accelerometer's sums and the trapezoid's
// P fit 32 bits (its squared deviations clamped at 32767 counts a side, a deviation no rest has),
// the gyro's energy and the steps' correction 64 bits; the second-order terms, summed in moving
// sub-blocks of at most kMaxSubBlockSamples, beta 64 bits and gamma 32 bits. The moving averages
// are fixed point (raw units^2 x 16), with one sample's weight from the expected interval.
template <typename Scalar>
class RawSums {
 public:
  using Input = RawFrame;
  struct Step {
    std::uint32_t us;
  };
  struct Cue {
    // the sums' deviation (from the sub-block's fixed reference); the squares of the cue's (from
    // the moving mean, in sixteenths of a count: 1/256 count^2), their sum and clipped sum
    std::int32_t d0, d1, d2;
    std::uint32_t q0, q1, q2, dev, clipped;
  };
  struct Rate {
    std::int32_t u[3];
    std::uint32_t e, e_clipped;
  };

  // The limits converted. Without hardware floating point a limit is converted only when it
  // differs from the previous sub-block's (most sub-blocks change none but the reference); with
  // it every limit is converted, which costs less than the compares.
  void start(const SubBlockLimits<Scalar>& l, const SubBlockLimits<Scalar>& old) {
    const bool first = !converted_;
    const bool all = first || hardware_float<Scalar>();
    converted_ = true;
    // The bias changes seldom, and its conversion is the dearest: converted only when it does.
    if (first || bits_differ(l.gyro_bias, old.gyro_bias)) {
      db_zero_ = true;
      for (int i = 0; i < 3; ++i) {
        const std::int32_t b = round_to_int(clamp_counts(l.gyro_bias(i)));
        u_prev_[i] += b - bias_[i];  // the trapezoid's other end, moved to the new bias
        bias_[i] = b;
        db_(i) = l.gyro_bias(i) - static_cast<Scalar>(b);
        db_zero_ = db_zero_ && db_(i) == Scalar(0);
      }
      db2_ = db_.squaredNorm();
    }
    if (l.acc_ref_is_mean) {
      for (int i = 0; i < 3; ++i) ref_[i] = round_q8(mean_q8_[i]);
    } else {
      for (int i = 0; i < 3; ++i) ref_[i] = round_to_int(clamp_counts(l.acc_ref(i)));
    }
    // A clip, a glitch limit or a bound beyond what the sums can hold is no clip, limit or bound.
    if (all || bits_differ(l.dev_clip, old.dev_clip))
      dev_clip_q8_ = to_u32_limit(Scalar(256) * l.dev_clip, kDevClipCap);
    if (all || bits_differ(l.energy_clip, old.energy_clip))
      energy_clip_ = to_u32_limit(l.energy_clip, kEnergyClipCap);
    if (all || bits_differ(l.glitch2, old.glitch2))
      glitch2_q8_ = to_u32_limit(Scalar(256) * l.glitch2, 0xFFFFFFFFu);
    if (all || bits_differ(l.energy_max, old.energy_max)) energy_max_ = to_u64_limit(l.energy_max);
    // The averages in fixed point: the accelerometer's as v = variance / (1 - w), which moves
    // w of the way to each sample's share as the gyro's does (rescaled when w changes).
    const bool new_weight = all || bits_differ(l.weight, old.weight);
    const bool new_accel = new_weight || bits_differ(l.accel_threshold, old.accel_threshold);
    const bool new_energy = all || bits_differ(l.energy_threshold, old.energy_threshold);
    const Scalar w_old = weight(old), w = weight(l);
    if (new_weight) {
      if (w != w_old)
        va_q8_ = static_cast<std::int32_t>(to_u32_limit(
            static_cast<Scalar>(va_q8_) * (Scalar(1) - w_old) / (Scalar(1) - w), 0x7FFFFFFFu));
      weight_q16_ = static_cast<std::int32_t>(w * Scalar(65536));
      // |d| <= fit_ keeps d * weight_q16_ within 31 bits (read only where a long multiply is a
      // call).
      if constexpr (kLongMultiplyIsACall) {
        fit_ = weight_q16_ > 0 ? 0x7FFFFFFFu / static_cast<std::uint32_t>(weight_q16_) : 0u;
        fit_ = fit_ < (1u << 30) ? fit_ : (1u << 30);
      }
    }
    if (new_accel)
      accel_max_q8_ = static_cast<std::int32_t>(
          to_u32_limit(Scalar(256) * l.accel_threshold / (Scalar(1) - w), 0x7FFFFFFFu));
    if (new_energy)
      energy_max_q4_ =
          static_cast<std::int32_t>(to_u32_limit(Scalar(16) * l.energy_threshold, 0x7FFFFFFFu));
  }
  // The next start() converts every limit.
  void stale() { converted_ = false; }
  void forget_rate() { u_prev_[0] = u_prev_[1] = u_prev_[2] = 0; }
  void set_averages(const Vector3<Scalar>& mean, Scalar accel, Scalar energy,
                    const SubBlockLimits<Scalar>& l) {
    for (int i = 0; i < 3; ++i) mean_q8_[i] = round_to_int(Scalar(256) * clamp_counts(mean(i)));
    va_q8_ = static_cast<std::int32_t>(
        to_u32_limit(Scalar(256) * accel / (Scalar(1) - weight(l)), 0x7FFFFFFFu));
    ee_q4_ = static_cast<std::int32_t>(to_u32_limit(Scalar(16) * energy, 0x7FFFFFFFu));
  }
  // set_averages()'s inverse.
  void averages(Vector3<Scalar>& mean, Scalar& accel, Scalar& energy,
                const SubBlockLimits<Scalar>& l) const {
    for (int i = 0; i < 3; ++i) mean(i) = static_cast<Scalar>(mean_q8_[i]) * Scalar(1.0 / 256);
    accel = static_cast<Scalar>(va_q8_) * (Scalar(1) - weight(l)) * Scalar(1.0 / 256);
    energy = static_cast<Scalar>(ee_q4_) * Scalar(1.0 / 16);
  }
  // Written out member by member: a loop here becomes a call to memset, costlier than the stores.
  void clear(const SubBlockLimits<Scalar>& /*l*/) {
    s1_[0] = s1_[1] = s1_[2] = 0;
    u1_[0] = u1_[1] = u1_[2] = 0;
    p_[0] = p_[1] = p_[2] = 0;
    q_[0] = q_[1] = q_[2] = 0;
    x_[0] = x_[1] = x_[2] = 0;
    c_[0] = c_[1] = c_[2] = 0;
    step0_ = 0;
    dev_ = energy_ = 0;
  }

  static Step step(std::uint32_t step_us, const SubBlockLimits<Scalar>& /*l*/) { return {step_us}; }
  void cue(const Input& f, const SubBlockLimits<Scalar>& /*l*/, Cue& c) const {
    c.d0 = f.acc[0] - ref_[0], c.d1 = f.acc[1] - ref_[1], c.d2 = f.acc[2] - ref_[2];
    const std::int32_t m0 = clamp16((f.acc[0] * 256 - mean_q8_[0]) >> 4),
                       m1 = clamp16((f.acc[1] * 256 - mean_q8_[1]) >> 4),
                       m2 = clamp16((f.acc[2] * 256 - mean_q8_[2]) >> 4);
    c.q0 = static_cast<std::uint32_t>(m0 * m0);
    c.q1 = static_cast<std::uint32_t>(m1 * m1);
    c.q2 = static_cast<std::uint32_t>(m2 * m2);
    c.dev = c.q0 + c.q1 + c.q2;
    const std::uint32_t k = dev_clip_q8_;
    c.clipped = (c.q0 < k ? c.q0 : k) + (c.q1 < k ? c.q1 : k) + (c.q2 < k ? c.q2 : k);
  }
  bool glitch(const Cue& c, const SubBlockLimits<Scalar>& /*l*/) const {
    return c.dev > glitch2_q8_;
  }
  void rate(const Input& f, const SubBlockLimits<Scalar>& /*l*/, Rate& r) const {
    r.e = 0;
#pragma GCC unroll 3
    for (int i = 0; i < 3; ++i) {
      r.u[i] = f.gyro[i] + bias_[i];
      const std::int32_t g = clamp16(r.u[i]);
      r.e += static_cast<std::uint32_t>(g * g);
    }
    r.e_clipped = r.e < energy_clip_ ? r.e : energy_clip_;
  }
  // The averages, w of the way to each sample's share (the accelerometer's in 1/256 count^2, the
  // gyro's in 1/16), and the moving mean (1/256 count).
  void follow_accel(const Input& f, const Cue& c, const Step& /*h*/) {
    va_q8_ += weighted(static_cast<std::int32_t>(c.clipped), va_q8_);
    mean_q8_[0] += weighted(f.acc[0] * 256, mean_q8_[0]);
    mean_q8_[1] += weighted(f.acc[1] * 256, mean_q8_[1]);
    mean_q8_[2] += weighted(f.acc[2] * 256, mean_q8_[2]);
  }
  void follow_energy(const Rate& r, const Step& /*h*/) {
    ee_q4_ += weighted(static_cast<std::int32_t>(r.e_clipped << 4), ee_q4_);
  }
  bool accel_still(const SubBlockLimits<Scalar>& /*l*/) const { return va_q8_ <= accel_max_q8_; }
  bool energy_still(const SubBlockLimits<Scalar>& /*l*/) const { return ee_q4_ <= energy_max_q4_; }
  void sum_accel(const Input& /*f*/, const Cue& c) {
    s1_[0] += c.d0;
    s1_[1] += c.d1;
    s1_[2] += c.d2;
    dev_ += c.dev;
  }
  void sum_rate(const Rate& r) {
    u1_[0] += r.u[0];
    u1_[1] += r.u[1];
    u1_[2] += r.u[2];
    energy_ += r.e;
  }
  // Trapezoid: s = u_k + u_(k-1), twice the interval's mean rate. With P the sum of the earlier s
  // of this sub-block: beta += P x s; gamma's sum of P - k s (k the earlier intervals) is
  // 2 Q - (K - 1) P at the end, Q the sum of the earlier P (finish()). A still sub-block's
  // rotation is first order (the header says why): no beta, no gamma.
  void rotate(const Rate& r, const Step& h, bool still, std::uint32_t intervals) {
    const std::int32_t s0 = r.u[0] + u_prev_[0], s1 = r.u[1] + u_prev_[1], s2 = r.u[2] + u_prev_[2];
    if (!still) {
      cross_add(x_[0], p_[1], s2, p_[2], s1);
      cross_add(x_[1], p_[2], s0, p_[0], s2);
      cross_add(x_[2], p_[0], s1, p_[1], s0);
      q_[0] += static_cast<std::uint32_t>(p_[0]);
      q_[1] += static_cast<std::uint32_t>(p_[1]);
      q_[2] += static_cast<std::uint32_t>(p_[2]);
    }
    p_[0] += s0;
    p_[1] += s1;
    p_[2] += s2;
    // alpha exactly whatever the steps: h0 P + sum s (step - h0), h0 the first step; with equal
    // steps (a FIFO) the correction is zero and costs a compare.
    if (intervals == 0) {
      step0_ = h.us;
    } else if (h.us != step0_) {
      const std::int64_t ds = static_cast<std::int64_t>(h.us) - step0_;
      c_[0] += s0 * ds;
      c_[1] += s1 * ds;
      c_[2] += s2 * ds;
    }
  }
  void keep_rate(const Rate& r) {
    u_prev_[0] = r.u[0];
    u_prev_[1] = r.u[1];
    u_prev_[2] = r.u[2];
  }
  // Past kMaxSubBlockSamples (a still sub-block), the limit is kStillSubBlockFactor (16) times
  // less: the sum 16 times over is compared (at most 2^45: no overflow).
  bool energy_full(const SubBlockLimits<Scalar>& /*l*/, bool long_still) const {
    static_assert(kStillSubBlockFactor == 16, "the shift below");
    return (long_still ? energy_ << 4 : energy_) > energy_max_;
  }

  // The sums into s (whose counts are set).
  void finish(SubBlockStats<Scalar>& s, const SubBlockLimits<Scalar>& /*l*/) const {
    const Scalar n = static_cast<Scalar>(s.n);
    // The gyro's sums are about the rounded bias; the limits' is db_ away.
    Scalar db_dot_u1 = Scalar(0);
    for (int i = 0; i < 3; ++i) {
      s.acc_ref(i) = static_cast<Scalar>(ref_[i]);
      s.acc_sum(i) = static_cast<Scalar>(s1_[i]);
      if (!db_zero_) db_dot_u1 += db_(i) * static_cast<Scalar>(u1_[i]);
    }
    s.dev = to_scalar<Scalar>(dev_) * Scalar(1.0 / 256);
    for (int i = 0; i < 3; ++i)
      s.moving_mean(i) = static_cast<Scalar>(mean_q8_[i]) * Scalar(1.0 / 256);
    const Scalar energy = to_scalar<Scalar>(energy_);
    s.energy = energy;
    if (!db_zero_) {
      s.energy = energy + Scalar(2) * db_dot_u1 + n * db2_;
      s.energy = s.energy > Scalar(0) ? s.energy : Scalar(0);
    }
    // The rotation statistics of the integer rate u = w + round(b0) at the mean interval h:
    // alpha = h/2 P, beta = h^2/4 X, gamma = h^2/2 Y; then the rest of the bias, exactly.
    if (s.intervals > 0) {
      const Scalar duration = static_cast<Scalar>(s.duration_us) * Scalar(1e-6);
      const Scalar h0 = static_cast<Scalar>(step0_) * Scalar(1e-6);
      for (int i = 0; i < 3; ++i) {
        const Scalar a = h0 * static_cast<Scalar>(p_[i]);
        s.seg.alpha(i) =
            Scalar(0.5) * (c_[i] == 0 ? a : a + Scalar(1e-6) * to_scalar<Scalar>(c_[i]));
      }
      s.seg.duration = duration;
      if (!s.still) {
        const Scalar h = duration / static_cast<Scalar>(s.intervals);
        const Scalar b = Scalar(0.25) * h * h, g = Scalar(0.5) * h * h;
        for (int i = 0; i < 3; ++i) {
          s.seg.beta(i) = b * to_scalar<Scalar>(x_[i]);
          s.seg.gamma(i) = g * static_cast<Scalar>(gamma_sum(i, s.intervals));
        }
        if (!db_zero_) s.seg.add_bias(db_);
      } else if (!db_zero_) {
        s.seg.add_bias_first_order(db_);
      }
    }
  }

 private:
  // Caps that keep the clipped shares (in their fixed-point units) in range.
  static constexpr std::uint32_t kDevClipCap = 1u << 28;     // per axis, 1/256 count^2
  static constexpr std::uint32_t kEnergyClipCap = 1u << 26;  // per sample

  static Scalar weight(const SubBlockLimits<Scalar>& l) {
    return l.weight > Scalar(0) && l.weight < Scalar(1) ? l.weight : Scalar(0);
  }

  // w (x - y) in fixed point.
  std::int32_t weighted(std::int32_t x, std::int32_t y) const {
    const std::int32_t d = x - y;
    // |d| <= fit_ (d + fit_ in [0, 2 fit_], one unsigned compare) keeps the product in 32 bits.
    if (kLongMultiplyIsACall && static_cast<std::uint32_t>(d) + fit_ <= 2u * fit_)
      return (d * weight_q16_) >> 16;
    return static_cast<std::int32_t>((static_cast<std::int64_t>(d) * weight_q16_) >> 16);
  }

  // Sum over the intervals of P - k s: 2 Q - (K - 1) P, which fits 32 bits as the sum does (the
  // terms are taken modulo 2^32, so their own range does not matter).
  std::int32_t gamma_sum(int i, std::uint32_t intervals) const {
    const std::uint32_t k1 = intervals - 1u;
    return static_cast<std::int32_t>(2u * q_[i] - k1 * static_cast<std::uint32_t>(p_[i]));
  }

  Vector3<Scalar> db_ = Vector3<Scalar>::Zero();  // the limits' bias less its rounding, bias_
  Scalar db2_ = Scalar(0);                        // |db_|^2
  bool db_zero_ = true, converted_ = false;
  std::int32_t ref_[3] = {0, 0, 0}, bias_[3] = {0, 0, 0}, u_prev_[3] = {0, 0, 0};
  std::int32_t s1_[3] = {0, 0, 0}, u1_[3] = {0, 0, 0}, p_[3] = {0, 0, 0};
  std::uint32_t q_[3] = {0, 0, 0};  // the sum of P before each interval (modulo 2^32)
  std::int64_t x_[3] = {0, 0, 0}, c_[3] = {0, 0, 0};
  std::uint32_t step0_ = 0;
  std::uint64_t dev_ = 0, energy_ = 0, energy_max_ = 0;  // dev_: 1/256 count^2
  std::uint32_t dev_clip_q8_ = 0, energy_clip_ = 0, glitch2_q8_ = 0;
  std::int32_t mean_q8_[3] = {0, 0, 0};
  std::int32_t va_q8_ = 0, ee_q4_ = 0, accel_max_q8_ = 0, energy_max_q4_ = 0, weight_q16_ = 0;
  std::uint32_t fit_ = 0;  // the largest |d| weighted() multiplies in 32 bits
};

}  // namespace detail

// The sub-block accumulator: readings in the scalar type (add(ImuSample)) or 16-bit counts
// (add(RawFrame)), one kind per stream, decided by its first sample after forget_kind(). Both
// kinds take the same per-sample steps (step()) in their own arithmetic (detail::FloatSums,
// detail::RawSums) and fill the same SubBlockStats.
template <typename Scalar>
class SubBlock {
 public:
  // Empty, with the limits for this sub-block. The previous sample's rate (the trapezoid's other
  // end) is kept, moved to the new bias (forget_rate() after start() clears it). Until the
  // stream's kind is known both kinds start.
  void start(const SubBlockLimits<Scalar>& l) {
    const bool both = !known_;
    if (both || raw_) raw_sums_.start(l, lim_);
    if (both || !raw_) float_sums_.start(l, lim_);
    lim_ = l;
    use_gyro_ = l.use_gyro;
    if (both || raw_) raw_sums_.clear(lim_);
    if (both || !raw_) float_sums_.clear(lim_);
    clear();
  }
  // The next sample decides the stream's kind again (a stream that starts over).
  void forget_kind() {
    if (known_ && !raw_) raw_sums_.stale();
    known_ = raw_ = false;
  }
  // The rate before the next sample is zero (after a rest), or unknown (it starts the stream
  // again: it has no interval then, its step_us is 0). Call it after start().
  void forget_rate() {
    raw_sums_.forget_rate();
    float_sums_.forget_rate();
  }
  // The moving averages (the accelerometer's variance summed over the axes, the gyro's energy).
  void set_averages(const Vector3<Scalar>& mean, Scalar accel, Scalar energy) {
    raw_sums_.set_averages(mean, accel, energy, lim_);
    float_sums_.set_averages(mean, accel, energy);
  }

  std::uint32_t size() const { return n_; }
  std::uint32_t t_begin() const { return t_begin_; }
  // The sum of |u|^2 is past the limits' energy_max (kStillSubBlockFactor times less for a
  // still sub-block past kMaxSubBlockSamples samples: long_still), in a stream of Input
  // (RawFrame or ImuSample<Scalar>).
  template <class Input>
  bool energy_full(bool long_still) const {
    if constexpr (std::is_same<Input, RawFrame>::value)
      return raw_sums_.energy_full(lim_, long_still);
    else
      return float_sums_.energy_full(lim_, long_still);
  }
  // The latest sample's state.
  bool still() const { return still_; }
  // A sub-block that ended because a sample's state differed: true once, with its sums.
  bool take_done(SubBlockStats<Scalar>& out) { return done_.take(out); }
  // The finished sub-block if one is held (see FinishedSubBlock::held()).
  const SubBlockStats<Scalar>* done() const { return done_.held(); }
  void release_done() { done_.release(); }

  // One sample, step_us after the previous one (0: none before it). False: a glitch (its
  // accelerometer reading beyond the glitch limit): nothing changed, but a sample of the other
  // kind has switched the stream's kind first (become()).
  __attribute__((always_inline)) bool add(const ImuSample<Scalar>& x, std::uint32_t step_us,
                                          bool acc_saturated) {
    if (raw_ || !known_) become(false);
    return step(float_sums_, x, step_us, acc_saturated);
  }
  __attribute__((always_inline)) bool add(const RawFrame& f, std::uint32_t step_us,
                                          bool acc_saturated) {
    if (!raw_) become(true);
    return step(raw_sums_, f, step_us, acc_saturated);
  }

  // A temperature for the sample added last (1/4096 deg C, relative to the stream's reference).
  void add_temperature(std::int32_t q) { temp_.add(q); }

  SubBlockStats<Scalar> finish() const { return raw_ ? finish(raw_sums_) : finish(float_sums_); }

 private:
  // One sample through the detector's cue, its moving averages and the sums, in the kind's
  // arithmetic.
  template <class Kind>
  __attribute__((always_inline)) bool step(Kind& k, const typename Kind::Input& x,
                                           std::uint32_t step_us, bool acc_saturated) {
    typename Kind::Cue cue;
    k.cue(x, lim_, cue);
    if (!acc_saturated && k.glitch(cue, lim_)) return false;
    const typename Kind::Step h = k.step(step_us, lim_);
    typename Kind::Rate r;
    k.rate(x, lim_, r);
    // A saturated accelerometer reading changes neither its average nor its sums.
    if (!acc_saturated) k.follow_accel(x, cue, h);
    k.follow_energy(r, h);
    const bool still =
        !acc_saturated && k.accel_still(lim_) && (!use_gyro_ || k.energy_still(lim_));
    if (n_ > 0 && still != still_) {
      done_.stats = finish(k);
      done_.full = true;
      k.clear(lim_);
      clear();
    }
    still_ = still;
    if (!acc_saturated) {
      k.sum_accel(x, cue);
      ++n_acc_;
    }
    k.sum_rate(r);
    if (step_us != 0) {
      k.rotate(r, h, still, intervals_);
      ++intervals_;
      duration_us_ += step_us;
    }
    k.keep_rate(r);
    if (n_ == 0) t_begin_ = x.t_us;
    t_end_ = x.t_us;
    ++n_;
    return true;
  }

  template <class Kind>
  SubBlockStats<Scalar> finish(const Kind& k) const {
    SubBlockStats<Scalar> s;
    s.still = still_;
    s.n = n_;
    s.n_acc = n_acc_;
    s.intervals = intervals_;
    s.duration_us = duration_us_;
    s.t_begin = t_begin_;
    s.t_end = t_end_;
    k.finish(s, lim_);
    // The accelerometer's sum scaled to all n samples.
    if (n_acc_ > 0 && n_acc_ < n_)
      s.acc_sum *= static_cast<Scalar>(n_) / static_cast<Scalar>(n_acc_);
    s.path = n_ > 0 ? s.seg.duration * std::sqrt(s.energy / static_cast<Scalar>(n_)) : Scalar(0);
    temp_.finish(s);
    return s;
  }

  // The stream's kind: readings (false) or frames (true). A stream that changes kind drops the
  // open sub-block and starts the new kind's arithmetic from the current limits, with the moving
  // averages where the old kind left them.
  void become(bool raw) {
    if (known_) {
      Vector3<Scalar> mean = Vector3<Scalar>::Zero();
      Scalar accel = Scalar(0), energy = Scalar(0);
      if (raw_)
        raw_sums_.averages(mean, accel, energy, lim_);
      else
        float_sums_.averages(mean, accel, energy, lim_);
      if (raw) raw_sums_.stale();
      const SubBlockLimits<Scalar> l = lim_;
      known_ = false;
      set_averages(mean, accel, energy);
      start(l);
      forget_rate();
    }
    known_ = true;
    raw_ = raw;
  }

  void clear() {
    n_ = n_acc_ = intervals_ = duration_us_ = 0;
    temp_.clear();
  }

  // The per-sample members first (short offsets on ARMv6-M), the limits and the finished
  // sub-block last.
  std::uint32_t n_ = 0, n_acc_ = 0, intervals_ = 0, duration_us_ = 0;
  std::uint32_t t_begin_ = 0, t_end_ = 0;
  SubBlockTemperature temp_{};
  bool known_ = false, raw_ = false, still_ = true, use_gyro_ = true;
  detail::RawSums<Scalar> raw_sums_{};
  detail::FloatSums<Scalar> float_sums_{};
  SubBlockLimits<Scalar> lim_{};
  FinishedSubBlock<Scalar> done_{};
};

}  // namespace imucal
