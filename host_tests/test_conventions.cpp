// SPDX-License-Identifier: MIT
// docs/conventions.md, checked: each peer's calibration formula written as that peer states it
// (imu_tk's CalibratedTriad, x-io Fusion's FusionCalibrationInertial / FusionCalibrationMagnetic,
// Kalibr's scale-misalignment measurement model, Magneto's A^-1 (m - b)), fed with imucal's
// parameters converted by the doc's formulas, must give imucal's calibrated vectors (imucal's
// side: the library's own accel_apply, gyro_apply, mag_apply). And back: imucal -> peer ->
// imucal gives the parameters again. Everything in double: the only error is rounding, so the
// tolerance is a few hundred ulps of the vectors' size.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "imucal/models/accel_model.hpp"
#include "imucal/models/gyro_model.hpp"
#include "imucal/models/mag_model.hpp"
#include "imucal/sim/random.hpp"

namespace imucal {
namespace {

using V3 = Vector3<double>;
using M3 = Matrix3<double>;

constexpr double kPi = 3.14159265358979323846;
constexpr double kStandardG = 9.80665;  // m/s^2 per g
constexpr double kTol = 1e-12;          // relative: rounding of a few 3x3 products and a QR
constexpr int kTrials = 200;

// ---- random imucal parameters (raw counts in, SI out), as a 16-bit IMU gives them ----

AccelVector<double> random_accel(sim::Random& rng) {
  AccelVector<double> p;
  const double nominal = 9.80665 / 16384.0;  // m/s^2 per count at +-2 g
  for (int k = 0; k < 3; ++k) {
    p(kAlphaYz + k) = 0.02 * rng.normal();
    p(kScaleX + k) = nominal * (1.0 + 0.05 * rng.normal());
    p(kBiasX + k) = 500.0 * rng.normal();
  }
  return p;
}

GyroVector<double> random_gyro(sim::Random& rng) {
  GyroVector<double> p;
  const double nominal = kPi / 180.0 / 131.0;  // rad/s per count at +-250 deg/s
  for (int k = 0; k < 6; ++k) p(kGammaYz + k) = 0.02 * rng.normal();
  for (int k = 0; k < 3; ++k) {
    p(kGyroScaleX + k) = nominal * (1.0 + 0.05 * rng.normal());
    p(kGyroBiasX + k) = 50.0 * rng.normal();
  }
  return p;
}

V3 random_vector(sim::Random& rng, double scale) { return rng.normal3() * scale; }

M3 random_rotation(sim::Random& rng, double max_angle) {
  const V3 axis = rng.normal3().normalized();
  return Eigen::AngleAxis<double>(rng.uniform(-max_angle, max_angle), axis).toRotationMatrix();
}

// A symmetric positive definite soft iron near unit_ut (uT per count) and its hard iron (counts).
MagCalibration<double> random_mag(sim::Random& rng, bool aligned) {
  MagCalibration<double> m;
  M3 w = M3::Identity();
  for (int r = 0; r < 3; ++r) {
    w(r, r) += 0.1 * rng.normal();
    for (int c = r + 1; c < 3; ++c) w(r, c) = w(c, r) = 0.05 * rng.normal();
  }
  m.soft_iron = 0.15 * w;
  if (aligned) m.soft_iron = random_rotation(rng, 0.2) * m.soft_iron;
  m.hard_iron = random_vector(rng, 300.0);
  m.status = Status::kOk;
  return m;
}

// |a - b| <= kTol max(|a|, |b|), for vectors and matrices (Frobenius norm).
template <class A, class B>
::testing::AssertionResult near(const Eigen::MatrixBase<A>& a, const Eigen::MatrixBase<B>& b) {
  const double err = (a.eval() - b.eval()).norm(), size = std::max(a.norm(), b.norm());
  if (err <= kTol * size) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "|difference| " << err << " for size " << size;
}

template <int N>
::testing::AssertionResult same_params(const Eigen::Matrix<double, N, 1>& a,
                                       const Eigen::Matrix<double, N, 1>& b) {
  for (int k = 0; k < N; ++k)
    if (!(std::abs(a(k) - b(k)) <= kTol * std::max(1.0, std::abs(b(k)))))
      return ::testing::AssertionFailure() << "parameter " << k << ": " << a(k) << " vs " << b(k);
  return ::testing::AssertionSuccess();
}

// ---- the doc's formulas (docs/conventions.md, "Reading a general matrix") ----

// The unit-diagonal T of the 6 misalignment angles, in the imu_tk / imucal layout.
M3 unit_t(double yz, double zy, double zx, double xz, double xy, double yx) {
  M3 t;
  t << 1, -yz, zy,  //
      xz, 1, -zx,   //
      -xy, yx, 1;
  return t;
}

// Any 3x3 M (non-zero diagonal) as imucal's 9 gyro parameters: s_j = M_jj, T = M diag(s)^-1.
Eigen::Matrix<double, 9, 1> gyro_chart(const M3& m) {
  Eigen::Matrix<double, 9, 1> p;
  const V3 s = m.diagonal();
  const M3 t = m * s.cwiseInverse().asDiagonal();
  p << -t(0, 1), t(0, 2), -t(1, 2), t(1, 0), -t(2, 0), t(2, 1), s(0), s(1), s(2);
  return p;
}

// An upper-triangular M as imucal's 6 accelerometer parameters (alpha, s).
Eigen::Matrix<double, 6, 1> accel_chart(const M3& m) {
  Eigen::Matrix<double, 6, 1> p;
  p << -m(0, 1) / m(1, 1), m(0, 2) / m(2, 2), -m(1, 2) / m(2, 2), m(0, 0), m(1, 1), m(2, 2);
  return p;
}

// P = Q R by Gram-Schmidt on P's columns in the order x, y, z: Q orthogonal, R upper triangular
// with a positive diagonal.
void qr(const M3& p, M3& q, M3& r) {
  r.setZero();
  for (int j = 0; j < 3; ++j) {
    V3 u = p.col(j);
    for (int i = 0; i < j; ++i) {
      r(i, j) = q.col(i).dot(p.col(j));
      u -= r(i, j) * q.col(i);
    }
    r(j, j) = u.norm();
    q.col(j) = u / r(j, j);
  }
}

// P = L Q (L lower triangular, positive diagonal): Gram-Schmidt on P's rows, x, y, z.
void lq(const M3& p, M3& l, M3& q) {
  M3 qt, rt;
  qr(p.transpose(), qt, rt);
  l = rt.transpose();
  q = qt.transpose();
}

// ---- the peers, as each states its formula ----

// imu_tk, CalibratedTriad_: T (its general layout), K = diag(s), X' = T K (X - B).
struct ImuTkTriad {
  double mis_yz = 0, mis_zy = 0, mis_zx = 0, mis_xz = 0, mis_xy = 0, mis_yx = 0;
  V3 scale = V3::Ones(), bias = V3::Zero();
  V3 unbias_normalize(const V3& x) const {
    M3 t;
    t << 1, -mis_yz, mis_zy,  //
        mis_xz, 1, -mis_zx,   //
        -mis_xy, mis_yx, 1;
    return t * scale.asDiagonal() * (x - bias);
  }
};

// x-io Fusion, FusionCalibrationInertial: misalignment * (sensitivity o (uncalibrated - offset)).
struct FusionInertial {
  M3 misalignment = M3::Identity();
  V3 sensitivity = V3::Ones(), offset = V3::Zero();
  V3 apply(const V3& u) const { return misalignment * (u - offset).cwiseProduct(sensitivity); }
};

// x-io Fusion, FusionCalibrationMagnetic: S (u - h); before the model change: S u - h.
struct FusionMagnetic {
  M3 soft_iron = M3::Identity();
  V3 hard_iron = V3::Zero();
  V3 apply(const V3& u) const { return soft_iron * (u - hard_iron); }
  V3 apply_before_change(const V3& u) const { return soft_iron * u - hard_iron; }
};

// Kalibr, IccScaledMisalignedImu: the measurement from the true specific force f_i and rate w_i
// in the IMU frame i: alpha = M_a f_i + b_a, omega = M_g C_gyro_i w_i + A f_i + b_g.
struct KalibrScaleMisalignment {
  M3 m_accel = M3::Identity(), m_gyro = M3::Identity(), c_gyro_i = M3::Identity();
  M3 a_gyro = M3::Zero();
  V3 b_accel = V3::Zero(), b_gyro = V3::Zero();
  V3 accel_measurement(const V3& f_i) const { return m_accel * f_i + b_accel; }
  V3 gyro_measurement(const V3& w_i, const V3& f_i) const {
    return m_gyro * (c_gyro_i * w_i) + a_gyro * f_i + b_gyro;
  }
};

// Magneto: m_cal = A^-1 (m_raw - b).
struct Magneto {
  M3 a_inv = M3::Identity();
  V3 b = V3::Zero();
  V3 apply(const V3& m) const { return a_inv * (m - b); }
};

// ---- the doc's conversions ----

ImuTkTriad imutk_from_accel(const AccelVector<double>& p) {
  ImuTkTriad t;
  t.mis_yz = p(kAlphaYz);
  t.mis_zy = p(kAlphaZy);
  t.mis_zx = p(kAlphaZx);
  t.scale = p.segment<3>(kScaleX);
  t.bias = -p.segment<3>(kBiasX);
  return t;
}

ImuTkTriad imutk_from_gyro(const GyroVector<double>& p) {
  ImuTkTriad t;
  t.mis_yz = p(kGammaYz);
  t.mis_zy = p(kGammaZy);
  t.mis_zx = p(kGammaZx);
  t.mis_xz = p(kGammaXz);
  t.mis_xy = p(kGammaXy);
  t.mis_yx = p(kGammaYx);
  t.scale = p.segment<3>(kGyroScaleX);
  t.bias = -p.segment<3>(kGyroBiasX);
  return t;
}

AccelVector<double> accel_from_imutk(const ImuTkTriad& t) {
  AccelVector<double> p;
  p << t.mis_yz, t.mis_zy, t.mis_zx, t.scale, -t.bias;
  return p;
}

GyroVector<double> gyro_from_imutk(const ImuTkTriad& t) {
  GyroVector<double> p;
  p << t.mis_yz, t.mis_zy, t.mis_zx, t.mis_xz, t.mis_xy, t.mis_yx, t.scale, -t.bias;
  return p;
}

// Fusion wants g and deg/s: unit = the SI value of one of Fusion's units.
FusionInertial fusion_from_accel(const AccelVector<double>& p, double g) {
  FusionInertial f;
  f.misalignment = unit_t(p(kAlphaYz), p(kAlphaZy), p(kAlphaZx), 0, 0, 0);
  f.sensitivity = p.segment<3>(kScaleX) / g;
  f.offset = -p.segment<3>(kBiasX);
  return f;
}

FusionInertial fusion_from_gyro(const GyroVector<double>& p) {
  FusionInertial f;
  f.misalignment =
      unit_t(p(kGammaYz), p(kGammaZy), p(kGammaZx), p(kGammaXz), p(kGammaXy), p(kGammaYx));
  f.sensitivity = p.segment<3>(kGyroScaleX) * (180.0 / kPi);
  f.offset = -p.segment<3>(kGyroBiasX);
  return f;
}

// Back: P = misalignment diag(sensitivity) * unit; the accelerometer needs P = Q R, imucal's
// frame is then Q^T times Fusion's.
AccelVector<double> accel_from_fusion(const FusionInertial& f, double g, M3& q) {
  M3 r;
  qr(f.misalignment * f.sensitivity.asDiagonal() * g, q, r);
  AccelVector<double> p;
  p << accel_chart(r), -f.offset;
  return p;
}

GyroVector<double> gyro_from_fusion(const FusionInertial& f, const M3& q) {
  GyroVector<double> p;
  p << gyro_chart(q.transpose() * f.misalignment * f.sensitivity.asDiagonal() * (kPi / 180.0)),
      -f.offset;
  return p;
}

// imucal -> Kalibr: (T K)^-1 = M_a C (LQ), then M_g C_gyro_i = M^-1 C^T (LQ), b = -bias. The
// IMU frame i of Kalibr is C times imucal's.
KalibrScaleMisalignment kalibr_from(const AccelVector<double>& pa, const GyroVector<double>& pg,
                                    M3& c) {
  KalibrScaleMisalignment k;
  lq(accel_matrix(pa).inverse(), k.m_accel, c);
  lq(gyro_matrix<double>(pg).inverse() * c.transpose(), k.m_gyro, k.c_gyro_i);
  k.b_accel = -pa.segment<3>(kBiasX);
  k.b_gyro = -pg.segment<3>(kGyroBiasX);
  return k;
}

// Kalibr -> imucal: M_a^-1 = Q R, T K = R, imucal's frame is Q^T times Kalibr's i; the gyro's
// M = Q^T C_gyro_i^T M_g^-1 (A has no counterpart and is dropped).
void from_kalibr(const KalibrScaleMisalignment& k, AccelVector<double>& pa, GyroVector<double>& pg,
                 M3& q) {
  M3 r;
  qr(k.m_accel.inverse(), q, r);
  pa << accel_chart(r), -k.b_accel;
  pg << gyro_chart(q.transpose() * k.c_gyro_i.transpose() * k.m_gyro.inverse()), -k.b_gyro;
}

// ---- the tests ----

TEST(ConventionsImuTk, SameCalibratedVectorsAndParametersBack) {
  sim::Random rng(101);
  for (int trial = 0; trial < kTrials; ++trial) {
    const AccelVector<double> pa = random_accel(rng);
    const GyroVector<double> pg = random_gyro(rng);
    const ImuTkTriad ta = imutk_from_accel(pa), tg = imutk_from_gyro(pg);
    for (int n = 0; n < 5; ++n) {
      const V3 a = random_vector(rng, 16384.0), w = random_vector(rng, 3000.0);
      EXPECT_TRUE(near(ta.unbias_normalize(a), accel_apply(pa, a))) << "trial " << trial;
      EXPECT_TRUE(near(tg.unbias_normalize(w), gyro_apply(pg, w))) << "trial " << trial;
    }
    EXPECT_TRUE(same_params(accel_from_imutk(ta), pa));
    EXPECT_TRUE(same_params(gyro_from_imutk(tg), pg));
  }
}

TEST(ConventionsFusion, InertialInGAndDegreesPerSecondAndBack) {
  sim::Random rng(202);
  for (int trial = 0; trial < kTrials; ++trial) {
    const AccelVector<double> pa = random_accel(rng);
    const GyroVector<double> pg = random_gyro(rng);
    const double g = trial % 2 == 0 ? kStandardG : 9.81;  // the standard g or the local one
    const FusionInertial fa = fusion_from_accel(pa, g), fg = fusion_from_gyro(pg);
    for (int n = 0; n < 5; ++n) {
      const V3 a = random_vector(rng, 16384.0), w = random_vector(rng, 3000.0);
      EXPECT_TRUE(near(fa.apply(a) * g, accel_apply(pa, a))) << "trial " << trial;
      EXPECT_TRUE(near(fg.apply(w) * (kPi / 180.0), gyro_apply(pg, w))) << "trial " << trial;
    }
    M3 q;
    EXPECT_TRUE(same_params(accel_from_fusion(fa, g, q), pa));
    EXPECT_TRUE(near(q, M3::Identity()));  // imucal's own T: no frame change
    EXPECT_TRUE(same_params(gyro_from_fusion(fg, q), pg));
  }
}

// A Fusion calibration of any shape (general misalignment, e.g. from another tool) read into
// imucal: the same vectors, in imucal's frame Q^T times Fusion's, for both sensors.
TEST(ConventionsFusion, GeneralMisalignmentReadIntoImucalFrame) {
  sim::Random rng(303);
  for (int trial = 0; trial < kTrials; ++trial) {
    FusionInertial fa, fg;
    double m[6];  // drawn last first, then the rotation
    for (int i = 5; i >= 0; --i) m[i] = 0.02 * rng.normal();
    const M3 rotation = random_rotation(rng, 0.3);
    fa.misalignment = rotation * unit_t(m[0], m[1], m[2], m[3], m[4], m[5]);
    fg.misalignment = random_rotation(rng, 0.3);
    fa.sensitivity = V3::Constant(1.0 / 16384.0) + random_vector(rng, 1e-6);
    fg.sensitivity = V3::Constant(1.0 / 131.0) + random_vector(rng, 1e-4);
    fa.offset = random_vector(rng, 500.0);
    fg.offset = random_vector(rng, 50.0);
    M3 q;
    const AccelVector<double> pa = accel_from_fusion(fa, kStandardG, q);
    const GyroVector<double> pg = gyro_from_fusion(fg, q);
    EXPECT_TRUE(near(q.transpose() * q, M3::Identity()));
    EXPECT_NEAR(q.determinant(), 1.0, kTol);
    for (int n = 0; n < 5; ++n) {
      const V3 a = random_vector(rng, 16384.0), w = random_vector(rng, 3000.0);
      EXPECT_TRUE(near(q * accel_apply(pa, a), fa.apply(a) * kStandardG)) << "trial " << trial;
      EXPECT_TRUE(near(q * gyro_apply(pg, w), fg.apply(w) * (kPi / 180.0))) << "trial " << trial;
    }
  }
}

TEST(ConventionsFusion, MagneticBothModelsAndBack) {
  sim::Random rng(404);
  for (int trial = 0; trial < kTrials; ++trial) {
    const MagCalibration<double> m = random_mag(rng, trial % 2 == 1);
    FusionMagnetic f;  // the current model, S (u - h)
    f.soft_iron = m.soft_iron;
    f.hard_iron = -m.hard_iron;
    FusionMagnetic old;  // before the change: S u - h
    old.soft_iron = m.soft_iron;
    old.hard_iron = -m.soft_iron * m.hard_iron;
    for (int n = 0; n < 5; ++n) {
      const V3 u = random_vector(rng, 400.0);
      EXPECT_TRUE(near(f.apply(u), mag_apply(m, u))) << "trial " << trial;
      EXPECT_TRUE(near(old.apply_before_change(u), mag_apply(m, u))) << "trial " << trial;
    }
    EXPECT_TRUE(near(-f.hard_iron, m.hard_iron));
    EXPECT_TRUE(near(-old.soft_iron.inverse() * old.hard_iron, m.hard_iron));
  }
}

// Kalibr states the forward model (raw from truth): imucal's calibrated vectors, rotated into
// Kalibr's IMU frame, must regenerate the raw readings imucal calibrated.
TEST(ConventionsKalibr, ScaleMisalignmentRegeneratesTheRawReadingsAndBack) {
  sim::Random rng(505);
  for (int trial = 0; trial < kTrials; ++trial) {
    // Kalibr's measurements are SI (sensor_msgs/Imu): raw units m/s^2 and rad/s here.
    AccelVector<double> pa = random_accel(rng);
    GyroVector<double> pg = random_gyro(rng);
    pa.segment<3>(kScaleX) *= 16384.0 / kStandardG;
    pa.segment<3>(kBiasX) *= kStandardG / 16384.0;
    pg.segment<3>(kGyroScaleX) *= 131.0 * 180.0 / kPi;
    pg.segment<3>(kGyroBiasX) *= kPi / 180.0 / 131.0;
    M3 c;
    const KalibrScaleMisalignment k = kalibr_from(pa, pg, c);
    EXPECT_TRUE(near(c.transpose() * c, M3::Identity()));
    EXPECT_NEAR(c.determinant(), 1.0, kTol);
    EXPECT_TRUE(near(k.c_gyro_i.transpose() * k.c_gyro_i, M3::Identity()));
    for (int r = 0; r < 3; ++r) {
      EXPECT_GT(k.m_accel(r, r), 0.0);
      EXPECT_GT(k.m_gyro(r, r), 0.0);
      for (int col = r + 1; col < 3; ++col) {  // lower triangular, as Kalibr estimates them
        EXPECT_EQ(k.m_accel(r, col), 0.0);
        EXPECT_EQ(k.m_gyro(r, col), 0.0);
      }
    }
    for (int n = 0; n < 5; ++n) {
      const V3 a = random_vector(rng, 9.81), w = random_vector(rng, 2.0);
      const V3 f_i = c * accel_apply(pa, a), w_i = c * gyro_apply(pg, w);
      EXPECT_TRUE(near(k.accel_measurement(f_i), a)) << "trial " << trial;
      EXPECT_TRUE(near(k.gyro_measurement(w_i, f_i), w)) << "trial " << trial;
    }
    AccelVector<double> pa_back;
    GyroVector<double> pg_back;
    M3 q;
    from_kalibr(k, pa_back, pg_back, q);
    EXPECT_TRUE(same_params(pa_back, pa));
    EXPECT_TRUE(same_params(pg_back, pg));
    EXPECT_TRUE(near(q, c));  // the frame comes back too: imucal's = Q^T Kalibr's = C^T C
  }
}

// A Kalibr result (any lower-triangular M_a, M_g and rotation C_gyro_i) through imucal and back.
TEST(ConventionsKalibr, KalibrResultThroughImucalAndBack) {
  sim::Random rng(606);
  for (int trial = 0; trial < kTrials; ++trial) {
    KalibrScaleMisalignment k;
    for (int r = 0; r < 3; ++r) {
      k.m_accel(r, r) = 1.0 + 0.05 * rng.normal();
      k.m_gyro(r, r) = 1.0 + 0.05 * rng.normal();
      for (int col = 0; col < r; ++col) {
        k.m_accel(r, col) = 0.02 * rng.normal();
        k.m_gyro(r, col) = 0.02 * rng.normal();
      }
    }
    k.c_gyro_i = random_rotation(rng, 0.3);
    k.b_accel = random_vector(rng, 0.3);
    k.b_gyro = random_vector(rng, 0.05);
    AccelVector<double> pa;
    GyroVector<double> pg;
    M3 q;
    from_kalibr(k, pa, pg, q);
    for (int n = 0; n < 5; ++n) {  // imucal's vectors are Kalibr's truth, seen in frame Q^T i
      const V3 f_i = random_vector(rng, 9.81), w_i = random_vector(rng, 2.0);
      const V3 a = k.accel_measurement(f_i), w = k.gyro_measurement(w_i, f_i);
      EXPECT_TRUE(near(q * accel_apply(pa, a), f_i)) << "trial " << trial;
      EXPECT_TRUE(near(q * gyro_apply(pg, w), w_i)) << "trial " << trial;
    }
    M3 c;
    const KalibrScaleMisalignment back = kalibr_from(pa, pg, c);
    EXPECT_TRUE(near(back.m_accel, k.m_accel));
    EXPECT_TRUE(near(back.m_gyro, k.m_gyro));
    EXPECT_TRUE(near(back.c_gyro_i, k.c_gyro_i));
    EXPECT_TRUE(near(c, q));
    EXPECT_TRUE(near(back.b_accel, k.b_accel));
    EXPECT_TRUE(near(back.b_gyro, k.b_gyro));
  }
}

TEST(ConventionsMagneto, CombinedBiasAndCorrectionMatrixAndBack) {
  sim::Random rng(707);
  for (int trial = 0; trial < kTrials; ++trial) {
    const MagCalibration<double> m = random_mag(rng, trial % 2 == 1);
    // Magneto scaled to a norm H of the user's choice: here nT (1000 per uT) or uT.
    const double per_ut = trial % 3 == 0 ? 1000.0 : 1.0;
    Magneto mg;
    mg.a_inv = m.soft_iron * per_ut;
    mg.b = -m.hard_iron;
    for (int n = 0; n < 5; ++n) {
      const V3 u = random_vector(rng, 400.0);
      EXPECT_TRUE(near(mg.apply(u), mag_apply(m, u) * per_ut)) << "trial " << trial;
    }
    EXPECT_TRUE(near(mg.a_inv / per_ut, m.soft_iron));
    EXPECT_TRUE(near(-mg.b, m.hard_iron));
  }
}

// The doc's chart of a general matrix: gyro_chart() is an exact inverse of gyro_matrix().
TEST(ConventionsCharts, GeneralMatrixToGyroParametersAndBack) {
  sim::Random rng(808);
  for (int trial = 0; trial < kTrials; ++trial) {
    M3 m = random_rotation(rng, 0.5) * 0.01;
    m += M3::Identity() * 0.01;  // a clearly non-zero diagonal
    GyroVector<double> p = GyroVector<double>::Zero();
    p.head<9>() = gyro_chart(m);
    EXPECT_TRUE(near(gyro_matrix<double>(p), m));
  }
}

}  // namespace
}  // namespace imucal
