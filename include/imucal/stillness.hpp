// imucal/stillness.hpp: tells still from moving, sample by sample, causally, in a few dozen bytes.
// The streaming calibrator uses it; anything that needs rests from a raw IMU stream can. Never
// allocates, throws or blocks. Header-only.
//
// Two cues, each an exponential moving average with time constant `seconds` (weighted by the
// actual step, so the statistics do not change with the sample rate):
//   - the accelerometer's variance about its own moving mean, summed over the axes (raw units^2);
//   - the gyro's energy |u|^2 of the bias-corrected rate u = w + b (raw units^2).
// A sample is still when both are at or below their thresholds. Each sample's contribution is
// clipped at `clip` times the threshold: a lone spike cannot end a rest, real motion still shows
// within two or three samples.
//
// Thresholds follow the data. Each cue keeps the level it has in rests (its floor, learned from
// every rest) and the level of the moves (an upper envelope: it rises at once, decays slowly),
// both from what the caller classified (learn_rest, learn_motion, with the means of the
// unclipped per-sample cues sample_accel() and sample_energy()). The threshold is `k` times the
// floor; for the gyro, if higher, a point between the first rest's floor and the move level on a
// log scale (a fraction `gap` of the way up, at most `reach` times that floor): a rest held in
// the hand after a quiet start (gyro jitter up to about five times the table-top noise) still
// counts, and once it has, the floor follows it. Turns (tens to hundreds of deg/s) stay far
// above. The accelerometer's threshold stays at k times its floor: a slow turn changes little
// but the direction of gravity, and on the Xsens recording a looser one joins rests across turns.
#pragma once

#include <Eigen/Core>
#include <cmath>

#include "imucal/normal_equations.hpp"

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
  // Starts from a still period: the accelerometer's mean (relative to the caller's reference)
  // and per-axis variance, and the gyro's energy with its bias removed (0 without a gyro: the
  // gyro cue is then off).
  void start(const StillnessSettings<Scalar>& s, const Vector3<Scalar>& acc_mean,
             const Vector3<Scalar>& acc_var, Scalar gyro_energy) {
    settings_ = s;
    mean_ = acc_mean;
    var_ = acc_var;
    energy_ = gyro_energy;
    first_acc_ = rest_acc_ = acc_var.sum();
    first_energy_ = rest_energy_ = gyro_energy;
    move_acc_ = move_energy_ = Scalar(0);
    use_gyro_ = gyro_energy > Scalar(0);
    update_thresholds();
  }

  // One sample: a = raw accelerometer minus the caller's reference, u = bias-corrected gyro rate,
  // dt = its interval (0 for the first sample after a gap), accel_unusable = the accelerometer
  // reading says nothing (saturated): the sample counts as motion. Returns whether it is still.
  bool update(const Vector3<Scalar>& a, const Vector3<Scalar>& u, Scalar dt, bool accel_unusable) {
    const Scalar w = dt / (settings_.seconds + dt);
    const Scalar wa = accel_unusable ? Scalar(0) : w;
    const Scalar keep = Scalar(1) - wa;
    Scalar acc = Scalar(0), dev = Scalar(0), energy = Scalar(0);
#pragma GCC unroll 3
    for (int i = 0; i < 3; ++i) {
      const Scalar d = a(i) - mean_(i);
      mean_(i) += wa * d;
      const Scalar d2 = d * d;
      dev += d2;
      const Scalar v = keep * (var_(i) + wa * (d2 < clip_var_ ? d2 : clip_var_));
      var_(i) = v;
      acc += v;
      energy += u(i) * u(i);
    }
    energy_ += w * ((energy < clip_energy_ ? energy : clip_energy_) - energy_);
    sample_accel_ = accel_unusable ? Scalar(0) : dev;
    sample_energy_ = energy;
    return !accel_unusable && acc <= acc_max_ && (!use_gyro_ || energy_ <= energy_max_);
  }

  // Whether a (relative) accelerometer reading lies further than sqrt(limit2) from the moving
  // mean on any axis (a glitch, for the caller to refuse before update()).
  bool far_from_mean(const Vector3<Scalar>& a, Scalar limit2) const {
    bool far = false;
    for (int i = 0; i < 3; ++i) {
      const Scalar d = a(i) - mean_(i);
      far = far || d * d > limit2;
    }
    return far;
  }

  // The unclipped cues of the latest sample: its squared deviation from the accelerometer's
  // moving mean (summed over the axes) and its gyro energy. Their means over a rest or a move
  // are what learn_rest() and learn_motion() take.
  Scalar sample_accel() const { return sample_accel_; }
  Scalar sample_energy() const { return sample_energy_; }

  // A rest ended / a move ended: the mean cues over it. The floor follows the rests (a quarter
  // of the way per rest, on a log scale), the move level the moves.
  // (per move block: a tenth of the way, as a move spans many blocks).
  void learn_rest(Scalar accel_mean, Scalar energy_mean) {
    rest_acc_ = blend(rest_acc_, accel_mean, Scalar(0.25));
    if (use_gyro_) rest_energy_ = blend(rest_energy_, energy_mean, Scalar(0.25));
    update_thresholds();
  }
  void learn_motion(Scalar accel_mean, Scalar energy_mean) {
    move_acc_ = envelope(move_acc_, accel_mean);
    if (use_gyro_) move_energy_ = envelope(move_energy_, energy_mean);
    update_thresholds();
  }

  Scalar accel_threshold() const { return acc_max_; }
  Scalar energy_threshold() const { return energy_max_; }
  Scalar rest_accel() const { return rest_acc_; }
  Scalar rest_energy() const { return rest_energy_; }
  Scalar first_rest_energy() const { return first_energy_; }

 private:
  // Geometric blend: a^(1-f) b^f (levels span decades; positive inputs only, else a is kept).
  static Scalar blend(Scalar a, Scalar b, Scalar f) {
    if (!(b > Scalar(0)) || !(a > Scalar(0))) return a > Scalar(0) ? a : b;
    return a * std::pow(b / a, f);
  }

  // Rises to a higher level at once, decays towards a lower one by 2 % per call (a move spans
  // many blocks, a hand-held rest mistaken for motion must not drag it down).
  static Scalar envelope(Scalar level, Scalar x) {
    if (!(x > Scalar(0))) return level;
    return x >= level ? x : blend(level, x, Scalar(0.02));
  }

  Scalar threshold(Scalar floor, Scalar first, Scalar move, Scalar k) const {
    const Scalar low = k * floor;
    if (!(move > first) || !(first > Scalar(0))) return low;
    Scalar t = first * std::pow(move / first, settings_.gap);
    const Scalar most = settings_.reach * first;
    t = t < most ? t : most;
    return t > low ? t : low;
  }

  void update_thresholds() {
    acc_max_ = settings_.accel_k * rest_acc_;
    energy_max_ = threshold(rest_energy_, first_energy_, move_energy_, settings_.gyro_k);
    clip_var_ = settings_.clip * acc_max_;
    clip_energy_ = settings_.clip * energy_max_;
  }

  StillnessSettings<Scalar> settings_{};
  Vector3<Scalar> mean_ = Vector3<Scalar>::Zero(), var_ = Vector3<Scalar>::Zero();
  Scalar energy_ = Scalar(0);
  Scalar sample_accel_ = Scalar(0), sample_energy_ = Scalar(0);
  Scalar rest_acc_ = Scalar(0), rest_energy_ = Scalar(0);
  Scalar first_acc_ = Scalar(0), first_energy_ = Scalar(0);
  Scalar move_acc_ = Scalar(0), move_energy_ = Scalar(0);
  Scalar acc_max_ = Scalar(0), energy_max_ = Scalar(0);
  Scalar clip_var_ = Scalar(0), clip_energy_ = Scalar(0);
  bool use_gyro_ = true;
};

}  // namespace imucal
