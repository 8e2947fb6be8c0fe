// SPDX-License-Identifier: MIT
// imucal/stream/initial_rest.hpp: finds the first still period of a raw IMU stream. A window
// of four quarters slides over the stream (each quarter a quarter of `seconds` long); when the
// quarter means agree within the noise and the quarter variances alike, the window is still. It
// gives what the calibrator starts from: the gyro bias, the per-axis noise of both sensors (the
// first stillness thresholds), the sample period and the acceleration sum that opens the first
// rest. Header-only, no allocation.
#pragma once

#include <cstdint>

#include "imucal/models/accel_model.hpp"
#include "imucal/status.hpp"
#include "imucal/stream/ring.hpp"

namespace imucal {

template <typename Scalar>
class InitialRestWindow {
 public:
  // A still window.
  struct Found {
    Vector3<Scalar> acc_ref = Vector3<Scalar>::Zero();        // the first quarter's mean (raw)
    Vector3<Scalar> acc_sum = Vector3<Scalar>::Zero();        // every sample's, relative to acc_ref
    Vector3<Scalar> acc_variance = Vector3<Scalar>::Zero();   // of one sample, per axis
    Vector3<Scalar> gyro_mean = Vector3<Scalar>::Zero();      // raw
    Vector3<Scalar> gyro_variance = Vector3<Scalar>::Zero();  // of one sample, per axis
    Scalar samples = Scalar(0);
    Scalar period = Scalar(0);  // mean sample period, s
    std::uint32_t t_begin = 0, t_end = 0;
  };

  // Forgets every sample (after a gap, a frozen sensor, a saturated accelerometer).
  void restart() { *this = InitialRestWindow{}; }

  // Seconds covered so far (for the progress report).
  Scalar elapsed() const {
    Scalar e = cur_.elapsed;
    for (int k = 0; k < quarters_.size(); ++k) e += quarters_.at(k).elapsed;
    return e;
  }

  // Whether an accelerometer reading is a glitch: further than `sigmas` noise sigmas (the
  // noisiest axis of the last complete quarter, or of the first kGlitchMinSamples samples before
  // one is complete; at least kGlitchFloor of the mean reading's magnitude) from their mean, the
  // distance over the three axes. Such a reading is to be refused, not added. A run of more than
  // kGlitchMaxRun glitches in a row is no glitch but a change (the hand moved): the window restarts
  // and the reading is not a glitch. Before any reference: never a glitch.
  bool glitch(const Vector3<Scalar>& acc, Scalar sigmas) {
    if (!has_ref_) return false;
    if (!((acc - ref_mean_).squaredNorm() > sigmas * sigmas * ref_var_)) {
      glitch_run_ = 0;
      return false;
    }
    if (++glitch_run_ <= kGlitchMaxRun) return true;
    restart();
    return false;
  }

  // One sample, dt seconds after the previous one (0 for the first after a restart). kRunning:
  // the window is filling. kOk: it is still, found() gives the result. kSensorFrozen (an axis
  // without noise) or kInitialRestDisturbed: the window is full and not still; it slides on with
  // the next quarter. Without a gyro (use_gyro false) its readings are not looked at.
  Status add(const Vector3<Scalar>& acc, const Vector3<Scalar>& gyro, std::uint32_t t_us, Scalar dt,
             Scalar seconds, bool use_gyro) {
    QuarterSums& c = cur_;
    if (c.n == 0) {
      c.acc_ref = acc;
      c.gyro_ref = gyro;
      c.t_begin = t_us;
      dt = quarters_.empty() ? Scalar(0) : dt;  // the window's span starts at its first sample
    }
    c.elapsed += dt;
    const Vector3<Scalar> a = acc - c.acc_ref, g = gyro - c.gyro_ref;
    c.acc_sum += a;
    c.acc_sq += a.cwiseProduct(a);
    c.gyro_sum += g;
    c.gyro_sq += g.cwiseProduct(g);
    ++c.n;
    c.t_end = t_us;
    if (quarters_.empty() && c.n == kGlitchMinSamples) set_glitch_reference(Quarter(c));
    if (c.elapsed < Scalar(0.25) * seconds) return Status::kRunning;
    return close_quarter(use_gyro);
  }

  // What the window holds, after add() returned kOk (until the next add() or restart()).
  Found found() const {
    Found f;
    Vector3<Scalar> gyro_sum = Vector3<Scalar>::Zero();
    const Quarter& first = at(0);
    for (int k = 0; k < 4; ++k) {
      const Quarter& q = at(k);
      const Scalar nq = static_cast<Scalar>(q.n);
      f.acc_variance += nq * q.acc_var;
      f.gyro_variance += nq * q.gyro_var;
      f.acc_sum += nq * (q.acc_mean - first.acc_mean);  // relative to the first quarter's mean
      gyro_sum += nq * (q.gyro_mean - first.gyro_mean);
      f.samples += nq;
    }
    f.acc_variance /= f.samples;
    f.gyro_variance /= f.samples;
    f.acc_ref = first.acc_mean;
    f.gyro_mean = first.gyro_mean + gyro_sum / f.samples;
    f.t_begin = first.t_begin;
    f.t_end = at(3).t_end;
    f.period = static_cast<Scalar>(f.t_end - f.t_begin) * Scalar(1e-6) / (f.samples - Scalar(1));
    return f;
  }

 private:
  // A quarter while it fills: sums re-centred on its own first reading (float keeps the noise's
  // precision on raw counts ~33000 even after the board moved).
  struct QuarterSums {
    Vector3<Scalar> acc_ref = Vector3<Scalar>::Zero(), gyro_ref = Vector3<Scalar>::Zero();
    Vector3<Scalar> acc_sum = Vector3<Scalar>::Zero(), acc_sq = Vector3<Scalar>::Zero();
    Vector3<Scalar> gyro_sum = Vector3<Scalar>::Zero(), gyro_sq = Vector3<Scalar>::Zero();
    Scalar elapsed = Scalar(0);
    std::uint32_t n = 0;
    std::uint32_t t_begin = 0, t_end = 0;
  };
  // A complete quarter: means and per-axis variances.
  struct Quarter {
    Vector3<Scalar> acc_mean = Vector3<Scalar>::Zero(), acc_var = Vector3<Scalar>::Zero();
    Vector3<Scalar> gyro_mean = Vector3<Scalar>::Zero(), gyro_var = Vector3<Scalar>::Zero();
    Scalar elapsed = Scalar(0);
    std::uint32_t n = 0;
    std::uint32_t t_begin = 0, t_end = 0;

    Quarter() = default;
    explicit Quarter(const QuarterSums& q)
        : elapsed(q.elapsed), n(q.n), t_begin(q.t_begin), t_end(q.t_end) {
      if (n == 0) return;
      const Scalar k = Scalar(1) / static_cast<Scalar>(n);
      const Vector3<Scalar> ma = k * q.acc_sum, mg = k * q.gyro_sum;
      acc_mean = q.acc_ref + ma;
      gyro_mean = q.gyro_ref + mg;
      acc_var = (k * q.acc_sq - ma.cwiseProduct(ma)).cwiseMax(Scalar(0));
      gyro_var = (k * q.gyro_sq - mg.cwiseProduct(mg)).cwiseMax(Scalar(0));
    }
  };

  const Quarter& at(int k) const { return quarters_.at(k); }

  // The glitch test's reference: a quarter's mean and its noisiest axis's variance (at least
  // kGlitchFloor of the mean's magnitude, squared).
  void set_glitch_reference(const Quarter& q) {
    const Scalar floor = kGlitchFloor * kGlitchFloor * q.acc_mean.squaredNorm();
    const Scalar v = q.acc_var.maxCoeff();
    ref_mean_ = q.acc_mean;
    ref_var_ = v > floor ? v : floor;
    has_ref_ = true;
  }

  // The quarter is complete: into the ring (the oldest slides out), then the window's test.
  Status close_quarter(bool use_gyro) {
    quarters_.push(Quarter(cur_));
    set_glitch_reference(at(quarters_.size() - 1));
    cur_ = QuarterSums{};
    if (!quarters_.full()) return Status::kRunning;
    return test(use_gyro);
  }

  // Still: every quarter's variance within 9x the smallest (motion raises it by orders of
  // magnitude), and every quarter mean within (8 sigma of a quarter mean) + (1 sigma of a
  // sample) of the window's mean. The second term keeps the test from growing stricter with the
  // sample rate: a warming board's slow drift is not motion, a tilt of a fraction of a degree is.
  Status test(bool use_gyro) const {
    Vector3<Scalar> va_min = at(0).acc_var, va_max = va_min;
    Vector3<Scalar> vg_min = at(0).gyro_var, vg_max = vg_min;
    Scalar n = Scalar(0);
    Vector3<Scalar> va = Vector3<Scalar>::Zero(), vg = Vector3<Scalar>::Zero();
    Vector3<Scalar> acc_sum = Vector3<Scalar>::Zero(), gyro_sum = Vector3<Scalar>::Zero();
    const Quarter& first = at(0);
    for (int k = 0; k < 4; ++k) {
      const Quarter& q = at(k);
      const Scalar nq = static_cast<Scalar>(q.n);
      va_min = va_min.cwiseMin(q.acc_var);
      va_max = va_max.cwiseMax(q.acc_var);
      vg_min = vg_min.cwiseMin(q.gyro_var);
      vg_max = vg_max.cwiseMax(q.gyro_var);
      va += nq * q.acc_var;
      vg += nq * q.gyro_var;
      acc_sum += nq * (q.acc_mean - first.acc_mean);  // relative to the first quarter's mean
      gyro_sum += nq * (q.gyro_mean - first.gyro_mean);
      n += nq;
    }
    va /= n;
    vg /= n;
    const Vector3<Scalar> acc_mean = acc_sum / n, gyro_mean = gyro_sum / n;
    // No noise on an axis: a frozen or disconnected sensor, no threshold can be set from it.
    if (!(va_min.minCoeff() > Scalar(0)) || (use_gyro && !(vg_min.minCoeff() > Scalar(0))))
      return Status::kSensorFrozen;
    for (int i = 0; i < 3; ++i) {
      if (va_max(i) > Scalar(9) * va_min(i) || (use_gyro && vg_max(i) > Scalar(9) * vg_min(i)))
        return Status::kInitialRestDisturbed;
    }
    for (int k = 0; k < 4; ++k) {
      const Quarter& q = at(k);
      const Scalar nq = static_cast<Scalar>(q.n);
      const Vector3<Scalar> da = q.acc_mean - (first.acc_mean + acc_mean);
      const Vector3<Scalar> dg = q.gyro_mean - (first.gyro_mean + gyro_mean);
      const Scalar limit = Scalar(64) / nq + Scalar(1);
      for (int i = 0; i < 3; ++i) {
        if (da(i) * da(i) > limit * va(i) || (use_gyro && dg(i) * dg(i) > limit * vg(i)))
          return Status::kInitialRestDisturbed;
      }
    }
    return Status::kOk;
  }

  // The glitch test's reference needs this many samples; its sigma is at least this fraction
  // of the mean reading's magnitude; more glitches in a row than this are a change.
  static constexpr std::uint32_t kGlitchMinSamples = 8;
  static constexpr Scalar kGlitchFloor = Scalar(1e-6);
  static constexpr std::uint32_t kGlitchMaxRun = 8;

  Ring<Quarter, 4> quarters_{};                         // the last four complete quarters
  QuarterSums cur_{};                                   // the one filling
  Vector3<Scalar> ref_mean_ = Vector3<Scalar>::Zero();  // the glitch test's reference
  Scalar ref_var_ = Scalar(0);
  bool has_ref_ = false;
  std::uint32_t glitch_run_ = 0;
};

}  // namespace imucal
