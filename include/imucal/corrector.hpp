// SPDX-License-Identifier: MIT
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
// a non-finite output there; apply_checked() and mag_checked() refuse it instead, and never
// return kOk with a non-finite result. A sensor without a usable calibration passes through
// unchanged (M = I, c = 0) and parts() says so. Never allocates.
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
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>

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

  // Both sensors pass through unchanged: every member zero (Bound::kNone too) but the matrices'
  // diagonals.
  void clear() {
    std::memset(static_cast<void*>(this), 0, bytes());
    for (int k = 0; k < kSensors; ++k)
      for (int i = 0; i < 3; ++i) m_[k](i, i) = Scalar(1);
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
    if (a && !load(accel_matrix(c.accel.params), c.accel.params.data() + kBiasX, next, kAccel))
      return refuse(Bound::kNonFinite);
    if (g &&
        !load(gyro_matrix<From>(c.gyro.params), c.gyro.params.data() + kGyroBiasX, next, kGyro))
      return refuse(Bound::kNonFinite);
    copy_from(next);
    return Status::kOk;
  }
  // Everything a record holds: accelerometer, gyro, magnetometer, temperature model, all checked
  // before any is loaded. Without a set_temperature() call the biases are those at the model's
  // reference temperature.
  Status set(const CalibrationRecord& r) {
    Corrector next;
    // A magnetometer's record alone holds no accelerometer or gyro to load.
    const bool mag_alone = (r.parts & (kRecordAccel | kRecordGyro)) == 0 && (r.parts & kRecordMag);
    Status s = mag_alone ? Status::kOk : next.set(r.calibration);
    if (s == Status::kOk && (r.parts & kRecordMag)) s = next.set_mag(r.mag);
    if (s == Status::kOk && (r.parts & kRecordTemperature)) {
      s = next.set_temperature_model(r.temperature);
      if (s == Status::kNotStarted) s = Status::kOk;  // a model for sensors not in the record
    }
    if (s != Status::kOk) {
      bound_ = next.bound_;
      return s;
    }
    copy_from(next);
    return Status::kOk;
  }

  // The magnetometer's calibration (m_cal = S (m_raw + h)); refused unless usable and within
  // bounds (the corrector unchanged).
  template <typename From>
  Status set_mag(const MagCalibration<From>& m) {
    if (!succeeded(m.status)) return m.status;
    const Bound b = mag_bound(m.soft_iron, m.hard_iron, m.field_ut);
    if (b != Bound::kNone) return refuse(b);
    if (!load(m.soft_iron, m.hard_iron.data(), *this, kMag)) return refuse(Bound::kNonFinite);
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
    Model next{};
    next.sensors = static_cast<std::uint8_t>((a ? 1u : 0u) | (g ? 2u : 0u));
    next.reference = static_cast<Scalar>(t.reference_c);
    next.min = static_cast<Scalar>(t.min_c);
    next.max = static_cast<Scalar>(t.max_c);
    const TemperatureBias<From>* const in[kTemperatureSensors] = {&t.accel, &t.gyro};
    for (int k = 0; k < kTemperatureSensors; ++k) {
      if (!(next.sensors & (1u << k))) continue;
      const Vector3<From>* const terms[3] = {&in[k]->b0, &in[k]->b1, &in[k]->b2};
      for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i) next.b[k][j][i] = static_cast<Scalar>((*terms[j])(i));
      if (!bounds::finite(&next.b[k][0][0], 9)) return refuse(Bound::kNonFinite);
    }
    const Bound b = model_bound(t, next, a ? &m_[kAccel] : nullptr, g ? &m_[kGyro] : nullptr);
    if (b != Bound::kNone) return refuse(b);
    Offsets c;
    Scalar at = next.reference;
    const Bound offset = offsets(next, at, c);
    if (offset != Bound::kNone) return refuse(offset);
    model_ = next;
    commit(c, at);
    parts_ = static_cast<std::uint16_t>(parts_ | kRecordTemperature);
    return Status::kOk;
  }

  // The biases at temperature t (deg C), clamped to the model's range. kNonFiniteInput for a NaN
  // or an infinity (the previous biases stay); kNotStarted without a model. Never kOk with a
  // non-finite offset (kImplausible, the previous biases kept).
  Status set_temperature(Scalar t) {
    if (!(parts_ & kRecordTemperature)) return Status::kNotStarted;
    if (!bounds::is_finite(t)) return Status::kNonFiniteInput;
    Offsets c;
    const Bound offset = offsets(model_, t, c);
    if (offset != Bound::kNone) return refuse(offset);
    commit(c, t);
    return Status::kOk;
  }
  Scalar temperature() const { return temperature_c_; }  // as last set (after clamping)

  // The hot path: no branches, no checks.
  void apply(const Vector3<Scalar>& acc_raw, const Vector3<Scalar>& gyro_raw, Vector3<Scalar>& acc,
             Vector3<Scalar>& gyro) const {
    affine(m_[kAccel], acc_raw, c_[kAccel], acc);
    affine(m_[kGyro], gyro_raw, c_[kGyro], gyro);
  }
  Vector3<Scalar> accel(const Vector3<Scalar>& raw) const {
    return affine(m_[kAccel], raw, c_[kAccel]);
  }
  Vector3<Scalar> gyro(const Vector3<Scalar>& raw) const {
    return affine(m_[kGyro], raw, c_[kGyro]);
  }
  Vector3<Scalar> mag(const Vector3<Scalar>& raw) const { return affine(m_[kMag], raw, c_[kMag]); }

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
  // As mag(), refused in the same way (kNonFiniteInput, the output untouched).
  Status mag_checked(const Vector3<Scalar>& raw, Vector3<Scalar>& out) const {
    const Vector3<Scalar> m = mag(raw);
    if (!((m - m).sum() == Scalar(0))) return Status::kNonFiniteInput;
    out = m;
    return Status::kOk;
  }

  std::uint16_t parts() const { return parts_; }  // RecordPart bits: the calibrated sensors
  Bound bound() const { return bound_; }          // the bound the last refused set...() call broke
  const Matrix3<Scalar>& accel_matrix_used() const { return m_[kAccel]; }
  const Vector3<Scalar>& accel_offset() const { return c_[kAccel]; }
  const Matrix3<Scalar>& gyro_matrix_used() const { return m_[kGyro]; }
  const Vector3<Scalar>& gyro_offset() const { return c_[kGyro]; }
  const Matrix3<Scalar>& mag_matrix_used() const { return m_[kMag]; }
  const Vector3<Scalar>& mag_offset() const { return c_[kMag]; }

 private:
  // The sensors, sensor k's RecordPart bit being 1 << k; the first two have temperature models.
  static constexpr int kAccel = 0, kGyro = 1, kMag = 2, kSensors = 3, kTemperatureSensors = 2;
  static_assert(kRecordAccel == 1u << kAccel && kRecordGyro == 1u << kGyro &&
                    kRecordMag == 1u << kMag,
                "sensor k's part bit");

  // The temperature model as set_temperature() applies it: per sensor (accelerometer, gyro) the
  // bias b(T) = b0 + d (b1 + d b2), d = T - T0, in raw units (temperature_model.hpp).
  struct Model {
    Scalar b[kTemperatureSensors][3][3];  // [sensor][b0, b1, b2][axis]
    Scalar reference, min, max;           // T0 and the range fitted (deg C)
    std::uint8_t sensors;                 // bit k: sensor k's biases follow the temperature
  };
  using Offsets = Scalar[kTemperatureSensors][3];  // c of the sensors with a temperature model

  // A corrector is its bytes (numbers, enums and fixed-size Eigen matrices): copied with one
  // memcpy, not member-wise code. The bytes up to its last member (a derived class's members may
  // live in the padding after it).
  static constexpr std::size_t bytes() { return offsetof(Corrector, bound_) + sizeof(Bound); }
  void copy_from(const Corrector& other) {
    std::memcpy(static_cast<void*>(this), static_cast<const void*>(&other), bytes());
  }

  Status refuse(Bound b) {
    bound_ = b;
    return b == Bound::kNonFinite ? Status::kNonFiniteInput : Status::kImplausible;
  }

  // Sensor k of `to` gets M = m_in and c = M b, c in the calibration's own precision (M a_raw
  // and c nearly cancel on raw counts), then rounded once; refused (nothing changed) unless every
  // entry is finite. b: the 3 values of the bias.
  template <typename From>
  static bool load(const Matrix3<From>& m_in, const From* b, Corrector& to, int k) {
    const Matrix3<Scalar> m = m_in.template cast<Scalar>();
    From mb[3];
    bounds::product(m_in, b, mb);
    Scalar c[3];
    for (int i = 0; i < 3; ++i) c[i] = static_cast<Scalar>(mb[i]);
    if (!bounds::finite(m.data(), 9) || !bounds::finite(c, 3)) return false;
    // Element by element: Eigen's assignment is out-of-line code at -Os.
    for (int i = 0; i < 9; ++i) to.m_[k](i) = m(i);
    for (int i = 0; i < 3; ++i) to.c_[k](i) = c[i];
    to.parts_ = static_cast<std::uint16_t>(to.parts_ | (1u << k));
    return true;
  }

  // The model's bound (temperature_model_bound), in the corrector's precision.
  template <typename From>
  static Bound model_bound(const TemperatureModel<From>& t, const Model& cast,
                           const Matrix3<Scalar>* accel_m, const Matrix3<Scalar>* gyro_m) {
    if constexpr (std::is_same<From, Scalar>::value) {
      return temperature_model_bound(t, accel_m, gyro_m);  // `cast` holds the same values
    } else {
      TemperatureModel<Scalar> m;
      m.reference_c = cast.reference;
      m.min_c = cast.min;
      m.max_c = cast.max;
      TemperatureBias<Scalar>* const out[kTemperatureSensors] = {&m.accel, &m.gyro};
      for (int k = 0; k < kTemperatureSensors; ++k) {
        if (!(cast.sensors & (1u << k))) continue;
        out[k]->status = Status::kOk;
        for (int i = 0; i < 3; ++i) {
          out[k]->b0(i) = cast.b[k][0][i];
          out[k]->b1(i) = cast.b[k][1][i];
          out[k]->b2(i) = cast.b[k][2][i];
        }
      }
      return temperature_model_bound(m, accel_m, gyro_m);
    }
  }

  // The offsets c = M b(t) of the sensors whose biases follow the model (the others keep theirs),
  // t clamped to the model's range (not extrapolated); kAccelOffset or kGyroOffset for one that
  // is not finite.
  Bound offsets(const Model& model, Scalar& t, Offsets& c) const {
    t = !bounds::at_most(model.min, t) ? model.min
                                       : (!bounds::at_most(t, model.max) ? model.max : t);
    const Scalar d = t + bounds::negated(model.reference);
    for (int k = 0; k < kTemperatureSensors; ++k) {
      for (int i = 0; i < 3; ++i) c[k][i] = c_[k](i);
      if (!(model.sensors & (1u << k))) continue;
      const Scalar(&b)[3][3] = model.b[k];
      Scalar v[3];
      for (int i = 0; i < 3; ++i) v[i] = b[0][i] + d * (b[1][i] + d * b[2][i]);
      bounds::product(m_[k], v, c[k]);
      if (!bounds::finite(c[k], 3)) return k == kAccel ? Bound::kAccelOffset : Bound::kGyroOffset;
    }
    return Bound::kNone;
  }
  void commit(const Offsets& c, Scalar t) {
    for (int k = 0; k < kTemperatureSensors; ++k)
      for (int i = 0; i < 3; ++i) c_[k](i) = c[k][i];
    temperature_c_ = t;
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

  Matrix3<Scalar> m_[kSensors];  // M per sensor (Sensor order)
  Vector3<Scalar> c_[kSensors];  // c per sensor
  Model model_{};
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
