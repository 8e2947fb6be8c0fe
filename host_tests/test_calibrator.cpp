// SPDX-License-Identifier: MIT
// The streaming calibrator on simulated full-motion recordings with known truth (rests, hand
// turns about changing axes with coning, noise, bias, sample-rate jitter): both calibrations
// within 3 sigma, float and double; the stream's bad cases each with their status.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "imucal/calibrator/calibrator.hpp"
#include "imucal/sim/motion_sim.hpp"
#include "support/calibrator_sim.hpp"
#include "support/gtest_status.hpp"

namespace imucal {
namespace {

using namespace test;  // NOLINT: the simulation helpers

template <typename Scalar>
void full_motion(bool refine_bias, std::uint64_t seed) {
  Scenario sc;
  sc.plan.initial_rest_s = 1.5 * kInitialRest;
  sc.plan.poses = kPoses + 6;
  sc.plan.record_attitude = false;
  sim::Random rng(seed);
  const sim::Recording rec = sim::simulate_motion(sc.plan, sc.acc, sc.gyro, rng);
  Calibrator<Scalar> cal(settings_for<Scalar>(sc, refine_bias));
  EXPECT_EQ(count(stream<Scalar>(cal, rec.samples), Status::kOk),
            static_cast<int>(rec.samples.size()));
  const Progress before = cal.progress();
  // The last rest becomes a pose when the stream ends (no motion came to end it).
  EXPECT_EQ(before.poses, static_cast<int>(rec.rests.size()) - 1);
  EXPECT_EQ(before.phase, Phase::kReady);
  EXPECT_EQ(before.hint, Hint::kSolve);
  EXPECT_EQ(cal.solve_all(), cal.calibration().gyro.status);
  const Progress p = cal.progress();
  EXPECT_EQ(p.poses, static_cast<int>(rec.rests.size()));
  EXPECT_EQ(p.moves, p.poses - 1);
  EXPECT_EQ(p.rests_too_short, 0);
  EXPECT_EQ(p.moves_dropped, 0);
  EXPECT_EQ(p.faces_covered, 6);
  EXPECT_EQ(p.axes_turned, 0x7);
  EXPECT_EQ(p.phase, Phase::kDone);
  // Each pose lies inside its true rest (the detector trims, it never reaches into motion), but
  // for a move's last or first sample whose true rate is below the gyro's own noise.
  const double noise_rate = sc.gyro.noise * sc.gyro.nominal_scale;
  for (int k = 0; k < p.poses; ++k) {
    const double begin = cal.pose_begin_us(k) * 1e-6, end = cal.pose_end_us(k) * 1e-6;
    const auto& r = rec.rests[static_cast<std::size_t>(k)];
    for (std::size_t i = r.begin > 0 ? r.begin - 1 : 0; i <= r.end && i < rec.samples.size(); ++i)
      if (!rec.samples[i].still && rec.samples[i].t >= begin - 1e-6 &&
          rec.samples[i].t <= end + 1e-6) {
        EXPECT_LE(rec.samples[i].rate.norm(), noise_rate) << k;
      }
    EXPECT_GE(begin, rec.samples[r.begin].t - 0.05) << k;
    EXPECT_LE(end, rec.samples[r.end - 1].t + 0.05) << k;
  }
  const Calibration<Scalar>& c = cal.calibration();
  ASSERT_TRUE(succeeded(c.accel.status)) << to_string(c.accel.status);
  ASSERT_TRUE(succeeded(c.gyro.status)) << to_string(c.gyro.status);
  double worst = 0.0;
  expect_within_3_sigma(c, rec, &worst);
  std::printf(
      "seed %llu: %d poses, %d moves, %d segments, worst |error|/sigma %.2f, gyro rms %.3f deg, "
      "quality %d\n",
      static_cast<unsigned long long>(seed), p.poses, p.moves, p.segments, worst,
      static_cast<double>(c.gyro.residual_rms) * 57.29578, static_cast<int>(c.quality));
  EXPECT_EQ(c.quality, Quality::kGood);
}

TEST(Calibrator, FullMotionWithin3SigmaDouble) {
  for (std::uint64_t seed : {1u, 2u, 3u}) full_motion<double>(false, seed);
}
TEST(Calibrator, FullMotionWithin3SigmaFloat) {
  for (std::uint64_t seed : {1u, 2u, 3u}) full_motion<float>(false, seed);
}
// No gyro scale given, raw counts: segments start as if for rad/s (one per sample, 4770 times
// too fine), the store coarsens until they fit, and the scale is found by the 1-D search. Four
// recordings: every parameter within 4 sigma, and the RMS of error/sigma over all 84 within
// [0.7, 1.3] (a single recording's 21 fall beyond 3 sigma twice in a while by chance alone).
TEST(Calibrator, FullMotionWithoutANominalGyroScale) {
  double sum_z2 = 0.0;
  int values = 0;
  for (std::uint64_t seed : {7u, 8u, 9u, 10u}) {
    Scenario sc;
    sc.plan.initial_rest_s = 1.5 * kInitialRest;
    sc.plan.poses = kPoses;
    sc.plan.record_attitude = false;
    sim::Random rng(seed);
    const sim::Recording rec = sim::simulate_motion(sc.plan, sc.acc, sc.gyro, rng);
    CalibratorSettings<float> settings = settings_for<float>(sc, false);
    settings.gyro.nominal_scale = 0.0f;
    static Calibrator<float> cal;
    cal.reset(settings);
    EXPECT_EQ(count(stream(cal, rec.samples), Status::kOk), static_cast<int>(rec.samples.size()));
    ASSERT_TRUE(succeeded(cal.solve_all())) << to_string(cal.calibration().gyro.status);
    const Progress p = cal.progress();
    EXPECT_GT(p.coarsenings, 3);
    EXPECT_EQ(p.moves, p.poses - 1);
    const Calibration<float>& c = cal.calibration();
    auto add = [&](double estimate, double truth, double sigma) {
      const double z = (estimate - truth) / sigma;
      EXPECT_LT(std::abs(z), 4.0) << "seed " << seed;
      sum_z2 += z * z;
      ++values;
    };
    for (int k = 0; k < kAccelParams; ++k)
      add(static_cast<double>(c.accel.params(k)), rec.acc.params(k),
          static_cast<double>(c.accel.sigma(k)));
    for (int k = 0; k < kGyroParams; ++k)
      add(static_cast<double>(c.gyro.params(k)), rec.gyro.params(k),
          static_cast<double>(c.gyro.sigma(k)));
    std::printf("no nominal scale, seed %llu: %d segments after %d coarsenings\n",
                static_cast<unsigned long long>(seed), p.segments, p.coarsenings);
  }
  const double rms = std::sqrt(sum_z2 / values);
  std::printf("RMS error/sigma over %d values: %.2f\n", values, rms);
  EXPECT_GT(rms, 0.7);
  EXPECT_LT(rms, 1.3);
}

TEST(Calibrator, FullMotionRefinedBiasFloat) {
  for (std::uint64_t seed : {4u, 5u}) full_motion<float>(true, seed);
}

// ---- The stream's bad cases: each with its status, nothing collected lost -----------------

TEST(CalibratorStream, BumpDuringARestGivesTwoPosesAndAShortMove) {
  SimRun r;
  r.sc.plan.record_attitude = false;
  r.sc.plan.initial_rest_s = kInitialRest;
  r.sc.plan.poses = kPoses;
  r.sc.plan.bump_rest = 6;
  r.sc.plan.rest_min_s = 4.0;
  sim::Random rng(21);
  r.rec = sim::simulate_motion(r.sc.plan, r.sc.acc, r.sc.gyro, rng);
  ASSERT_EQ(r.rec.rests.size(), kPoses + 2u);  // the bump splits rest 6 in two still parts
  Calibrator<float> cal(settings_for<float>(r.sc, false));
  const auto st = stream(cal, r.rec.samples);
  EXPECT_EQ(count(st, Status::kOk), static_cast<int>(st.size()));
  ASSERT_TRUE(succeeded(cal.solve_all()));
  const Progress p = cal.progress();
  EXPECT_EQ(p.poses, kPoses + 2);
  EXPECT_EQ(p.moves, kPoses + 1);  // the bump is a move of its own: a short, small residual
  expect_within_3_sigma(cal.calibration(), r.rec);
}

// Each pose is also handed out as a rest summary (last_rest(), for the temperature fit): the
// same accelerometer mean as the pose, the gyro mean within its noise of the true raw rate at
// rest (-b), and the pose window's mean temperature.
TEST(CalibratorStream, EveryPoseIsSummarisedAsARest) {
  SimRun r = make_run(23);
  Calibrator<float> cal(settings_for<float>(r.sc, false));
  auto temperature = [](double t) { return 20.0 + 0.05 * t; };  // a warming board, 3 degC/min
  int seen = 0, checked = 0;
  for (std::size_t i = 0; i < r.rec.samples.size(); ++i) {
    ImuSample<float> s = to_sample<float>(r.rec.samples[i]);
    s.temperature = static_cast<float>(temperature(r.rec.samples[i].t));
    ASSERT_EQ(cal.add(s), Status::kOk);
    const int poses = cal.progress().poses;
    if (poses == seen) continue;
    ASSERT_EQ(poses, seen + 1);
    seen = poses;
    const RestSummary<float>& rest = cal.last_rest();
    const int k = poses - 1;
    EXPECT_EQ(rest.accel_mean, cal.poses()[k].mean) << k;
    EXPECT_EQ(rest.samples, cal.poses()[k].samples) << k;
    const double t0 = cal.pose_begin_us(k) * 1e-6, t1 = cal.pose_end_us(k) * 1e-6;
    EXPECT_NEAR(rest.duration_s, t1 - t0, 0.02) << k;
    // The temperature rises linearly: the pose's mean is the one at its middle (within the
    // rate's jitter and float rounding of 20-30 degC readings).
    ASSERT_TRUE(rest.has_temperature) << k;
    EXPECT_NEAR(rest.temperature_c, temperature(0.5 * (t0 + t1)), 2e-3) << k;
    // Raw gyro at rest is -b plus white noise: 5 sigma of the mean of n samples.
    const double sigma_mean = r.sc.gyro.noise / std::sqrt(static_cast<double>(rest.samples));
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(rest.gyro_mean(a), -r.rec.gyro.params(kGyroBiasX + a), 5.0 * sigma_mean)
          << "pose " << k << " axis " << a;
    ++checked;
  }
  EXPECT_EQ(checked, kPoses);  // the last rest becomes a pose only when the stream ends
  // The initial rest's noise, for setting a RestMonitor's thresholds: the simulator's white
  // noise, within the scatter of a variance over the initial-rest window's samples (5 sigma).
  const double n0 =
      static_cast<double>(CalibratorSettings<float>{}.initial_rest_seconds) * r.sc.plan.rate_hz;
  for (int a = 0; a < 3; ++a) {
    const double v = r.sc.gyro.noise * r.sc.gyro.noise;
    EXPECT_NEAR(cal.gyro_noise_variance()(a), v, 5.0 * v * std::sqrt(2.0 / n0)) << a;
  }
}

// Rests shorter than min_rest_seconds are not poses: their samples join the move around them,
// which stays one valid move (the chain of residuals is unbroken).
TEST(CalibratorStream, RestsTooShortJoinTheMove) {
  SimRun r = make_run(22, kPoses + 8);
  CalibratorSettings<float> s = settings_for<float>(r.sc, false);
  s.min_rest_seconds = 3.6f;  // rests last 3-6 s: over a third are too short once trimmed
  Calibrator<float> cal(s);
  stream(cal, r.rec.samples);
  ASSERT_TRUE(succeeded(cal.solve_all()))
      << to_string(cal.calibration().accel.status) << " / "
      << to_string(cal.calibration().gyro.status) << " poses " << cal.progress().poses << " short "
      << cal.progress().rests_too_short;
  const Progress p = cal.progress();
  std::printf("%d poses, %d rests too short\n", p.poses, p.rests_too_short);
  EXPECT_GT(p.rests_too_short, 5);
  EXPECT_EQ(p.poses + p.rests_too_short, static_cast<int>(r.rec.rests.size()));
  EXPECT_EQ(p.moves, p.poses - 1);
  EXPECT_LE(p.moves_dropped, 1);  // the recording's last rest is too short too: ends in a move
  expect_within_3_sigma(cal.calibration(), r.rec);
}

// (The recordings are edited in place, not copied: the M33 board has 2 MB.)
TEST(CalibratorStream, RecordingEndingInMotionDropsOnlyTheLastMove) {
  SimRun r = make_run(23);
  r.rec.samples.resize(at_time(r.rec, move_middle(r.rec, kPoses - 1)));
  const std::vector<sim::MotionSample>& cut = r.rec.samples;
  Calibrator<float> cal(settings_for<float>(r.sc, false));
  stream(cal, cut);
  ASSERT_TRUE(succeeded(cal.solve_all()));
  const Progress p = cal.progress();
  EXPECT_EQ(p.last_event, Status::kEndedInMotion);
  EXPECT_EQ(p.poses, kPoses);  // rests 0 .. kPoses - 1
  EXPECT_EQ(p.moves, kPoses - 1);
  EXPECT_EQ(p.moves_dropped, 1);
  expect_within_3_sigma(cal.calibration(), r.rec);
}

TEST(CalibratorStream, TooFewPosesRefusesToSolveAndKeepsCollecting) {
  SimRun r = make_run(24, 14);
  // The first part: the initial rest and 7 more, cut in the middle of the next move.
  const std::size_t cut = at_time(r.rec, move_middle(r.rec, 7));
  Calibrator<float> cal(settings_for<float>(r.sc, false));
  for (std::size_t i = 0; i < cut; ++i) cal.add(to_sample<float>(r.rec.samples[i]));
  EXPECT_EQ(cal.solve(), Status::kTooFewPoses);
  const Progress p = cal.progress();
  EXPECT_EQ(p.phase, Phase::kCollecting);
  EXPECT_EQ(p.poses, 8);
  EXPECT_NE(p.hint, Hint::kSolve);
  // More turning makes it solvable: the stream simply continues, nothing was lost.
  for (std::size_t i = cut; i < r.rec.samples.size(); ++i)
    EXPECT_EQ(cal.add(to_sample<float>(r.rec.samples[i])), Status::kOk);
  EXPECT_TRUE(succeeded(cal.solve_all()));
  EXPECT_EQ(cal.progress().poses, 15);
  EXPECT_EQ(cal.progress().moves, 14);
}

// After a stream cut once (gap, frozen spell): every pose kept, the chain of moves broken once.
void expect_one_move_dropped(Calibrator<float>& cal, const sim::Recording& rec) {
  ASSERT_TRUE(succeeded(cal.solve_all()));
  const Progress p = cal.progress();
  EXPECT_EQ(p.poses, kPoses + 1);
  EXPECT_EQ(p.moves, kPoses - 1);
  EXPECT_EQ(p.moves_dropped, 1);
  expect_within_3_sigma(cal.calibration(), rec);
}

TEST(CalibratorStream, GapDuringAMoveDropsThatMoveOnly) {
  SimRun r = make_run(26);
  const std::size_t cut = at_time(r.rec, move_middle(r.rec, 6));
  std::vector<sim::MotionSample>& v = r.rec.samples;
  v.erase(v.begin() + static_cast<long>(cut), v.begin() + static_cast<long>(cut + 50));  // 0.5 s
  Calibrator<float> cal(settings_for<float>(r.sc, false));
  const auto st = stream(cal, v);
  EXPECT_EQ(count(st, Status::kTimestampGap), 1);
  expect_one_move_dropped(cal, r.rec);
}

TEST(CalibratorStream, FrozenSensorIsRefusedAndTheRestInProgressDiscarded) {
  SimRun r = make_run(27);
  std::vector<sim::MotionSample>& v = r.rec.samples;
  // Rest 8 freezes for a second, half a second after it began: identical readings, time
  // advancing.
  const std::size_t from = r.rec.rests[8].begin + 50;
  for (std::size_t i = from + 1; i < from + 100; ++i) {
    v[i].acc = v[from].acc;
    v[i].gyro = v[from].gyro;
  }
  Calibrator<float> cal(settings_for<float>(r.sc, false));
  int frozen = 0, ok = 0;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const Status st = cal.add(to_sample<float>(v[i]));
    frozen += st == Status::kSensorFrozen;
    ok += st == Status::kOk;
    if (i == from + 99) {
      EXPECT_EQ(cal.progress().last_event, Status::kSensorFrozen);
      EXPECT_EQ(cal.progress().hint, Hint::kCheckSensor);
    }
  }
  EXPECT_NE(cal.progress().hint, Hint::kCheckSensor);  // the sensor recovered
  EXPECT_GT(frozen, 40);                               // from frozen_seconds (0.5 s) on
  EXPECT_EQ(frozen + ok, static_cast<int>(v.size()));
  // The rest's part before the freeze is lost, the part after it is a pose that starts a new
  // chain: the move into rest 8 is dropped.
  expect_one_move_dropped(cal, r.rec);
}

// A full pose store keeps what it has, says so once, and is ready to solve; later rests are not
// stored (the chain of moves cannot skip a pose).
TEST(CalibratorStream, FullPoseStoreKeepsItsPosesAndIsReady) {
  SimRun r = make_run(31, 16);
  Calibrator<float, 12> cal(settings_for<float>(r.sc, false));
  int full = 0;
  for (const auto& m : r.rec.samples) {
    const Status st = cal.add(to_sample<float>(m));
    full += st == Status::kCapacityExceeded;
    EXPECT_TRUE(st == Status::kOk || st == Status::kCapacityExceeded);
  }
  EXPECT_EQ(full, 1);
  const Progress p = cal.progress();
  EXPECT_EQ(p.poses, 12);
  EXPECT_EQ(p.moves, 11);
  EXPECT_EQ(p.phase, Phase::kReady);
  EXPECT_EQ(p.hint, Hint::kSolve);
  EXPECT_EQ(p.last_event, Status::kCapacityExceeded);
  ASSERT_TRUE(succeeded(cal.solve_all())) << to_string(cal.calibration().gyro.status);
  EXPECT_EQ(cal.progress().poses, 12);
  for (int k = 0; k < 12; ++k)  // the first 12 rests, in order
    EXPECT_GE(cal.pose_begin_us(k) * 1e-6,
              r.rec.samples[r.rec.rests[static_cast<std::size_t>(k)].begin].t - 1e-6);
}

// reset() in the middle of a move, then a new recording: the same result as a new calibrator
// (no rate, flag or event of the old run carries over).
TEST(CalibratorStream, ResetMidMoveStartsClean) {
  // Static calibrators and one recording at a time: the M33 board has 2 MB and a 64 KB stack.
  static Calibrator<float> cal, fresh;
  {
    SimRun a = make_run(32);
    cal.reset(settings_for<float>(a.sc, false));
    const std::size_t cut = at_time(a.rec, move_middle(a.rec, 3));
    for (std::size_t i = 0; i < cut; ++i) cal.add(to_sample<float>(a.rec.samples[i]));
  }
  SimRun b = make_run(33);
  cal.reset(settings_for<float>(b.sc, false));
  fresh.reset(settings_for<float>(b.sc, false));
  for (const auto& m : b.rec.samples) {
    const ImuSample<float> s = to_sample<float>(m);
    ASSERT_EQ(cal.add(s), fresh.add(s));
  }
  ASSERT_TRUE(succeeded(cal.solve_all()));
  ASSERT_TRUE(succeeded(fresh.solve_all()));
  EXPECT_EQ(cal.calibration().accel.params, fresh.calibration().accel.params);
  EXPECT_EQ(cal.calibration().gyro.params, fresh.calibration().gyro.params);
}

#ifndef IMUCAL_SMALL_TARGET  // 1 kHz: ten times the samples, host only
// At 1 kHz without a gyro scale, still blocks are cut short by the (raw-unit) segment bounds;
// the delay line must still hold trim_seconds before a block joins a rest: no pose reaches
// into the motion that follows it.
TEST(CalibratorStream, TrimHoldsAt1kHzWithoutAGyroScale) {
  SimRun r;
  r.sc.plan.rate_hz = 1000.0;
  r.sc.plan.poses = 12;
  r.sc.plan.initial_rest_s = kInitialRest;
  r.sc.plan.record_attitude = false;
  sim::Random rng(34);
  r.rec = sim::simulate_motion(r.sc.plan, r.sc.acc, r.sc.gyro, rng);
  CalibratorSettings<float> settings = settings_for<float>(r.sc, false);
  settings.gyro.nominal_scale = 0.0f;
  Calibrator<float> cal(settings);
  for (const auto& m : r.rec.samples) cal.add(to_sample<float>(m));
  ASSERT_TRUE(succeeded(cal.solve_all())) << to_string(cal.calibration().gyro.status);
  ASSERT_EQ(cal.progress().poses, 13);
  double margin = 1e9;
  for (int k = 0; k < 12; ++k) {  // the last rest ends with the recording, not with motion
    const auto& rest = r.rec.rests[static_cast<std::size_t>(k)];
    margin = std::min(margin, r.rec.samples[rest.end - 1].t - cal.pose_end_us(k) * 1e-6);
  }
  std::printf("1 kHz, no gyro scale: smallest gap between a pose's end and the motion %.3f s\n",
              margin);
  EXPECT_GT(margin, 0.1);  // trim_seconds 0.3, less the detector's reaction
}
#endif

TEST(CalibratorStream, BadSamplesAreRefusedWithoutLosingAnything) {
  SimRun r = make_run(28);
  static Calibrator<float> cal, clean;  // static: two of them would fill the 64 KB stack
  cal.reset(settings_for<float>(r.sc, false));
  clean.reset(settings_for<float>(r.sc, false));
  const std::size_t half = r.rec.samples.size() / 2;
  for (std::size_t i = 0; i < r.rec.samples.size(); ++i) {
    const ImuSample<float> s = to_sample<float>(r.rec.samples[i]);
    clean.add(s);
    ASSERT_EQ(cal.add(s), Status::kOk) << i;
    if (i == half) {
      ImuSample<float> nan = s;
      nan.gyro(1) = std::numeric_limits<float>::quiet_NaN();
      nan.t_us += 1000;
      EXPECT_EQ(cal.add(nan), Status::kNonFiniteInput);
      ImuSample<float> back = s;
      back.t_us -= 5000;  // time going backwards
      EXPECT_EQ(cal.add(back), Status::kTimeBackwards);
      EXPECT_EQ(cal.add(s), Status::kTimeRepeated);
    }
  }
  EXPECT_EQ(cal.progress().samples_refused, 3u);
  ASSERT_TRUE(succeeded(cal.solve_all()));
  ASSERT_TRUE(succeeded(clean.solve_all()));
  // Identical to the clean stream: the refused samples changed nothing.
  EXPECT_EQ(cal.calibration().accel.params, clean.calibration().accel.params);
  EXPECT_EQ(cal.calibration().gyro.params, clean.calibration().gyro.params);
  // After the solve the calibrator takes no more samples until reset(), which starts afresh.
  EXPECT_EQ(cal.add(to_sample<float>(r.rec.samples.back())), Status::kBusy);
  cal.reset(settings_for<float>(r.sc, false));
  EXPECT_EQ(cal.progress().phase, Phase::kInitialRest);
  EXPECT_EQ(cal.progress().poses, 0);
  for (const auto& m : r.rec.samples) cal.add(to_sample<float>(m));
  ASSERT_TRUE(succeeded(cal.solve_all()));
  EXPECT_EQ(cal.calibration().gyro.params, clean.calibration().gyro.params);
}

// The initial rest is the first still period of initial_rest_seconds: motion before it (a
// recording that starts turning) is reported and skipped, and the first rest serves instead.
TEST(CalibratorStream, MotionBeforeAnyRestIsSkippedUntilTheFirstStillPeriod) {
  SimRun r;
  r.sc.plan.initial_rest_s = 0.5;  // shorter than the window: the recording starts moving
  r.sc.plan.poses = 4;
  r.sc.plan.rest_min_s = 4.0;
  r.sc.plan.record_attitude = false;
  sim::Random rng(29);
  r.rec = sim::simulate_motion(r.sc.plan, r.sc.acc, r.sc.gyro, rng);
  Calibrator<float> cal(settings_for<float>(r.sc, false));
  int disturbed = 0;
  const std::size_t first_rest_end = r.rec.rests[1].end;
  for (std::size_t i = 0; i < first_rest_end; ++i)
    disturbed += cal.add(to_sample<float>(r.rec.samples[i])) == Status::kInitialRestDisturbed;
  EXPECT_GE(disturbed, 1);  // the first move, seen by the sliding window
  const Progress p = cal.progress();
  EXPECT_EQ(p.phase, Phase::kCollecting);
  // The initial rest was found inside the first true rest, not across the move before it.
  for (std::size_t i = first_rest_end; i < r.rec.samples.size(); ++i)
    cal.add(to_sample<float>(r.rec.samples[i]));
  cal.end_stream();  // four poses: too few to solve, all of them listed
  ASSERT_EQ(cal.progress().poses, 4);
  EXPECT_GE(cal.pose_begin_us(0) * 1e-6, r.rec.samples[r.rec.rests[1].begin].t - 1e-6);
  EXPECT_LE(cal.pose_end_us(0) * 1e-6, r.rec.samples[r.rec.rests[1].end - 1].t + 1e-6);
}

// Progress while collecting: the faces fill in, the hint points at a missing one, and the
// solve proceeds in bounded slices.
TEST(CalibratorStream, ProgressAndSlicedSolve) {
  SimRun r = make_run(30);
  Calibrator<float> cal(settings_for<float>(r.sc, false));
  EXPECT_EQ(cal.progress().hint, Hint::kHoldStill);
  const std::size_t third = at_time(r.rec, r.rec.samples[r.rec.rests[3].begin].t + 2.0);
  for (std::size_t i = 0; i < third; ++i) cal.add(to_sample<float>(r.rec.samples[i]));
  Progress p = cal.progress();
  EXPECT_EQ(p.phase, Phase::kCollecting);
  EXPECT_EQ(p.poses, 3);
  EXPECT_LT(p.faces_covered, 6);
  EXPECT_EQ(p.hint, Hint::kTurnToFace);
  EXPECT_FALSE((p.faces >> p.next_face) & 1);
  for (std::size_t i = third; i < r.rec.samples.size(); ++i)
    cal.add(to_sample<float>(r.rec.samples[i]));
  EXPECT_EQ(cal.progress().phase, Phase::kReady);
  ASSERT_EQ(cal.solve(), Status::kRunning);
  EXPECT_EQ(cal.progress().phase, Phase::kSolving);
  int slices = 1;
  Status s;
  while ((s = cal.solve_step()) == Status::kRunning) ++slices;
  EXPECT_TRUE(succeeded(s));
  // At least one slice per accelerometer iteration and per 32 segments of each gyro pass.
  const int per_pass = cal.segment_count() / 32;
  EXPECT_GE(slices, cal.calibration().accel.iterations +
                        per_pass * (cal.calibration().gyro.iterations + 1));
  EXPECT_EQ(cal.progress().phase, Phase::kDone);
}

}  // namespace
}  // namespace imucal
