// SPDX-License-Identifier: MIT
// imucal/stream/blocks.hpp: the unit the calibrator sorts a stream into. A block is a short
// run of consecutive samples, all still or all moving: its gyro statistics (a GyroSegment of
// u = w + b0), its path angle, its acceleration sum and the detector's cues. Still blocks wait
// in the delay line until enough stillness follows them to count as rest; a rest is blocks
// appended together, and becomes a pose (its mean, its noise, its RestSummary). Header-only, no
// allocation.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "imucal/models/accel_model.hpp"
#include "imucal/stream/compensated_sum.hpp"
#include "imucal/stream/gyro_segment.hpp"
#include "imucal/stream/rest_summary.hpp"
#include "imucal/stream/ring.hpp"
#include "imucal/stream/sub_block.hpp"

namespace imucal {

// The acceleration sum is re-centred: relative to acc_ref (the block's first raw reading), so
// that the summands are noise-sized, and blocks are appended compensated (compensated_add): a
// rest of hours keeps its mean exact (the 24-hour test in test_stream_faults.cpp holds float to
// double).
template <typename Scalar>
struct SampleBlock {
  GyroSegment<Scalar> seg{};
  Vector3<Scalar> acc_ref = Vector3<Scalar>::Zero();
  Vector3<Scalar> acc_sum = Vector3<Scalar>::Zero();
  Vector3<Scalar> acc_comp = Vector3<Scalar>::Zero();    // low part: the sum is sum + comp
  Scalar path = Scalar(0);                               // sum |u| dt
  Scalar accel_cue = Scalar(0), energy_cue = Scalar(0);  // the detector's sample cues, summed
  Scalar temp_sum = Scalar(0);  // temperatures relative to the stream's first one
  std::uint32_t temp_n = 0;     // samples that carried a temperature
  std::uint32_t n = 0;
  std::uint32_t t_begin = 0;
  std::uint32_t t_end = 0;
  bool still = true;
  bool long_enough = false;  // rests: lasted min_rest_seconds (sticky: the clock wraps)

  // Empty, keeping acc_ref, t_begin and still (set again by the first sample).
  void clear() {
    seg = GyroSegment<Scalar>{};
    acc_sum.setZero();
    acc_comp.setZero();
    path = Scalar(0);
    accel_cue = energy_cue = Scalar(0);
    temp_sum = Scalar(0);
    temp_n = 0;
    n = 0;
    long_enough = false;
  }

  // One division (a soft-float division costs three multiplies on a core without an FPU).
  Vector3<Scalar> acc_mean() const {
    return acc_ref + (acc_sum + acc_comp) * (Scalar(1) / static_cast<Scalar>(n));
  }

  // A sub-block's samples follow this block's.
  void add(const SubBlockStats<Scalar>& s) { fold(s, Vector3<Scalar>::Zero(), s.dev, s.energy); }

  // The later block's samples follow this one's.
  void append(const SampleBlock& later) {
    fold(later, later.acc_comp, later.accel_cue, later.energy_cue);
  }

  // The samples of b (a block or a sub-block: the same fields) follow this block's.
  template <class B>
  void fold(const B& b, const Vector3<Scalar>& comp, Scalar b_accel_cue, Scalar b_energy_cue) {
    if (n == 0) {  // the same sums, without the arithmetic on zeros
      seg = b.seg;
      acc_ref = b.acc_ref;
      acc_sum = b.acc_sum;
      acc_comp = comp;
      path = b.path;
      accel_cue = b_accel_cue;
      energy_cue = b_energy_cue;
      temp_sum = b.temp_sum;
      temp_n = b.temp_n;
      t_begin = b.t_begin;
      n = b.n;
      t_end = b.t_end;
      return;
    }
    seg.append(b.seg);
    add_acc(b.acc_ref, b.acc_sum, comp, b.n);
    path += b.path;
    accel_cue += b_accel_cue;
    energy_cue += b_energy_cue;
    temp_sum += b.temp_sum;
    temp_n += b.temp_n;
    if (n == 0) t_begin = b.t_begin;
    n += b.n;
    t_end = b.t_end;
  }

  // A sum of m readings about ref (sum + comp) joins this block's: moved to this block's reference
  // (m (ref - acc_ref): exact for raw counts), added compensated.
  void add_acc(const Vector3<Scalar>& ref, const Vector3<Scalar>& sum, const Vector3<Scalar>& comp,
               std::uint32_t m) {
    if (n == 0) {
      acc_ref = ref;
      acc_sum = sum;
      acc_comp = comp;
      return;
    }
    const Vector3<Scalar> moved = sum + comp + static_cast<Scalar>(m) * (ref - acc_ref);
    for (int i = 0; i < 3; ++i) compensated_add(acc_sum(i), acc_comp(i), moved(i));
  }

  // As a pose's noise (Pose::noise): the variance of one sample on one axis, from the detector's
  // accelerometer cue (each sample's squared deviation from the moving mean, over the three
  // axes). With white noise of variance s^2 that deviation has variance s^2 (1 + w / (2 - w))
  // per axis, w = dt / (seconds + dt) the weight of the moving mean of `seconds`. 0: unknown.
  Scalar noise_variance(Scalar seconds) const {
    const Scalar k = static_cast<Scalar>(n);
    const Scalar dt = static_cast<Scalar>(t_end - t_begin) * Scalar(1e-6) / k;
    const Scalar w = dt / (seconds + dt);
    const Scalar noise = accel_cue / (Scalar(3) * k) * (Scalar(1) - w / Scalar(2));
    return std::isfinite(noise) && noise > Scalar(0) ? noise : Scalar(0);
  }

  // As a RestSummary (for the temperature fit). The gyro mean comes from the segment statistics:
  // alpha / duration is the time-weighted mean of u = w + b0. Samples not in the segment (the
  // initial rest's) average u = 0 by definition of b0: dividing by the whole span counts them.
  // (The span wraps after 71.6 min; the segment's duration does not.) temp_ref: what the
  // temperatures are relative to.
  RestSummary<Scalar> summary(const Vector3<Scalar>& b0, Scalar temp_ref) const {
    RestSummary<Scalar> r;
    r.accel_mean = acc_mean();
    const Scalar span = static_cast<Scalar>(t_end - t_begin) * Scalar(1e-6);
    const Scalar d = seg.duration > span ? seg.duration : span;
    r.gyro_mean = d > Scalar(0) ? Vector3<Scalar>(seg.alpha / d - b0) : Vector3<Scalar>(-b0);
    r.has_temperature = temp_n > 0;
    r.temperature_c =
        r.has_temperature ? temp_ref + temp_sum / static_cast<Scalar>(temp_n) : Scalar(0);
    r.samples = n;
    r.duration_s = d;
    r.begin_us = t_begin;
    r.end_us = t_end;
    return r;
  }
};

// The still blocks not yet known to be rest: a ring of N, oldest first. A block joins the rest
// once enough stillness follows it; when motion comes, those still in the line go to the move.
template <typename Scalar, int N>
class DelayLine {
 public:
  static_assert(N >= 2, "delay line too short");
  using Block = SampleBlock<Scalar>;

  void clear() { line_.clear(); }
  int size() const { return line_.size(); }
  bool empty() const { return line_.empty(); }
  const Block& oldest() const { return line_.oldest(); }
  const Block& newest() const { return line_.newest(); }

  // A full line (blocks cut short by the segment bounds) grows its newest block instead.
  void add(const Block& b) {
    if (line_.full()) {
      line_.newest().append(b);
      return;
    }
    line_.push(b);
  }
  void drop_oldest() { line_.pop(); }
  // How long the stillness after the oldest block has lasted (microseconds; 0 with one block).
  std::uint32_t span_after_oldest() const {
    if (line_.size() < 2) return 0;
    return newest().t_end - oldest().t_end;
  }
  // f(block) for every block, oldest first.
  template <class F>
  void for_each(const F& f) {
    for (int k = 0; k < line_.size(); ++k) f(line_.at(k));
  }
  // Moves every block, oldest first, to f(block).
  template <class F>
  void drain(const F& f) {
    line_.drain(f);
  }

 private:
  Ring<Block, N> line_{};
};

}  // namespace imucal
