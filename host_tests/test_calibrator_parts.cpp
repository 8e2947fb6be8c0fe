// The streaming calibrator's parts (include/imucal/calibrator/), each on its own: the initial
// rest's window, blocks and the delay line, the move store and its coarsening, the pose
// collection with coverage and hints, and the solve sequence. Float, the device's type, on every
// target; the solve sequence also in double.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "imucal/calibrator/calibrator.hpp"
#include "imucal/calibrator/move_store.hpp"
#include "imucal/calibrator/pose_collection.hpp"
#include "imucal/calibrator/solve_sequence.hpp"
#include "imucal/sim/accel_sim.hpp"
#include "imucal/sim/motion_sim.hpp"
#include "imucal/sim/random.hpp"
#include "imucal/stream/blocks.hpp"
#include "imucal/stream/checks.hpp"
#include "imucal/stream/initial_rest.hpp"
#include "support/gtest_status.hpp"

namespace imucal {
namespace {

using V3 = Vector3<float>;

V3 to_float(const Vector3<double>& v) { return v.cast<float>(); }

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
TEST(CalibratorInitialRest, StillWindowGivesBiasNoiseAndPeriod) {
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
TEST(CalibratorInitialRest, TiltInTheWindowIsDisturbedThenItSlidesOn) {
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
TEST(CalibratorInitialRest, AnAxisWithoutNoiseIsAFrozenSensor) {
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

TEST(CalibratorStreamChecks, FullScaleBallAndExactLimits) {
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

TEST(CalibratorStreamChecks, AClockResetNeedsARunOfOrderedSamples) {
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

TEST(CalibratorStreamChecks, RateWindowsOfOneSecond) {
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
TEST(CalibratorBlocks, AppendedBlocksKeepTheMeanOfAllSamples) {
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
TEST(CalibratorBlocks, NoiseFromTheDetectorsCue) {
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

TEST(CalibratorBlocks, DelayLineKeepsOrderAndGrowsItsNewestWhenFull) {
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

// ---- The move store ------------------------------------------------------------------------

GyroSegment<double> random_segment(sim::Random& rng, int samples) {
  GyroSegment<double> s;
  for (int k = 0; k < samples; ++k) s.add(0.5 * rng.normal3(), 0.01);
  return s;
}

GyroSegment<double> composed(const MoveStore<double, 8, 16>& st, const GyroMove& m) {
  GyroSegment<double> c;
  for (int k = 0; k < m.segments; ++k) c.append(st.segment(m.first_segment + k));
  return c;
}

// No pose yet: nothing to integrate from. Between two poses: one move, its statistics the
// composition of what was added.
TEST(CalibratorMoveStore, AMoveRunsFromPoseToPose) {
  sim::Random rng(5);
  MoveStore<double, 8, 16> st;
  st.reset(1e-9, 1e-12);  // bounds too small to merge anything
  st.add(random_segment(rng, 5), 0.1);
  EXPECT_EQ(st.segment_count(), 0);
  st.arrive(0, nullptr, nullptr);
  GyroSegment<double> truth;
  for (int k = 0; k < 4; ++k) {
    const GyroSegment<double> s = random_segment(rng, 5);
    truth.append(s);
    st.add(s, 0.1);
  }
  EXPECT_TRUE(st.in_move());
  st.arrive(1, nullptr, nullptr);
  ASSERT_EQ(st.move_count(), 1);
  EXPECT_EQ(st.move(0).from_pose, 0);
  EXPECT_EQ(st.move(0).to_pose, 1);
  EXPECT_EQ(st.move(0).segments, 4);
  const GyroSegment<double> c = composed(st, st.move(0));
  EXPECT_LT((c.alpha - truth.alpha).norm(), 1e-14);
  EXPECT_LT((c.beta - truth.beta).norm(), 1e-14);
  EXPECT_LT((c.gamma - truth.gamma).norm(), 1e-14);
  EXPECT_GT(st.rotation().minCoeff(), 0.0);
}

// A full store merges adjacent segments of the same move: fewer segments, every move's
// composed statistics unchanged (exact algebra), the bounds doubled.
TEST(CalibratorMoveStore, AFullStoreCoarsensAndKeepsEveryMove) {
  sim::Random rng(6);
  MoveStore<double, 8, 16> st;
  st.reset(10.0, 1e-15);  // every segment a new one
  std::vector<GyroSegment<double>> truth;
  st.arrive(0, nullptr, nullptr);
  for (int m = 0; m < 4; ++m) {
    GyroSegment<double> t;
    for (int k = 0; k < 6; ++k) {
      const GyroSegment<double> s = random_segment(rng, 2);
      t.append(s);
      st.add(s, 0.1);
    }
    truth.push_back(t);
    st.arrive(m + 1, nullptr, nullptr);
  }
  EXPECT_GE(st.coarsenings(), 1);
  EXPECT_LE(st.segment_count(), 16);
  EXPECT_EQ(st.moves_dropped(), 0);
  ASSERT_EQ(st.move_count(), 4);
  for (int m = 0; m < 4; ++m) {
    const GyroSegment<double> c = composed(st, st.move(m));
    EXPECT_LT((c.alpha - truth[static_cast<std::size_t>(m)].alpha).norm(), 1e-12) << m;
    EXPECT_LT((c.beta - truth[static_cast<std::size_t>(m)].beta).norm(), 1e-12) << m;
    EXPECT_LT((c.gamma - truth[static_cast<std::size_t>(m)].gamma).norm(), 1e-12) << m;
  }
  EXPECT_GE(st.max_error2(), 4e-30 * (1 - 1e-12));  // doubled at least once from 1e-15
}

// Every move one segment and the store full: the move in progress is dropped (counted), the
// recorded ones kept, and the chain starts again at the next pose.
TEST(CalibratorMoveStore, NothingLeftToMergeDropsTheMoveInProgress) {
  sim::Random rng(7);
  MoveStore<double, 32, 16> st;
  st.reset(1e-9, 1e-12);
  st.arrive(0, nullptr, nullptr);
  for (int m = 0; m < 16; ++m) {
    st.add(random_segment(rng, 3), 5.0);
    st.arrive(m + 1, nullptr, nullptr);
  }
  ASSERT_EQ(st.segment_count(), 16);
  st.add(random_segment(rng, 3), 5.0);
  EXPECT_EQ(st.moves_dropped(), 1);
  EXPECT_FALSE(st.in_move());
  EXPECT_EQ(st.move_count(), 16);
  st.arrive(17, nullptr, nullptr);  // no move recorded into it
  EXPECT_EQ(st.move_count(), 16);
}

// A rest that turned: its first half ends the move into it, its second half starts the next;
// a move that holds only that half and is dropped was never a move.
TEST(CalibratorMoveStore, RestHalvesAndTheirMoves) {
  sim::Random rng(8);
  const GyroSegment<double> rest = random_segment(rng, 50);
  GyroSegment<double> head, tail;
  ASSERT_TRUE(split_rest_rotation(rest, head, tail));
  EXPECT_LT((head.alpha + tail.alpha - rest.alpha).norm(), 1e-15);
  EXPECT_DOUBLE_EQ(head.duration + tail.duration, rest.duration);
  EXPECT_FALSE(split_rest_rotation(GyroSegment<double>{}, head, tail));

  MoveStore<double, 8, 16> st;
  st.reset(1e-9, 1e-12);
  st.arrive(0, nullptr, nullptr);
  st.add(random_segment(rng, 3), 0.1);
  st.arrive(1, &head, &tail);
  ASSERT_EQ(st.move_count(), 1);
  EXPECT_EQ(st.move(0).segments, 2);  // the move and the head
  EXPECT_EQ(st.segment_count(), 3);   // and the tail, waiting for the next move
  st.drop();
  EXPECT_EQ(st.moves_dropped(), 0);
  EXPECT_EQ(st.segment_count(), 2);
}

// ---- Pose collection, coverage and hints -------------------------------------------------------

TEST(CalibratorPoses, FacesCoverageAndHints) {
  PoseCollection<float, 8> poses;
  const V3 zero(32768, 32768, 32768);
  const float g = 4000;
  const V3 faces[6] = {V3(g, 0, 0),  V3(-g, 0, 0), V3(0, g, 0),
                       V3(0, -g, 0), V3(0, 0, g),  V3(0, 0, -g)};
  Progress p;
  p.phase = Phase::kCollecting;
  for (int k = 0; k < 6; ++k) {
    const std::uint32_t t = 1000u * static_cast<std::uint32_t>(k);
    ASSERT_EQ(poses.add(zero + faces[k] + V3(300, -200, 100), 100, 9.0f, t, t + 500), Status::kOk);
    set_coverage(p, poses.faces(zero), V3(1, 1, 0.1f));
    EXPECT_EQ(p.faces_covered, k + 1);
    EXPECT_EQ(p.next_face, k < 5 ? k + 1 : 5);
    EXPECT_EQ(coverage_hint(p, false, false, true),
              k < 5 ? Hint::kTurnToFace : Hint::kTurnAboutAxis);
  }
  EXPECT_EQ(poses.faces(zero), 0x3f);
  // No zero given: the middle of the poses' spread.
  EXPECT_EQ(poses.faces(V3::Constant(std::numeric_limits<float>::quiet_NaN())), 0x3f);
  EXPECT_EQ(p.axes_turned, 0x3);
  EXPECT_EQ(p.next_axis, 2);
  EXPECT_EQ(coverage_hint(p, false, false, false), Hint::kTurnToFace);  // no gyro: more poses
  EXPECT_EQ(coverage_hint(p, false, true, true), Hint::kHoldLonger);
  EXPECT_EQ(coverage_hint(p, true, false, true), Hint::kCheckSensor);
  p.phase = Phase::kReady;
  EXPECT_EQ(coverage_hint(p, false, false, true), Hint::kSolve);
  EXPECT_EQ(poses.begin_us(3), 3000u);
  EXPECT_EQ(poses.end_us(3), 3500u);
  // A pose that cannot be one is refused, the others kept.
  EXPECT_EQ(poses.add(V3(std::numeric_limits<float>::quiet_NaN(), 0, 0), 100, 9.0f, 0, 1),
            Status::kNonFiniteInput);
  EXPECT_EQ(poses.size(), 6);
}

// The bias from the rests: their time-weighted mean rate; its sigma the white noise's over the
// rests' total length, or their scatter if larger.
TEST(CalibratorPoses, BiasFromTheRestsMeanRate) {
  PoseCollection<double, 8> poses;
  Vector3<double> u;
  EXPECT_FALSE(poses.mean_rest_rate(u));
  const Vector3<double> fallback(1, 2, 3);
  EXPECT_EQ(poses.rest_rate_sigma(Vector3<double>::Ones(), 0.01, fallback), fallback);
  poses.add_rest_rate(Vector3<double>(1, 0, 0), 2.0);
  poses.add_rest_rate(Vector3<double>(3, 0, 0), 2.0);
  ASSERT_TRUE(poses.mean_rest_rate(u));
  EXPECT_DOUBLE_EQ(u(0), 2.0);
  // Scatter: variance 1 about the mean, over n - 1 = 1 -> 1 on x; white noise elsewhere:
  // 4 * 0.01 / 4 s = 0.01.
  const Vector3<double> sd = poses.rest_rate_sigma(Vector3<double>::Constant(4), 0.01, fallback);
  EXPECT_NEAR(sd(0), 1.0, 1e-12);
  EXPECT_NEAR(sd(1), 0.1, 1e-12);
}

// ---- The solve sequence ----------------------------------------------------------------------

// Noise-free poses: the accelerometer alone gives the truth, the verdict names what is missing
// (no gyro asked, six faces: good).
TEST(CalibratorSolveSequence, AccelerometerAloneFromPoses) {
  sim::Random rng(21);
  const sim::AccelSensorSpec spec = sim::AccelSensorSpec::raw_counts();
  const sim::AccelTruth truth = sim::draw_accel_truth(spec, rng);
  PoseCollection<double, 24> poses;
  for (int k = 0; k < 24; ++k) {
    const Vector3<double> up = k < 6 ? sim::detail::face(k) : sim::random_direction(rng);
    ASSERT_EQ(poses.add(sim::raw_from_calibrated(truth, truth.gravity * up), 500, 11.0, 0, 1),
              Status::kOk);
  }
  static SolveSequence<double, 24> seq;
  AccelSettings<double> as;
  as.gravity = truth.gravity;
  seq.configure(as, GyroSettings<double>{});
  Calibration<double> cal;
  ASSERT_EQ(seq.start(as, poses.span(), cal), Status::kRunning);
  SolveInputs<double> in;
  in.poses = poses.span();
  in.has_gyro = false;
  Status s = Status::kRunning;
  int steps = 0;
  while (s == Status::kRunning && steps < 100) {
    s = seq.step(in, GyroSettings<double>{}, cal);
    ++steps;
  }
  ASSERT_TRUE(succeeded(s)) << to_string(s);
  EXPECT_FALSE(seq.in_gyro());
  for (int k = 0; k < kAccelParams; ++k)
    EXPECT_NEAR(cal.accel.params(k), truth.params(k), 1e-7 * (1 + std::abs(truth.params(k)))) << k;
  const char* why = nullptr;
  const std::uint8_t faces = poses.faces(Vector3<double>::Constant(-truth.params(kBiasX)));
  EXPECT_EQ(faces, 0x3f);
  const Vector3<double> noise = Vector3<double>::Constant(11);
  EXPECT_EQ(judge_quality(cal, false, faces, noise, poses.span(), 1.0, &why), Quality::kGood);
  EXPECT_STREQ(why, "every check passed");
  EXPECT_EQ(judge_quality(cal, false, std::uint8_t(0x1f), noise, poses.span(), 1.0, &why),
            Quality::kFair);
  EXPECT_STREQ(why, "not every face was up in a pose");
  EXPECT_EQ(judge_quality(cal, true, faces, noise, poses.span(), 1.0),
            Quality::kPoor);  // a gyro asked for and not calibrated
}

// Poses all about one axis cannot calibrate the accelerometer: the start refuses with the
// reason, and the verdict is none.
TEST(CalibratorSolveSequence, DegeneratePosesFailWithTheReason) {
  PoseCollection<float, 12> poses;
  for (int k = 0; k < 12; ++k)
    ASSERT_EQ(poses.add(V3(0, 0, 9.8f) + V3(1e-3f * static_cast<float>(k), 0, 0), 100, 1e-4f, 0, 1),
              Status::kOk);
  static SolveSequence<float, 12> seq;
  seq.configure(AccelSettings<float>{}, GyroSettings<float>{});
  Calibration<float> cal;
  Status s = seq.start(AccelSettings<float>{}, poses.span(), cal);
  SolveInputs<float> in;
  in.poses = poses.span();
  for (int k = 0; k < 100 && s == Status::kRunning; ++k)
    s = seq.step(in, GyroSettings<float>{}, cal);
  EXPECT_FALSE(succeeded(s));
  EXPECT_EQ(s, cal.accel.status);
  const char* why = nullptr;
  const V3 noise = V3::Constant(1e-4f);
  EXPECT_EQ(judge_quality(cal, true, std::uint8_t(0x3f), noise, poses.span(), 1.0f, &why),
            Quality::kNone);
  EXPECT_STREQ(why, "the accelerometer was not calibrated");
}

// The gyro's part from a simulated recording's poses and moves, collected by a calibrator and
// solved here on their own (bias refined from the initial rest's): every parameter of both
// sensors within 4 sigma of the truth.
TEST(CalibratorSolveSequence, GyroFromPosesAndMovesWithin4Sigma) {
  sim::MotionPlan plan;
  plan.initial_rest_s = 10.0;
  plan.poses = 12;
  plan.record_attitude = false;
  const sim::AccelSensorSpec acc_spec = sim::AccelSensorSpec::raw_counts();
  const sim::GyroSensorSpec gyro_spec = sim::GyroSensorSpec::raw_counts();
  sim::Random rng(31);
  const sim::Recording rec = sim::simulate_motion(plan, acc_spec, gyro_spec, rng);
  CalibratorSettings<float> settings;
  settings.accel.gravity = static_cast<float>(plan.gravity);
  settings.gyro.nominal_scale = static_cast<float>(gyro_spec.nominal_scale);
  settings.gyro.refine_bias = true;
  static Calibrator<float, 16, 200> cal;
  cal.reset(settings);
  for (const sim::MotionSample& m : rec.samples) {
    ImuSample<float> s;
    s.t_us = static_cast<std::uint32_t>(std::llround(m.t * 1e6));
    s.acc = to_float(m.acc);
    s.gyro = to_float(m.gyro);
    ASSERT_EQ(cal.add(s), Status::kOk);
  }
  cal.end_stream();
  ASSERT_GE(cal.move_count(), 10);

  static SolveSequence<float, 16> seq;
  seq.configure(settings.accel, settings.gyro);
  Calibration<float> out;
  ASSERT_EQ(seq.start(settings.accel, cal.poses(), out), Status::kRunning);
  static GyroSegment<float> segments[200];
  static GyroMove moves[16];
  for (int k = 0; k < cal.segment_count(); ++k) segments[k] = cal.segment(k);
  for (int k = 0; k < cal.move_count(); ++k) moves[k] = cal.move(k);
  SolveInputs<float> in;
  in.poses = cal.poses();
  in.segments = segments;
  in.moves = moves;
  in.move_count = cal.move_count();
  in.gyro_bias0 = cal.gyro_bias0();
  Status s = Status::kRunning;
  bool saw_gyro = false;
  for (int k = 0; k < 1000 && s == Status::kRunning; ++k) {
    s = seq.step(in, settings.gyro, out);
    saw_gyro = saw_gyro || seq.in_gyro();
  }
  ASSERT_TRUE(succeeded(s)) << to_string(s);
  EXPECT_TRUE(saw_gyro);
  ASSERT_TRUE(succeeded(out.accel.status));
  ASSERT_TRUE(succeeded(out.gyro.status));
  for (int k = 0; k < kAccelParams; ++k) {
    const double z = (static_cast<double>(out.accel.params(k)) - rec.acc.params(k)) /
                     static_cast<double>(out.accel.sigma(k));
    EXPECT_LT(std::abs(z), 4.0) << "accel " << k;
  }
  for (int k = 0; k < kGyroParams; ++k) {
    const double z = (static_cast<double>(out.gyro.params(k)) - rec.gyro.params(k)) /
                     static_cast<double>(out.gyro.sigma(k));
    EXPECT_LT(std::abs(z), 4.0) << "gyro " << k;
  }
}

}  // namespace
}  // namespace imucal
