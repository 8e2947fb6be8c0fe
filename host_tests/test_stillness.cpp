// SPDX-License-Identifier: MIT
// The stillness detector on its own: the float log2/exp2 its move level runs on (and the log/exp
// of the gyro scale search), the gyro
// threshold that follows the moves, and glitches refused without a trace. On every target: the
// float arithmetic is the device's.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "imucal/sim/random.hpp"
#include "imucal/stream/stillness.hpp"
#include "imucal/stream/sub_block.hpp"

namespace imucal {
namespace {

// One unit in the last place of a float of this magnitude.
double ulp_of(double v) {
  const float f = static_cast<float>(std::abs(v));
  return static_cast<double>(std::nextafter(f, std::numeric_limits<float>::infinity()) - f);
}

TEST(StillnessMath, FloatLog2IsWithinTwoTenthsOfAMillionth) {
  double worst = 0;
  int n = 0;
  // Log-spaced over the normal floats, plus the points where the mantissa range is split.
  for (double e = -125.9; e < 127.9; e += 0.0137) {
    for (double x : {std::exp2(e), 1.41421356 * std::exp2(std::floor(e)),
                     1.41421357 * std::exp2(std::floor(e))}) {
      const float xf = static_cast<float>(x);
      if (!(xf >= std::numeric_limits<float>::min()) || std::isinf(xf)) continue;
      const double exact = std::log2(static_cast<double>(xf));
      const double got = static_cast<double>(detail::log2_of(xf));
      const double err = std::abs(got - exact);
      const double bound = 2e-7 + ulp_of(exact);  // the result's own rounding
      EXPECT_LE(err, bound) << "x = " << xf;
      worst = std::max(worst, err / bound);
      ++n;
    }
  }
  EXPECT_GT(n, 50000);
  std::printf("log2: %d values, worst error %.2f of the bound\n", n, worst);
}

TEST(StillnessMath, FloatExp2IsWithinTwoTenthsOfAMillionthRelative) {
  double worst = 0;
  int n = 0;
  for (double y = -125.99; y < 126.99; y += 0.00731) {
    const float yf = static_cast<float>(y);
    const double exact = std::exp2(static_cast<double>(yf));
    const double got = static_cast<double>(detail::exp2_of(yf));
    const double rel = std::abs(got - exact) / exact;
    EXPECT_LE(rel, 2e-7 + 1.2e-7) << "y = " << yf;  // and the result's own rounding (2^-23)
    worst = std::max(worst, rel);
    ++n;
  }
  EXPECT_GT(n, 30000);
  std::printf("exp2: %d values, worst relative error %.3g\n", n, worst);
  // Outside the normal range, written out too: the top binade, subnormal results, overflow,
  // underflow, NaN.
  for (const float yf : {127.0f, 127.5f, 127.99f, -126.0f, -130.25f, -140.5f, -149.0f}) {
    const double exact = std::exp2(static_cast<double>(yf));
    const double got = static_cast<double>(detail::exp2_of(yf));
    // A subnormal result is rounded to a multiple of 2^-149.
    EXPECT_LE(std::abs(got - exact), (2e-7 + 1.2e-7) * exact + std::exp2(-149.0)) << "y = " << yf;
  }
  EXPECT_EQ(detail::exp2_of(128.0f), std::numeric_limits<float>::infinity());
  EXPECT_EQ(detail::exp2_of(200.0f), std::numeric_limits<float>::infinity());
  EXPECT_EQ(detail::exp2_of(-200.0f), 0.0f);
  EXPECT_EQ(detail::exp2_of(-std::numeric_limits<float>::infinity()), 0.0f);
  EXPECT_TRUE(std::isnan(detail::exp2_of(std::numeric_limits<float>::quiet_NaN())));
  EXPECT_TRUE(std::isnan(detail::log2_of(-1.0f)));
  EXPECT_EQ(detail::log2_of(0.0f), -std::numeric_limits<float>::infinity());
  // log2 outside the normal range: subnormal arguments, +inf, NaN.
  for (const float xf : {1e-39f, 3e-42f, std::numeric_limits<float>::denorm_min()}) {
    const double exact = std::log2(static_cast<double>(xf));
    EXPECT_LE(std::abs(static_cast<double>(detail::log2_of(xf)) - exact), 2e-7 + ulp_of(exact))
        << "x = " << xf;
  }
  EXPECT_EQ(detail::log2_of(std::numeric_limits<float>::infinity()),
            std::numeric_limits<float>::infinity());
  EXPECT_TRUE(std::isnan(detail::log2_of(std::numeric_limits<float>::quiet_NaN())));
}

// The natural log and exp the gyro scale search runs on (float): from log2_of and exp2_of, so
// within their bounds plus the conversion's rounding.
TEST(StillnessMath, FloatLogAndExpFollowLog2AndExp2) {
  double worst_log = 0, worst_exp = 0;
  for (double e = -80.0; e < 80.0; e += 0.0173) {
    const float xf = static_cast<float>(std::exp(e));
    const double exact = std::log(static_cast<double>(xf));
    const double err = std::abs(static_cast<double>(detail::log_of(xf)) - exact);
    EXPECT_LE(err, 2e-7 + 2 * ulp_of(exact)) << "x = " << xf;
    worst_log = std::max(worst_log, err);
    const float yf = static_cast<float>(e);
    const double exact_exp = std::exp(static_cast<double>(yf));
    const double rel = std::abs(static_cast<double>(detail::exp_of(yf)) - exact_exp) / exact_exp;
    // Plus the exponent's error before exp2: y log2(e) rounded to float (half an ulp) and
    // log2(e) itself as a float constant; an error d in the exponent is ln(2) d relative.
    const double y2 = std::abs(static_cast<double>(yf)) * 1.4426950408889634;
    const double const_err = std::abs(static_cast<double>(1.44269504f) - 1.4426950408889634);
    const double bound =
        2e-7 + 1.2e-7 +
        0.6931471805599453 * (0.5 * ulp_of(y2) + std::abs(static_cast<double>(yf)) * const_err);
    EXPECT_LE(rel, bound) << "y = " << yf;
    worst_exp = std::max(worst_exp, rel);
  }
  std::printf("log: worst absolute error %.3g; exp: worst relative error %.3g\n", worst_log,
              worst_exp);
}

// The gyro threshold: k x the floor, or first (move / first)^gap if higher, at most reach x first.
template <typename Scalar>
double expected_threshold(const StillnessSettings<Scalar>& s, double first, double move) {
  const double low = static_cast<double>(s.gyro_k) * first;
  if (!(move > first)) return low;
  const double most = static_cast<double>(s.reach) * first;
  const double t = std::min(most, first * std::pow(move / first, static_cast<double>(s.gap)));
  return std::max(low, t);
}

template <typename Scalar>
void threshold_follows_the_moves() {
  const StillnessSettings<Scalar> settings{};
  const double first = 2.5e-3;  // rad^2/s^2: a gyro's energy at rest, raw units
  StillnessDetector<Scalar> d;
  d.start(settings, Vector3<Scalar>::Zero(), Vector3<Scalar>::Constant(Scalar(1e-4)),
          static_cast<Scalar>(first));
  EXPECT_NEAR(static_cast<double>(d.energy_threshold()), 6 * first, 1e-6 * first);
  // Moves from far below the cap (the threshold between rest and move) to far above (the cap),
  // rising at once and decaying 2 % of the way (log scale) per block.
  double level = 0;
  sim::Random rng(3);
  for (int k = 0; k < 400; ++k) {
    const double x = first * std::exp(rng.uniform(0, std::log(1e7)));
    level = level == 0 || x >= level ? x : level * std::pow(x / level, 0.02);
    d.learn_motion(static_cast<Scalar>(x));
    const double want = expected_threshold(settings, first, level);
    ASSERT_NEAR(static_cast<double>(d.energy_threshold()), want, 2e-5 * want) << "block " << k;
  }
  // A move that is no move (no energy) changes nothing.
  const Scalar before = d.energy_threshold();
  d.learn_motion(Scalar(0));
  EXPECT_EQ(d.energy_threshold(), before);
}

TEST(StillnessDetector, GyroThresholdFollowsTheMovesFloat) { threshold_follows_the_moves<float>(); }
TEST(StillnessDetector, GyroThresholdFollowsTheMovesDouble) {
  threshold_follows_the_moves<double>();
}

// A glitch is refused before anything changes: the sub-block that saw it goes on exactly as one
// that did not; a saturated reading is motion, never a glitch. Both arithmetics, float and
// 16-bit counts.
template <typename Scalar, class Acc, class MakeInput>
void glitch_leaves_no_trace(const MakeInput& input) {
  const StillnessSettings<Scalar> settings{};
  StillnessDetector<Scalar> d;
  const Vector3<Scalar> var = Vector3<Scalar>::Constant(Scalar(4));  // raw counts^2
  d.start(settings, Vector3<Scalar>::Zero(), var, Scalar(0.01));
  d.set_glitch_limit(Scalar(1e4) * Scalar(4));  // 100 sigma
  SubBlockLimits<Scalar> l;
  d.limits(l);
  l.weight = Scalar(0.01) / (settings.seconds + Scalar(0.01));
  Acc with, without;
  for (Acc* a : {&with, &without}) {
    a->start(l);
    a->set_averages(Vector3<Scalar>::Zero(), var.sum(), Scalar(0.01));
  }
  sim::Random rng(5);
  int still = 0, glitches = 0;
  for (int k = 0; k < 500; ++k) {
    const Vector3<double> a(2 * rng.normal(), 2 * rng.normal(), 2 * rng.normal());
    const Vector3<double> u = Vector3<double>::Constant(0.05 * rng.normal());
    const std::uint32_t t = 10000u * static_cast<std::uint32_t>(k + 1);
    if (k % 50 == 25) {
      const Vector3<double> far = a + Vector3<double>(0, 300, 0);
      ASSERT_FALSE(input(with, far, u, t, false));
      ++glitches;
      // The same reading flagged saturated is motion, not a glitch.
      Acc copy = with;
      ASSERT_TRUE(input(copy, far, u, t, true));
      EXPECT_FALSE(copy.still());
    }
    ASSERT_TRUE(input(with, a, u, t, false));
    ASSERT_TRUE(input(without, a, u, t, false));
    ASSERT_EQ(with.still(), without.still());
    still += with.still();
    SubBlockStats<Scalar> s1, s2;
    ASSERT_EQ(with.take_done(s1), without.take_done(s2));
    if (with.size() >= 16) {  // sub-blocks of 16
      s1 = with.finish();
      s2 = without.finish();
      ASSERT_EQ(s1.dev, s2.dev);
      ASSERT_EQ(s1.energy, s2.energy);
      ASSERT_EQ(s1.acc_sum, s2.acc_sum);
      with.start(l);
      without.start(l);
    }
  }
  EXPECT_EQ(glitches, 10);
  EXPECT_GE(still, 490);  // white noise at the start's own level: still throughout
}

TEST(StillnessDetector, GlitchLeavesNoTraceFloat) {
  glitch_leaves_no_trace<float, SubBlock<float>>([](SubBlock<float>& acc, const Vector3<double>& a,
                                                    const Vector3<double>& u, std::uint32_t t,
                                                    bool saturated) {
    ImuSample<float> s;
    s.t_us = t;
    s.acc = a.cast<float>();
    s.gyro = u.cast<float>();
    return acc.add(s, 10000u, saturated);
  });
}
TEST(StillnessDetector, GlitchLeavesNoTraceDouble) {
  glitch_leaves_no_trace<double, SubBlock<double>>(
      [](SubBlock<double>& acc, const Vector3<double>& a, const Vector3<double>& u, std::uint32_t t,
         bool saturated) {
        ImuSample<double> s;
        s.t_us = t;
        s.acc = a;
        s.gyro = u;
        return acc.add(s, 10000u, saturated);
      });
}
TEST(StillnessDetector, GlitchLeavesNoTraceCounts) {
  // Counts: the readings scaled so that 2 units of noise are 20 counts (the limits alike).
  glitch_leaves_no_trace<float, SubBlock<float>>([](SubBlock<float>& acc, const Vector3<double>& a,
                                                    const Vector3<double>& u, std::uint32_t t,
                                                    bool saturated) {
    RawFrame f;
    f.t_us = t;
    for (int i = 0; i < 3; ++i) {
      f.acc[i] = static_cast<std::int16_t>(std::lround(a(i)));
      f.gyro[i] = static_cast<std::int16_t>(std::lround(u(i)));
    }
    return acc.add(f, 10000u, saturated);
  });
}

}  // namespace
}  // namespace imucal
