// imucal/corrector.hpp: the apply path. Built once from a calibration (or a decoded record), it
// maps every raw sample to a calibrated one with one 3x3 multiply-add per sensor:
//
//   a_cal = M_a a_raw + c_a,   M_a = T K,   c_a = T K b     (accel_model.hpp; m/s^2)
//   w_cal = M_w w_raw + c_w,   M_w = T K,   c_w = T K b     (gyro_model.hpp; rad/s)
//
//   m_cal = S m_raw + c_m,     c_m = S h                  (mag_model.hpp; uT)
//
// apply() has no branches and no checks: 9 multiply-adds and 3 adds per sensor (instruction
// count on Cortex-M4F in the README, bench/insn/bench_apply.cpp). A non-finite raw reading gives
// a non-finite output there; apply_checked() refuses it instead, and never returns kOk with a
// non-finite result. A sensor without a usable calibration passes through unchanged (M = I,
// c = 0) and parts() says so. Never allocates.
//
// Every value is checked against its physical bounds (plausibility.hpp) before it is loaded: a
// calibration with a part out of bounds is refused whole (kImplausible, bound() says which; a
// NaN or infinity: kNonFiniteInput) and the corrector keeps what it had.
//
// With a temperature model (temperature_model.hpp), the biases follow the temperature:
// set_temperature(T) recomputes c_a and c_w from b(T) (clamped to the temperatures the model was
// fitted over: it is not extrapolated). Call it when the temperature changes (it costs about
// as much as two samples), so the per-sample path stays the same.
//
// Threads and interrupts: the const members (apply(), apply_checked(), accel(), ...) only read;
// set...() write. Any number of readers may run together, but no reader while a writer runs on
// the same object: a sample applied in an interrupt while a task calls set() or
// set_temperature() can mix the old and the new calibration. To swap the calibration while an
// interrupt applies it, keep two correctors and publish the index of the one to use (no lock in
// the interrupt): CorrectorSwap below; the pattern is in docs/corrector_swap.md.
#pragma once

#include <Eigen/Core>
#include <atomic>
#include <cstdint>

#include "imucal/models/accel_model.hpp"
#include "imucal/models/calibration.hpp"
#include "imucal/models/gyro_model.hpp"
#include "imucal/models/mag_model.hpp"
#include "imucal/models/plausibility.hpp"
#include "imucal/models/temperature_model.hpp"
#include "imucal/status.hpp"
#include "imucal/store/record.hpp"

namespace imucal {

template <typename Scalar>
class Corrector {
 public:
  Corrector() { clear(); }

  // Both sensors pass through unchanged.
  void clear() {
    acc_m_.setIdentity();
    acc_c_.setZero();
    gyro_m_.setIdentity();
    gyro_c_.setZero();
    mag_m_.setIdentity();
    mag_c_.setZero();
    temperature_ = TemperatureModel<Scalar>{};
    temperature_c_ = Scalar(0);
    parts_ = 0;
    bound_ = Bound::kNone;
  }

  // Loads the usable parts (succeeded status); the others pass through. kOk if at least one part
  // was loaded, with parts() telling which sensors are calibrated; otherwise why not (the
  // accelerometer's status). A usable part with a value out of its physical bounds refuses the
  // whole calibration: kNonFiniteInput (NaN, infinity) or kImplausible, bound() naming the
  // bound, and the corrector unchanged.
  template <typename From>
  Status set(const Calibration<From>& c) {
    const bool a = succeeded(c.accel.status), g = succeeded(c.gyro.status);
    Bound b = a ? accel_bound(c.accel.params) : Bound::kNone;
    if (b == Bound::kNone && g) b = gyro_bound(c.gyro.params);
    if (b != Bound::kNone) return refuse(b);
    if (!a && !g) return c.accel.status == Status::kOk ? Status::kNotStarted : c.accel.status;
    Corrector next;
    if (a) {
      const AccelVector<From>& p = c.accel.params;
      const Vector3<From> bias(p(kBiasX), p(kBiasY), p(kBiasZ));
      if (!load(accel_matrix(p), bias, next.acc_m_, next.acc_c_)) return refuse(Bound::kNonFinite);
      next.parts_ = static_cast<std::uint16_t>(next.parts_ | kRecordAccel);
    }
    if (g) {
      const GyroVector<From>& p = c.gyro.params;
      const Vector3<From> bias(p(kGyroBiasX), p(kGyroBiasY), p(kGyroBiasZ));
      if (!load(gyro_matrix<From>(p), bias, next.gyro_m_, next.gyro_c_))
        return refuse(Bound::kNonFinite);
      next.parts_ = static_cast<std::uint16_t>(next.parts_ | kRecordGyro);
    }
    *this = next;
    return Status::kOk;
  }
  // Everything a record holds: accelerometer, gyro, magnetometer, temperature model, all checked
  // before any is loaded. Without a set_temperature() call the biases are those at the model's
  // reference temperature.
  Status set(const CalibrationRecord& r) {
    Corrector next;
    Status s = next.set(r.calibration);
    if (s == Status::kOk && (r.parts & kRecordMag)) s = next.set_mag(r.mag);
    if (s == Status::kOk && (r.parts & kRecordTemperature)) {
      s = next.set_temperature_model(r.temperature);
      if (s == Status::kNotStarted) s = Status::kOk;  // a model for sensors not in the record
    }
    if (s != Status::kOk) {
      bound_ = next.bound_;
      return s;
    }
    *this = next;
    return Status::kOk;
  }

  // The magnetometer's calibration (m_cal = S (m_raw + h)); refused unless usable and within
  // bounds (the corrector unchanged).
  template <typename From>
  Status set_mag(const MagCalibration<From>& m) {
    if (!succeeded(m.status)) return m.status;
    const Bound b = mag_bound(m.soft_iron, m.hard_iron, m.field_ut);
    if (b != Bound::kNone) return refuse(b);
    if (!load(m.soft_iron, m.hard_iron, mag_m_, mag_c_)) return refuse(Bound::kNonFinite);
    parts_ = static_cast<std::uint16_t>(parts_ | kRecordMag);
    return Status::kOk;
  }

  // The temperature model of the biases, for the sensors already set (set() first). The biases
  // become those at its reference temperature until set_temperature() is called. Refused (the
  // corrector unchanged) if a value is out of its bounds, checked through the sensors' matrices.
  template <typename From>
  Status set_temperature_model(const TemperatureModel<From>& t) {
    const bool a = succeeded(t.accel.status) && (parts_ & kRecordAccel);
    const bool g = succeeded(t.gyro.status) && (parts_ & kRecordGyro);
    if (!a && !g) return Status::kNotStarted;
    TemperatureModel<Scalar> m;
    m.order = t.order;
    m.reference_c = static_cast<Scalar>(t.reference_c);
    m.min_c = static_cast<Scalar>(t.min_c);
    m.max_c = static_cast<Scalar>(t.max_c);
    m.rests = t.rests;
    if (a) m.accel = cast_bias(t.accel);
    if (g) m.gyro = cast_bias(t.gyro);
    if ((a && !succeeded(m.accel.status)) || (g && !succeeded(m.gyro.status)))
      return refuse(Bound::kNonFinite);
    const Bound b = temperature_model_bound(m, a ? &acc_m_ : nullptr, g ? &gyro_m_ : nullptr);
    if (b != Bound::kNone) return refuse(b);
    const TemperatureModel<Scalar> previous = temperature_;
    const Scalar previous_c = temperature_c_;
    const std::uint16_t previous_parts = parts_;
    temperature_ = m;
    parts_ = static_cast<std::uint16_t>(parts_ | kRecordTemperature);
    const Status s = set_temperature(m.reference_c);
    if (s != Status::kOk) {
      temperature_ = previous;
      temperature_c_ = previous_c;
      parts_ = previous_parts;
    }
    return s;
  }

  // The biases at temperature t (deg C), clamped to the model's range. kNonFiniteInput for a NaN
  // or an infinity (the previous biases stay); kNotStarted without a model. Never kOk with a
  // non-finite offset (kImplausible, the previous biases kept).
  Status set_temperature(Scalar t) {
    if (!(parts_ & kRecordTemperature)) return Status::kNotStarted;
    if (!all_finite(t)) return Status::kNonFiniteInput;
    const TemperatureModel<Scalar>& m = temperature_;
    t = t < m.min_c ? m.min_c : (t > m.max_c ? m.max_c : t);
    Vector3<Scalar> ca = acc_c_, cg = gyro_c_;
    if (succeeded(m.accel.status)) ca.noalias() = acc_m_ * m.accel.at(t, m.reference_c);
    if (succeeded(m.gyro.status)) cg.noalias() = gyro_m_ * m.gyro.at(t, m.reference_c);
    if (!all_finite(ca)) return refuse(Bound::kAccelOffset);
    if (!all_finite(cg)) return refuse(Bound::kGyroOffset);
    acc_c_ = ca;
    gyro_c_ = cg;
    temperature_c_ = t;
    return Status::kOk;
  }
  Scalar temperature() const { return temperature_c_; }  // as last set (after clamping)

  // The hot path: no branches, no checks.
  void apply(const Vector3<Scalar>& acc_raw, const Vector3<Scalar>& gyro_raw, Vector3<Scalar>& acc,
             Vector3<Scalar>& gyro) const {
    affine(acc_m_, acc_raw, acc_c_, acc);
    affine(gyro_m_, gyro_raw, gyro_c_, gyro);
  }
  Vector3<Scalar> accel(const Vector3<Scalar>& raw) const { return affine(acc_m_, raw, acc_c_); }
  Vector3<Scalar> gyro(const Vector3<Scalar>& raw) const { return affine(gyro_m_, raw, gyro_c_); }
  Vector3<Scalar> mag(const Vector3<Scalar>& raw) const { return affine(mag_m_, raw, mag_c_); }

  // As apply(), but a raw reading that is not finite, or so large that the result is not, is
  // refused (kNonFiniteInput, outputs untouched): never kOk with a NaN or an infinity.
  Status apply_checked(const Vector3<Scalar>& acc_raw, const Vector3<Scalar>& gyro_raw,
                       Vector3<Scalar>& acc, Vector3<Scalar>& gyro) const {
    Vector3<Scalar> a, w;
    apply(acc_raw, gyro_raw, a, w);
    // A NaN or infinity in a raw reading reaches the result (finite M: Inf * 0 is NaN).
    if (!((a - a).sum() + (w - w).sum() == Scalar(0))) return Status::kNonFiniteInput;
    acc = a;
    gyro = w;
    return Status::kOk;
  }

  std::uint16_t parts() const { return parts_; }  // RecordPart bits: the calibrated sensors
  Bound bound() const { return bound_; }          // the bound the last refused set...() call broke
  const Matrix3<Scalar>& accel_matrix_used() const { return acc_m_; }
  const Vector3<Scalar>& accel_offset() const { return acc_c_; }
  const Matrix3<Scalar>& gyro_matrix_used() const { return gyro_m_; }
  const Vector3<Scalar>& gyro_offset() const { return gyro_c_; }
  const Matrix3<Scalar>& mag_matrix_used() const { return mag_m_; }
  const Vector3<Scalar>& mag_offset() const { return mag_c_; }

 private:
  Status refuse(Bound b) {
    bound_ = b;
    return b == Bound::kNonFinite ? Status::kNonFiniteInput : Status::kImplausible;
  }

  // c = M b in the calibration's own precision (M a_raw and c nearly cancel on raw counts),
  // then rounded once; refused (nothing changed) unless every entry is finite.
  template <typename From>
  static bool load(const Matrix3<From>& m_in, const Vector3<From>& b, Matrix3<Scalar>& m_out,
                   Vector3<Scalar>& c_out) {
    const Matrix3<Scalar> m = m_in.template cast<Scalar>();
    const Vector3<Scalar> c = (m_in * b).template cast<Scalar>();
    if (!((m - m).sum() + (c - c).sum() == Scalar(0))) return false;
    m_out = m;
    c_out = c;
    return true;
  }

  // out = m x + c, written out: Eigen's 3x3 product becomes an out-of-line call once a program
  // uses it in a few places (GCC -O2 on the M4F: 96 instead of 62 instructions per apply()).
  static void affine(const Matrix3<Scalar>& m, const Vector3<Scalar>& x, const Vector3<Scalar>& c,
                     Vector3<Scalar>& out) {
    const Scalar x0 = x(0), x1 = x(1), x2 = x(2);
    const Scalar o0 = m(0, 0) * x0 + m(0, 1) * x1 + m(0, 2) * x2 + c(0);
    const Scalar o1 = m(1, 0) * x0 + m(1, 1) * x1 + m(1, 2) * x2 + c(1);
    const Scalar o2 = m(2, 0) * x0 + m(2, 1) * x1 + m(2, 2) * x2 + c(2);
    out(0) = o0;
    out(1) = o1;
    out(2) = o2;
  }
  static Vector3<Scalar> affine(const Matrix3<Scalar>& m, const Vector3<Scalar>& x,
                                const Vector3<Scalar>& c) {
    Vector3<Scalar> out;
    affine(m, x, c, out);
    return out;
  }

  template <typename From>
  static TemperatureBias<Scalar> cast_bias(const TemperatureBias<From>& b) {
    TemperatureBias<Scalar> o;
    o.b0 = b.b0.template cast<Scalar>();
    o.b1 = b.b1.template cast<Scalar>();
    o.b2 = b.b2.template cast<Scalar>();
    o.b0_sigma = b.b0_sigma.template cast<Scalar>();
    o.b1_sigma = b.b1_sigma.template cast<Scalar>();
    o.b2_sigma = b.b2_sigma.template cast<Scalar>();
    const bool finite =
        ((o.b0 - o.b0).sum() + (o.b1 - o.b1).sum() + (o.b2 - o.b2).sum()) == Scalar(0);
    o.status = finite ? Status::kOk : Status::kNonFiniteInput;
    return o;
  }

  Matrix3<Scalar> acc_m_, gyro_m_, mag_m_;
  Vector3<Scalar> acc_c_, gyro_c_, mag_c_;
  TemperatureModel<Scalar> temperature_{};
  Scalar temperature_c_ = Scalar(0);
  std::uint16_t parts_ = 0;
  Bound bound_ = Bound::kNone;
};

// Two correctors and the index of the one in use, for a calibration that changes while an
// interrupt applies it (docs/corrector_swap.md). The interrupt calls active() once per sample
// and applies that corrector; a task prepares the other one (spare(), or prepare() for a copy of
// the active one, e.g. to set_temperature()) and then publish()es it. The interrupt takes no lock
// and never sees a corrector being written: the task writes only the spare, and a sample that
// began on the old corrector finishes before the task runs again (an interrupt runs to
// completion on the core it preempts). One writer task; readers only in interrupts of that core
// (or in tasks that cannot be preempted by the writer between active() and the end of a sample).
template <typename Scalar>
class CorrectorSwap {
 public:
  // Interrupt side: the corrector to apply to this sample.
  const Corrector<Scalar>& active() const {
    return slot_[active_.load(std::memory_order_acquire) & 1u];
  }
  // Task side: the corrector not in use, to set(); then publish().
  Corrector<Scalar>& spare() { return slot_[1u - (active_.load(std::memory_order_relaxed) & 1u)]; }
  // Task side: the spare, holding a copy of the active corrector.
  Corrector<Scalar>& prepare() {
    Corrector<Scalar>& s = spare();
    s = active();
    return s;
  }
  // Task side: the spare becomes the active corrector for every sample that starts from now.
  void publish() {
    active_.store(1u - (active_.load(std::memory_order_relaxed) & 1u), std::memory_order_release);
  }

 private:
  Corrector<Scalar> slot_[2];
  std::atomic<unsigned> active_{0};
};

}  // namespace imucal
