// SPDX-License-Identifier: MIT
// The temperature model of the biases (temperature_fit.hpp) and the field rest detector
// (rest_monitor.hpp) on simulated drifts with known truth (sim/temperature_sim.hpp): recovery
// within 3 sigma (linear and quadratic, float and double, exact and offset base), honest sigmas
// over many seeds, float against double, the fit improving as field rests arrive, refusals, the
// detector on a raw stream, and the chain detector -> fit.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <vector>

#include "imucal/sim/temperature_sim.hpp"
#include "imucal/stream/rest_monitor.hpp"
#include "imucal/temperature/temperature_fit.hpp"
#include "support/gtest_status.hpp"
#include "support/monitor_run.hpp"

namespace imucal {
namespace {

using test::FoundRest;
using test::monitor_settings;
using test::run_monitor;

using RestList = std::vector<RestSummary<double>>;

template <typename S, typename T>
RestSummary<S> cast_rest(const RestSummary<T>& r) {
  RestSummary<S> o;
  o.accel_mean = r.accel_mean.template cast<S>();
  o.gyro_mean = r.gyro_mean.template cast<S>();
  o.temperature_c = static_cast<S>(r.temperature_c);
  o.has_temperature = r.has_temperature;
  o.samples = r.samples;
  o.duration_s = static_cast<S>(r.duration_s);
  return o;
}

template <typename S, typename T>
Calibration<S> cast_base(const Calibration<T>& c) {
  Calibration<S> o;
  o.accel.params = c.accel.params.template cast<S>();
  o.accel.status = c.accel.status;
  o.gyro.params = c.gyro.params.template cast<S>();
  o.gyro.status = c.gyro.status;
  o.quality = c.quality;
  o.has_temperature = c.has_temperature;
  o.temperature_c = static_cast<S>(c.temperature_c);
  return o;
}

template <typename S>
TemperatureSettings<S> settings_of(int order) {
  TemperatureSettings<S> s;
  s.order = order;
  return s;
}

template <typename S>
Status fit(const Calibration<double>& base, const RestList& rests, int order,
           TemperatureModel<S>& out) {
  TemperatureFit<S> f;
  EXPECT_EQ(f.reset(cast_base<S>(base), settings_of<S>(order)), Status::kOk);
  for (const auto& r : rests) EXPECT_EQ(f.add_rest(cast_rest<S>(r)), Status::kOk);
  EXPECT_EQ(f.rests(), static_cast<int>(rests.size()));
  return f.solve(out);
}

// Error / sigma of every coefficient (b0, b1, and b2 for order 2; accelerometer then gyro).
struct Scores {
  std::vector<double> z;
  void add(double est, double truth, double sigma) {
    EXPECT_GT(sigma, 0.0);
    z.push_back((est - truth) / sigma);
  }
  template <typename S>
  void add(const TemperatureBias<S>& e, const TemperatureBias<double>& t, int order) {
    for (int i = 0; i < 3; ++i) {
      add(static_cast<double>(e.b0(i)), t.b0(i), static_cast<double>(e.b0_sigma(i)));
      add(static_cast<double>(e.b1(i)), t.b1(i), static_cast<double>(e.b1_sigma(i)));
      if (order == 2)
        add(static_cast<double>(e.b2(i)), t.b2(i), static_cast<double>(e.b2_sigma(i)));
    }
  }
  template <typename S>
  void add(const TemperatureModel<S>& m, const sim::TemperatureTruth& t) {
    add(m.accel, t.model.accel, m.order);
    add(m.gyro, t.model.gyro, m.order);
  }
  double worst() const {
    double w = 0.0;
    for (double v : z) w = std::max(w, std::abs(v));
    return w;
  }
  int beyond(double k) const {
    int n = 0;
    for (double v : z) n += std::abs(v) > k;
    return n;
  }
  double rms() const {
    double s = 0.0;
    for (double v : z) s += v * v;
    return z.empty() ? 0.0 : std::sqrt(s / static_cast<double>(z.size()));
  }
};

// The repo's rule: every number within 3 sigma, one of them may fall in (3, 4].
void expect_within_3_sigma(const Scores& s, const char* what) {
  EXPECT_LE(s.worst(), 4.0) << what;
  EXPECT_LE(s.beyond(3.0), 1) << what;
}

sim::TemperatureTruth draw_truth(int order, std::uint64_t seed, bool counts = false) {
  sim::Random rng(seed);
  const auto acc = counts ? sim::AccelSensorSpec::raw_counts() : sim::AccelSensorSpec::si();
  const auto gyro = counts ? sim::GyroSensorSpec::raw_counts() : sim::GyroSensorSpec::si();
  return sim::draw_temperature_truth(acc, gyro, order, 30.0, rng);
}

RestList draw_rests(const sim::TemperatureTruth& t, int count, std::uint64_t seed,
                    bool counts = false, bool one_orientation = false) {
  sim::Random rng(seed);
  sim::RestPlan plan;
  plan.rests = count;
  plan.one_orientation = one_orientation;
  const auto acc = counts ? sim::AccelSensorSpec::raw_counts() : sim::AccelSensorSpec::si();
  const auto gyro = counts ? sim::GyroSensorSpec::raw_counts() : sim::GyroSensorSpec::si();
  return sim::simulate_rests(t, acc, gyro, plan, rng);
}

// A base calibrated at another temperature: its biases are those at T0 + 8 deg C.
Calibration<double> offset_base(const sim::TemperatureTruth& t) {
  const double d = 8.0;
  return sim::base_calibration(
      t, t.model.accel.at(t.model.reference_c + d, t.model.reference_c) - t.model.accel.b0,
      t.model.gyro.at(t.model.reference_c + d, t.model.reference_c) - t.model.gyro.b0);
}

#ifdef IMUCAL_SMALL_TARGET
constexpr int kSeeds = 3;
constexpr int kHonestySeeds = 12;
#else
constexpr int kSeeds = 6;
constexpr int kHonestySeeds = 30;
#endif

// 1. Linear drift, ~30 rests over 10..50 deg C in random orientations: b0 and b1 of both sensors
// within 3 sigma, with the base at the truth and with the base's biases off (as when calibrated
// at another temperature), float and double.
template <typename S>
void linear_ramp(const char* label) {
  double worst = 0.0;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    const auto truth = draw_truth(1, 100 + static_cast<std::uint64_t>(seed));
    const RestList rests = draw_rests(truth, 30, 200 + static_cast<std::uint64_t>(seed));
    for (int offset = 0; offset < 2; ++offset) {
      const Calibration<double> base = offset ? offset_base(truth) : sim::base_calibration(truth);
      TemperatureModel<S> m;
      ASSERT_EQ(fit<S>(base, rests, 1, m), Status::kOk) << "seed " << seed;
      EXPECT_EQ(m.accel.status, Status::kOk);
      EXPECT_EQ(m.gyro.status, Status::kOk);
      EXPECT_EQ(m.rests, 30);
      EXPECT_EQ(m.order, 1);
      EXPECT_NEAR(static_cast<double>(m.reference_c), 30.0, 1e-5);
      EXPECT_GE(static_cast<double>(m.min_c), 10.0);
      EXPECT_LE(static_cast<double>(m.max_c), 50.0);
      EXPECT_GT(static_cast<double>(m.max_c - m.min_c), 35.0);
      Scores s;
      s.add(m, truth);
      EXPECT_EQ(s.z.size(), 12u);
      expect_within_3_sigma(s, label);
      worst = std::max(worst, s.worst());
    }
  }
  std::printf("[ linear %s ] worst |z| %.2f over %d seeds x 2 bases x 12\n", label, worst, kSeeds);
}

TEST(TemperatureFit, LinearRampDouble) { linear_ramp<double>("double"); }

// A linear-only fit (TemperatureFit<float, 1>, what a device that needs no quadratic model
// links): the same numbers as the general one at order 1, and order 2 refused.
TEST(TemperatureFit, LinearOnlyFitIsTheSame) {
  const auto truth = draw_truth(1, 101);
  const RestList rests = draw_rests(truth, 30, 201);
  const Calibration<float> base = cast_base<float>(sim::base_calibration(truth));
  static TemperatureFit<float, 1> lin;
  static TemperatureFit<float, 2> gen;
  EXPECT_EQ(lin.reset(base, settings_of<float>(2)), Status::kInvalidArgument);
  ASSERT_EQ(lin.reset(base, settings_of<float>(1)), Status::kOk);
  ASSERT_EQ(gen.reset(base, settings_of<float>(1)), Status::kOk);
  for (const auto& r : rests) {
    ASSERT_EQ(lin.add_rest(cast_rest<float>(r)), Status::kOk);
    ASSERT_EQ(gen.add_rest(cast_rest<float>(r)), Status::kOk);
  }
  TemperatureModel<float> a, b;
  ASSERT_EQ(lin.solve(a), Status::kOk);
  ASSERT_EQ(gen.solve(b), Status::kOk);
  EXPECT_EQ(a.accel.b1, b.accel.b1);
  EXPECT_EQ(a.gyro.b0, b.gyro.b0);
  EXPECT_EQ(a.gyro.b1_sigma, b.gyro.b1_sigma);
  EXPECT_LT(sizeof lin, sizeof gen);
}
TEST(TemperatureFit, LinearRampFloat) { linear_ramp<float>("float"); }

// 2. Quadratic drift (order 2): b0, b1, b2 within 3 sigma.
template <typename S>
void quadratic(const char* label) {
  double worst = 0.0;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    const auto truth = draw_truth(2, 300 + static_cast<std::uint64_t>(seed));
    const RestList rests = draw_rests(truth, 40, 400 + static_cast<std::uint64_t>(seed));
    TemperatureModel<S> m;
    ASSERT_EQ(fit<S>(offset_base(truth), rests, 2, m), Status::kOk) << "seed " << seed;
    EXPECT_EQ(m.order, 2);
    Scores s;
    s.add(m, truth);
    EXPECT_EQ(s.z.size(), 18u);
    expect_within_3_sigma(s, label);
    worst = std::max(worst, s.worst());
  }
  std::printf("[ quadratic %s ] worst |z| %.2f over %d seeds x 18\n", label, worst, kSeeds);
}

TEST(TemperatureFit, QuadraticDouble) { quadratic<double>("double"); }
TEST(TemperatureFit, QuadraticFloat) { quadratic<float>("float"); }

// A linear fit of quadratic data is visibly wrong (the test above is not passing by accident).
TEST(TemperatureFit, LinearFitOfQuadraticDriftIsOutside3Sigma) {
  const auto truth = draw_truth(2, 301);
  const RestList rests = draw_rests(truth, 40, 401);
  TemperatureModel<double> m;
  ASSERT_EQ(fit<double>(sim::base_calibration(truth), rests, 1, m), Status::kOk);
  Scores s;
  s.add(m, truth);
  EXPECT_GT(s.worst(), 5.0);
}

// 3. Sigma is honest: over many seeds, the RMS of error / sigma is near 1.
template <typename S>
void honesty(int order, const char* label) {
  Scores all, accel, gyro;
  for (int seed = 1; seed <= kHonestySeeds; ++seed) {
    const auto truth = draw_truth(order, 500 + static_cast<std::uint64_t>(seed));
    const RestList rests = draw_rests(truth, 30, 600 + static_cast<std::uint64_t>(seed));
    TemperatureModel<S> m;
    ASSERT_EQ(fit<S>(offset_base(truth), rests, order, m), Status::kOk);
    all.add(m, truth);
    accel.add(m.accel, truth.model.accel, order);
    gyro.add(m.gyro, truth.model.gyro, order);
  }
  std::printf(
      "[ honesty %s order %d ] RMS z %.3f (accel %.3f, gyro %.3f) over %zu numbers, "
      "worst %.2f\n",
      label, order, all.rms(), accel.rms(), gyro.rms(), all.z.size(), all.worst());
  EXPECT_GE(all.rms(), 0.7);
  EXPECT_LE(all.rms(), 1.3);
  EXPECT_GE(accel.rms(), 0.7);
  EXPECT_LE(accel.rms(), 1.3);
  EXPECT_GE(gyro.rms(), 0.7);
  EXPECT_LE(gyro.rms(), 1.3);
}

TEST(TemperatureFit, SigmaHonestLinearDouble) { honesty<double>(1, "double"); }
TEST(TemperatureFit, SigmaHonestLinearFloat) { honesty<float>(1, "float"); }
TEST(TemperatureFit, SigmaHonestQuadraticDouble) { honesty<double>(2, "double"); }

// 4. Float against double on the same rests (raw 16-bit counts, the hard case for float: means
// near 33000, biases near -32768): every estimate within 0.1 sigma, every sigma within 5 %
// (measured: 1.5 % host, 2.4 % M33).
TEST(TemperatureFit, FloatMatchesDouble) {
  double worst = 0.0, worst_sigma = 0.0;
  for (int order = 1; order <= 2; ++order) {
    for (int seed = 1; seed <= kSeeds; ++seed) {
      const auto truth = draw_truth(order, 700 + static_cast<std::uint64_t>(seed), true);
      RestList rests = draw_rests(truth, 40, 800 + static_cast<std::uint64_t>(seed), true);
      for (auto& r : rests) r = cast_rest<double>(cast_rest<float>(r));  // the same numbers
      const Calibration<double> base = cast_base<double>(cast_base<float>(offset_base(truth)));
      TemperatureModel<double> d;
      TemperatureModel<float> f;
      ASSERT_EQ(fit<double>(base, rests, order, d), Status::kOk);
      ASSERT_EQ(fit<float>(base, rests, order, f), Status::kOk);
      const TemperatureBias<double>* bd[2] = {&d.accel, &d.gyro};
      const TemperatureBias<float>* bf[2] = {&f.accel, &f.gyro};
      for (int k = 0; k < 2; ++k) {
        for (int i = 0; i < 3; ++i) {
          const double v_d[3] = {bd[k]->b0(i), bd[k]->b1(i), bd[k]->b2(i)};
          const double s_d[3] = {bd[k]->b0_sigma(i), bd[k]->b1_sigma(i), bd[k]->b2_sigma(i)};
          const float v_f[3] = {bf[k]->b0(i), bf[k]->b1(i), bf[k]->b2(i)};
          const float s_f[3] = {bf[k]->b0_sigma(i), bf[k]->b1_sigma(i), bf[k]->b2_sigma(i)};
          for (int j = 0; j <= order; ++j) {
            const double z = std::abs(static_cast<double>(v_f[j]) - v_d[j]) / s_d[j];
            const double rel = std::abs(static_cast<double>(s_f[j]) / s_d[j] - 1.0);
            EXPECT_LE(z, 0.1) << "order " << order << " seed " << seed << " sensor " << k
                              << " axis " << i << " b" << j;
            EXPECT_LE(rel, 0.05) << "order " << order << " seed " << seed << " sensor " << k
                                 << " axis " << i << " b" << j;
            worst = std::max(worst, z);
            worst_sigma = std::max(worst_sigma, rel);
          }
        }
      }
    }
  }
  std::printf("[ float vs double ] worst %.4f sigma apart; sigmas within %.2e relative\n", worst,
              worst_sigma);
}

// 5. In the field: fit from the first 30 rests (10..30 deg C), then add the other 30
// (30..50 deg C) to the same object: every sigma shrinks, the result stays within 3 sigma, and it
// equals a fit of all the rests at once (the accumulator forgets nothing).
template <typename S>
void incremental(const char* label) {
  double worst_ratio = 0.0;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    const auto truth = draw_truth(1, 900 + static_cast<std::uint64_t>(seed));
    const RestList rests = draw_rests(truth, 60, 1000 + static_cast<std::uint64_t>(seed));
    const Calibration<double> base = offset_base(truth);
    TemperatureFit<S> f;
    ASSERT_EQ(f.reset(cast_base<S>(base), settings_of<S>(1)), Status::kOk);
    for (std::size_t i = 0; i < rests.size() / 2; ++i)
      ASSERT_EQ(f.add_rest(cast_rest<S>(rests[i])), Status::kOk);
    TemperatureModel<S> early, late, once;
    ASSERT_EQ(f.solve(early), Status::kOk);
    EXPECT_LE(static_cast<double>(early.max_c), 30.0);
    Scores s_early;
    s_early.add(early, truth);
    expect_within_3_sigma(s_early, label);
    for (std::size_t i = rests.size() / 2; i < rests.size(); ++i)
      ASSERT_EQ(f.add_rest(cast_rest<S>(rests[i])), Status::kOk);
    ASSERT_EQ(f.solve(late), Status::kOk);
    EXPECT_EQ(late.rests, 60);
    EXPECT_GE(static_cast<double>(late.max_c), 45.0);
    Scores s_late;
    s_late.add(late, truth);
    expect_within_3_sigma(s_late, label);
    const TemperatureBias<S>* e[2] = {&early.accel, &early.gyro};
    const TemperatureBias<S>* l[2] = {&late.accel, &late.gyro};
    // Twice the rests over twice the span: b1's sigma ~ 1 / (sqrt(2) 2) ~ 0.35 of before (each
    // sigma is itself estimated from 21 degrees of freedom, hence the margin per coefficient).
    double ratio_sum = 0.0;
    for (int k = 0; k < 2; ++k) {
      for (int i = 0; i < 3; ++i) {
        EXPECT_LT(l[k]->b1_sigma(i), S(0.8) * e[k]->b1_sigma(i)) << "sensor " << k;
        EXPECT_LT(l[k]->b0_sigma(i), e[k]->b0_sigma(i)) << "sensor " << k;
        ratio_sum += static_cast<double>(l[k]->b1_sigma(i) / e[k]->b1_sigma(i));
      }
    }
    EXPECT_LT(ratio_sum / 6.0, 0.6);
    worst_ratio = std::max(worst_ratio, ratio_sum / 6.0);
    ASSERT_EQ(fit<S>(base, rests, 1, once), Status::kOk);
    EXPECT_EQ(once.accel.b1, late.accel.b1);
    EXPECT_EQ(once.gyro.b1, late.gyro.b1);
    EXPECT_EQ(once.accel.b0_sigma, late.accel.b0_sigma);
  }
  std::printf("[ field %s ] b1 sigma after / before: mean over axes at most %.2f\n", label,
              worst_ratio);
}

TEST(TemperatureFit, KeepsImprovingInTheFieldDouble) { incremental<double>("double"); }
TEST(TemperatureFit, KeepsImprovingInTheFieldFloat) { incremental<float>("float"); }

// 6. Refusals.
template <typename S>
void refusals() {
  const auto truth = draw_truth(1, 1100);
  const Calibration<S> base = cast_base<S>(sim::base_calibration(truth));
  const RestList rests = draw_rests(truth, 30, 1101);
  TemperatureModel<S> m;

  // Before reset, or reset with a bad base or settings: nothing is taken.
  {
    TemperatureFit<S> f;
    EXPECT_EQ(f.add_rest(cast_rest<S>(rests[0])), Status::kNotStarted);
    EXPECT_EQ(f.solve(m), Status::kNotStarted);
    EXPECT_EQ(m.accel.status, Status::kNotStarted);
    Calibration<S> bad = base;
    bad.accel.status = Status::kTooFewPoses;
    EXPECT_EQ(f.reset(bad), Status::kInvalidArgument);
    EXPECT_EQ(f.add_rest(cast_rest<S>(rests[0])), Status::kNotStarted);
    bad = base;
    bad.gyro.status = Status::kTooFewMoves;
    EXPECT_EQ(f.reset(bad), Status::kInvalidArgument);
    bad = base;
    bad.has_temperature = false;  // and no reference_c given
    EXPECT_EQ(f.reset(bad), Status::kInvalidArgument);
    TemperatureSettings<S> given;
    given.reference_c = S(25);
    EXPECT_EQ(f.reset(bad, given), Status::kOk);
    EXPECT_EQ(f.reference_c(), S(25));
    bad = base;
    bad.accel.params(kScaleY) = S(0);
    EXPECT_EQ(f.reset(bad), Status::kInvalidArgument);
    bad = base;
    bad.gyro.params(kGyroBiasX) = std::numeric_limits<S>::quiet_NaN();
    EXPECT_EQ(f.reset(bad), Status::kInvalidArgument);
    EXPECT_EQ(f.reset(base, settings_of<S>(3)), Status::kInvalidArgument);
    EXPECT_EQ(f.reset(base, settings_of<S>(0)), Status::kInvalidArgument);
    TemperatureSettings<S> neg;
    neg.min_span_c = S(-1);
    EXPECT_EQ(f.reset(base, neg), Status::kInvalidArgument);
  }

  // All rests at one temperature: no slope.
  {
    TemperatureFit<S> f;
    ASSERT_EQ(f.reset(base), Status::kOk);
    for (auto r : rests) {
      r.temperature_c = 31.0;
      ASSERT_EQ(f.add_rest(cast_rest<S>(r)), Status::kOk);
    }
    EXPECT_EQ(f.solve(m), Status::kTemperatureSpanSmall);
    EXPECT_EQ(m.accel.status, Status::kTemperatureSpanSmall);
    EXPECT_EQ(m.gyro.status, Status::kTemperatureSpanSmall);
    EXPECT_EQ(m.accel.b0, Vector3<S>::Zero());  // a failed part is zeros, never NaN
  }

  // Too few rests: 5 are enough for the gyro (2 unknowns per axis), not for the accelerometer
  // (9); 2 are too few for both.
  {
    TemperatureFit<S> f;
    ASSERT_EQ(f.reset(base), Status::kOk);
    EXPECT_EQ(f.solve(m), Status::kTooFewSamples);
    EXPECT_EQ(m.gyro.status, Status::kTooFewSamples);
    EXPECT_EQ(m.rests, 0);
    for (int i = 0; i < 2; ++i)
      ASSERT_EQ(f.add_rest(cast_rest<S>(rests[static_cast<std::size_t>(i * 20)])), Status::kOk);
    EXPECT_EQ(f.solve(m), Status::kTooFewSamples);
    EXPECT_EQ(m.accel.status, Status::kTooFewSamples);
    EXPECT_EQ(m.gyro.status, Status::kTooFewSamples);
    for (int i = 1; i < 4; ++i)
      ASSERT_EQ(f.add_rest(cast_rest<S>(rests[static_cast<std::size_t>(i * 7)])), Status::kOk);
    EXPECT_EQ(f.solve(m), Status::kTooFewSamples);
    EXPECT_EQ(m.accel.status, Status::kTooFewSamples);
    EXPECT_EQ(m.gyro.status, Status::kOk);
  }

  // All rests in one orientation (a unit mounted in place): the accelerometer's bias cannot be
  // told from the radius, the gyro is fine.
  {
    const RestList fixed = draw_rests(truth, 30, 1102, false, true);
    TemperatureFit<S> f;
    ASSERT_EQ(f.reset(base), Status::kOk);
    for (const auto& r : fixed) ASSERT_EQ(f.add_rest(cast_rest<S>(r)), Status::kOk);
    EXPECT_EQ(f.solve(m), Status::kRankDeficient);
    EXPECT_EQ(m.accel.status, Status::kRankDeficient);
    EXPECT_EQ(m.gyro.status, Status::kOk);
    Scores s;
    s.add(m.gyro, truth.model.gyro, 1);
    expect_within_3_sigma(s, "one orientation, gyro");
  }

  // Bad rests are refused and change nothing.
  {
    TemperatureFit<S> f;
    ASSERT_EQ(f.reset(base), Status::kOk);
    for (const auto& r : rests) ASSERT_EQ(f.add_rest(cast_rest<S>(r)), Status::kOk);
    TemperatureModel<S> before, after;
    ASSERT_EQ(f.solve(before), Status::kOk);
    const S min_before = f.min_c(), max_before = f.max_c();
    RestSummary<S> r = cast_rest<S>(rests[3]);
    r.temperature_c = S(80);  // would widen the range if it were taken
    RestSummary<S> bad = r;
    bad.has_temperature = false;
    EXPECT_EQ(f.add_rest(bad), Status::kInvalidArgument);
    bad = r;
    bad.temperature_c = std::numeric_limits<S>::quiet_NaN();
    EXPECT_EQ(f.add_rest(bad), Status::kNonFiniteInput);
    bad = r;
    bad.accel_mean(1) = std::numeric_limits<S>::quiet_NaN();
    EXPECT_EQ(f.add_rest(bad), Status::kNonFiniteInput);
    bad = r;
    bad.gyro_mean(2) = std::numeric_limits<S>::infinity();
    EXPECT_EQ(f.add_rest(bad), Status::kNonFiniteInput);
    bad = r;
    bad.samples = 0;
    EXPECT_EQ(f.add_rest(bad), Status::kTooFewSamples);
    EXPECT_EQ(f.rests(), 30);
    EXPECT_EQ(f.min_c(), min_before);
    EXPECT_EQ(f.max_c(), max_before);
    ASSERT_EQ(f.solve(after), Status::kOk);
    EXPECT_EQ(after.accel.b1, before.accel.b1);
    EXPECT_EQ(after.gyro.b1, before.gyro.b1);
    EXPECT_EQ(after.accel.b1_sigma, before.accel.b1_sigma);
  }
}

TEST(TemperatureFit, RefusalsDouble) { refusals<double>(); }
TEST(TemperatureFit, RefusalsFloat) { refusals<float>(); }

// 8. End to end: a warming board (10 -> 50 deg C) resting in many orientations; RestMonitor
// (float) finds the rests, TemperatureFit (float) fits them: b0 and b1 within 3 sigma.
TEST(TemperatureEndToEnd, MonitorThenFit) {
  const auto acc = sim::AccelSensorSpec::si();
  const auto gyro = sim::GyroSensorSpec::si();
#ifdef IMUCAL_SMALL_TARGET
  const int rests = 24;
#else
  const int rests = 40;
#endif
  double worst = 0.0;
  for (int seed = 1; seed <= 2; ++seed) {
    sim::Random rng(1400 + static_cast<std::uint64_t>(seed));
    const auto truth = sim::draw_temperature_truth(acc, gyro, 1, 30.0, rng);
    sim::StreamPlan plan;
    plan.rest_s.assign(static_cast<std::size_t>(rests), 10.0);
    plan.profile.start_c = 10.0;
    plan.profile.end_c = 50.0;
    plan.profile.ramp_s = rests * 12.0;
    sim::TemperatureStream stream(truth, acc, gyro, plan, rng);
    RestMonitor<float> monitor(
        monitor_settings<float>(acc, gyro, truth.raw_gyro(Vector3<double>::Zero(), 10.0)));
    const std::vector<FoundRest> found = run_monitor(stream, monitor, false);
    EXPECT_EQ(static_cast<int>(found.size()), rests);
    TemperatureFit<float> f;
    ASSERT_EQ(f.reset(cast_base<float>(offset_base(truth))), Status::kOk);
    for (const FoundRest& r : found)
      ASSERT_EQ(f.add_rest(cast_rest<float>(r.summary)), Status::kOk);
    TemperatureModel<float> m;
    ASSERT_EQ(f.solve(m), Status::kOk);
    Scores s;
    s.add(m, truth);
    expect_within_3_sigma(s, "end to end");
    worst = std::max(worst, s.worst());
  }
  std::printf("[ end to end ] worst |z| %.2f\n", worst);
}

// ---- Temperatures outside the record's bounds ----

// A rest at -300 degC (a broken or unconnected sensor's reading) is refused and changes
// nothing: the model's range stays within the temperatures a record holds (-100..200 degC,
// plausibility.hpp), so the accelerometer and gyro calibration it goes with can be saved. A
// reference temperature outside them is refused at reset. The bounds themselves are taken.
template <typename S>
void implausible_temperatures() {
  const auto truth = draw_truth(1, 1500);
  const Calibration<S> base = cast_base<S>(sim::base_calibration(truth));
  const RestList rests = draw_rests(truth, 30, 1501);
  TemperatureFit<S> f;
  ASSERT_EQ(f.reset(base), Status::kOk);
  for (const auto& r : rests) ASSERT_EQ(f.add_rest(cast_rest<S>(r)), Status::kOk);
  TemperatureModel<S> before, after;
  ASSERT_EQ(f.solve(before), Status::kOk);
  const S min_before = f.min_c(), max_before = f.max_c();
  for (const double t : {-300.0, -100.5, 200.5, 1e30, -1e30}) {
    RestSummary<S> r = cast_rest<S>(rests[3]);
    r.temperature_c = static_cast<S>(t);
    EXPECT_EQ(f.add_rest(r), Status::kTemperatureImplausible) << t;
  }
  EXPECT_EQ(f.rests(), 30);
  EXPECT_EQ(f.min_c(), min_before);
  EXPECT_EQ(f.max_c(), max_before);
  ASSERT_EQ(f.solve(after), Status::kOk);
  EXPECT_EQ(after.min_c, before.min_c);
  EXPECT_EQ(after.accel.b1, before.accel.b1);
  EXPECT_EQ(after.gyro.b1, before.gyro.b1);
  for (const double t : {-100.0, 200.0}) {
    RestSummary<S> r = cast_rest<S>(rests[3]);
    r.temperature_c = static_cast<S>(t);
    EXPECT_EQ(f.add_rest(r), Status::kOk) << t;
  }
  EXPECT_EQ(f.min_c(), S(-100));
  EXPECT_EQ(f.max_c(), S(200));
  TemperatureSettings<S> cold;
  cold.reference_c = S(-300);
  EXPECT_EQ(f.reset(base, cold), Status::kInvalidArgument);
  Calibration<S> hot = base;
  hot.temperature_c = S(1e30);
  EXPECT_EQ(f.reset(hot), Status::kInvalidArgument);
  EXPECT_EQ(f.add_rest(cast_rest<S>(rests[0])), Status::kNotStarted);
}

TEST(TemperatureFit, ImplausibleTemperaturesRefusedDouble) { implausible_temperatures<double>(); }
TEST(TemperatureFit, ImplausibleTemperaturesRefusedFloat) { implausible_temperatures<float>(); }

}  // namespace
}  // namespace imucal
