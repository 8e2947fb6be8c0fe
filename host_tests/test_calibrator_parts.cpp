// SPDX-License-Identifier: MIT
// The streaming calibrator's parts (include/imucal/calibrator/), each on its own: the move store
// and its coarsening, the pose collection with coverage and hints, and the solve sequence (the
// stream layer's parts are in test_stream.cpp). Float, the device's type, on every
// target; the solve sequence also in double.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "imucal/calibrator/calibrator.hpp"
#include "imucal/calibrator/pose_collection.hpp"
#include "imucal/calibrator/solve_sequence.hpp"
#include "imucal/sim/accel_sim.hpp"
#include "imucal/sim/motion_sim.hpp"
#include "imucal/sim/random.hpp"
#include "imucal/solve/move_store.hpp"
#include "imucal/stream/blocks.hpp"
#include "imucal/stream/checks.hpp"
#include "imucal/stream/initial_rest.hpp"
#include "support/gtest_status.hpp"

namespace imucal {
namespace {

using V3 = Vector3<float>;

V3 to_float(const Vector3<double>& v) { return v.cast<float>(); }

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
  EXPECT_GE(st.bounds().max_error2, 4e-30 * (1 - 1e-12));  // doubled at least once from 1e-15
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
