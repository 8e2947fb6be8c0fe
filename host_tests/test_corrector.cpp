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
  EXPECT_EQ(corr.parts(), 0);
  EXPECT_EQ(corr.accel(w), w);
}

TEST(Corrector, ANaNInACalibrationIsNotLoaded) {
  Calibration<double> c = xsens_like();
  c.accel.params(kAlphaZy) = std::numeric_limits<double>::quiet_NaN();
  Corrector<float> corr;
  EXPECT_EQ(corr.set(c), Status::kOk);  // the gyro is still usable
  EXPECT_EQ(corr.parts(), kRecordGyro);
  c.gyro.params(kGyroScaleX) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(corr.set(c), Status::kNonFiniteInput);
  EXPECT_EQ(corr.parts(), 0);
  EXPECT_TRUE(corr.accel_matrix_used().isIdentity());
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
}

TEST(Corrector, FromADecodedRecord) {
  CalibrationRecord r;
  ASSERT_EQ(make_record(xsens_like(), 1, 2, r), Status::kOk);
  std::uint8_t bytes[kRecordMaxBytes];
  std::size_t n = 0;
  ASSERT_EQ(encode_record(r, bytes, sizeof bytes, &n), Status::kOk);
  CalibrationRecord back;
  ASSERT_EQ(decode_record(bytes, n, back), Status::kOk);
  Corrector<float> from_record, from_float;
  ASSERT_EQ(from_record.set(back), Status::kOk);
  ASSERT_EQ(from_float.set(r.calibration), Status::kOk);
  const Vector3<float> a(33000.0f, 30000.0f, 36000.0f);
  EXPECT_EQ(from_record.accel(a), from_float.accel(a));  // the record loses nothing
  EXPECT_EQ(from_record.parts(), kRecordAccel | kRecordGyro);
}

}  // namespace
}  // namespace imucal
