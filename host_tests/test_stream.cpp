// SPDX-License-Identifier: MIT
// The stream layer (include/imucal/stream/), each part on its own: the ring, the initial rest's
// window, the front end's checks, blocks and the delay line, the segmenter, and the rest monitor
// built from them. Float, the device's type, on every target; the rest monitor also in double.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <vector>

#include "imucal/models/gyro_model.hpp"
#include "imucal/sim/accel_sim.hpp"
#include "imucal/sim/motion_sim.hpp"
#include "imucal/sim/random.hpp"
#include "imucal/sim/temperature_sim.hpp"
#include "imucal/stream/blocks.hpp"
#include "imucal/stream/checks.hpp"
#include "imucal/stream/initial_rest.hpp"
#include "imucal/stream/rest_monitor.hpp"
#include "imucal/stream/ring.hpp"
#include "imucal/stream/segmenter.hpp"
#include "support/gtest_status.hpp"
#include "support/monitor_run.hpp"

namespace imucal {
namespace {

using test::FoundRest;
using test::monitor_settings;
using test::run_monitor;
using V3 = Vector3<float>;

V3 to_float(const Vector3<double>& v) { return v.cast<float>(); }

// ---- The ring ----------------------------------------------------------------------------------

TEST(Ring, OldestFirstAndAFullRingDropsItsOldest) {
  Ring<int, 3> r;
  EXPECT_TRUE(r.empty());
  EXPECT_FALSE(r.push(1));
  EXPECT_FALSE(r.push(2));
  EXPECT_FALSE(r.push(3));
  EXPECT_TRUE(r.full());
  EXPECT_TRUE(r.push(4));  // 1 goes
  ASSERT_EQ(r.size(), 3);
  EXPECT_EQ(r.oldest(), 2);
  EXPECT_EQ(r.at(1), 3);
  EXPECT_EQ(r.newest(), 4);
  r.pop();
  EXPECT_EQ(r.oldest(), 3);
  std::vector<int> drained;
  r.drain([&](int v) { drained.push_back(v); });
  EXPECT_EQ(drained, (std::vector<int>{3, 4}));
  EXPECT_TRUE(r.empty());
  for (int k = 0; k < 10; ++k) r.push(k);  // wraps many times
  EXPECT_EQ(r.oldest(), 7);
  EXPECT_EQ(r.newest(), 9);
}

// ---- Initial rest ------------------------------------------------------------------------------

struct StillSource {
  Vector3<double> acc{120.0, -340.0, 4100.0}, gyro{12.0, -7.0, 3.0};
  double acc_sd = 3.0, gyro_sd = 2.0;  // raw counts
  sim::Random rng{11};
  std::uint32_t t_us = 0;
  void next(V3& a, V3& g) {
    a = to_float(acc + acc_sd * rng.normal3());
    g = to_float(gyro + gyro_sd * rng.normal3());
    t_us += 10000;  // 100 Hz
  }
};

// Feeds samples until the window answers something else than kRunning (at most `limit`).
Status feed(InitialRestWindow<float>& w, StillSource& src, int limit, bool use_gyro,
            InitialRestWindow<float>::Found& f, int* taken = nullptr) {
  Status s = Status::kRunning;
  int n = 0;
  for (; n < limit && s == Status::kRunning; ++n) {
    V3 a, g;
    src.next(a, g);
    s = w.add(a, g, src.t_us, n == 0 ? 0.0f : 0.01f, 2.0f, use_gyro);
  }
  if (s == Status::kOk) f = w.found();
  if (taken != nullptr) *taken = n;
  return s;
}

// A still start: two seconds of samples give the gyro's bias, each sensor's noise and the
// period, each within what the noise of 200 samples allows (4 sigma).
TEST(InitialRest, StillWindowGivesBiasNoiseAndPeriod) {
  InitialRestWindow<float> w;
  StillSource src;
  InitialRestWindow<float>::Found f;
  int taken = 0;
  ASSERT_EQ(feed(w, src, 1000, true, f, &taken), Status::kOk);
  // Four quarters of at least 0.5 s each (a float sum of 0.01 s steps may need one more).
  EXPECT_GE(taken, 201);
  EXPECT_LE(taken, 205);
  const double n = static_cast<double>(f.samples);
  EXPECT_EQ(n, taken);
  EXPECT_NEAR(static_cast<double>(f.period), 0.01, 1e-7);
  EXPECT_EQ(f.t_end - f.t_begin, static_cast<std::uint32_t>((taken - 1) * 10000));
  const Vector3<double> acc_mean = (f.acc_ref + f.acc_sum / f.samples).cast<double>();
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(acc_mean(i), src.acc(i), 4 * src.acc_sd / std::sqrt(n)) << i;
    EXPECT_NEAR(static_cast<double>(f.gyro_mean(i)), src.gyro(i), 4 * src.gyro_sd / std::sqrt(n));
    // A variance from n samples has a relative sigma of sqrt(2 / n).
    const double rel = 4 * std::sqrt(2 / n);
    EXPECT_NEAR(static_cast<double>(f.acc_variance(i)), src.acc_sd * src.acc_sd,
                rel * src.acc_sd * src.acc_sd);
    EXPECT_NEAR(static_cast<double>(f.gyro_variance(i)), src.gyro_sd * src.gyro_sd,
                rel * src.gyro_sd * src.gyro_sd);
  }
  EXPECT_GE(static_cast<double>(w.elapsed()), 2.0 - 1e-5);
  EXPECT_LE(static_cast<double>(w.elapsed()), 2.04 + 1e-5);
}

// A tilt of 10 sigma within the window: disturbed, then the window slides on and finds the
// stillness after the tilt, at the new level.
TEST(InitialRest, TiltInTheWindowIsDisturbedThenItSlidesOn) {
  InitialRestWindow<float> w;
  StillSource src;
  InitialRestWindow<float>::Found f;
  ASSERT_EQ(feed(w, src, 120, true, f), Status::kRunning);
  src.acc(0) += 10 * src.acc_sd;
  EXPECT_EQ(feed(w, src, 1000, true, f), Status::kInitialRestDisturbed);
  Status s = Status::kInitialRestDisturbed;
  int quarters = 0;
  while (s == Status::kInitialRestDisturbed && quarters < 10) {
    s = feed(w, src, 1000, true, f);
    ++quarters;
  }
  ASSERT_EQ(s, Status::kOk);
  EXPECT_LE(quarters, 4);  // the tilt leaves the window within four quarters
  const double n = static_cast<double>(f.samples);
  EXPECT_NEAR(static_cast<double>(f.acc_ref(0) + f.acc_sum(0) / f.samples), src.acc(0),
              4 * src.acc_sd / std::sqrt(n));
}

// An axis that does not move at all (a frozen or disconnected sensor) sets no threshold.
TEST(InitialRest, AnAxisWithoutNoiseIsAFrozenSensor) {
  InitialRestWindow<float> w;
  StillSource src;
  src.gyro_sd = 0.0;
  InitialRestWindow<float>::Found f;
  EXPECT_EQ(feed(w, src, 1000, true, f), Status::kSensorFrozen);
  // Without a gyro its readings are not looked at.
  w.restart();
  EXPECT_EQ(feed(w, src, 1000, false, f), Status::kOk);
}

// ---- Stream checks -------------------------------------------------------------------------

TEST(StreamChecks, FullScaleBallAndExactLimits) {
  FullScale<float> fs;
  fs.set(0.0f, 65535.0f);
  EXPECT_TRUE(fs.in_ball(V3(32768, 32768, 32768)));
  EXPECT_FALSE(fs.in_ball(V3(100, 100, 100)));  // a corner: outside the ball, inside the box
  EXPECT_FALSE(fs.outside(V3(100, 100, 100)));
  EXPECT_TRUE(fs.outside(V3(32768, 65535, 32768)));
  EXPECT_TRUE(fs.outside(V3(0, 32768, 32768)));
  EXPECT_FALSE(fs.in_ball(V3(std::numeric_limits<float>::quiet_NaN(), 32768, 32768)));
  FullScale<float> none;
  none.set(-std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity());
  EXPECT_TRUE(none.in_ball(V3(1e15f, -1e15f, 0)));
}

TEST(StreamChecks, AClockResetNeedsARunOfOrderedSamples) {
  ClockResetWatch w;
  w.reset();
  EXPECT_FALSE(w.went_back(1000, 50000, 3));
  w.in_order();  // a stray one, then order again
  EXPECT_FALSE(w.went_back(2000, 50000, 3));
  EXPECT_FALSE(w.went_back(12000, 50000, 3));
  EXPECT_TRUE(w.went_back(22000, 50000, 3));
  EXPECT_FALSE(w.went_back(30000, 50000, 3));
  EXPECT_FALSE(w.went_back(500000, 50000, 3));  // a step above max_step starts a new run
  EXPECT_FALSE(w.went_back(510000, 50000, 3));
  EXPECT_TRUE(w.went_back(520000, 50000, 3));
}

// A temperature in fixed point (1/4096 deg C): from a float's bits exactly what rounding the
// exact product half away from zero gives, on either scalar type; saturated far out of range.
TEST(StreamChecks, TemperaturesInFixedPointRoundAsTheExactProduct) {
  sim::Random rng(41);
  for (int k = 0; k < 200000; ++k) {
    // Readings over the range and beyond, and values on and beside the rounding ties.
    float t = static_cast<float>(rng.uniform(-300.0, 300.0));
    if (k % 4 == 1) t = static_cast<float>(std::floor(rng.uniform(-1e6, 1e6)) + 0.5) / 4096.0f;
    if (k % 4 == 2) t = std::nextafter(t, k % 8 == 2 ? 1e9f : -1e9f);
    if (k % 4 == 3) t = static_cast<float>(rng.uniform(-1e-3, 1e-3));
    const double exact = std::round(static_cast<double>(t) * 4096.0);
    ASSERT_EQ(detail::to_temperature_q_bits(t), static_cast<std::int32_t>(exact)) << t;
    ASSERT_EQ(detail::to_temperature_q_float(t), static_cast<std::int32_t>(exact)) << t;
    ASSERT_EQ(detail::to_temperature_q(static_cast<double>(t)), static_cast<std::int32_t>(exact));
  }
  for (auto* q : {&detail::to_temperature_q_bits, &detail::to_temperature_q_float}) {
    EXPECT_EQ(q(0.0f), 0);
    EXPECT_EQ(q(-0.0f), 0);
    EXPECT_EQ(q(1e-40f), 0);  // subnormal
    EXPECT_EQ(q(std::numeric_limits<float>::infinity()), detail::kTemperatureQMax);
    EXPECT_EQ(q(-3e5f), -detail::kTemperatureQMax);
    EXPECT_EQ(q(262143.98f), 1073741760);  // the largest float below saturation
  }
  EXPECT_EQ(detail::to_temperature_q(-std::numeric_limits<double>::infinity()),
            -detail::kTemperatureQMax);
  EXPECT_EQ(detail::to_temperature_q(150.0f), 614400);
  EXPECT_EQ(detail::from_temperature_q<float>(614400), 150.0f);
}

// Whatever the limits, a temperature that is not finite is ignored, and readings at the far ends
// of the widest range sum without overflow.
TEST(StreamChecks, TemperatureLimitsAsWideAsTheyComeStillRefuseInfinity) {
  struct NoSink {
    void stream_cut() {}
    void sensor_froze() {}
  } sink;
  StreamSettings<float> set;
  set.temperature_min_c = -std::numeric_limits<float>::infinity();
  set.temperature_max_c = std::numeric_limits<float>::max();
  ASSERT_TRUE(set.valid());
  StreamChecks<float> checks;
  checks.reset(set);
  checks.set_gap_limit(1000000u);
  const float readings[] = {-4096.0f,
                            4096.0f,
                            std::numeric_limits<float>::infinity(),
                            -std::numeric_limits<float>::infinity(),
                            1e9f,
                            25.0f};
  const bool taken[] = {true, true, false, false, false, true};
  std::uint32_t t = 0;
  for (int k = 0; k < 6; ++k) {
    RawFrame f;
    f.t_us = t += 10000u;
    f.acc[0] = static_cast<std::int16_t>(k);  // not frozen
    CheckedSample<float> c;
    const Status st = checks.check(f, readings[k], sink, c);
    ASSERT_TRUE(sample_taken(st) || st == Status::kOk) << k;
    EXPECT_EQ(c.has_temperature(), taken[k]) << k;
    EXPECT_EQ(st == Status::kTemperatureImplausible, !taken[k]) << k;
    if (taken[k]) {
      EXPECT_EQ(c.temperature_q,
                detail::to_temperature_q(readings[k]) - detail::to_temperature_q(-4096.0f));
    }
    checks.accept(f);
  }
  EXPECT_EQ(checks.temperature().count(), 3u);
  float mean = 0;
  ASSERT_TRUE(checks.temperature().mean(mean));
  EXPECT_NEAR(static_cast<double>(mean), 25.0 / 3.0, 1e-3);
  EXPECT_EQ(checks.counts().temperature_bad, 3u);
}
// A sensor frozen longer than the microsecond clock's 71.6 minutes stays frozen: its spell's
// length saturates rather than wrapping to a few microseconds and letting its repeats through.
TEST(StreamChecks, AFreezeLongerThanTheClockStaysRefused) {
  struct NoSink {
    int freezes = 0;
    void stream_cut() {}
    void sensor_froze() { ++freezes; }
  } sink;
  StreamSettings<float> set;  // frozen after 0.5 s
  ASSERT_TRUE(set.valid());
  StreamChecks<float> checks;
  checks.reset(set);
  checks.set_gap_limit(1000000u);
  RawFrame f;
  f.acc[2] = 16384;
  std::uint32_t t = 0;
  CheckedSample<float> c;
  const std::uint32_t frames = 80u * 60u * 50u;  // 80 minutes at 50 Hz
  std::uint32_t taken = 0, refused = 0;
  for (std::uint32_t k = 0; k < frames; ++k) {
    f.t_us = t += 20000u;
    const Status st = checks.check(f, std::numeric_limits<float>::quiet_NaN(), sink, c);
    if (sample_taken(st)) {
      checks.accept(f);
      ++taken;
    } else {
      ASSERT_EQ(st, Status::kSensorFrozen) << k;
      ++refused;
    }
  }
  EXPECT_EQ(taken, 25u);  // the first, and 0.5 s of repeats before the freeze is declared
  EXPECT_EQ(refused, frames - 25u);
  EXPECT_EQ(sink.freezes, 1);
  EXPECT_EQ(checks.counts().frozen, frames - 25u);
}

// Without a gyro its readings are not checked against its full scale: limits that leave out the
// zeros standing for its readings (0 to 65535, a sensor's unsigned counts) refuse nothing.
TEST(StreamChecks, WithoutAGyroItsFullScaleIsNotChecked) {
  struct NoSink {
    void stream_cut() {}
    void sensor_froze() {}
  } sink;
  StreamSettings<float> set;
  set.has_gyro = false;
  set.accel_min = set.gyro_min = 0.0f;
  set.accel_max = set.gyro_max = 65535.0f;
  ASSERT_TRUE(set.valid());
  StreamChecks<float> checks;
  checks.reset(set);
  checks.set_gap_limit(1000000u);
  CheckedSample<float> c;
  std::uint32_t t = 0;
  for (int k = 0; k < 10; ++k) {
    RawFrame f;
    f.t_us = t += 10000u;
    f.acc[0] = static_cast<std::int16_t>(100 + k);
    f.acc[1] = 200;
    f.acc[2] = 16384;
    EXPECT_EQ(checks.check(f, std::numeric_limits<float>::quiet_NaN(), sink, c), Status::kOk) << k;
    checks.accept(f);
    ImuSample<float> s;
    s.t_us = t += 10000u;
    s.acc = V3(100.0f + static_cast<float>(k), 200.0f, 16384.0f);
    EXPECT_EQ(checks.check(s, sink, c), Status::kOk) << k;
    checks.accept(s);
  }
  EXPECT_EQ(checks.counts().gyro_saturated, 0u);
}

// Settings are converted before they are checked: absurd ones (NaN, negative, past the clock)
// convert without undefined behaviour (the sanitizers' build holds it) and are refused.
TEST(StreamChecks, AbsurdDurationsConvertAndAreRefused) {
  EXPECT_EQ(detail::seconds_to_us(0.25f), 250000u);
  EXPECT_EQ(detail::seconds_to_us(600.0), 600000000u);
  EXPECT_EQ(detail::seconds_to_us(std::numeric_limits<float>::quiet_NaN()), 0u);
  EXPECT_EQ(detail::seconds_to_us(-1.0f), 0u);
  EXPECT_EQ(detail::seconds_to_us(1e10f), 0xFFFFFFFFu);
  EXPECT_EQ(detail::seconds_to_us(std::numeric_limits<double>::infinity()), 0xFFFFFFFFu);
  const float absurd[] = {std::numeric_limits<float>::quiet_NaN(), -1.0f, 1e10f};
  for (const float x : absurd) {
    RestMonitorSettings<float> set;
    set.frozen_seconds = x;
    RestMonitor<float> monitor;
    EXPECT_EQ(monitor.reset(set), Status::kInvalidArgument) << x;
    set = RestMonitorSettings<float>{};
    set.block_seconds = x;
    EXPECT_EQ(monitor.reset(set), Status::kInvalidArgument) << x;
  }
}

TEST(StreamChecks, RateWindowsOfOneSecond) {
  RateWatch r;
  r.restart();
  int off = 0;
  for (int k = 0; k < 500; ++k) off += r.off(10000u, 100.0f, 0.1f) ? 1 : 0;  // 100 Hz
  EXPECT_EQ(off, 0);
  for (int k = 0; k < 300; ++k) off += r.off(5000u, 100.0f, 0.1f) ? 1 : 0;  // 200 Hz
  EXPECT_GE(off, 1);
  TemperatureMean<float> t;
  float m = 0;
  EXPECT_FALSE(t.mean(m));
  for (int k = 0; k < 1000; ++k) t.add(25.0f + 0.001f * static_cast<float>(k % 11));
  ASSERT_TRUE(t.mean(m));
  EXPECT_NEAR(static_cast<double>(m), 25.005, 1e-4);
}

// ---- Blocks and the delay line -----------------------------------------------------------------

SampleBlock<float> block_of(sim::Random& rng, int n, std::uint32_t t0, const V3& acc) {
  SampleBlock<float> b;
  for (int k = 0; k < n; ++k) {
    const V3 a = acc + to_float(rng.normal3());
    const V3 u = to_float(0.01 * rng.normal3());
    if (b.n == 0) {
      b.acc_ref = a;
      b.t_begin = t0;
    }
    b.seg.add(u, k == 0 ? 0.0f : 0.01f);
    b.acc_sum += a - b.acc_ref;
    ++b.n;
    b.t_end = t0 + static_cast<std::uint32_t>(k) * 10000u;
  }
  return b;
}

// Appended blocks hold the mean of all their samples (raw counts near 33000: the re-centred,
// compensated sums keep float at the noise's precision).
TEST(Blocks, AppendedBlocksKeepTheMeanOfAllSamples) {
  sim::Random rng(3);
  const V3 level(33000, 32000, 36000);
  SampleBlock<float> a = block_of(rng, 10, 0, level);
  const SampleBlock<float> b = block_of(rng, 15, 100000, level + V3(2, 0, 0));
  const Vector3<double> expected =
      (10.0 * a.acc_mean().cast<double>() + 15.0 * b.acc_mean().cast<double>()) / 25.0;
  a.append(b);
  EXPECT_EQ(a.n, 25u);
  EXPECT_EQ(a.t_begin, 0u);
  EXPECT_EQ(a.t_end, b.t_end);
  for (int i = 0; i < 3; ++i)  // two float ulps at 36000
    EXPECT_NEAR(static_cast<double>(a.acc_mean()(i)), expected(i), 8e-3) << i;
}

// The pose noise undoes the moving mean's share in the detector's cue: a cue of
// 3 s^2 (1 + w / (2 - w)) a sample gives s^2.
TEST(Blocks, NoiseFromTheDetectorsCue) {
  SampleBlock<float> b;
  b.n = 500;
  b.t_begin = 0;
  b.t_end = 5000000;  // dt 0.01 s
  const double seconds = 0.5, dt = 0.01, w = dt / (seconds + dt), s2 = 9.0;
  b.accel_cue = static_cast<float>(500 * 3 * s2 * (1 + w / (2 - w)));
  EXPECT_NEAR(static_cast<double>(b.noise_variance(static_cast<float>(seconds))), s2, 1e-4 * s2);
  b.accel_cue = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(b.noise_variance(0.5f), 0.0f);
  // The rest's mean rate: alpha over the duration, less b0.
  b.seg.alpha = V3(0.5f, -1.0f, 2.0f);
  b.seg.duration = 5.0f;
  const RestSummary<float> r = b.summary(V3(0.1f, 0.1f, 0.1f), 20.0f);
  EXPECT_NEAR(static_cast<double>(r.gyro_mean(2)), 0.4 - 0.1, 1e-6);
  EXPECT_FALSE(r.has_temperature);
  EXPECT_EQ(r.samples, 500u);
}

TEST(Blocks, DelayLineKeepsOrderAndGrowsItsNewestWhenFull) {
  sim::Random rng(4);
  DelayLine<float, 3> line;
  for (int k = 0; k < 3; ++k)
    line.add(block_of(rng, 5, static_cast<std::uint32_t>(k) * 50000u, V3(0, 0, 100)));
  EXPECT_EQ(line.size(), 3);
  EXPECT_EQ(line.span_after_oldest(), 100000u);
  line.add(block_of(rng, 5, 150000u, V3(0, 0, 100)));  // full: appended to the newest
  EXPECT_EQ(line.size(), 3);
  EXPECT_EQ(line.newest().n, 10u);
  EXPECT_EQ(line.newest().t_end, 190000u);
  std::vector<std::uint32_t> order;
  line.drain([&](const SampleBlock<float>& b) { order.push_back(b.t_begin); });
  EXPECT_EQ(order, (std::vector<std::uint32_t>{0u, 50000u, 100000u}));
  EXPECT_TRUE(line.empty());
}

// 7. A stream of rests (12 s, 12 s, 90 s, 12 s, then 3 s) and turns while the board warms from
// 20 to 40 deg C, its clock wrapping: one rest each for the 12 s ones, two for the 90 s one (split
// at max_rest_seconds = 60), none for the 3 s one; each mean within noise of the truth at the
// rest's mean temperature; bad samples refused along the way without changing the outcome.
// The warming stream of the tests below: its sensors, truth and plan.
struct WarmingRests {
  sim::AccelSensorSpec acc = sim::AccelSensorSpec::raw_counts();
  sim::GyroSensorSpec gyro = sim::GyroSensorSpec::raw_counts();
  sim::TemperatureTruth truth;
  sim::StreamPlan plan;
  WarmingRests() {
    sim::Random rng(1200);
    truth = sim::draw_temperature_truth(acc, gyro, 1, 30.0, rng);
    plan.rest_s = {12.0, 12.0, 90.0, 12.0, 3.0};
    plan.profile.start_c = 20.0;
    plan.profile.end_c = 40.0;
    plan.profile.ramp_s = 140.0;
  }
};

template <typename S>
void monitor_stream(const char* label) {
  WarmingRests w;
  const auto& acc = w.acc;
  const auto& gyro = w.gyro;
  const auto& truth = w.truth;
  sim::StreamPlan plan = w.plan;
  plan.t0_us = 0xFFFFFFFFu - 20000000u;  // wraps 20 s in
  for (int faults = 0; faults < 2; ++faults) {
    sim::Random stream_rng(1201);
    sim::TemperatureStream stream(truth, acc, gyro, plan, stream_rng);
    RestMonitor<S> monitor(
        monitor_settings<S>(acc, gyro, truth.raw_gyro(Vector3<double>::Zero(), 20.0)));
    const std::vector<FoundRest> found = run_monitor(stream, monitor, faults == 1);
    ASSERT_EQ(found.size(), 5u) << label;
    const int expected_index[5] = {0, 1, 2, 2, 3};
    double worst = 0.0;
    for (std::size_t i = 0; i < found.size(); ++i) {
      const RestSummary<double>& r = found[i].summary;
      EXPECT_EQ(found[i].rest_index, expected_index[i]);
      EXPECT_TRUE(r.has_temperature);
      EXPECT_GE(r.duration_s, 5.0);
      EXPECT_LE(r.duration_s, 60.0 + 1e-3);
      EXPECT_NEAR(r.duration_s, static_cast<double>(r.samples) / 100.0, 0.05 * r.duration_s);
      const Vector3<double> up = stream.rest_up(found[i].rest_index);
      const double t = r.temperature_c;
      const Vector3<double> acc_true = truth.raw_accel(truth.acc.gravity * up, t);
      const Vector3<double> gyro_true = truth.raw_gyro(Vector3<double>::Zero(), t);
      const double k = 1.0 / std::sqrt(static_cast<double>(r.samples));
      for (int a = 0; a < 3; ++a) {
        const double za = (r.accel_mean(a) - acc_true(a)) / (acc.noise * k);
        const double zg = (r.gyro_mean(a) - gyro_true(a)) / (gyro.noise * k);
        EXPECT_LE(std::abs(za), 4.5) << label << " rest " << i << " axis " << a;
        EXPECT_LE(std::abs(zg), 4.5) << label << " rest " << i << " axis " << a;
        worst = std::max(worst, std::max(std::abs(za), std::abs(zg)));
      }
    }
    EXPECT_GT(found[2].summary.duration_s, 55.0);  // the 90 s rest: a full 60 s piece first
    EXPECT_GT(found[3].summary.temperature_c, found[2].summary.temperature_c + 5.0);
    std::printf("[ monitor %s%s ] %zu rests, means worst %.2f noise sigmas\n", label,
                faults ? " with faults" : "", found.size(), worst);
  }
}

TEST(RestMonitor, StreamFloat) { monitor_stream<float>("float"); }

// The optional shift check: the same stream, with the mean allowed to move only 8 counts (less
// than this fast warm-up's drift over 60 s): the long rest comes in more, shorter pieces.
TEST(RestMonitor, ShiftLimitSplitsADriftingRest) {
  WarmingRests w;
  sim::Random stream_rng(1201);
  sim::TemperatureStream stream(w.truth, w.acc, w.gyro, w.plan, stream_rng);
  RestMonitorSettings<float> set =
      monitor_settings<float>(w.acc, w.gyro, w.truth.raw_gyro(Vector3<double>::Zero(), 20.0));
  set.accel_shift_max = 8.0f;
  RestMonitor<float> monitor(set);
  const std::vector<FoundRest> found = run_monitor(stream, monitor, false);
  EXPECT_GT(found.size(), 5u);
  for (const FoundRest& f : found) EXPECT_LT(f.summary.duration_s, 50.0);
}
TEST(RestMonitor, StreamDouble) { monitor_stream<double>("double"); }

// With room for moves, the monitor hands on each move between two rests as segments, as they
// come: walked through the true gyro model (the bias at the move's start) they give the rotation
// that the samples between the two rests give, integrated one by one; and they carry the gravity
// direction of the rest a move began at to that of the rest it ended at. A gap in a move leaves it
// incomplete; the others stay whole.
TEST(RestMonitor, MovesBetweenRestsComeWholeAsSegments) {
  WarmingRests w;
  const double k = 1.0 / w.truth.gyro.params(kGyroScaleX);  // counts per rad/s
  const Matrix3<double> m = gyro_matrix<double>(w.truth.gyro.params);
  const auto true_bias = [&w](double t_c) {  // added
    return Vector3<double>(-w.truth.raw_gyro(Vector3<double>::Zero(), t_c));
  };
  for (int gap = 0; gap < 2; ++gap) {
    sim::Random stream_rng(1201);
    sim::TemperatureStream stream(w.truth, w.acc, w.gyro, w.plan, stream_rng);
    RestMonitorSettings<double> set = test::monitor_settings<double>(
        w.acc, w.gyro, w.truth.raw_gyro(Vector3<double>::Zero(), 20.0));
    set.move_max_angle = 0.6 * k;  // the protocol's bounds
    set.move_max_error = 1e-3 * k * k * k;
    RestMonitor<double, 4, 8, 16> monitor(set);
    // What the direct integration needs of each sample since the rest handed out last (at most
    // the 60 s piece of the long rest): one allocation, within the smallest board's heap.
    struct Kept {
      std::uint32_t t_us;
      Vector3<double> gyro;
      double temperature;
    };
    std::vector<Kept> samples;
    samples.reserve(7000);
    std::uint32_t move = 0;
    double t_move = 0.0;
    Matrix3<double> rt = Matrix3<double>::Identity();  // R^T of the move so far
    std::vector<RestSummary<double>> rests;
    std::vector<int> index;  // the true rest each came from
    int complete = 0, checked = 0;
    bool skipped = false;
    double worst_walk = 0.0, worst_truth = 0.0;
    ImuSample<double> s;
    while (stream.next(s)) {
      // One gap of 0.6 s in the first move.
      if (gap == 1 && !skipped && !rests.empty() && !monitor.resting()) {
        for (int i = 0; i < 60 && stream.next(s); ++i) {
        }
        skipped = true;
      }
      samples.push_back(Kept{s.t_us, s.gyro, s.temperature});
      const Status st = monitor.add(s);
      EXPECT_TRUE(st == Status::kOk || sample_taken(st)) << to_string(st);
      GyroSegment<double> seg;
      std::uint32_t n = 0;
      while (monitor.take_move_segment(seg, n)) {
        if (n != move) {  // a new move: the bias at its start stands for it
          move = n;
          t_move = s.temperature;
          rt.setIdentity();
        }
        std::uint32_t b = 0, e = 0;
        Vector3<double> b0;
        ASSERT_TRUE(monitor.move_from(n, b, e, b0));
        rt = rotation_exp<double>(-seg.rotation_vector(m, true_bias(t_move) - b0)) * rt;
      }
      RestSummary<double> r;
      while (monitor.take(r)) {
        // Kept: the samples after the rests handed out before this one (a move's).
        if (!rests.empty()) {
          const std::uint32_t before = rests.back().end_us;
          samples.erase(std::remove_if(samples.begin(), samples.end(),
                                       [before](const Kept& x) { return x.t_us < before; }),
                        samples.end());
        }
        rests.push_back(r);
        index.push_back(stream.rest_index());
        if (!monitor.move_complete(move, r.begin_us, r.end_us)) continue;
        ++complete;
        std::uint32_t b = 0, e = 0;
        Vector3<double> b0;
        ASSERT_TRUE(monitor.move_from(move, b, e, b0));
        // The samples from the rest's end to this one's start, one by one (trapezoid).
        Matrix3<double> direct = Matrix3<double>::Identity();
        Vector3<double> prev = Vector3<double>::Zero();
        std::uint32_t prev_t = 0;
        for (const Kept& x : samples) {
          const Vector3<double> u = m * (x.gyro + true_bias(t_move));
          if (x.t_us > e && x.t_us <= r.begin_us)
            direct = rotation_exp<double>(-(0.5e-6 * (x.t_us - prev_t)) * (u + prev)) * direct;
          prev = u;
          prev_t = x.t_us;
        }
        for (std::size_t i = 0; i + 1 < rests.size(); ++i) {
          if (rests[i].begin_us != b || rests[i].end_us != e) continue;
          const Vector3<double> from = stream.rest_up(index[i]);
          const double walk = (rt * from - direct * from).norm();
          const double truth = (rt * from - stream.rest_up(index.back())).norm();
          EXPECT_LT(walk, 1e-4) << "move " << move;  // the segments' second-order expansion
          // and the bias's drift on this fast warm-up (4 counts per deg C, 0.14 deg C/s)
          EXPECT_LT(truth, 3e-3) << "move " << move;
          worst_walk = std::max(worst_walk, walk);
          worst_truth = std::max(worst_truth, truth);
          ++checked;
        }
      }
    }
    // Three moves end at rests handed out (the 90 s rest comes in two pieces with no move
    // between; the last rest is shorter than min_rest_seconds); the gap breaks the first.
    EXPECT_EQ(complete, gap == 0 ? 3 : 2);
    EXPECT_EQ(checked, complete);
    std::printf(
        "[ monitor moves%s ] %d whole: within %.1e rad of the samples one by one, %.1e "
        "of the truth\n",
        gap ? " with a gap" : "", complete, worst_walk, worst_truth);
  }
}

// New settings within one stream (reset_in_stream()): a sample behind the latest one is still
// refused, where a plain reset() starts a new stream that takes it.
TEST(RestMonitor, AResetWithinTheStreamKeepsItsTimeOrder) {
  RestMonitorSettings<float> set;
  set.accel_noise = 3e-4f;
  set.gyro_noise = 4e-6f;
  RestMonitor<float> m(set);
  ImuSample<float> s;
  s.acc = Vector3<float>(0.1f, -0.2f, 9.8f);
  for (std::uint32_t k = 1; k <= 10; ++k) {
    s.t_us = 10000u * k;
    s.acc(0) = 0.1f + 0.001f * static_cast<float>(k % 3);
    ASSERT_EQ(m.add(s), Status::kOk);
  }
  ASSERT_EQ(m.reset_in_stream(set), Status::kOk);
  s.t_us = 60000u;  // behind the latest, 100 ms
  EXPECT_EQ(m.add(s), Status::kTimeBackwards);
  s.t_us = 100000u;
  EXPECT_EQ(m.add(s), Status::kTimeRepeated);
  s.t_us = 110000u;
  EXPECT_EQ(m.add(s), Status::kOk);
  ASSERT_EQ(m.reset(set), Status::kOk);
  s.t_us = 60000u;
  EXPECT_EQ(m.add(s), Status::kOk);
}

// n samples of a still stream at 100 Hz after t (noise as GapEndsTheRest's) into m: kOk, or the
// first other status.
Status still_samples(RestMonitor<float>& m, sim::Random& rng, std::uint32_t& t, int n,
                     ImuSample<float>& s) {
  Status last = Status::kOk;
  for (int k = 0; k < n; ++k) {
    t += 10000u;
    s.t_us = t;
    s.acc = Vector3<float>(0.1f, -0.2f, 9.8f) + to_float(0.01 * rng.normal3());
    s.gyro = to_float(0.002 * rng.normal3());
    last = m.add(s);
    if (last != Status::kOk) return last;
  }
  return last;
}

RestMonitorSettings<float> gap_test_settings() {
  RestMonitorSettings<float> set;
  set.accel_noise = 3e-4f;
  set.gyro_noise = 4e-6f;
  set.max_rest_seconds = 60.0f;
  return set;
}

// A stall of 600 ms (a FIFO overrun, a bus held) after which one sensor repeats its last reading
// (a quantised gyro, a driver's cached registers): the step is a gap, not time the sensor was
// seen frozen, and the rest before it is handed out.
TEST(RestMonitor, ARepeatedReadingAcrossAStallIsAGapNotAFrozenSensor) {
  RestMonitor<float> m(gap_test_settings());
  sim::Random rng(1301);
  std::uint32_t t = 1000u;
  ImuSample<float> s;
  ASSERT_EQ(still_samples(m, rng, t, 1000, s), Status::kOk);
  t += 600000u;
  s.t_us = t;
  s.acc(0) += 0.01f;  // the accelerometer moves on, the gyro repeats itself
  EXPECT_EQ(m.add(s), Status::kTimestampGap);
  EXPECT_EQ(m.stream_counts().frozen, 0u);
  EXPECT_EQ(m.stream_counts().gaps, 1u);
  RestSummary<float> r;
  ASSERT_TRUE(m.take(r));
  EXPECT_GT(r.duration_s, 9.0f);
  // A sensor that stays frozen is refused across a stall as before it.
  Status st = Status::kOk;
  for (int k = 0; k < 60; ++k) {
    t += 10000u;
    s.t_us = t;
    st = m.add(s);
  }
  ASSERT_EQ(st, Status::kSensorFrozen);
  t += 600000u;
  s.t_us = t;
  EXPECT_EQ(m.add(s), Status::kSensorFrozen);
}

// With the sensor's rate given (nominal_rate_hz), a step over gap_factor periods is a gap: 400 ms
// at 100 Hz. Without it only max_step_seconds (0.5 s) is.
TEST(RestMonitor, AStepOverGapFactorNominalPeriodsIsAGap) {
  for (const float rate : {100.0f, 0.0f}) {
    RestMonitorSettings<float> set = gap_test_settings();
    set.nominal_rate_hz = rate;
    RestMonitor<float> m(set);
    sim::Random rng(1302);
    std::uint32_t t = 1000u;
    ImuSample<float> s;
    ASSERT_EQ(still_samples(m, rng, t, 50, s), Status::kOk);
    t += 390000u;
    EXPECT_EQ(still_samples(m, rng, t, 1, s), rate > 0.0f ? Status::kTimestampGap : Status::kOk)
        << rate;
    t += 30000u;  // 40 ms: under 5 periods is no gap
    EXPECT_EQ(still_samples(m, rng, t, 1, s), Status::kOk) << rate;
    EXPECT_EQ(m.stream_counts().gaps, rate > 0.0f ? 1u : 0u) << rate;
  }
}

// The sample that makes a clock reset is refused as a glitch: the stream still starts again
// there, on the new clock, and the next sample is taken (not refused as behind the old clock).
TEST(RestMonitor, AGlitchWhereTheStreamStartsAgainKeepsTheRestart) {
  RestMonitorSettings<float> set = gap_test_settings();
  set.glitch_sigma = 10.0f;
  RestMonitor<float> m(set);
  sim::Random rng(1304);
  std::uint32_t t = 1000000000u;
  ImuSample<float> s;
  ASSERT_EQ(still_samples(m, rng, t, 300, s), Status::kOk);
  t = 1000u;  // the clock starts again: the third sample behind it is the reset
  EXPECT_EQ(still_samples(m, rng, t, 1, s), Status::kTimeBackwards);
  EXPECT_EQ(still_samples(m, rng, t, 1, s), Status::kTimeBackwards);
  t += 10000u;
  s.t_us = t;
  s.acc(0) += 5.0f;  // and a reading no hand makes
  EXPECT_EQ(m.add(s), Status::kGlitch);
  EXPECT_EQ(m.stream_counts().clock_resets, 1u);
  EXPECT_EQ(still_samples(m, rng, t, 200, s), Status::kOk);
  EXPECT_EQ(m.stream_counts().clock_resets, 1u);
  EXPECT_EQ(m.stream_counts().time_backwards, 2u);
}

// New settings within the stream: the rests found and not yet taken are counted as dropped.
TEST(RestMonitor, ANewSettingsRestsNotTakenAreCountedDropped) {
  const RestMonitorSettings<float> set = gap_test_settings();
  RestMonitor<float> m(set);
  sim::Random rng(1303);
  std::uint32_t t = 1000u;
  ImuSample<float> s;
  for (int rest = 0; rest < 2; ++rest) {
    ASSERT_EQ(still_samples(m, rng, t, 800, s), Status::kOk);
    t += 2000000u;
    ASSERT_EQ(still_samples(m, rng, t, 1, s), Status::kTimestampGap);
  }
  ASSERT_EQ(m.dropped(), 0u);
  ASSERT_EQ(m.reset_in_stream(set), Status::kOk);
  EXPECT_EQ(m.dropped(), 2u);
  RestSummary<float> r;
  EXPECT_FALSE(m.take(r));
}

TEST(RestMonitor, GapEndsTheRestAndSettingsAreChecked) {
  RestMonitorSettings<float> set;
  RestMonitor<float> m(set);  // thresholds not set
  ImuSample<float> s;
  s.t_us = 1000;
  EXPECT_EQ(m.add(s), Status::kInvalidArgument);
  set.accel_noise = 3e-4f;      // 0.01 per axis
  set.gyro_noise = 4e-6f;       // 0.002 on x
  set.max_rest_seconds = 0.5f;  // shorter than the shortest rest handed out
  EXPECT_EQ(m.reset(set), Status::kInvalidArgument);
  set.max_rest_seconds = 60.0f;
  set.trim_seconds = 0.0f;
  EXPECT_EQ(m.reset(set), Status::kInvalidArgument);
  set.trim_seconds = 0.25f;
  set.gyro_noise = -1.0f;
  EXPECT_EQ(m.reset(set), Status::kInvalidArgument);
  set.gyro_noise = 4e-6f;
  set.stillness.accel_k = 0.5f;
  EXPECT_EQ(m.reset(set), Status::kInvalidArgument);
  set.stillness = StillnessSettings<float>{};
  set.max_rest_seconds = 60.0f;
  ASSERT_EQ(m.reset(set), Status::kOk);

  // 8 s still, a 2 s hole, 8 s still: two rests (each about 8 s less the trimmed blocks).
  sim::Random rng(1300);
  std::uint32_t t = 4000000000u;
  int gaps = 0;
  for (int k = 0; k < 1600; ++k) {
    t += 10000u;
    if (k == 800) t += 2000000u;
    s.t_us = t;
    s.acc = Vector3<float>(0.1f, -0.2f, 9.8f) + Vector3<float>(static_cast<float>(rng.normal()),
                                                               static_cast<float>(rng.normal()),
                                                               static_cast<float>(rng.normal())) *
                                                    0.01f;
    s.gyro = Vector3<float>(static_cast<float>(rng.normal()) * 0.002f, 0.0f, 0.0f);
    s.temperature = 25.0f;
    const Status st = m.add(s);
    if (st == Status::kTimestampGap) ++gaps;
    EXPECT_TRUE(st == Status::kOk || st == Status::kTimestampGap);
  }
  EXPECT_EQ(gaps, 1);
  m.finish();
  RestSummary<float> r;
  int n = 0;
  while (m.take(r)) {
    ++n;
    EXPECT_NEAR(r.duration_s, 7.7f, 0.35f);
    EXPECT_NEAR(r.accel_mean(2), 9.8f, 0.01f);
    EXPECT_TRUE(r.has_temperature);
    EXPECT_NEAR(r.temperature_c, 25.0f, 1e-4f);
  }
  EXPECT_EQ(n, 2);
  // No temperature: the rest says so.
  ASSERT_EQ(m.reset(set), Status::kOk);
  for (int k = 0; k < 700; ++k) {
    s.t_us = 1000u + 10000u * static_cast<std::uint32_t>(k);
    s.acc = Vector3<float>(0.1f, -0.2f, 9.8f) + to_float(0.01 * rng.normal3());
    s.gyro = to_float(0.002 * rng.normal3());
    s.temperature = std::numeric_limits<float>::quiet_NaN();
    ASSERT_EQ(m.add(s), Status::kOk);
  }
  m.finish();
  ASSERT_TRUE(m.take(r));
  EXPECT_FALSE(r.has_temperature);
  EXPECT_FALSE(m.take(r));
}

// ---- The front end -----------------------------------------------------------------------------

// Records what the front end told its consumer.
struct CountingSink {
  int cuts = 0, freezes = 0;
  void stream_cut() { ++cuts; }
  void sensor_froze() { ++freezes; }
};

// Still samples at 100 Hz with noise (a frozen sensor repeats itself; these do not).
struct NoisySource {
  sim::Random rng{21};
  std::uint32_t t_us = 1000;
  ImuSample<float> next() {
    ImuSample<float> s;
    t_us += 10000u;
    s.t_us = t_us;
    s.acc = V3(0.1f, -0.2f, 9.8f) + to_float(0.01 * rng.normal3());
    s.gyro = to_float(0.002 * rng.normal3());
    s.temperature = 25.0f;
    return s;
  }
};

// Every kind of bad sample gets its status and count; refusals change nothing the next sample is
// ordered against; the consumer hears of every cut and of a freeze once.
TEST(StreamChecks, EveryBadSampleHasItsStatusCountAndCut) {
  StreamSettings<float> set;
  set.accel_min = -100.0f;
  set.accel_max = 100.0f;
  set.gyro_min = -30.0f;
  set.gyro_max = 30.0f;
  StreamChecks<float> checks;
  checks.reset(set);
  checks.set_gap_limit(50000u);
  CountingSink sink;
  NoisySource src;
  CheckedSample<float> c;
  const auto take = [&](const ImuSample<float>& s) {
    const Status st = checks.check(s, sink, c);
    if (sample_taken(st)) checks.accept(s);
    return st;
  };
  ImuSample<float> s = src.next();
  EXPECT_EQ(take(s), Status::kOk);
  EXPECT_EQ(c.dt(), 0.0f);  // the stream starts here
  s = src.next();
  EXPECT_EQ(take(s), Status::kOk);
  EXPECT_NEAR(static_cast<double>(c.dt()), 0.01, 1e-9);
  ImuSample<float> bad = src.next();
  bad.acc(1) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(take(bad), Status::kNonFiniteInput);
  bad = s;  // the same time again
  EXPECT_EQ(take(bad), Status::kTimeRepeated);
  bad.t_us = s.t_us - 5000u;
  EXPECT_EQ(take(bad), Status::kTimeBackwards);
  s = src.next();
  s.temperature = 400.0f;
  EXPECT_EQ(take(s), Status::kTemperatureImplausible);
  EXPECT_TRUE(std::isnan(c.temperature));
  s = src.next();
  s.acc(2) = 150.0f;
  EXPECT_EQ(take(s), Status::kAccelSaturated);
  EXPECT_TRUE(c.acc_saturated);
  s = src.next();
  s.gyro(0) = 31.0f;
  EXPECT_EQ(take(s), Status::kGyroSaturated);
  EXPECT_EQ(sink.cuts, 1);
  s = src.next();
  EXPECT_EQ(take(s), Status::kOk);
  EXPECT_EQ(c.dt(), 0.0f);  // nothing integrates across the saturated one
  s = src.next();
  s.t_us += 200000u;  // a 0.2 s hole
  src.t_us = s.t_us;
  EXPECT_EQ(take(s), Status::kTimestampGap);
  EXPECT_EQ(sink.cuts, 2);
  // Three samples behind the clock, in order: a clock reset (the third is taken).
  std::uint32_t t = s.t_us - 100000u;
  for (int k = 0; k < 3; ++k) {
    s = src.next();
    s.t_us = t;
    t += 10000u;
    EXPECT_EQ(take(s), k < 2 ? Status::kTimeBackwards : Status::kClockReset) << k;
  }
  EXPECT_EQ(sink.cuts, 3);
  src.t_us = s.t_us;
  // A sensor that repeats itself for frozen_seconds: refused from then on, one freeze.
  const ImuSample<float> same = src.next();
  int frozen = 0;
  for (int k = 0; k < 80; ++k) {
    s = same;
    s.t_us = src.t_us + 10000u * static_cast<std::uint32_t>(k);
    if (take(s) == Status::kSensorFrozen) ++frozen;
  }
  EXPECT_EQ(sink.freezes, 1);
  EXPECT_GE(frozen, 28);
  EXPECT_LE(frozen, 31);
  EXPECT_TRUE(checks.frozen());
  const StreamCounts& n = checks.counts();
  EXPECT_EQ(n.non_finite, 1u);
  EXPECT_EQ(n.time_repeated, 1u);
  EXPECT_EQ(n.time_backwards, 3u);
  EXPECT_EQ(n.clock_resets, 1u);
  EXPECT_EQ(n.gaps, 1u);
  EXPECT_EQ(n.temperature_bad, 1u);
  EXPECT_EQ(n.accel_saturated, 1u);
  EXPECT_EQ(n.gyro_saturated, 1u);
  EXPECT_EQ(n.frozen, static_cast<std::uint32_t>(frozen));
  set.gap_factor = 0.5f;
  EXPECT_FALSE(set.valid());
}

// ---- The segmenter -----------------------------------------------------------------------------

// Collects what the segmenter hands out.
template <typename S>
struct SegmenterSink {
  Segmenter<S, 8>* seg = nullptr;
  SegmentBounds<S> bounds{S(0.6), S(1e-3), S(1e-6), S(0.1)};
  std::vector<SampleBlock<S>> rests;
  std::vector<bool> long_enough;
  GyroSegment<S> move{};
  int move_blocks = 0;
  const SegmentBounds<S>& segment_bounds() const { return bounds; }
  void move_block(const SampleBlock<S>& b) {
    move.append(b.seg);
    ++move_blocks;
  }
  void rest_ended(const SampleBlock<S>& r, bool is_long) {
    rests.push_back(r);
    long_enough.push_back(is_long);
    if (is_long) seg->learn_rest(r);
  }
};

// 100 Hz: still for still_s, then a turn at `rate` (rad/s about z) for turn_s, then still.
// A sample as the front end passes it on: step_us after the previous one, temperature_c against a
// reference of 0 deg C.
template <typename S>
CheckedSample<S> checked(std::uint32_t step_us, double temperature_c) {
  CheckedSample<S> c;
  c.step_us = step_us;
  c.temperature = static_cast<S>(temperature_c);
  c.temperature_q = detail::to_temperature_q(temperature_c);
  return c;
}

template <typename S>
void feed_rest_turn_rest(Segmenter<S, 8>& seg, SegmenterSink<S>& sink, sim::Random& rng,
                         const Vector3<double>& bias, double still_s, double turn_s, double rate,
                         std::uint32_t& t) {
  const int n1 = static_cast<int>(still_s * 100), n2 = static_cast<int>(turn_s * 100);
  for (int k = 0; k < 2 * n1 + n2; ++k) {
    ImuSample<S> s;
    t += 10000u;
    s.t_us = t;
    const bool turning = k >= n1 && k < n1 + n2;
    Vector3<double> w = 0.002 * rng.normal3() - bias;  // raw: truth minus the added bias
    if (turning) w(2) += rate;
    s.gyro = w.cast<S>();
    s.acc = (Vector3<double>(0.1, -0.2, 9.8) + 0.01 * rng.normal3()).cast<S>();
    ASSERT_TRUE(seg.add(s, checked<S>(k == 0 && t == 10000u ? 0u : 10000u, 25.0), sink));
  }
}

// A rest, a turn of 1 rad, a rest: two long rests with the gyro mean at the bias, and the turn's
// rotation handed out as move blocks (the trimmed rest edges included).
TEST(Segmenter, RestsAndTheMoveBetweenThem) {
  Segmenter<float, 8> seg;
  SegmenterSettings<float> set;
  ASSERT_TRUE((Segmenter<float, 8>::valid(set)));
  seg.reset(set);
  const Vector3<double> bias(0.01, -0.02, 0.005);
  seg.start(StillnessSettings<float>{}, V3(0.1f, -0.2f, 9.8f), V3::Constant(1e-4f), 3.0f * 4e-6f,
            to_float(bias));
  SegmenterSink<float> sink;
  sink.seg = &seg;
  sim::Random rng(5);
  std::uint32_t t = 0;
  feed_rest_turn_rest(seg, sink, rng, bias, 3.0, 1.0, 1.0, t);
  ASSERT_TRUE(seg.end(sink));
  ASSERT_EQ(sink.rests.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_TRUE(sink.long_enough[i]);
    const RestSummary<float> r = sink.rests[i].summary(seg.gyro_bias(), 0.0f);
    EXPECT_GT(r.duration_s, 2.4f);
    EXPECT_LE(r.duration_s, 3.01f);
    const double k = 4.0 / std::sqrt(static_cast<double>(r.samples));
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(static_cast<double>(r.gyro_mean(a)), -bias(a), 0.002 * k) << i << " " << a;
    EXPECT_NEAR(static_cast<double>(r.temperature_c), 25.0, 1e-5);
  }
  // The move: the 1 rad turn (the bias is removed from every block).
  EXPECT_GT(sink.move_blocks, 10);
  EXPECT_NEAR(static_cast<double>(sink.move.alpha(2)), 1.0, 0.01);
  EXPECT_NEAR(static_cast<double>(sink.move.alpha.template head<2>().norm()), 0.0, 0.01);
}

// The bias can change in the middle of a rest: the rest's statistics move with it exactly, as if
// the new bias had been added from the start.
TEST(Segmenter, ChangingTheBiasMovesWhatIsHeldExactly) {
  const Vector3<double> bias(0.01, -0.02, 0.005);
  Segmenter<double, 8> a, b;
  SegmenterSink<double> sa, sb;
  sa.seg = &a;
  sb.seg = &b;
  for (auto* s : {&a, &b}) s->reset(SegmenterSettings<double>{});
  // Stillness from the accelerometer alone, so that both see the same rest whatever their bias.
  a.start(StillnessSettings<double>{}, Vector3<double>(0.1, -0.2, 9.8),
          Vector3<double>::Constant(1e-4), 0.0, bias);
  b.start(StillnessSettings<double>{}, Vector3<double>(0.1, -0.2, 9.8),
          Vector3<double>::Constant(1e-4), 0.0, Vector3<double>::Zero());
  sim::Random ra(9), rb(9);
  std::uint32_t ta = 0, tb = 0;
  // b starts without the bias and is told it half-way through the first rest.
  feed_rest_turn_rest(a, sa, ra, bias, 3.0, 0.0, 0.0, ta);
  ASSERT_TRUE(a.end(sa));
  // Half of the same stream, the bias, then the rest of it (same seed: same samples).
  const int half = 300;
  for (int k = 0; k < 600; ++k) {
    if (k == half) b.set_gyro_bias(bias);
    ImuSample<double> s;
    tb += 10000u;
    s.t_us = tb;
    s.gyro = 0.002 * rb.normal3() - bias;
    s.acc = Vector3<double>(0.1, -0.2, 9.8) + 0.01 * rb.normal3();
    ASSERT_TRUE(b.add(s, checked<double>(k == 0 ? 0u : 10000u, 25.0), sb));
  }
  ASSERT_TRUE(b.end(sb));
  ASSERT_EQ(sa.rests.size(), 1u);
  ASSERT_EQ(sb.rests.size(), 1u);
  const RestSummary<double> x = sa.rests[0].summary(bias, 0.0);
  const RestSummary<double> y = sb.rests[0].summary(bias, 0.0);
  EXPECT_EQ(x.samples, y.samples);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(x.gyro_mean(i), y.gyro_mean(i), 1e-12) << i;
    EXPECT_NEAR(sa.rests[0].seg.beta(i), sb.rests[0].seg.beta(i), 1e-12) << i;
  }
}

// Optional splits: a 10 s rest comes in pieces of at most max_rest_seconds.
TEST(Segmenter, ALongRestIsSplitAtMaxRestSeconds) {
  Segmenter<float, 8> seg;
  SegmenterSettings<float> set;
  set.max_rest_seconds = 3.0f;
  ASSERT_TRUE((Segmenter<float, 8>::valid(set)));
  seg.reset(set);
  const Vector3<double> bias = Vector3<double>::Zero();
  seg.start(StillnessSettings<float>{}, V3(0.1f, -0.2f, 9.8f), V3::Constant(1e-4f), 1.2e-5f,
            V3::Zero());
  SegmenterSink<float> sink;
  sink.seg = &seg;
  sim::Random rng(6);
  std::uint32_t t = 0;
  feed_rest_turn_rest(seg, sink, rng, bias, 5.0, 0.0, 0.0, t);  // 10 s still
  seg.end(sink);
  ASSERT_GE(sink.rests.size(), 4u);
  double total = 0.0;
  for (const auto& r : sink.rests) {
    const double d = (r.t_end - r.t_begin) * 1e-6;
    EXPECT_LE(d, 3.0 + 1e-6);
    total += r.n;
  }
  EXPECT_EQ(total, 1000.0);  // nothing lost between the pieces
}

// ---- The rest monitor on the front end ---------------------------------------------------------

RestMonitorSettings<float> plain_monitor_settings() {
  RestMonitorSettings<float> set;
  set.accel_noise = 3e-4f;   // 0.01 per axis
  set.gyro_noise = 1.2e-5f;  // 0.002 per axis
  set.min_rest_seconds = 2.0f;
  return set;
}

// The monitor takes its samples through the calibrator's front end: a frozen sensor is refused
// (and the rest it sat in discarded), an implausible temperature ignored, a clock reset resumes
// the stream instead of refusing every later sample, a gyro at full scale cuts the rest.
TEST(RestMonitor, TheFrontEndsStatusesAndWhatTheyCost) {
  RestMonitorSettings<float> set = plain_monitor_settings();
  set.gyro_min = -30.0f;
  set.gyro_max = 30.0f;
  RestMonitor<float> m(set);
  NoisySource src;
  RestSummary<float> r;
  // 4 s still with a 400 deg C reading in it: one rest at 25 deg C.
  for (int k = 0; k < 400; ++k) {
    ImuSample<float> s = src.next();
    if (k == 200) s.temperature = 400.0f;
    EXPECT_EQ(m.add(s), k == 200 ? Status::kTemperatureImplausible : Status::kOk) << k;
  }
  // A gyro at full scale ends it there.
  ImuSample<float> s = src.next();
  s.gyro(1) = 40.0f;
  EXPECT_EQ(m.add(s), Status::kGyroSaturated);
  ASSERT_TRUE(m.take(r));
  EXPECT_NEAR(static_cast<double>(r.temperature_c), 25.0, 1e-5);
  EXPECT_GT(r.duration_s, 3.5f);
  // The clock goes back by ten minutes and stays back: after clock_reset_samples it is a reset
  // and the stream goes on.
  src.t_us -= 600u * 1000000u;
  int resets = 0, refused = 0;
  for (int k = 0; k < 400; ++k) {
    const Status st = m.add(src.next());
    if (st == Status::kClockReset) ++resets;
    if (st == Status::kTimeBackwards) ++refused;
  }
  EXPECT_EQ(resets, 1);
  EXPECT_EQ(refused, 2);
  m.finish();
  ASSERT_TRUE(m.take(r));  // the rest after the reset
  EXPECT_GT(r.duration_s, 3.5f);
  // A frozen sensor: refused after frozen_seconds; what it sat in is not a rest.
  const ImuSample<float> same = src.next();
  int frozen = 0;
  for (int k = 0; k < 400; ++k) {
    s = same;
    s.t_us = same.t_us + 10000u * static_cast<std::uint32_t>(k);
    if (m.add(s) == Status::kSensorFrozen) ++frozen;
  }
  src.t_us = s.t_us;
  EXPECT_GE(frozen, 340);
  m.finish();
  EXPECT_FALSE(m.take(r));
  EXPECT_EQ(m.stream_counts().frozen, static_cast<std::uint32_t>(frozen));
  EXPECT_EQ(m.stream_counts().gyro_saturated, 1u);
  EXPECT_EQ(m.stream_counts().clock_resets, 1u);
  EXPECT_EQ(m.stream_counts().temperature_bad, 1u);
}

}  // namespace
}  // namespace imucal
