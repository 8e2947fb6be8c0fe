// SPDX-License-Identifier: MIT
// Bad sensors and bad streams, each with its status and its count, and a calibration afterwards
// within 3 sigma of the truth (what was collected before the fault is kept); then the long run:
// a 24-hour rest at 1 kHz whose pose mean stays exact in float.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <vector>

#include "imucal/calibrator/calibrator.hpp"
#include "support/calibrator_sim.hpp"
#include "support/gtest_status.hpp"
#include "support/sanitizers.hpp"

namespace imucal {
namespace {

using namespace test;  // NOLINT: the simulation helpers

// Raw 16-bit counts: the full scale is the ADC's range.
CalibratorSettings<float> settings(const SimRun& r) {
  CalibratorSettings<float> s = settings_for<float>(r.sc, false);
  s.accel_min = s.gyro_min = 0.0f;
  s.accel_max = s.gyro_max = 65535.0f;
  s.nominal_rate_hz = static_cast<float>(r.sc.plan.rate_hz);
  return s;
}

struct Outcome {
  std::vector<Status> statuses;  // what add() returned, one per sample offered
  Progress before_solve{};
  Status solved = Status::kNotStarted;
};

// Streams the recording; `edit` may change sample i (returning false drops it) and may offer
// extra samples first through `extra`.
using Edit =
    std::function<bool(std::size_t i, ImuSample<float>& s, std::vector<ImuSample<float>>& extra)>;
Outcome run(Calibrator<float>& cal, const SimRun& r, const Edit& edit) {
  Outcome o;
  cal.reset(settings(r));
  std::vector<ImuSample<float>> extra;
  for (std::size_t i = 0; i < r.rec.samples.size(); ++i) {
    ImuSample<float> s = to_sample<float>(r.rec.samples[i]);
    extra.clear();
    const bool keep = edit(i, s, extra);
    for (const auto& e : extra) o.statuses.push_back(cal.add(e));
    if (keep) o.statuses.push_back(cal.add(s));
  }
  o.before_solve = cal.progress();
  o.solved = cal.solve_all();
  return o;
}

// The calibrator is static: two of them (32 KB each) would not fit the boards' test stack.
Calibrator<float>& calibrator() {
  static Calibrator<float> cal;
  return cal;
}

// A normal calibration afterwards: both sensors within 3 sigma of the truth.
void expect_calibrated(const Outcome& o, const SimRun& r) {
  ASSERT_TRUE(succeeded(o.solved)) << to_string(o.solved);
  expect_within_3_sigma(calibrator().calibration(), r.rec);
}

class StreamFaults : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    run_ = new SimRun(make_run(42));
    clean_ = new Outcome(
        run(calibrator(), *run_,
            [](std::size_t, ImuSample<float>&, std::vector<ImuSample<float>>&) { return true; }));
  }
  static void TearDownTestSuite() {
    delete run_;
    delete clean_;
  }
  static const SimRun& r() { return *run_; }
  static const Outcome& clean() { return *clean_; }
  static std::size_t mid_move(std::size_t k) { return at_time(r().rec, move_middle(r().rec, k)); }
  // The longest rest after the initial one (rests last 3-6 s): split in two, each half is
  // still a pose; 4 s of it fit a rate fault.
  static std::size_t longest_rest() {
    std::size_t best = 1;
    const auto& rests = r().rec.rests;
    for (std::size_t k = 1; k + 1 < rests.size(); ++k)
      if (rests[k].end - rests[k].begin > rests[best].end - rests[best].begin) best = k;
    return best;
  }
  static std::size_t mid_rest(std::size_t k) {
    const sim::StillInterval& rest = r().rec.rests[k];
    return (rest.begin + rest.end) / 2;
  }

  static SimRun* run_;
  static Outcome* clean_;
};
SimRun* StreamFaults::run_ = nullptr;
Outcome* StreamFaults::clean_ = nullptr;

TEST_F(StreamFaults, CleanStreamHasNoCounts) {
  EXPECT_EQ(count(clean().statuses, Status::kOk), static_cast<int>(clean().statuses.size()));
  const StreamCounts& c = clean().before_solve.stream;
  EXPECT_EQ(c.non_finite + c.accel_saturated + c.gyro_saturated + c.frozen + c.time_repeated +
                c.time_backwards + c.clock_resets + c.gaps + c.rate_off + c.glitches +
                c.temperature_bad,
            0u);
  ASSERT_TRUE(succeeded(clean().solved));
}

TEST_F(StreamFaults, NonFiniteReadingsAreRefusedAndCounted) {
  const std::size_t a = mid_move(3), b = mid_rest(6);
  const Outcome o = run(calibrator(), r(), [&](std::size_t i, ImuSample<float>& s, auto& extra) {
    if (i == a || i == b) {
      ImuSample<float> bad = s;
      bad.t_us -= 100;  // between two samples
      bad.acc(i == a ? 0 : 2) = std::numeric_limits<float>::quiet_NaN();
      extra.push_back(bad);
      bad.acc = s.acc;
      bad.gyro(1) = -std::numeric_limits<float>::infinity();
      extra.push_back(bad);
    }
    return true;
  });
  EXPECT_EQ(count(o.statuses, Status::kNonFiniteInput), 4);
  EXPECT_EQ(o.before_solve.stream.non_finite, 4u);
  EXPECT_EQ(o.before_solve.samples_refused, 4u);
  // Refused outright: the rest of the stream is exactly the clean one.
  EXPECT_EQ(o.before_solve.poses, clean().before_solve.poses);
  EXPECT_EQ(o.before_solve.moves, clean().before_solve.moves);
  expect_calibrated(o, r());
}

// A temperature of +-Inf or an absurd finite value is ignored (the sample is taken) and
// counted; the calibration's mean temperature is that of the good readings.
TEST_F(StreamFaults, ImplausibleTemperaturesAreIgnoredAndCounted) {
  const std::size_t a = mid_rest(2), b = mid_move(4), c = mid_rest(5);
  const Outcome o = run(calibrator(), r(), [&](std::size_t i, ImuSample<float>& s, auto&) {
    s.temperature = 25.0f;
    if (i == a) s.temperature = std::numeric_limits<float>::infinity();
    if (i == b) s.temperature = -std::numeric_limits<float>::infinity();
    if (i == c) s.temperature = 1e30f;
    return true;
  });
  EXPECT_EQ(count(o.statuses, Status::kTemperatureImplausible), 3);
  EXPECT_EQ(o.before_solve.stream.temperature_bad, 3u);
  EXPECT_EQ(o.before_solve.samples_refused, 0u);
  EXPECT_EQ(o.before_solve.poses, clean().before_solve.poses);
  expect_calibrated(o, r());
  ASSERT_TRUE(calibrator().calibration().has_temperature);
  EXPECT_EQ(calibrator().calibration().temperature_c, 25.0f);
}

// A single absurd accelerometer reading (1e12, inside the default full scale of +-1e15) in the
// first rest after the initial-rest window and one in a move: refused and counted, nothing else
// changes.
TEST_F(StreamFaults, AGlitchIsRefusedAndCounted) {
  const std::size_t a = at_time(r().rec, 0.75 * r().rec.samples[r().rec.rests[0].end - 1].t);
  const std::size_t b = mid_move(3);
  Calibrator<float>& cal = calibrator();
  CalibratorSettings<float> s = settings(r());
  s.accel_min = -1e15f;  // the defaults: only readings too large for the float sums
  s.accel_max = 1e15f;
  auto stream_with = [&](bool glitches) {
    cal.reset(s);
    std::vector<Status> statuses;
    for (std::size_t i = 0; i < r().rec.samples.size(); ++i) {
      const ImuSample<float> x = to_sample<float>(r().rec.samples[i]);
      if (glitches && (i == a || i == b)) {
        ImuSample<float> bad = x;
        bad.t_us -= 100;  // between two samples
        bad.acc(1) = 1e12f;
        statuses.push_back(cal.add(bad));
      }
      statuses.push_back(cal.add(x));
    }
    return statuses;
  };
  stream_with(false);
  const Progress clean_progress = cal.progress();
  ASSERT_TRUE(succeeded(cal.solve_all()));
  const AccelVector<float> clean_params = cal.calibration().accel.params;
  const std::vector<Status> st = stream_with(true);
  const Progress p = cal.progress();
  EXPECT_EQ(count(st, Status::kGlitch), 2);
  EXPECT_EQ(p.stream.glitches, 2u);
  EXPECT_EQ(p.samples_refused, 2u);
  EXPECT_EQ(p.poses, clean_progress.poses);
  EXPECT_EQ(p.moves, clean_progress.moves);
  ASSERT_TRUE(succeeded(cal.solve_all()));
  expect_within_3_sigma(cal.calibration(), r().rec);
  // Pose 0 is the clean one: the glitch never entered its mean.
  const Calibration<float>& got = cal.calibration();
  for (int k = 0; k < kAccelParams; ++k)
    EXPECT_LT(std::abs(got.accel.params(k) - clean_params(k)), 0.01f * got.accel.sigma(k)) << k;
}

// Glitches during the initial rest (the window's noise as the reference): refused and counted,
// the window and everything after it exactly as without them.
TEST_F(StreamFaults, AGlitchInTheInitialRestIsRefusedAndCounted) {
  Calibrator<float>& cal = calibrator();
  CalibratorSettings<float> s = settings(r());
  s.accel_min = -1e15f;  // the defaults: only readings too large for the float sums
  s.accel_max = 1e15f;
  const double window = static_cast<double>(s.initial_rest_seconds);
  const double t0 = r().rec.samples[0].t;
  std::vector<std::size_t> at;
  for (const double f : {0.1, 0.3, 0.6, 0.95}) at.push_back(at_time(r().rec, t0 + f * window));
  auto stream_with = [&](bool glitches, Vector3<float>& bias0, Vector3<float>& noise0) {
    cal.reset(s);
    std::vector<Status> statuses;
    bool found = false;
    for (std::size_t i = 0; i < r().rec.samples.size(); ++i) {
      const ImuSample<float> x = to_sample<float>(r().rec.samples[i]);
      if (glitches && std::find(at.begin(), at.end(), i) != at.end()) {
        EXPECT_EQ(cal.progress().phase, Phase::kInitialRest) << i;
        ImuSample<float> bad = x;
        bad.t_us -= 100;  // between two samples
        bad.acc(static_cast<Eigen::Index>(i % 3)) = (i % 2 ? -1.0f : 1.0f) * 1e12f;
        statuses.push_back(cal.add(bad));
      }
      statuses.push_back(cal.add(x));
      if (!found && cal.progress().phase != Phase::kInitialRest) {
        found = true;
        bias0 = cal.gyro_bias0();
        noise0 = cal.accel_noise_variance();
      }
    }
    return statuses;
  };
  Vector3<float> clean_bias, clean_noise, bias, noise;
  stream_with(false, clean_bias, clean_noise);
  const Progress clean_progress = cal.progress();
  const std::vector<Status> st = stream_with(true, bias, noise);
  const Progress p = cal.progress();
  EXPECT_EQ(count(st, Status::kGlitch), 4);
  EXPECT_EQ(p.stream.glitches, 4u);
  EXPECT_EQ(p.samples_refused, 4u);
  // The window held the same samples: the same bias and noise, bit for bit.
  EXPECT_EQ(bias, clean_bias);
  EXPECT_EQ(noise, clean_noise);
  EXPECT_EQ(p.poses, clean_progress.poses);
  EXPECT_EQ(p.moves, clean_progress.moves);
  ASSERT_TRUE(succeeded(cal.solve_all()));
  expect_within_3_sigma(cal.calibration(), r().rec);
}

TEST_F(StreamFaults, GyroSaturationDropsOnlyThatMove) {
  const std::size_t a = mid_move(5);
  const Outcome o = run(calibrator(), r(), [&](std::size_t i, ImuSample<float>& s, auto&) {
    if (i >= a && i < a + 5) s.gyro(2) = 65535.0f;  // clipped for 50 ms of a fast turn
    return true;
  });
  EXPECT_EQ(count(o.statuses, Status::kGyroSaturated), 5);
  EXPECT_EQ(o.before_solve.stream.gyro_saturated, 5u);
  EXPECT_EQ(o.before_solve.samples_refused, 5u);
  EXPECT_EQ(o.before_solve.moves_dropped, 1);
  EXPECT_EQ(o.before_solve.poses, clean().before_solve.poses);  // every rest is still a pose
  EXPECT_EQ(o.before_solve.moves, clean().before_solve.moves - 1);
  expect_calibrated(o, r());
}

TEST_F(StreamFaults, AccelSaturationCountsAsMotion) {
  // In a move: taken (the gyro is fine), the move is kept.
  const std::size_t a = mid_move(2);
  // In a rest: those samples cannot be at rest: the rest is split around them.
  const std::size_t b = mid_rest(longest_rest());
  const Outcome o = run(calibrator(), r(), [&](std::size_t i, ImuSample<float>& s, auto&) {
    if (i >= a && i < a + 4) s.acc(0) = 0.0f;
    if (i == b) s.acc(1) = 65535.0f;
    return true;
  });
  EXPECT_EQ(count(o.statuses, Status::kAccelSaturated), 5);
  EXPECT_EQ(o.before_solve.stream.accel_saturated, 5u);
  EXPECT_EQ(o.before_solve.samples_refused, 0u);
  EXPECT_EQ(o.before_solve.moves_dropped, 0);
  // The split rest gives two poses (its halves last 2-3 s) joined by a short "move".
  EXPECT_EQ(o.before_solve.poses, clean().before_solve.poses + 1);
  EXPECT_EQ(o.before_solve.moves, clean().before_solve.moves + 1);
  expect_calibrated(o, r());
}

TEST_F(StreamFaults, FrozenSensorIsCounted) {
  const std::size_t a = mid_rest(4);
  std::size_t frozen_samples = 0;
  Vector3<float> held = Vector3<float>::Zero();
  const Outcome o = run(calibrator(), r(), [&](std::size_t i, ImuSample<float>& s, auto&) {
    if (i == a) held = s.gyro;
    if (i >= a && i < a + 150) {  // the gyro repeats one reading for 1.5 s
      s.gyro = held;
      ++frozen_samples;
    }
    return true;
  });
  // Identical for frozen_seconds (0.5 s) before it counts: the samples after that are refused.
  const int refused = count(o.statuses, Status::kSensorFrozen);
  EXPECT_NEAR(refused, 100, 3);
  EXPECT_EQ(o.before_solve.stream.frozen, static_cast<std::uint32_t>(refused));
  expect_calibrated(o, r());
}

TEST_F(StreamFaults, RepeatedAndStrayBackwardTimestampsAreRefused) {
  const std::size_t a = mid_move(1), b = mid_rest(3);
  const Outcome o = run(calibrator(), r(), [&](std::size_t i, ImuSample<float>& s, auto& extra) {
    if (i == a + 1) {
      ImuSample<float> again = s;
      again.t_us = to_sample<float>(r().rec.samples[i - 1]).t_us;
      extra.push_back(again);  // the previous sample's timestamp, repeated
    }
    if (i == b || i == b + 10) {
      ImuSample<float> stray = s;
      stray.t_us -= 2000000;  // one bad timestamp, 2 s back
      extra.push_back(stray);
    }
    return true;
  });
  EXPECT_EQ(count(o.statuses, Status::kTimeRepeated), 1);
  EXPECT_EQ(count(o.statuses, Status::kTimeBackwards), 2);
  EXPECT_EQ(o.before_solve.stream.time_repeated, 1u);
  EXPECT_EQ(o.before_solve.stream.time_backwards, 2u);
  EXPECT_EQ(o.before_solve.stream.clock_resets, 0u);  // two strays apart are not a reset
  EXPECT_EQ(o.before_solve.poses, clean().before_solve.poses);
  EXPECT_EQ(o.before_solve.moves, clean().before_solve.moves);
  expect_calibrated(o, r());
}

TEST_F(StreamFaults, ClockResetResynchronisesAsAGap) {
  // Mid-move the clock jumps back 30 s and stays there (a timer restarted).
  const std::size_t a = mid_move(4);
  const Outcome o = run(calibrator(), r(), [&](std::size_t i, ImuSample<float>& s, auto&) {
    if (i >= a) s.t_us -= 30000000u;
    return true;
  });
  // The first samples behind the clock are refused until three came in order: then it resets.
  EXPECT_EQ(count(o.statuses, Status::kTimeBackwards), 2);
  EXPECT_EQ(count(o.statuses, Status::kClockReset), 1);
  EXPECT_EQ(o.before_solve.stream.time_backwards, 2u);
  EXPECT_EQ(o.before_solve.stream.clock_resets, 1u);
  EXPECT_EQ(o.before_solve.moves_dropped, 1);  // the move across the reset
  EXPECT_EQ(o.before_solve.poses, clean().before_solve.poses);
  expect_calibrated(o, r());
}

TEST_F(StreamFaults, TimestampJumpIsAGap) {
  const std::size_t a = mid_move(6);
  const Outcome o = run(calibrator(), r(), [&](std::size_t i, ImuSample<float>& s, auto&) {
    if (i >= a) s.t_us += 3000000u;  // 3 s missing
    return true;
  });
  EXPECT_EQ(count(o.statuses, Status::kTimestampGap), 1);
  EXPECT_EQ(o.before_solve.stream.gaps, 1u);
  EXPECT_EQ(o.before_solve.moves_dropped, 1);
  EXPECT_EQ(o.before_solve.poses, clean().before_solve.poses);
  expect_calibrated(o, r());
}

TEST_F(StreamFaults, SampleRateFarFromNominalIsReported) {
  // For 4 s inside a long rest every other sample is lost (50 Hz instead of 100): the steps stay
  // below the gap limit, the rest stays a pose, and the windows that saw it are counted.
  const std::size_t a = r().rec.rests[longest_rest()].begin + 50;
  const Outcome o = run(calibrator(), r(), [&](std::size_t i, ImuSample<float>&, auto&) {
    return !(i >= a && i < a + 400 && (i - a) % 2 == 1);
  });
  const int off = count(o.statuses, Status::kSampleRateOff);
  EXPECT_GE(off, 3);
  EXPECT_LE(off, 5);
  EXPECT_EQ(o.before_solve.stream.rate_off, static_cast<std::uint32_t>(off));
  EXPECT_EQ(o.before_solve.stream.gaps, 0u);
  EXPECT_EQ(o.before_solve.poses, clean().before_solve.poses);
  expect_calibrated(o, r());
  // A sensor configured for another rate: every second is off.
  CalibratorSettings<float> s = settings(r());
  s.nominal_rate_hz = 200.0f;
  Calibrator<float>& cal = calibrator();
  cal.reset(s);
  std::uint32_t seconds = 0;
  for (const auto& m : r().rec.samples) cal.add(to_sample<float>(m));
  seconds = static_cast<std::uint32_t>(r().rec.samples.back().t);
  EXPECT_NEAR(static_cast<double>(cal.progress().stream.rate_off), seconds, 2.0);
}

TEST_F(StreamFaults, FaultsDuringTheInitialRestRestartIt) {
  // A saturated accelerometer and a gyro at full scale early in the initial rest: it restarts
  // (kAccelSaturated, kGyroSaturated), the calibration still succeeds from the samples after.
  const Outcome o = run(calibrator(), r(), [&](std::size_t i, ImuSample<float>& s, auto&) {
    if (i == 100) s.acc(2) = 65535.0f;
    if (i == 200) s.gyro(0) = 0.0f;
    return true;
  });
  EXPECT_EQ(count(o.statuses, Status::kAccelSaturated), 1);
  EXPECT_EQ(count(o.statuses, Status::kGyroSaturated), 1);
  EXPECT_EQ(o.before_solve.stream.accel_saturated, 1u);
  EXPECT_EQ(o.before_solve.stream.gyro_saturated, 1u);
  expect_calibrated(o, r());
}

// ---- Long runs --------------------------------------------------------------------------------

// 24 hours at 1 kHz on the host (86.4 M samples); 75 minutes on the boards, Arm and RV32 (QEMU
// runs them at a few hundred million instructions a second), still across a wrap of the 32-bit
// microsecond clock (71.6 min).
#if defined(IMUCAL_TEST_ASAN)
// The sanitizer run (preset host-asan) looks for memory errors, not drift: the same code paths
// over 1.25 hours, still across the clock's wrap (the plain host run does the 24, which take
// 150-160 s under ASan).
constexpr double kLongHours = 1.25;
constexpr bool kWithDouble = true;
#elif defined(IMUCAL_SMALL_TARGET)
constexpr double kLongHours = 1.25;
constexpr bool kWithDouble = false;  // soft-float double on the boards: the exact mean is enough
#else
constexpr double kLongHours = 24.0;
constexpr bool kWithDouble = true;
#endif

// Cheap deterministic integer noise (xorshift32; the boards have no double FPU, so the
// generator stays in integers on the per-sample path): a sum of four uniform bytes, centred and
// scaled, near-Gaussian with a standard deviation of about 147.8 / divisor counts.
struct Noise {
  std::uint32_t x = 2463534242u;
  std::uint32_t next() {
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    return x;
  }
  int counts(int divisor) {
    const std::uint32_t r = next();
    const int sum =
        static_cast<int>((r & 0xFFu) + ((r >> 8) & 0xFFu) + ((r >> 16) & 0xFFu) + (r >> 24));
    return (sum - 510) / divisor;
  }
};

// The stream: raw counts (415 LSB per m/s^2, zero at 32768), 10 s initial rest with z up, a
// 1 s quarter turn about x, the long rest with y up, a turn back, 3 s of rest; noise about 5
// counts (accelerometer) and 3 (gyro). Integer counts: the exact pose mean is an integer sum.
struct LongStream {
  static constexpr int kG = 4071;           // 9.81 m/s^2 in counts
  static constexpr int kTurnCounts = 7492;  // pi/2 rad/s at 4770 counts per rad/s
  std::uint64_t n_long = 0, k = 0;
  std::uint64_t phase_end[5] = {};
  Noise noise;
  float temperature = 25.0f;
  explicit LongStream(double hours) {
    n_long = static_cast<std::uint64_t>(hours * 3600.0 * 1000.0);
    const std::uint64_t lengths[5] = {10000, 1000, n_long, 1000, 3000};
    std::uint64_t end = 0;
    for (int i = 0; i < 5; ++i) phase_end[i] = end += lengths[i];
  }
  bool next(ImuSample<float>& s, int& phase) {
    if (k >= phase_end[4]) return false;
    phase = 0;
    while (k >= phase_end[phase]) ++phase;
    // Timestamps: 1 ms with a jitter of -30..+30 us; the clock wraps every 71.6 min.
    s.t_us = static_cast<std::uint32_t>(k * 1000u + noise.next() % 61u - 30u);
    int gy = 0, gz = kG, rate = 0;  // gravity in the sensor frame; rate about x
    if (phase == 1 || phase == 3) {
      // The turns (2000 samples in all): the only place for trigonometry.
      const double done = static_cast<double>(k - phase_end[phase - 1]) * 1e-3;  // 0..1 s
      const double angle = 1.5707963 * (phase == 1 ? done : 1.0 - done);
      gy = static_cast<int>(std::lround(kG * std::sin(angle)));
      gz = static_cast<int>(std::lround(kG * std::cos(angle)));
      rate = phase == 1 ? kTurnCounts : -kTurnCounts;
    } else if (phase == 2) {
      gy = kG;
      gz = 0;
    }
    s.acc = Vector3<float>(static_cast<float>(32768 + noise.counts(30)),
                           static_cast<float>(32768 + gy + noise.counts(30)),
                           static_cast<float>(32768 + gz + noise.counts(30)));
    s.gyro = Vector3<float>(static_cast<float>(32768 + 40 + rate + noise.counts(50)),
                            static_cast<float>(32768 - 25 + noise.counts(50)),
                            static_cast<float>(32768 + 10 + noise.counts(50)));
    // Temperature: 25 C +-5 C over a day (the day's sine, updated each second), 0.05 C noise.
    if (k % 1000 == 0)
      temperature = static_cast<float>(25.0 + 5.0 * std::sin(static_cast<double>(k) * 7.27e-8));
    s.temperature = temperature + 0.0003f * static_cast<float>(noise.counts(1));
    ++k;
    return true;
  }
};

TEST(LongRun, ADayOfRestKeepsItsMeanExactInFloat) {
  static Calibrator<float> f;
  static Calibrator<double> d;
  CalibratorSettings<float> sf;
  sf.gyro.nominal_scale = 1.0f / 4770.0f;
  sf.accel_min = sf.gyro_min = 0.0f;
  sf.accel_max = sf.gyro_max = 65535.0f;
  sf.nominal_rate_hz = 1000.0f;
  f.reset(sf);
  CalibratorSettings<double> sd;
  sd.gyro.nominal_scale = 1.0 / 4770.0;
  sd.nominal_rate_hz = 1000.0;
  if (kWithDouble) d.reset(sd);
  LongStream in(kLongHours);
  ImuSample<float> s;
  int phase = 0;
  // The exact sums of the long rest's samples (integers) and of all temperatures (double).
  std::int64_t exact[3] = {0, 0, 0};
  double temp_sum = 0.0;
  std::uint64_t samples = 0, not_ok = 0;
  // Why the accumulation is re-centred and compensated: the long rest summed plainly in float,
  // in 0.1 s blocks relative to the initial rest's first reading (as it was before), for
  // comparison: it must be off by far more than the tolerance below, or this test proves little.
  float plain_sum = 0.0f, plain_block = 0.0f, plain_ref = 0.0f;
  int plain_n = 0;
  while (in.next(s, phase)) {
    if (samples == 0) plain_ref = s.acc(1);
    not_ok += f.add(s) != Status::kOk;
    if (kWithDouble) {
      ImuSample<double> sdbl;
      sdbl.t_us = s.t_us;
      sdbl.acc = s.acc.cast<double>();
      sdbl.gyro = s.gyro.cast<double>();
      sdbl.temperature = static_cast<double>(s.temperature);
      d.add(sdbl);
    }
    temp_sum += static_cast<double>(s.temperature);
    ++samples;
    if (phase != 2) continue;
    for (int i = 0; i < 3; ++i) exact[i] += static_cast<std::int64_t>(s.acc(i));
    plain_block += s.acc(1) - plain_ref;
    if (++plain_n % 100 == 0) {
      plain_sum += plain_block;
      plain_block = 0.0f;
    }
  }
  plain_sum += plain_block;
  EXPECT_EQ(not_ok, 0u);
  EXPECT_EQ(f.progress().stream.rate_off, 0u);
  // The long rest is pose 1 (pose 0 the initial rest), trimmed at both ends by at most the
  // detector's delay: compare with the exact mean of the samples it holds.
  ASSERT_GE(f.poses().size, 2);
  const Pose<float>& p = f.poses()[1];
  const std::uint64_t n = p.samples;
  EXPECT_GT(n, in.n_long - 2000);
  EXPECT_LE(n, in.n_long);
  // The pose holds n of the n_long samples; the missing ones (at most 2000 at its ends) move
  // the mean by at most 2000 x (the noise range, 30 counts) / n: below 1e-3 counts for hours.
  const double bound_trim = 2000.0 * 30.0 / static_cast<double>(n);
  for (int i = 0; i < 3; ++i) {
    const double truth = static_cast<double>(exact[i]) / static_cast<double>(in.n_long);
    const double got = static_cast<double>(p.mean(i));
    // One float ulp at 36,000 counts is 0.0039: the float mean is within an ulp of the exact
    // one (plus the trim's share). A plain float sum would be off by counts (test below).
    const double ulp = static_cast<double>(std::nextafter(p.mean(i), 1e9f) - p.mean(i));
    EXPECT_LE(std::abs(got - truth), ulp + bound_trim) << "axis " << i;
    if (kWithDouble) {
      const Pose<double>& q = d.poses()[1];
      EXPECT_EQ(q.samples, p.samples);
      EXPECT_LE(std::abs(got - q.mean(i)), ulp) << "axis " << i;
    }
  }
  // The temperature mean (all samples), float against double.
  float t_mean = 0.0f;
  ASSERT_TRUE(f.mean_temperature(t_mean));
  EXPECT_NEAR(static_cast<double>(t_mean), temp_sum / static_cast<double>(samples), 1e-4);
  const double n_long = static_cast<double>(in.n_long);
  const double plain_error = static_cast<double>(plain_ref) +
                             static_cast<double>(plain_sum) / n_long -
                             static_cast<double>(exact[1]) / n_long;
  std::printf("a plain float sum would be off by %.3f counts\n", plain_error);
  EXPECT_GT(std::abs(plain_error), 0.05);  // more than 10 float ulps of the mean
  std::printf("%.0f h at 1 kHz: pose of %llu samples, mean error %.2e / %.2e / %.2e counts\n",
              kLongHours, static_cast<unsigned long long>(n),
              static_cast<double>(p.mean(0)) - static_cast<double>(exact[0]) / n_long,
              static_cast<double>(p.mean(1)) - static_cast<double>(exact[1]) / n_long,
              static_cast<double>(p.mean(2)) - static_cast<double>(exact[2]) / n_long);
}

}  // namespace
}  // namespace imucal
