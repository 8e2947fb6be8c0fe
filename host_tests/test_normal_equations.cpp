// SPDX-License-Identifier: MIT
// The incremental normal-equations accumulator against batch least squares, its covariance
// against Monte Carlo, and its refusals (singular systems, non-finite rows).
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>
#include <limits>

#include "imucal/sim/random.hpp"
#include "imucal/solve/ldlt.hpp"
#include "imucal/solve/normal_equations.hpp"
#include "support/gtest_status.hpp"

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

namespace imucal {
namespace {

constexpr int kN = 4;
constexpr int kRows = 30;
using NE = NormalEquations<double, kN>;
using Vec = NE::Vector;

struct Batch {
  Eigen::Matrix<double, kRows, kN> j;
  Eigen::Matrix<double, kRows, 1> e;
  Eigen::Matrix<double, kRows, 1> w;
};

Batch random_batch(std::uint64_t seed) {
  sim::Random rng(seed);
  Batch b;
  for (int r = 0; r < kRows; ++r) {
    for (int c = 0; c < kN; ++c) b.j(r, c) = rng.normal() * (c + 1);
    b.e(r) = rng.normal();
    b.w(r) = rng.uniform(0.5, 2.0);
  }
  return b;
}

TEST(NormalEquations, MatchesBatchLeastSquares) {
  const Batch b = random_batch(1);
  NE ne;
  for (int r = 0; r < kRows; ++r)
    ASSERT_EQ(ne.add(b.j.row(r).transpose(), b.e(r), b.w(r)), Status::kOk);
  const Eigen::Matrix<double, kN, kN> h = b.j.transpose() * b.w.asDiagonal() * b.j;
  const Vec v = b.j.transpose() * b.w.asDiagonal() * b.e;
  EXPECT_LT((ne.information() - h).norm(), 1e-12 * h.norm());
  EXPECT_LT((ne.gradient() - v).norm(), 1e-12 * v.norm());
  EXPECT_NEAR(ne.weighted_sse(), (b.w.array() * b.e.array().square()).sum(), 1e-12);
  EXPECT_EQ(ne.rows(), kRows);

  // Gauss-Newton step = weighted least squares of J d = -e: its residual is orthogonal to J's
  // columns (J^T W (e + J d) = 0), checked on the rows themselves, not on the accumulator.
  const Eigen::Matrix<double, kRows, 1> sw = b.w.cwiseSqrt();
  Vec delta;
  ASSERT_EQ(ne.solve_damped(0.0, delta), Status::kOk);
  const Vec normal = b.j.transpose() * b.w.asDiagonal() * (b.e + b.j * delta);
  EXPECT_LT(normal.norm(), 1e-12 * v.norm());
  EXPECT_GT(delta.norm(), 0.0);

  // Damped: (H + lambda diag(H)) d = -v.
  const double lambda = 0.7;
  Eigen::Matrix<double, kN, kN> hd = h;
  hd.diagonal() *= 1.0 + lambda;
  const Vec damped = hd.ldlt().solve(-v);
  ASSERT_EQ(ne.solve_damped(lambda, delta), Status::kOk);
  EXPECT_LT((delta - damped).norm(), 1e-10 * damped.norm());

  // Covariance f/(m-n) H^-1 and the predicted decrease of the Gauss-Newton model.
  Eigen::Matrix<double, kN, kN> cov = Eigen::Matrix<double, kN, kN>::Zero();
  ASSERT_EQ(ne.covariance(cov), Status::kOk);
  const Eigen::Matrix<double, kN, kN> expected_cov = ne.weighted_sse() / (kRows - kN) * h.inverse();
  EXPECT_LT((cov - expected_cov).norm(), 1e-10 * expected_cov.norm());
  // One column at a time, as a caller that spreads the covariance over calls takes it.
  for (int c = 0; c < kN; ++c) {
    Vec column = Vec::Zero();
    ASSERT_EQ(ne.inverse_column(c, -1.0, column), Status::kOk);
    EXPECT_LT((column - expected_cov.col(c)).norm(), 1e-10 * expected_cov.norm()) << c;
  }
  Vec untouched = Vec::Constant(7.0);
  EXPECT_EQ(ne.inverse_column(kN, -1.0, untouched), Status::kInvalidArgument);
  EXPECT_EQ(untouched, Vec::Constant(7.0));
  ASSERT_EQ(ne.solve_damped(0.0, delta), Status::kOk);
  const double f_after = (sw.asDiagonal() * (b.e + b.j * delta)).squaredNorm();
  EXPECT_NEAR(ne.predicted_decrease(delta), ne.weighted_sse() - f_after, 1e-10);
}

// sigma from the covariance must describe the actual scatter of the estimate: over 40 linear
// regressions with known truth the z-scores have RMS 1 (the 3-sigma band of that RMS for 40
// runs is about 0.67..1.33), and none is beyond 4.5.
TEST(NormalEquations, CovarianceDescribesEstimateScatter) {
  sim::Random rng(7);
  const Vec truth(1.0, -2.0, 0.5, 3.0);
  constexpr int kRuns = 40;
  Vec sum_z2 = Vec::Zero();
  double worst = 0.0;
  for (int run = 0; run < kRuns; ++run) {
    Eigen::Matrix<double, kRows, kN> j;
    Eigen::Matrix<double, kRows, 1> y, w;
    for (int r = 0; r < kRows; ++r) {
      j.row(r) << rng.normal(), rng.normal(), rng.normal(), 1.0;
      w(r) = rng.uniform(0.5, 4.0);
      y(r) = j.row(r).dot(truth) + rng.normal() / std::sqrt(w(r));
    }
    NE ne;
    for (int r = 0; r < kRows; ++r)
      ASSERT_EQ(ne.add(j.row(r).transpose(), -y(r), w(r)), Status::kOk);
    Vec p;
    ASSERT_EQ(ne.solve_damped(0.0, p), Status::kOk);
    NE at_estimate;  // the covariance needs f at the minimum
    for (int r = 0; r < kRows; ++r)
      ASSERT_EQ(at_estimate.add(j.row(r).transpose(), j.row(r).dot(p) - y(r), w(r)), Status::kOk);
    Vec sd = Vec::Zero();
    ASSERT_EQ(at_estimate.standard_deviations(sd), Status::kOk);
    const Vec z = (p - truth).cwiseQuotient(sd);
    sum_z2 += z.cwiseProduct(z);
    worst = std::max(worst, z.cwiseAbs().maxCoeff());
  }
  for (int k = 0; k < kN; ++k) {
    const double rms = std::sqrt(sum_z2(k) / kRuns);
    EXPECT_GT(rms, 0.67) << "parameter " << k;
    EXPECT_LT(rms, 1.33) << "parameter " << k;
  }
  EXPECT_LT(worst, 4.5);
}

TEST(NormalEquations, RefusesNonFiniteAndNegativeWeightRowsAndKeepsState) {
  NE ne;
  ASSERT_EQ(ne.add(Vec(1, 2, 3, 4), 0.5, 1.0), Status::kOk);
  const auto h = ne.information();
  const double f = ne.weighted_sse();
  EXPECT_EQ(ne.add(Vec(1, kNaN, 3, 4), 0.5, 1.0), Status::kNonFiniteInput);
  EXPECT_EQ(ne.add(Vec(1, 2, 3, 4), kInf, 1.0), Status::kNonFiniteInput);
  EXPECT_EQ(ne.add(Vec(1, 2, 3, 4), 0.5, kNaN), Status::kNonFiniteInput);
  EXPECT_EQ(ne.add(Vec(1, 2, 3, 4), 0.5, -1.0), Status::kInvalidArgument);
  EXPECT_EQ(ne.rows(), 1);
  EXPECT_EQ(ne.information(), h);
  EXPECT_EQ(ne.weighted_sse(), f);
}

TEST(NormalEquations, SingularSystemsGiveAStatusNotNaN) {
  const Vec sentinel(7, 7, 7, 7);
  // A parameter that no row depends on.
  NE zero_column;
  sim::Random rng(3);
  for (int r = 0; r < 10; ++r) {
    const Eigen::Vector3d j = rng.normal3();
    zero_column.add(Vec(j(0), j(1), j(2), 0.0), 1.0);
  }
  Vec delta = sentinel;
  EXPECT_EQ(zero_column.solve_damped(0.0, delta), Status::kRankDeficient);
  EXPECT_EQ(delta, sentinel);
  Eigen::Matrix<double, kN, kN> cov = Eigen::Matrix<double, kN, kN>::Zero();
  EXPECT_EQ(zero_column.covariance(cov), Status::kRankDeficient);
  Vec column = sentinel;
  EXPECT_EQ(zero_column.inverse_column(0, -1.0, column), Status::kRankDeficient);
  EXPECT_EQ(column, sentinel);

  // Two parameters that always move together.
  NE collinear;
  for (int r = 0; r < 10; ++r) {
    const double x = rng.normal(), e = rng.normal(), z = rng.normal();
    collinear.add(Vec(x, x, z, 1.0), e);
  }
  delta = sentinel;
  EXPECT_EQ(collinear.solve_damped(0.0, delta), Status::kRankDeficient);
  EXPECT_EQ(delta, sentinel);
  // Float: a row whose square overflows is refused, the sums stay finite.
  NormalEquations<float, kN> f;
  EXPECT_EQ(f.add(NormalEquations<float, kN>::Vector(1, 1, 1, 1), 1e20f), Status::kNonFiniteInput);
  EXPECT_EQ(f.add(NormalEquations<float, kN>::Vector(1e20f, 1, 1, 1), 1.0f),
            Status::kNonFiniteInput);
  EXPECT_EQ(f.rows(), 0);
  EXPECT_EQ(f.weighted_sse(), 0.0f);
  // Damping makes the same system solvable (that is what LM relies on).
  EXPECT_EQ(collinear.solve_damped(1e-3, delta), Status::kOk);
  EXPECT_TRUE(delta.allFinite());

  NE empty;
  EXPECT_EQ(empty.solve_damped(0.0, delta), Status::kRankDeficient);
  Vec sd = Vec::Zero();
  EXPECT_EQ(empty.standard_deviations(sd), Status::kTooFewResiduals);
  EXPECT_EQ(collinear.solve_damped(-1.0, delta), Status::kInvalidArgument);
}

TEST(NormalEquations, FloatAgreesWithDouble) {
  const Batch b = random_batch(5);
  NE d;
  NormalEquations<float, kN> f;
  for (int r = 0; r < kRows; ++r) {
    d.add(b.j.row(r).transpose(), b.e(r), b.w(r));
    f.add(b.j.row(r).transpose().cast<float>(), static_cast<float>(b.e(r)),
          static_cast<float>(b.w(r)));
  }
  Vec dd;
  Eigen::Matrix<float, kN, 1> df;
  ASSERT_EQ(d.solve_damped(0.0, dd), Status::kOk);
  ASSERT_EQ(f.solve_damped(0.0f, df), Status::kOk);
  EXPECT_LT((df.cast<double>() - dd).norm(), 1e-5 * dd.norm());
}

// An accumulator of capacity 7 sized to 4 at run time is the 4-unknown one: the same numbers to
// the last bit (the same arithmetic), the entries beyond its size ignored in the rows and 0 in
// every result. One accumulator serves both gyro solves (bias held or refined) this way.
TEST(NormalEquations, RunTimeSizeIsTheSmallerProblem) {
  const Batch b = random_batch(6);
  sim::Random rng(7);
  NE small;
  NormalEquations<double, 7> wide;
  wide.resize(kN);
  ASSERT_EQ(wide.size(), kN);
  for (int r = 0; r < kRows; ++r) {
    Eigen::Matrix<double, 7, 1> j;
    j << b.j.row(r).transpose(), rng.normal(), kNaN, kInf;  // beyond the size: ignored
    ASSERT_EQ(small.add(b.j.row(r).transpose(), b.e(r), b.w(r)), Status::kOk);
    ASSERT_EQ(wide.add(j, b.e(r), b.w(r)), Status::kOk);
  }
  EXPECT_EQ(wide.rows(), small.rows());
  EXPECT_EQ(wide.weighted_sse(), small.weighted_sse());
  EXPECT_EQ(wide.gradient_cosine(), small.gradient_cosine());
  Vec d4, sd4;
  Eigen::Matrix<double, 7, 1> d7, sd7;
  ASSERT_EQ(small.solve_damped(0.1, d4), Status::kOk);
  ASSERT_EQ(wide.solve_damped(0.1, d7), Status::kOk);
  EXPECT_EQ(d7.head<kN>(), d4);
  EXPECT_EQ(d7.tail<3>(), Eigen::Vector3d::Zero());
  EXPECT_EQ(wide.predicted_decrease(d7), small.predicted_decrease(d4));
  ASSERT_EQ(small.standard_deviations(sd4), Status::kOk);
  ASSERT_EQ(wide.standard_deviations(sd7), Status::kOk);
  EXPECT_EQ(sd7.head<kN>(), sd4);
  EXPECT_EQ(sd7.tail<3>(), Eigen::Vector3d::Zero());
  Eigen::Matrix<double, kN, kN> c4;
  Eigen::Matrix<double, 7, 7> c7;
  ASSERT_EQ(small.covariance(c4), Status::kOk);
  ASSERT_EQ(wide.covariance(c7), Status::kOk);
  EXPECT_EQ((c7.topLeftCorner<kN, kN>()), c4);
  EXPECT_EQ(c7.rightCols<3>().cwiseAbs().sum() + c7.bottomRows<3>().cwiseAbs().sum(), 0.0);
  EXPECT_EQ((wide.information().topLeftCorner<kN, kN>()), small.information());
  EXPECT_EQ(wide.h(5, 1), 0.0);
  // A size outside 1..N keeps the present one (and clears, as any resize).
  wide.resize(8);
  EXPECT_EQ(wide.size(), kN);
  EXPECT_EQ(wide.rows(), 0);
  wide.resize(0);
  EXPECT_EQ(wide.size(), kN);
}

// A problem's own rows (kN entries) go into a wider accumulator sized to them, bit for bit as
// the same rows padded; a row shorter than the accumulator's size is refused and changes nothing.
TEST(NormalEquations, ShorterRowsFoldAsPaddedOnes) {
  const Batch b = random_batch(8);
  NormalEquations<double, 7> padded, shorter;
  padded.resize(kN);
  shorter.resize(kN);
  for (int r = 0; r < kRows; ++r) {
    const Vec j = b.j.row(r).transpose();
    Eigen::Matrix<double, 7, 1> jp = Eigen::Matrix<double, 7, 1>::Zero();
    jp.head<kN>() = j;
    ASSERT_EQ(padded.add(jp, b.e(r), b.w(r)), Status::kOk);
    ASSERT_EQ(shorter.add(j, b.e(r), b.w(r)), Status::kOk);
  }
  EXPECT_EQ(shorter.rows(), padded.rows());
  EXPECT_EQ(shorter.weighted_sse(), padded.weighted_sse());
  EXPECT_EQ(shorter.information(), padded.information());
  EXPECT_EQ(shorter.gradient(), padded.gradient());
  shorter.resize(5);
  ASSERT_EQ(shorter.add(Vec(Vec::Ones()), 1.0), Status::kInvalidArgument);  // 4 entries for 5
  EXPECT_EQ(shorter.rows(), 0);
  EXPECT_EQ(shorter.weighted_sse(), 0.0);
}

// A random symmetric positive-definite n x n matrix (column-major in m) with condition number
// about `cond`: Q diag(...) Q^T, eigenvalues spaced geometrically from 1 to 1 / cond.
template <int N>
Eigen::Matrix<double, N, N> random_spd(sim::Random& rng, double cond) {
  Eigen::Matrix<double, N, N> g;
  for (int c = 0; c < N; ++c)
    for (int r = 0; r < N; ++r) g(r, c) = rng.normal();
  // Q: g's columns orthonormalised (modified Gram-Schmidt; Gaussian columns are independent).
  Eigen::Matrix<double, N, N> q = g;
  for (int c = 0; c < N; ++c) {
    for (int k = 0; k < c; ++k) q.col(c) -= q.col(k).dot(q.col(c)) * q.col(k);
    q.col(c).normalize();
  }
  Eigen::Matrix<double, N, 1> ev;
  for (int i = 0; i < N; ++i) ev(i) = std::pow(cond, -double(i) / std::max(N - 1, 1));
  return q * ev.asDiagonal() * q.transpose();
}

// Solves m x = b with ldlt_factor and ldlt_solve in scalar type S; x in double.
template <typename S, int N>
Status ldlt_solution(const Eigen::Matrix<double, N, N>& m, const Eigen::Matrix<double, N, 1>& b,
                     Eigen::Matrix<double, N, 1>& x, double min_ratio = 0.0) {
  Eigen::Matrix<S, N, N> a = m.template cast<S>();
  a.template triangularView<Eigen::StrictlyUpper>().setConstant(S(7));  // never read
  Eigen::Matrix<S, N, 1> d;
  const Status s = detail::ldlt_factor(a.data(), N, d.data(), static_cast<S>(min_ratio));
  if (s != Status::kOk) return s;
  Eigen::Matrix<S, N, 1> xs = b.template cast<S>();
  detail::ldlt_solve(a.data(), d.data(), N, xs.data());
  x = xs.template cast<double>();
  return Status::kOk;
}

// The factorisation's solution of m x = b with a known x, in double and float, for the sizes the
// library uses (4: Allan fit; 9, 12: accelerometer and gyro solves). Forward error of a
// backward-stable solve: a small multiple of n eps cond (b is formed in double; in float its
// rounding, eps_f |b|, counts as the solve's own).
template <int N>
void ldlt_solves_to_the_known_solution(std::uint64_t seed) {
  sim::Random rng(seed);
  for (const double cond : {1.0, 1e2, 1e4}) {
    const Eigen::Matrix<double, N, N> m = random_spd<N>(rng, cond);
    Eigen::Matrix<double, N, 1> known;
    for (int i = 0; i < N; ++i) known(i) = rng.normal();
    const Eigen::Matrix<double, N, 1> b = m * known;
    Eigen::Matrix<double, N, 1> x = Eigen::Matrix<double, N, 1>::Zero();
    ASSERT_EQ((ldlt_solution<double, N>(m, b, x)), Status::kOk) << "n " << N << " cond " << cond;
    const double eps_d = std::numeric_limits<double>::epsilon();
    EXPECT_LT((x - known).norm(), 10 * N * eps_d * cond * known.norm())
        << "n " << N << " cond " << cond;
    ASSERT_EQ((ldlt_solution<float, N>(m, b, x)), Status::kOk) << "n " << N << " cond " << cond;
    const double eps_f = static_cast<double>(std::numeric_limits<float>::epsilon());
    EXPECT_LT((x - known).norm(), 10 * N * eps_f * cond * known.norm())
        << "n " << N << " cond " << cond;
  }
}

TEST(Ldlt, SolvesPositiveDefiniteSystemsToTheKnownSolution) {
  ldlt_solves_to_the_known_solution<1>(11);
  ldlt_solves_to_the_known_solution<4>(12);
  ldlt_solves_to_the_known_solution<9>(13);
  ldlt_solves_to_the_known_solution<12>(14);
}

TEST(Ldlt, SaysWhyAMatrixIsRefused) {
  sim::Random rng(15);
  const Eigen::Matrix<double, 4, 4> spd = random_spd<4>(rng, 1e3);
  const Eigen::Vector4d b(1, 2, 3, 4);
  Eigen::Vector4d x = Eigen::Vector4d::Constant(5);
  // Indefinite: one negative eigenvalue.
  Eigen::Matrix<double, 4, 4> indefinite = spd;
  indefinite(2, 2) = -1.0;
  EXPECT_EQ((ldlt_solution<double, 4>(indefinite, b, x)), Status::kRankDeficient);
  // Exactly singular: a zero row and column.
  Eigen::Matrix<double, 4, 4> singular = spd;
  singular.row(1).setZero();
  singular.col(1).setZero();
  EXPECT_EQ((ldlt_solution<double, 4>(singular, b, x)), Status::kRankDeficient);
  EXPECT_EQ((ldlt_solution<float, 4>(singular, b, x)), Status::kRankDeficient);
  // A non-finite entry.
  Eigen::Matrix<double, 4, 4> nan = spd;
  nan(3, 0) = nan(0, 3) = kNaN;
  EXPECT_EQ((ldlt_solution<double, 4>(nan, b, x)), Status::kIllConditioned);
  nan(3, 0) = nan(0, 3) = kInf;
  EXPECT_EQ((ldlt_solution<double, 4>(nan, b, x)), Status::kIllConditioned);
  // Positive definite but past the pivot ratio asked for (cond 1e3: the pivots span about that).
  EXPECT_EQ((ldlt_solution<double, 4>(spd, b, x, 1e-1)), Status::kIllConditioned);
  EXPECT_EQ((ldlt_solution<double, 4>(spd, b, x, 1e-6)), Status::kOk);
  EXPECT_TRUE(x.allFinite());
}

}  // namespace
}  // namespace imucal
