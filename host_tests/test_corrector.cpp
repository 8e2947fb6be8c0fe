// SPDX-License-Identifier: MIT
// The apply path: the precomputed 3x3 multiply-add per sensor equals the model (accel_apply,
// gyro_apply in double) to float rounding on raw 16-bit counts; parts without a calibration pass
// through; a calibration with a NaN is not loaded; apply_checked refuses NaN readings.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "imucal/corrector.hpp"
#include "imucal/sim/random.hpp"
#include "support/example_calibration.hpp"
#include "support/gtest_status.hpp"

namespace imucal {
namespace {

Calibration<double> xsens_like() { return test::example_calibration(); }

TEST(Corrector, MatchesTheModelToFloatRounding) {
  const Calibration<double> c = xsens_like();
  Corrector<float> corr;
  ASSERT_EQ(corr.set(c), Status::kOk);
  EXPECT_EQ(corr.parts(), kRecordAccel | kRecordGyro);
  sim::Random rng(3);
  double worst_a = 0.0, worst_w = 0.0;
  for (int k = 0; k < 2000; ++k) {
    // Raw counts anywhere in the 16-bit range (integers: exact in float).
    Vector3<double> a, w;
    for (int i = 0; i < 3; ++i) {
      a(i) = std::round(rng.uniform(0.0, 65535.0));
      w(i) = std::round(rng.uniform(0.0, 65535.0));
    }
    Vector3<float> a_out, w_out;
    corr.apply(a.cast<float>(), w.cast<float>(), a_out, w_out);
    worst_a = std::max(worst_a, (a_out.cast<double>() - accel_apply(c.accel.params, a)).norm());
    worst_w = std::max(worst_w, (w_out.cast<double>() - gyro_apply(c.gyro.params, w)).norm());
  }
  // Float rounding: M a and c are each about |M| 32768 = 80 m/s^2 (7 rad/s); three roundings of
  // 2^-24 relative per term give ~2e-5 m/s^2 (2e-6 rad/s), 1/400 of the xsens noise (0.008).
  EXPECT_LT(worst_a, 80.0 * 6e-8 * 8);
  EXPECT_LT(worst_w, 7.0 * 6e-8 * 8);
  EXPECT_GT(worst_a, 0.0);  // it is float, not a copy of the double path
}

TEST(Corrector, DoubleCorrectorIsTheModel) {
  const Calibration<double> c = xsens_like();
  Corrector<double> corr;
  ASSERT_EQ(corr.set(c), Status::kOk);
  const Vector3<double> a(33000.0, 30000.0, 36000.0), w(32800.0, 32700.0, 32760.0);
  EXPECT_LT((corr.accel(a) - accel_apply(c.accel.params, a)).norm(), 1e-12);
  EXPECT_LT((corr.gyro(w) - gyro_apply(c.gyro.params, w)).norm(), 1e-12);
}

TEST(Corrector, MissingPartsPassThrough) {
  Calibration<double> c = xsens_like();
  c.gyro.status = Status::kTooFewMoves;
  Corrector<float> corr;
  ASSERT_EQ(corr.set(c), Status::kOk);
  EXPECT_EQ(corr.parts(), kRecordAccel);
  const Vector3<float> w(1.0f, -2.0f, 3.0f);
  EXPECT_EQ(corr.gyro(w), w);
  c.accel.status = Status::kPosesCoplanar;
  EXPECT_EQ(corr.set(c), Status::kPosesCoplanar);  // nothing to load: says why
  EXPECT_EQ(corr.parts(), kRecordAccel);           // and keeps what it had
  Corrector<float> fresh;
  EXPECT_EQ(fresh.set(c), Status::kPosesCoplanar);
  EXPECT_EQ(fresh.parts(), 0);
  EXPECT_EQ(fresh.accel(w), w);
}

// A part said usable but holding a NaN refuses the whole calibration; the corrector keeps what
// it had.
TEST(Corrector, ANaNInACalibrationIsNotLoaded) {
  Calibration<double> c = xsens_like();
  c.accel.params(kAlphaZy) = std::numeric_limits<double>::quiet_NaN();
  Corrector<float> corr;
  EXPECT_EQ(corr.set(c), Status::kNonFiniteInput);
  EXPECT_EQ(corr.bound(), Bound::kNonFinite);
  EXPECT_EQ(corr.parts(), 0);
  EXPECT_TRUE(corr.accel_matrix_used().isIdentity());
  ASSERT_EQ(corr.set(xsens_like()), Status::kOk);
  const Matrix3<float> before = corr.gyro_matrix_used();
  c = xsens_like();
  c.gyro.params(kGyroScaleX) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(corr.set(c), Status::kNonFiniteInput);
  EXPECT_EQ(corr.parts(), kRecordAccel | kRecordGyro);
  EXPECT_EQ(corr.gyro_matrix_used(), before);
}

TEST(Corrector, ApplyCheckedRefusesNonFiniteReadings) {
  Corrector<float> corr;
  ASSERT_EQ(corr.set(xsens_like()), Status::kOk);
  Vector3<float> a_out(7, 7, 7), w_out(7, 7, 7);
  Vector3<float> bad(32768.0f, std::numeric_limits<float>::quiet_NaN(), 32768.0f);
  const Vector3<float> good(32768.0f, 32768.0f, 32768.0f);
  EXPECT_EQ(corr.apply_checked(bad, good, a_out, w_out), Status::kNonFiniteInput);
  EXPECT_EQ(corr.apply_checked(good, bad, a_out, w_out), Status::kNonFiniteInput);
  EXPECT_EQ(a_out, Vector3<float>(7, 7, 7));
  EXPECT_EQ(corr.apply_checked(good, good, a_out, w_out), Status::kOk);
  EXPECT_TRUE(std::isfinite(a_out.sum()) && std::isfinite(w_out.sum()));
  // The magnetometer likewise, calibrated or passing through.
  for (int calibrated = 0; calibrated < 2; ++calibrated) {
    if (calibrated) {
      ASSERT_EQ(corr.set_mag(test::example_mag()), Status::kOk);
    }
    Vector3<float> m_out(7, 7, 7);
    EXPECT_EQ(corr.mag_checked(bad, m_out), Status::kNonFiniteInput);
    const Vector3<float> inf(std::numeric_limits<float>::infinity(), 0.0f, 0.0f);
    EXPECT_EQ(corr.mag_checked(inf, m_out), Status::kNonFiniteInput);
    EXPECT_EQ(m_out, Vector3<float>(7, 7, 7));
    const Vector3<float> field(120.0f, -340.0f, 560.0f);
    EXPECT_EQ(corr.mag_checked(field, m_out), Status::kOk);
    EXPECT_EQ(m_out, corr.mag(field));
  }
}

// The record as the store keeps it: encoded, then decoded.
void through_bytes(const CalibrationRecord& r, CalibrationRecord& back) {
  std::uint8_t bytes[kRecordMaxBytes];
  std::size_t n = 0;
  ASSERT_EQ(encode_record(r, bytes, sizeof bytes, &n), Status::kOk);
  ASSERT_EQ(decode_record(bytes, n, back), Status::kOk);
}

TEST(Corrector, FromADecodedRecord) {
  CalibrationRecord r;
  ASSERT_EQ(make_record(xsens_like(), 1, 2, r), Status::kOk);
  CalibrationRecord back;
  ASSERT_NO_FATAL_FAILURE(through_bytes(r, back));
  Corrector<float> from_record, from_float;
  ASSERT_EQ(from_record.set(back), Status::kOk);
  ASSERT_EQ(from_float.set(r.calibration), Status::kOk);
  const Vector3<float> a(33000.0f, 30000.0f, 36000.0f);
  EXPECT_EQ(from_record.accel(a), from_float.accel(a));  // the record loses nothing
  EXPECT_EQ(from_record.parts(), kRecordAccel | kRecordGyro);
}

// The magnetometer: S (m + h), within float rounding of the model in double.
TEST(Corrector, MagnetometerIsTheModel) {
  const MagCalibration<double> m = test::example_mag();
  Corrector<float> corr;
  ASSERT_EQ(corr.set(xsens_like()), Status::kOk);
  ASSERT_EQ(corr.set_mag(m), Status::kOk);
  EXPECT_EQ(corr.parts(), kRecordAccel | kRecordGyro | kRecordMag);
  sim::Random rng(4);
  double worst = 0.0;
  for (int k = 0; k < 1000; ++k) {
    Vector3<double> raw;
    for (int i = 0; i < 3; ++i) raw(i) = std::round(rng.uniform(-2000.0, 2000.0));
    worst =
        std::max(worst, (corr.mag(raw.cast<float>()).cast<double>() - mag_apply(m, raw)).norm());
  }
  EXPECT_LT(worst, 400.0 * 6e-8 * 8);  // |S m| up to ~400 uT, a few float roundings
  MagCalibration<double> bad = m;
  bad.status = Status::kPoorCoverage;
  Corrector<float> other;
  EXPECT_EQ(other.set_mag(bad), Status::kPoorCoverage);  // refused with the fit's reason
  EXPECT_EQ(other.parts(), 0);
}

// A magnetometer's record alone (the tool's magnetometer-only calibration) loads its
// magnetometer; the accelerometer and the gyro pass through.
TEST(Corrector, AMagnetometerRecordAloneIsApplied) {
  const MagCalibration<double> m = test::example_mag();
  CalibrationRecord r;
  ASSERT_EQ(make_record(Calibration<double>{}, 1, 2, r, &m), Status::kOk);
  ASSERT_EQ(r.parts, kRecordMag);
  CalibrationRecord back;
  ASSERT_NO_FATAL_FAILURE(through_bytes(r, back));
  Corrector<float> from_record, from_mag;
  ASSERT_EQ(from_record.set(back), Status::kOk);
  EXPECT_EQ(from_record.parts(), kRecordMag);
  ASSERT_EQ(from_mag.set_mag(back.mag), Status::kOk);
  const Vector3<float> raw(120.0f, -340.0f, 560.0f);
  EXPECT_EQ(from_record.mag(raw), from_mag.mag(raw));
  EXPECT_NE(from_record.mag(raw), raw);
  EXPECT_EQ(from_record.accel(raw), raw);
  // A record with nothing usable still loads nothing.
  CalibrationRecord empty = back;
  empty.parts = 0;
  Corrector<float> none;
  EXPECT_NE(none.set(empty), Status::kOk);
  EXPECT_EQ(none.parts(), 0);
}

// Biases follow the temperature model: at T the offsets are M b(T); outside the fitted range
// they stay at its edge (no extrapolation); a NaN temperature keeps the last ones.
TEST(Corrector, BiasesFollowTheTemperature) {
  const Calibration<double> c = xsens_like();
  const TemperatureModel<double> t = test::example_temperature(2);
  Corrector<double> corr;
  ASSERT_EQ(corr.set(c), Status::kOk);
  EXPECT_EQ(corr.set_temperature(30.0), Status::kNotStarted);  // no model yet
  ASSERT_EQ(corr.set_temperature_model(t), Status::kOk);
  EXPECT_EQ(corr.parts(), kRecordAccel | kRecordGyro | kRecordTemperature);
  EXPECT_EQ(corr.temperature(), t.reference_c);
  auto expected = [&](double temp, const Vector3<double>& a_raw, const Vector3<double>& w_raw,
                      Vector3<double>& a, Vector3<double>& w) {
    AccelVector<double> pa = c.accel.params;
    GyroVector<double> pg = c.gyro.params;
    const Vector3<double> ba = t.accel.at(temp, t.reference_c), bg = t.gyro.at(temp, t.reference_c);
    for (int i = 0; i < 3; ++i) {
      pa(kBiasX + i) = ba(i);
      pg(kGyroBiasX + i) = bg(i);
    }
    a = accel_apply(pa, a_raw);
    w = gyro_apply(pg, w_raw);
  };
  const Vector3<double> a_raw(33000.0, 30000.0, 36000.0), w_raw(32800.0, 32700.0, 32760.0);
  for (double temp : {5.0, 12.5, 24.5, 38.0, 45.0}) {
    ASSERT_EQ(corr.set_temperature(temp), Status::kOk);
    Vector3<double> a, w;
    expected(temp, a_raw, w_raw, a, w);
    EXPECT_LT((corr.accel(a_raw) - a).norm(), 1e-9) << temp;
    EXPECT_LT((corr.gyro(w_raw) - w).norm(), 1e-9) << temp;
  }
  // Clamped to [5, 45] degC.
  ASSERT_EQ(corr.set_temperature(80.0), Status::kOk);
  EXPECT_EQ(corr.temperature(), 45.0);
  Vector3<double> a45, w45;
  expected(45.0, a_raw, w_raw, a45, w45);
  EXPECT_LT((corr.accel(a_raw) - a45).norm(), 1e-9);
  EXPECT_EQ(corr.set_temperature(std::numeric_limits<double>::quiet_NaN()),
            Status::kNonFiniteInput);
  EXPECT_EQ(corr.temperature(), 45.0);
  EXPECT_LT((corr.accel(a_raw) - a45).norm(), 1e-9);
  // The slope matters: 45 degC and 5 degC differ by the model, not by rounding.
  ASSERT_EQ(corr.set_temperature(5.0), Status::kOk);
  EXPECT_GT((corr.accel(a_raw) - a45).norm(), 1e-3);
}

// A record with every part sets every part, and the float corrector follows the temperature.
TEST(Corrector, EveryPartFromARecord) {
  CalibrationRecord r;
  const MagCalibration<double> m = test::example_mag();
  const TemperatureModel<double> t = test::example_temperature(1);
  ASSERT_EQ(make_record(xsens_like(), 1, 2, r, &m, &t), Status::kOk);
  CalibrationRecord back;
  ASSERT_NO_FATAL_FAILURE(through_bytes(r, back));
  Corrector<float> corr;
  ASSERT_EQ(corr.set(back), Status::kOk);
  EXPECT_EQ(corr.parts(), kRecordAccel | kRecordGyro | kRecordMag | kRecordTemperature);
  const Vector3<float> w(32800.0f, 32700.0f, 32760.0f);
  ASSERT_EQ(corr.set_temperature(34.5f), Status::kOk);  // 10 degC above the reference
  const Vector3<float> warm = corr.gyro(w);
  ASSERT_EQ(corr.set_temperature(24.5f), Status::kOk);
  const Vector3<float> ref = corr.gyro(w);
  // 10 degC times the gyro slope, through M (rad/s per count).
  const Vector3<double> expected_change =
      gyro_matrix<double>(xsens_like().gyro.params) * (10.0 * t.gyro.b1);
  EXPECT_LT(((warm - ref).cast<double>() - expected_change).norm(), 1e-5);
}

}  // namespace
}  // namespace imucal

namespace imucal {
namespace {

// Finite but absurd values are refused before they are loaded, naming the bound; the corrector
// keeps the calibration it had.
TEST(CorrectorPlausibility, AbsurdValuesAreRefusedNamingTheBound) {
  Corrector<float> corr;
  ASSERT_EQ(corr.set(xsens_like()), Status::kOk);
  const Matrix3<float> m = corr.accel_matrix_used();
  const Vector3<float> offset = corr.accel_offset();
  struct Case {
    int accel_index, gyro_index;
    double value;
    Bound bound;
  };
  const Case cases[] = {
      {kScaleX, -1, 3e38, Bound::kAccelScale},        {kScaleZ, -1, 0.0, Bound::kAccelScale},
      {kAlphaYz, -1, 0.7, Bound::kAccelMisalignment}, {kBiasY, -1, 1e30, Bound::kAccelOffset},
      {-1, kGyroScaleY, 3e38, Bound::kGyroScale},     {-1, kGyroScaleY, 0.0, Bound::kGyroScale},
      {-1, kGammaZx, -0.8, Bound::kGyroMisalignment}, {-1, kGyroBiasZ, 1e12, Bound::kGyroOffset},
  };
  for (const Case& k : cases) {
    Calibration<double> c = xsens_like();
    if (k.accel_index >= 0) c.accel.params(k.accel_index) = k.value;
    if (k.gyro_index >= 0) c.gyro.params(k.gyro_index) = k.value;
    EXPECT_EQ(corr.set(c), Status::kImplausible) << to_string(k.bound);
    EXPECT_EQ(corr.bound(), k.bound) << to_string(corr.bound());
    EXPECT_EQ(corr.accel_matrix_used(), m);
    EXPECT_EQ(corr.accel_offset(), offset);
  }
  // The magnetometer: a field of 5000 uT, a soft iron of 3e38.
  MagCalibration<double> mag = test::example_mag();
  mag.field_ut = 5000.0;
  EXPECT_EQ(corr.set_mag(mag), Status::kImplausible);
  EXPECT_EQ(corr.bound(), Bound::kMagField);
  mag = test::example_mag();
  mag.soft_iron(0, 0) = 3e38;
  EXPECT_EQ(corr.set_mag(mag), Status::kImplausible);
  EXPECT_EQ(corr.bound(), Bound::kMagSoftIron);
  EXPECT_EQ(corr.parts() & kRecordMag, 0);
  // A temperature slope of 1e38 (finite in float too).
  TemperatureModel<double> t = test::example_temperature(1);
  t.accel.b1(1) = 1e38;
  EXPECT_EQ(corr.set_temperature_model(t), Status::kImplausible);
  EXPECT_EQ(corr.bound(), Bound::kAccelSlope);
  EXPECT_EQ(corr.parts() & kRecordTemperature, 0);
  EXPECT_EQ(corr.set_temperature(30.0f), Status::kNotStarted);
  EXPECT_EQ(corr.accel_offset(), offset);
  // A record holding the same (written by another encoder): refused whole, nothing changes.
  CalibrationRecord r;
  const MagCalibration<double> good_mag = test::example_mag();
  const TemperatureModel<double> good_t = test::example_temperature(1);
  ASSERT_EQ(make_record(xsens_like(), 1, 2, r, &good_mag, &good_t), Status::kOk);
  r.temperature.gyro.b1(0) = 1e38f;
  EXPECT_EQ(corr.set(r), Status::kImplausible);
  EXPECT_EQ(corr.bound(), Bound::kGyroSlope);
  EXPECT_EQ(corr.parts(), kRecordAccel | kRecordGyro);
}

// apply_checked() and set_temperature() never return kOk with a NaN or an infinity, whatever the
// reading or temperature, on the largest calibration the bounds allow.
TEST(CorrectorPlausibility, NeverOkWithANonFiniteResult) {
  Calibration<double> c = xsens_like();
  c.accel.params.setZero();
  c.accel.params(kScaleX) = c.accel.params(kScaleY) = c.accel.params(kScaleZ) = 999.0;
  c.accel.params(kAlphaYz) = 0.49;
  c.gyro.params(kGyroScaleX) = -999.0;
  c.gyro.params(kGyroBiasX) = 1.0;
  Corrector<float> corr;
  ASSERT_EQ(corr.set(c), Status::kOk);
  TemperatureModel<double> t = test::example_temperature(2);
  t.accel.b0.setConstant(1.0);
  t.accel.b1.setConstant(1e-3);  // 1 m/s^2 per degC through the scale of 999
  t.accel.b2.setConstant(1e-5);
  t.gyro.b0.setZero();
  t.gyro.b1.setZero();
  t.gyro.b2.setZero();
  ASSERT_EQ(corr.set_temperature_model(t), Status::kOk);
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float max = std::numeric_limits<float>::max();
  int ok = 0, refused = 0;
  for (float temperature : {-inf, -1e30f, -max, -100.0f, 0.0f, 45.0f, 1e30f, max, inf, nan}) {
    const Status s = corr.set_temperature(temperature);
    if (s == Status::kOk) {
      EXPECT_TRUE(std::isfinite(corr.accel_offset().sum())) << temperature;
      EXPECT_TRUE(std::isfinite(corr.temperature())) << temperature;
    } else {
      EXPECT_FALSE(std::isfinite(temperature)) << temperature;
    }
    for (float raw : {0.0f, 1.0f, 1e30f, 1e36f, -3e38f, max, -max, inf, -inf, nan}) {
      Vector3<float> a_out(7, 7, 7), w_out(7, 7, 7);
      const Vector3<float> x(raw, 1.0f, raw);
      if (corr.apply_checked(x, x, a_out, w_out) == Status::kOk) {
        EXPECT_TRUE(std::isfinite(a_out.sum()) && std::isfinite(w_out.sum())) << raw;
        ++ok;
      } else {
        EXPECT_EQ(a_out, Vector3<float>(7, 7, 7));
        ++refused;
      }
    }
  }
  EXPECT_GT(ok, 0);
  EXPECT_GT(refused, 0);
  // Finite readings whose result overflows float are refused too.
  Vector3<float> a_out, w_out;
  const Vector3<float> huge(3e38f, 3e38f, 3e38f);
  EXPECT_EQ(corr.apply_checked(huge, huge, a_out, w_out), Status::kNonFiniteInput);
}

}  // namespace
}  // namespace imucal
