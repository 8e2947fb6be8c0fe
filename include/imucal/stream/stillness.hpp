// SPDX-License-Identifier: MIT
// imucal/stream/stillness.hpp: tells still from moving, sub-block by sub-block (sub_block.hpp),
// causally, in a few dozen bytes. Never allocates, throws or blocks. Header-only.
//
// Two cues, each an exponential moving average with time constant `seconds` (weighted by the
// actual steps, so the statistics do not change with the sample rate; a sub-block of n samples
// advances it as n samples would, with their mean):
//   - the accelerometer's variance about its own moving mean, summed over the axes (raw units^2);
//   - the gyro's energy |u|^2 of the bias-corrected rate u = w + b (raw units^2).
// A sub-block is still when both are at or below their thresholds. Each sample's contribution is
// clipped at `clip` times the threshold: a lone spike cannot end a rest, real motion still shows
// within a sub-block or two.
//
// Thresholds follow the data. Each cue keeps the level it has in rests (its floor, learned from
// every rest), the gyro also the level of the moves (an upper envelope: it rises at once, decays
// slowly), both from what the caller classified (learn_rest, learn_motion, with the means of the
// unclipped per-sample cues). The threshold is `k` times the floor; for the gyro, if higher, a
// point between the first rest's floor and the move level on a log scale (a fraction `gap` of the
// way up, at most `reach` times that floor): a rest held in the hand after a quiet start (gyro
// jitter up to about five times the table-top noise) still counts, and once it has, the floor
// follows it. Turns (tens to hundreds of deg/s) stay far above. The accelerometer's threshold
// stays at k times its floor: a slow turn changes little but the direction of gravity, and on
// the Xsens recording a looser one joins rests across turns.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "imucal/solve/elementary.hpp"  // log2_of, exp2_of
#include "imucal/stream/sub_block.hpp"
#include "imucal/types.hpp"

namespace imucal {

template <typename Scalar>
struct StillnessSettings {
  Scalar seconds = Scalar(0.1);  // time constant of the moving averages
  Scalar accel_k = Scalar(4);    // accelerometer threshold at least this x its rest variance
  Scalar gyro_k = Scalar(6);     // gyro threshold at least this x its rest energy
  Scalar gap = Scalar(0.35);     // where the gyro's may sit between rest and move levels (log)
  Scalar reach = Scalar(64);     // ... but at most this x the first rest's level
  Scalar clip = Scalar(4);       // one sample adds at most clip x the threshold

  bool valid() const {
    return seconds > Scalar(0) && accel_k > Scalar(1) && gyro_k > Scalar(1) && gap >= Scalar(0) &&
           gap < Scalar(1) && reach >= Scalar(1) && clip > Scalar(1);
  }
};

template <typename Scalar>
class StillnessDetector {
 public:
  // Starts from a still period: the accelerometer's mean (raw) and per-axis variance, and the
  // gyro's energy with its bias removed (0 without a gyro: the gyro cue is then off).
  void start(const StillnessSettings<Scalar>& s, const Vector3<Scalar>& acc_mean,
             const Vector3<Scalar>& acc_var, Scalar gyro_energy) {
    settings_ = s;
    mean_ = acc_mean;
    var0_ = acc_var.sum();
    energy0_ = gyro_energy;
    rest_acc_ = acc_var.sum();
    first_energy_ = rest_energy_ = gyro_energy;
    move_log_ = -std::numeric_limits<Scalar>::infinity();  // no move yet
    first_log_ = first_energy_ > Scalar(0) ? detail::log2_of(first_energy_) : Scalar(0);
    // The move level from which on the gyro threshold is at its cap (reach x the first floor):
    // first (move / first)^gap >= reach first.
    cap_log_ = s.gap > Scalar(0) ? first_log_ + detail::log2_of(s.reach) / s.gap
                                 : std::numeric_limits<Scalar>::infinity();
    use_gyro_ = gyro_energy > Scalar(0);
    glitch2_ = std::numeric_limits<Scalar>::infinity();
    update_thresholds();
  }

  // Readings further than sqrt(limit2) from the moving mean (squared, summed over the axes) are
  // glitches from now on (the default: none is).
  void set_glitch_limit(Scalar limit2) { glitch2_ = limit2; }

  // What the next sub-block's samples are measured against: the moving mean, the clips of the
  // two cues, the thresholds, the glitch limit (the caller sets the bias, the rotation bound and
  // one sample's weight for raw frames).
  void limits(SubBlockLimits<Scalar>& l) const {
    l.acc_ref = mean_;
    l.dev_clip = clip_var_;
    l.energy_clip = clip_energy_;
    l.glitch2 = glitch2_;
    l.accel_threshold = acc_max_;
    l.energy_threshold = energy_max_;
    l.use_gyro = use_gyro_;
    l.seconds = settings_.seconds;
  }
  // The accelerometer's moving mean (raw), where the last sub-block left it.
  const Vector3<Scalar>& moving_mean() const { return mean_; }
  // The moving averages' values at start() (the sub-block accumulator carries them on).
  Scalar start_accel() const { return var0_; }
  Scalar start_energy() const { return energy0_; }

  // One sub-block (its samples taken with limits()): the moving mean where its last sample left
  // it; true if it is still (its samples' state, from the moving averages).
  bool update(const SubBlockStats<Scalar>& s) {
    if (s.n_acc > 0) mean_ = s.moving_mean;
    last_still_ = s.still;
    return s.still;
  }

  // A rest ended / a move ended: the mean cues over it. The floor follows the rests (a quarter
  // of the way per rest, on a log scale), the gyro's move level the moves (the accelerometer's
  // threshold does not depend on the moves: see the top).
  void learn_rest(Scalar accel_mean, Scalar energy_mean) {
    rest_acc_ = blend_quarter(rest_acc_, accel_mean);
    if (use_gyro_) rest_energy_ = blend_quarter(rest_energy_, energy_mean);
    update_thresholds();
  }
  void learn_motion(Scalar energy_mean) {
    if (!use_gyro_ || !(energy_mean > Scalar(0))) return;
    // The envelope on a log scale: up at once, down 2 % of the way.
    const Scalar x = detail::log2_of(energy_mean);
    move_log_ = x >= move_log_ ? x : move_log_ + Scalar(0.02) * (x - move_log_);
    update_thresholds();
  }

  // Whether the latest sub-block was still.
  bool still() const { return last_still_; }
  Scalar accel_threshold() const { return acc_max_; }
  Scalar energy_threshold() const { return energy_max_; }
  Scalar rest_accel() const { return rest_acc_; }
  Scalar rest_energy() const { return rest_energy_; }
  Scalar first_rest_energy() const { return first_energy_; }

 private:
  // Geometric blend a quarter of the way: a^(3/4) b^(1/4) (levels span decades; positive inputs
  // only, else a is kept). Two square roots: no pow linked.
  static Scalar blend_quarter(Scalar a, Scalar b) {
    if (!(b > Scalar(0)) || !(a > Scalar(0))) return a > Scalar(0) ? a : b;
    return a * std::sqrt(std::sqrt(b / a));
  }

  // The gyro's: k x its floor, or if higher a fraction gap of the way from the first rest's
  // level to the move level (log scale), at most reach x the first rest's level. The move level
  // is an envelope (learn_motion): a move spans many blocks, and a hand-held rest mistaken for
  // motion must not drag it down.
  Scalar energy_threshold_now() const {
    const Scalar low = settings_.gyro_k * rest_energy_;
    if (!(move_log_ > first_log_) || !(first_energy_ > Scalar(0))) return low;
    const Scalar most = settings_.reach * first_energy_;
    Scalar t = most;
    if (move_log_ < cap_log_) {
      t = detail::exp2_of(first_log_ + settings_.gap * (move_log_ - first_log_));
      t = t < most ? t : most;
    }
    return t > low ? t : low;
  }

  void update_thresholds() {
    acc_max_ = settings_.accel_k * rest_acc_;
    energy_max_ = energy_threshold_now();
    clip_var_ = settings_.clip * acc_max_;
    clip_energy_ = settings_.clip * energy_max_;
  }

  StillnessSettings<Scalar> settings_{};
  Vector3<Scalar> mean_ = Vector3<Scalar>::Zero();  // raw
  Scalar var0_ = Scalar(0), energy0_ = Scalar(0);
  Scalar rest_acc_ = Scalar(0), rest_energy_ = Scalar(0);
  Scalar first_energy_ = Scalar(0);
  Scalar move_log_ = Scalar(0), first_log_ = Scalar(0), cap_log_ = Scalar(0);  // log2 levels
  Scalar acc_max_ = Scalar(0), energy_max_ = Scalar(0);
  Scalar clip_var_ = Scalar(0), clip_energy_ = Scalar(0);
  Scalar glitch2_ = std::numeric_limits<Scalar>::infinity();
  bool use_gyro_ = true;
  bool last_still_ = true;
};

}  // namespace imucal
