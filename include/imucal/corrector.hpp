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
// a non-finite output there; apply_checked() refuses it instead. A sensor without a usable
// calibration passes through unchanged (M = I, c = 0) and parts() says so. Never allocates.
//
// With a temperature model (temperature_model.hpp), the biases follow the temperature:
// set_temperature(T) recomputes c_a and c_w from b(T) (clamped to the temperatures the model was
// fitted over: it is not extrapolated). Call it when the temperature changes (it costs about
// as much as two samples), so the per-sample path stays the same.
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "imucal/accel_model.hpp"
#include "imucal/calibrator.hpp"
#include "imucal/gyro_model.hpp"
#include "imucal/mag_model.hpp"
#include "imucal/record.hpp"
#include "imucal/status.hpp"
#include "imucal/temperature_model.hpp"

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
  }

  // Loads the usable parts (succeeded status, finite values); the others pass through.
  // kOk if at least one part was loaded; otherwise why not (the accelerometer's status, or
  // kNonFiniteInput for a "succeeded" part holding a NaN). Returns kOk with parts() telling
  // which sensors are calibrated.
  template <typename From>
  Status set(const Calibration<From>& c) {
    clear();
    Status why = succeeded(c.accel.status) ? Status::kOk : c.accel.status;
    if (succeeded(c.accel.status)) {
      const AccelVector<From>& p = c.accel.params;
      const Matrix3<From> m = accel_matrix(p);
      const Vector3<From> b(p(kBiasX), p(kBiasY), p(kBiasZ));
      if (load(m, b, acc_m_, acc_c_))
        parts_ = static_cast<std::uint16_t>(parts_ | kRecordAccel);
      else
        why = Status::kNonFiniteInput;
    }
    if (succeeded(c.gyro.status)) {
      const GyroVector<From>& p = c.gyro.params;
      const Matrix3<From> m = gyro_matrix<From>(p);
      const Vector3<From> b(p(kGyroBiasX), p(kGyroBiasY), p(kGyroBiasZ));
      if (load(m, b, gyro_m_, gyro_c_))
        parts_ = static_cast<std::uint16_t>(parts_ | kRecordGyro);
      else if (why == Status::kOk)
        why = Status::kNonFiniteInput;
    }
    return parts_ != 0 ? Status::kOk : (why == Status::kOk ? Status::kNotStarted : why);
  }
  // Everything a record holds: accelerometer, gyro, magnetometer, temperature model. Without a
  // set_temperature() call the biases are those at the model's reference temperature.
  Status set(const CalibrationRecord& r) {
    const Status s = set(r.calibration);
    if (s != Status::kOk) return s;
    if (r.parts & kRecordMag) set_mag(r.mag);
    if (r.parts & kRecordTemperature) set_temperature_model(r.temperature);
    return Status::kOk;
  }

  // The magnetometer's calibration (m_cal = S (m_raw + h)); refused unless usable and finite.
  template <typename From>
  Status set_mag(const MagCalibration<From>& m) {
    if (!succeeded(m.status)) return m.status;
    if (!load(m.soft_iron, m.hard_iron, mag_m_, mag_c_)) return Status::kNonFiniteInput;
    parts_ = static_cast<std::uint16_t>(parts_ | kRecordMag);
    return Status::kOk;
  }

  // The temperature model of the biases, for the sensors already set (set() first). The biases
  // become those at its reference temperature until set_temperature() is called.
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
      return Status::kNonFiniteInput;
    if (!(m.min_c <= m.max_c) || !(m.reference_c == m.reference_c)) return Status::kInvalidArgument;
    temperature_ = m;
    parts_ = static_cast<std::uint16_t>(parts_ | kRecordTemperature);
    return set_temperature(m.reference_c);
  }

  // The biases at temperature t (deg C), clamped to the model's range. kNonFiniteInput for a NaN
  // (the previous biases stay); kNotStarted without a model.
  Status set_temperature(Scalar t) {
    if (!(parts_ & kRecordTemperature)) return Status::kNotStarted;
    if (!(t == t)) return Status::kNonFiniteInput;
    const TemperatureModel<Scalar>& m = temperature_;
    t = t < m.min_c ? m.min_c : (t > m.max_c ? m.max_c : t);
    if (succeeded(m.accel.status)) acc_c_.noalias() = acc_m_ * m.accel.at(t, m.reference_c);
    if (succeeded(m.gyro.status)) gyro_c_.noalias() = gyro_m_ * m.gyro.at(t, m.reference_c);
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

  // As apply(), but a non-finite raw reading is refused (kNonFiniteInput, outputs untouched).
  Status apply_checked(const Vector3<Scalar>& acc_raw, const Vector3<Scalar>& gyro_raw,
                       Vector3<Scalar>& acc, Vector3<Scalar>& gyro) const {
    const Scalar nan_if_any = (acc_raw - acc_raw).sum() + (gyro_raw - gyro_raw).sum();
    if (!(nan_if_any == Scalar(0))) return Status::kNonFiniteInput;
    apply(acc_raw, gyro_raw, acc, gyro);
    return Status::kOk;
  }

  std::uint16_t parts() const { return parts_; }  // RecordPart bits: the calibrated sensors
  const Matrix3<Scalar>& accel_matrix_used() const { return acc_m_; }
  const Vector3<Scalar>& accel_offset() const { return acc_c_; }
  const Matrix3<Scalar>& gyro_matrix_used() const { return gyro_m_; }
  const Vector3<Scalar>& gyro_offset() const { return gyro_c_; }
  const Matrix3<Scalar>& mag_matrix_used() const { return mag_m_; }
  const Vector3<Scalar>& mag_offset() const { return mag_c_; }

 private:
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
};

}  // namespace imucal
