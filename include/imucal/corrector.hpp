// imucal/corrector.hpp: the apply path. Built once from a calibration (or a decoded record), it
// maps every raw sample to a calibrated one with one 3x3 multiply-add per sensor:
//
//   a_cal = M_a a_raw + c_a,   M_a = T K,   c_a = T K b     (accel_model.hpp; m/s^2)
//   w_cal = M_w w_raw + c_w,   M_w = T K,   c_w = T K b     (gyro_model.hpp; rad/s)
//
// apply() has no branches and no checks: 9 multiply-adds and 3 adds per sensor (instruction
// count on Cortex-M4F in the README, bench/insn/bench_apply.cpp). A non-finite raw reading gives
// a non-finite output there; apply_checked() refuses it instead. A sensor without a usable
// calibration passes through unchanged (M = I, c = 0) and parts() says so. Never allocates.
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "imucal/accel_model.hpp"
#include "imucal/calibrator.hpp"
#include "imucal/gyro_model.hpp"
#include "imucal/record.hpp"
#include "imucal/status.hpp"

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
  Status set(const CalibrationRecord& r) { return set(r.calibration); }

  // The hot path: no branches, no checks.
  void apply(const Vector3<Scalar>& acc_raw, const Vector3<Scalar>& gyro_raw, Vector3<Scalar>& acc,
             Vector3<Scalar>& gyro) const {
    acc.noalias() = acc_m_ * acc_raw + acc_c_;
    gyro.noalias() = gyro_m_ * gyro_raw + gyro_c_;
  }
  Vector3<Scalar> accel(const Vector3<Scalar>& raw) const { return acc_m_ * raw + acc_c_; }
  Vector3<Scalar> gyro(const Vector3<Scalar>& raw) const { return gyro_m_ * raw + gyro_c_; }

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

  Matrix3<Scalar> acc_m_, gyro_m_;
  Vector3<Scalar> acc_c_, gyro_c_;
  std::uint16_t parts_ = 0;
};

}  // namespace imucal
