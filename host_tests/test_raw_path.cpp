// SPDX-License-Identifier: MIT
// The integer path: 16-bit counts in (add_raw(), add_fifo()), integer sums per sample, the float
// work once a sub-block. Against the float path (add()) on the same counts: the sub-block's sums
// alike to rounding, a FIFO batch as its frames one by one, and the whole calibration on the real
// recordings (Xsens, both MPU-9150 boards) and a simulated protocol within 0.1 sigma.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "imucal/calibrator/calibrator.hpp"
#include "imucal/sim/motion_sim.hpp"
#include "imucal/sim/random.hpp"
#include "imucal/stream/fifo.hpp"
#include "imucal/stream/rest_monitor.hpp"
#include "imucal/stream/sub_block.hpp"
#include "support/fifo_bytes.hpp"
#include "support/gtest_status.hpp"
#include "support/xsens_reader.hpp"
#include "support/xsens_settings.hpp"

namespace imucal {
namespace {

constexpr double kPi = 3.14159265358979323846;

RawFrame frame_of(std::uint32_t t, const Vector3<double>& a, const Vector3<double>& g) {
  RawFrame f;
  f.t_us = t;
  for (int i = 0; i < 3; ++i) {
    f.acc[i] = static_cast<std::int16_t>(std::lround(a(i)));
    f.gyro[i] = static_cast<std::int16_t>(std::lround(g(i)));
  }
  return f;
}

template <typename Scalar>
ImuSample<Scalar> sample_of(const RawFrame& f) {
  ImuSample<Scalar> s;
  s.t_us = f.t_us;
  for (int i = 0; i < 3; ++i) {
    s.acc(i) = static_cast<Scalar>(f.acc[i]);
    s.gyro(i) = static_cast<Scalar>(f.gyro[i]);
  }
  return s;
}

// ---- One sub-block -----------------------------------------------------------------------------

// The same counts through both accumulators, a still spell then a fast turn (thousands of counts a
// sample, beta far from zero) with a bias that is not a whole count: every sum alike to float's
// rounding (the integer sums are exact; alpha, beta and gamma from the mean interval are exact
// here, the steps being equal), and the same state. The still spell's rotation is first order in
// both.
TEST(SubBlock, CountsGiveTheSumsOfTheSameReadings) {
  SubBlockLimits<double> l;
  l.acc_ref = Vector3<double>(120.4, -35.2, 4095.7);
  l.gyro_bias = Vector3<double>(-12.3, 7.6, 0.45);
  l.dev_clip = 400.0;
  l.energy_clip = 9e6;
  l.accel_threshold = 300.0;
  l.energy_threshold = 4e4;
  l.weight = 0.01 / 0.11;
  sim::Random rng(17);
  for (int spell = 0; spell < 2; ++spell) {
    SubBlock<double> raw;
    SubBlock<double> flt;
    raw.start(l);
    flt.start(l);
    raw.set_averages(l.acc_ref, 30.0, spell == 0 ? 100.0 : 1e6);
    flt.set_averages(l.acc_ref, 30.0, spell == 0 ? 100.0 : 1e6);
    for (int k = 0; k < 16; ++k) {
      const double rate = spell == 0 ? 0.0 : 2500.0 * std::sin(0.3 * k);
      const Vector3<double> a = Vector3<double>(120, -35, 4096) + 3.0 * rng.normal3();
      const Vector3<double> g =
          -l.gyro_bias + Vector3<double>(rate, -0.7 * rate, 0.2 * rate) + 4.0 * rng.normal3();
      const RawFrame f = frame_of(10000u * static_cast<std::uint32_t>(k + 1), a, g);
      const std::uint32_t step = k == 0 ? 0u : 10000u;
      ASSERT_TRUE(raw.add(f, step, false));
      ASSERT_TRUE(flt.add(sample_of<double>(f), step, false));
      ASSERT_EQ(raw.still(), flt.still()) << spell << " " << k;
    }
    SubBlockStats<double> r = raw.finish(), s = flt.finish();
    EXPECT_EQ(r.n, s.n);
    EXPECT_EQ(r.intervals, s.intervals);
    EXPECT_NEAR(r.seg.duration, s.seg.duration, 1e-12);
    const Vector3<double> mean_r = r.acc_ref + r.acc_sum / r.n,
                          mean_s = s.acc_ref + s.acc_sum / s.n;
    EXPECT_NEAR((mean_r - mean_s).norm(), 0.0, 1e-9);
    // The cue: the integer path's moving mean is kept to 1/256 count.
    EXPECT_NEAR(r.dev, s.dev, 0.02 * s.dev);
    EXPECT_NEAR(r.energy, s.energy, 1e-9 * s.energy + 1e-9);
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(r.seg.alpha(i), s.seg.alpha(i), 1e-9 * (1 + std::abs(s.seg.alpha(i)))) << i;
      EXPECT_NEAR(r.seg.beta(i), s.seg.beta(i), 1e-9 * (1 + std::abs(s.seg.beta(i)))) << i;
      EXPECT_NEAR(r.seg.gamma(i), s.seg.gamma(i), 1e-9 * (1 + std::abs(s.seg.gamma(i)))) << i;
    }
    if (spell == 0) {  // still: first order in both (alpha and the duration)
      EXPECT_EQ(r.seg.beta.norm(), 0.0);
      EXPECT_EQ(s.seg.beta.norm(), 0.0);
      EXPECT_EQ(r.seg.gamma.norm(), 0.0);
      EXPECT_EQ(s.seg.gamma.norm(), 0.0);
      EXPECT_GT(s.seg.alpha.norm(), 1e-3);
    } else {
      EXPECT_GT(s.seg.beta.norm(), 1.0);  // the second-order terms were exercised
    }
  }
}

// A still sub-block holds up to kStillSubBlockFactor * kMaxSubBlockSamples (512) frames: at the
// extremes of the counts (every accelerometer reading at full scale against a reference at the
// other end, the gyro at full scale, the steps irregular) its integer sums are still exact: the
// same as the same readings summed in double. With no thresholds every frame is still, and with
// no rotation bound nothing closes it but the caller.
TEST(SubBlock, AStillSubBlockOfTheMostFramesSumsExactly) {
  constexpr int kFrames = kStillSubBlockFactor * kMaxSubBlockSamples;
  SubBlockLimits<double> l;
  l.acc_ref = Vector3<double>(-32768, 32767, -32768);
  SubBlock<double> raw;
  SubBlock<double> flt;
  raw.start(l);
  flt.start(l);
  std::uint32_t t = 0;
  for (int k = 0; k < kFrames; ++k) {
    const double sign = k % 3 == 0 ? -1.0 : 1.0;
    RawFrame f;
    for (int i = 0; i < 3; ++i) {
      f.acc[i] = static_cast<std::int16_t>(i == 1 ? -32768 : 32767);
      f.gyro[i] = static_cast<std::int16_t>(sign * (i == 1 ? -32767.0 : 32767.0));
    }
    const std::uint32_t step = k == 0 ? 0u : 900u + 200u * static_cast<std::uint32_t>(k % 3);
    t += step;
    f.t_us = t;
    ASSERT_TRUE(raw.add(f, step, false)) << k;
    ASSERT_TRUE(flt.add(sample_of<double>(f), step, false)) << k;
    ASSERT_TRUE(raw.still());
    // The temperature far from the stream's reference: its sum passes 32 bits.
    raw.add_temperature(1 << 25);
    flt.add_temperature(1 << 25);
  }
  ASSERT_EQ(raw.size(), static_cast<std::uint32_t>(kFrames));
  const SubBlockStats<double> r = raw.finish(), s = flt.finish();
  EXPECT_EQ(r.n, s.n);
  EXPECT_EQ(r.intervals, s.intervals);
  EXPECT_EQ(r.duration_us, s.duration_us);
  EXPECT_EQ(r.acc_ref, s.acc_ref);
  EXPECT_EQ(r.acc_sum, s.acc_sum);  // 512 x 65535 each
  EXPECT_EQ(r.energy, s.energy);
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(r.seg.alpha(i), s.seg.alpha(i), 1e-12 * std::abs(s.seg.alpha(i))) << i;
  EXPECT_EQ(r.seg.beta.norm(), 0.0);  // still: first order
  EXPECT_EQ(r.temp_n, static_cast<std::uint32_t>(kFrames));
  EXPECT_EQ(r.temp_sum, kFrames * 8192.0);  // 2^34 / 4096
}

// A stream that changes kind (readings, then frames of the same counts, or back) goes on from
// where the moving averages were: readings that walk the accelerometer 1,000 counts away from
// where the detector started, then frames there, are taken, not refused as glitches against the
// start's mean; and the frames' own moving mean stays there.
TEST(SubBlock, AStreamThatChangesKindKeepsItsMovingAverages) {
  SubBlockLimits<double> l;
  l.acc_ref = Vector3<double>(0, 0, 4096);
  l.glitch2 = 100.0 * 100.0;  // counts^2
  l.accel_threshold = 300.0;
  l.energy_threshold = 4e4;
  l.weight = 0.01 / 0.11;
  l.seconds = 0.1;
  const Vector3<double> there(1000, 0, 4096);
  for (const bool frames_first : {false, true}) {
    SubBlock<double> acc;
    acc.start(l);
    acc.set_averages(l.acc_ref, 30.0, 100.0);
    sim::Random rng(21);
    std::uint32_t t = 0;
    const auto feed = [&](const Vector3<double>& a, bool frame) {
      t += 10000u;
      const RawFrame f = frame_of(t, a + rng.normal3(), Vector3<double>::Zero());
      const std::uint32_t step = t == 10000u ? 0u : 10000u;
      return frame ? acc.add(f, step, false) : acc.add(sample_of<double>(f), step, false);
    };
    // A slow walk (5 counts a sample: the moving mean lags by about 55), then 100 samples there.
    for (int k = 1; k <= 200; ++k) {
      ASSERT_TRUE(feed(l.acc_ref + (there - l.acc_ref) * (k / 200.0), frames_first)) << k;
      if (acc.size() >= 16) acc.start(l);
    }
    for (int k = 0; k < 100; ++k) {
      ASSERT_TRUE(feed(there, frames_first));
      if (acc.size() >= 16) acc.start(l);
    }
    // The other kind, at the same place.
    for (int k = 0; k < 20; ++k) {
      ASSERT_TRUE(feed(there, !frames_first)) << frames_first << " " << k;
      if (acc.size() >= 16) acc.start(l);
    }
    const SubBlockStats<double> s = acc.finish();
    EXPECT_LT((s.moving_mean - there).norm(), 2.0) << frames_first;
    EXPECT_LT((s.acc_ref + s.acc_sum / s.n - there).norm(), 2.0) << frames_first;
  }
}

// ---- FIFO batches ------------------------------------------------------------------------------

// A batch laid out as a sensor's FIFO (gyro first, big-endian, the axes in another order, padding)
// gives each frame the status add_raw() gives it, and the same calibrator state.
TEST(Fifo, ABatchIsItsFramesOneByOne) {
  FifoLayout layout;
  layout.stride = 14;  // 2 bytes of padding a frame
  layout.gyro_offset = 0;
  layout.acc_offset = 6;
  layout.axis_order[0] = 2;  // body x is the frame's third reading
  layout.axis_order[1] = 0;
  layout.axis_order[2] = 1;
  layout.big_endian = true;
  ASSERT_TRUE(layout.valid());
  FifoLayout bad = layout;
  bad.axis_order[1] = 2;
  EXPECT_FALSE(bad.valid());
  const int frames = 300;
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(frames * layout.stride), 0xEE);
  std::vector<RawFrame> direct;
  sim::Random rng(23);
  const std::uint32_t period_q8 = 2461538u;  // 104 Hz
  for (int k = 0; k < frames; ++k) {
    Vector3<double> a = Vector3<double>(100, -2000, 4000) + 3 * rng.normal3();
    if (k == 150) a(1) = 32767;  // one saturated reading
    RawFrame f = frame_of(0, a, Vector3<double>(5, -3, 2) + 2 * rng.normal3());
    f.t_us =
        5000u + static_cast<std::uint32_t>(
                    (static_cast<std::uint64_t>(period_q8) * static_cast<std::uint64_t>(k)) >> 8);
    direct.push_back(f);
    test::put_fifo_frame(bytes.data(), static_cast<std::uint32_t>(k), layout, f);
  }
  CalibratorSettings<float> set;
  set.accel_min = -32768;
  set.accel_max = 32767;
  static Calibrator<float> one, batch;
  one.reset(set);
  batch.reset(set);
  std::vector<Status> want;
  for (const RawFrame& f : direct) want.push_back(one.add_raw(f, 25.0f));
  std::vector<Status> got(static_cast<std::size_t>(frames));
  FifoTiming timing;
  timing.first_us = 5000u;
  timing.period_q8 = period_q8;
  // In batches of 50, the temperature once a batch.
  FifoResult total;
  for (int b = 0; b < frames; b += 50) {
    const FifoResult r = batch.add_fifo(
        &bytes[static_cast<std::size_t>(b * layout.stride)], 50, layout,
        FifoTiming{
            timing.first_us +
                static_cast<std::uint32_t>(
                    (static_cast<std::uint64_t>(period_q8) * static_cast<std::uint64_t>(b)) >> 8),
            period_q8, nullptr},
        25.0f, &got[static_cast<std::size_t>(b)]);
    total.taken += r.taken;
    total.refused += r.refused;
  }
  EXPECT_EQ(got, want);
  EXPECT_EQ(total.taken + total.refused, static_cast<std::uint32_t>(frames));
  EXPECT_EQ(batch.progress().stream.accel_saturated, 1u);
  EXPECT_EQ(one.progress().stream.accel_saturated, 1u);
  EXPECT_EQ(batch.progress().phase, one.progress().phase);
  float t1 = 0, t2 = 0;
  ASSERT_TRUE(one.mean_temperature(t1));
  ASSERT_TRUE(batch.mean_temperature(t2));
  EXPECT_NEAR(t1, 25.0f, 1e-5f);
  EXPECT_NEAR(t2, 25.0f, 1e-5f);
  // A bad layout or no buffer: every frame refused, nothing taken.
  static Calibrator<float> none;
  none.reset(set);
  const FifoResult r = none.add_fifo(bytes.data(), 10, bad, timing);
  EXPECT_EQ(r.refused, 10u);
  EXPECT_EQ(r.first_refusal, Status::kInvalidArgument);
  EXPECT_EQ(none.add_fifo(nullptr, 3, layout, timing).refused, 3u);
}

// A FIFO buffer's frames give back the readings written in its layout (both byte orders, the axes
// in order and not, readings at odd offsets as behind a one-byte header), and the timestamps
// of a period as first_us + floor(k period_q8 / 256) to the microsecond, past the point where
// k period_q8 overflows 32 bits; per-frame timestamps as they are.
TEST(Fifo, FramesReadBackAsWrittenWithTheirTimestamps) {
  FifoLayout layouts[3];
  layouts[1].stride = 16;  // a header byte, the accelerometer, the gyro, a temperature byte
  layouts[1].acc_offset = 1;
  layouts[1].gyro_offset = 7;
  layouts[1].big_endian = true;
  layouts[2].stride = 13;
  layouts[2].gyro_offset = 0;
  layouts[2].acc_offset = 7;
  layouts[2].axis_order[0] = 1;
  layouts[2].axis_order[1] = 2;
  layouts[2].axis_order[2] = 0;
  const std::uint32_t frames = 3000;  // 3000 * 2461538 (104 Hz) needs 33 bits
  sim::Random rng(5);
  std::vector<RawFrame> want(frames);
  for (RawFrame& f : want) {
    for (int i = 0; i < 3; ++i) {
      f.acc[i] = static_cast<std::int16_t>(std::lround(rng.uniform(-32768.0, 32767.0)));
      f.gyro[i] = static_cast<std::int16_t>(std::lround(rng.uniform(-32768.0, 32767.0)));
    }
  }
  want[0].acc[0] = -32768;
  want[0].gyro[2] = 32767;
  std::vector<std::uint32_t> stamps(frames);
  for (std::uint32_t k = 0; k < frames; ++k) stamps[k] = 0xFFFF0000u + 977u * k * k;
  const std::uint32_t periods[] = {2461538u, 0xFFFFFFFFu, 0u};
  for (const FifoLayout& layout : layouts) {
    ASSERT_TRUE(layout.valid());
    std::vector<std::uint8_t> bytes(std::size_t{frames} * layout.stride, 0xA5);
    for (std::uint32_t k = 0; k < frames; ++k)
      test::put_fifo_frame(bytes.data(), k, layout, want[k]);
    for (const std::uint32_t period_q8 : periods) {
      const FifoTiming timing{4000000000u, period_q8, nullptr};
      std::uint32_t mismatches = 0;
      for (std::uint32_t k = 0; k < frames; ++k) {
        const RawFrame f = fifo_frame(bytes.data(), k, layout, timing);
        const auto t =
            static_cast<std::uint32_t>(timing.first_us + ((std::uint64_t{period_q8} * k) >> 8));
        bool same = f.t_us == t;
        for (int i = 0; i < 3; ++i)
          same = same && f.acc[i] == want[k].acc[i] && f.gyro[i] == want[k].gyro[i];
        if (!same) ++mismatches;
      }
      EXPECT_EQ(mismatches, 0u) << "stride " << layout.stride << ", period_q8 " << period_q8;
    }
    const FifoTiming stamped{0u, 2461538u, stamps.data()};
    std::uint32_t mismatches = 0;
    for (std::uint32_t k = 0; k < frames; ++k) {
      const RawFrame f = fifo_frame(bytes.data(), k, layout, stamped);
      if (f.t_us != stamps[k] || f.acc[1] != want[k].acc[1] || f.gyro[1] != want[k].gyro[1])
        ++mismatches;
    }
    EXPECT_EQ(mismatches, 0u) << "stride " << layout.stride << ", per-frame timestamps";
  }
}

// ---- Whole calibrations
// --------------------------------------------------------------------------

// Counts in, float and integer paths side by side; every parameter within 0.1 sigma of the float
// path's, the same poses.
struct PathRun {
  Calibration<float> cal;
  int poses = 0, moves = 0;
};

template <class Feed>
PathRun run_path(const CalibratorSettings<float>& set, bool raw, const Feed& feed) {
  static Calibrator<float> c;
  c.reset(set);
  feed([&](const RawFrame& f) {
    if (raw) {
      c.add_raw(f);
    } else {
      c.add(sample_of<float>(f));
    }
  });
  PathRun out;
  c.end_stream();
  out.poses = c.progress().poses;
  out.moves = c.progress().moves;
  EXPECT_TRUE(succeeded(c.solve_all()))
      << to_string(c.calibration().accel.status) << " " << to_string(c.calibration().gyro.status);
  out.cal = c.calibration();
  return out;
}

template <class Feed>
void expect_paths_agree(const char* name, const CalibratorSettings<float>& set, const Feed& feed,
                        double gyro_limit = 0.1) {
  const PathRun f = run_path(set, false, feed), r = run_path(set, true, feed);
  EXPECT_EQ(r.poses, f.poses) << name;
  EXPECT_EQ(r.moves, f.moves) << name;
  double worst = 0;
  for (int k = 0; k < kAccelParams; ++k) {
    const double d = std::abs(static_cast<double>(r.cal.accel.params(k) - f.cal.accel.params(k))) /
                     static_cast<double>(f.cal.accel.sigma(k));
    EXPECT_LE(d, 0.1) << name << " accel " << k;
    worst = std::max(worst, d);
  }
  for (int k = 0; k < kGyroParams; ++k) {
    if (!(f.cal.gyro.sigma(k) > 0)) continue;
    const double d = std::abs(static_cast<double>(r.cal.gyro.params(k) - f.cal.gyro.params(k))) /
                     static_cast<double>(f.cal.gyro.sigma(k));
    EXPECT_LE(d, gyro_limit) << name << " gyro " << k;
    worst = std::max(worst, d);
  }
  std::printf("[ %s ] %d poses, %d moves; integer path within %.3f sigma of the float path\n", name,
              f.poses, f.moves, worst);
}

TEST(RawPath, XsensRecordingAsTheFloatPath) {
  const std::string dir = test::find_xsens_dir();
  if (dir.empty()) {
#ifdef IMUCAL_REQUIRE_XSENS
    FAIL() << "xsens recording required but not found";
#endif
    GTEST_SKIP() << "xsens recording not found (set IMUCAL_XSENS_DIR)";
  }
  // Unsigned 16-bit counts: as signed ones, 32768 less (the biases are 32768 less too).
  CalibratorSettings<float> set = test::xsens_calibrator_settings();
  set.accel_zero_hint = Vector3<float>::Zero();
  expect_paths_agree("xsens", set, [&](const auto& take) {
    test::XsensStream in;
    ASSERT_TRUE(in.open(dir)) << in.error();
    double t;
    Vector3<float> a, g;
    while (in.next(t, a, g)) {
      const auto us = static_cast<std::uint32_t>(std::llround(t * 1e6));
      take(frame_of(us, a.cast<double>() - Vector3<double>::Constant(32768),
                    g.cast<double>() - Vector3<double>::Constant(32768)));
    }
  });
}

// The MPU-9150 logs are counts times the nominal factors (9.81/2048 m/s^2, 1/16.384 deg/s).
TEST(RawPath, Mpu9150RecordingsAsTheFloatPath) {
  const char* env = std::getenv("IMUCAL_MPU9150_DIR");
#ifdef IMUCAL_MPU9150_DEFAULT_DIR
  const std::string dir = env != nullptr ? env : IMUCAL_MPU9150_DEFAULT_DIR;
#else
  const std::string dir = env != nullptr ? env : "../shared/data/mpu9150";
#endif
  for (const char* board : {"imu0.log", "imu1.log"}) {
    std::FILE* probe = std::fopen((dir + "/" + board).c_str(), "r");
    if (probe == nullptr) {
#ifdef IMUCAL_REQUIRE_XSENS
      FAIL() << "MPU-9150 recording required but not found in " << dir;
#endif
      GTEST_SKIP() << "MPU-9150 recordings not found (set IMUCAL_MPU9150_DIR)";
    }
    std::fclose(probe);
    CalibratorSettings<float> set;
    set.accel.gravity = 9.81f;
    set.gyro.nominal_scale = static_cast<float>(kPi / 180 / 16.384);
    expect_paths_agree(board, set, [&](const auto& take) {
      std::FILE* f = std::fopen((dir + "/" + board).c_str(), "r");
      ASSERT_NE(f, nullptr);
      double v[6];
      std::uint32_t k = 0;
      while (std::fscanf(f, "%lf %lf %lf %lf %lf %lf", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5]) ==
             6) {
        const Vector3<double> a = Vector3<double>(v[0], v[1], v[2]) / (9.81 / 2048);
        const Vector3<double> g = Vector3<double>(v[3], v[4], v[5]) / (kPi / 180 / 16.384);
        take(frame_of(10000u * k++, a, g));
      }
      std::fclose(f);
    });
  }
}

// A simulated protocol in counts (signed 16-bit, 1 kHz on the host; the cross targets' RAM holds
// a shorter one at 200 Hz): the integer path on a fast stream.
TEST(RawPath, SimulatedFastProtocolAsTheFloatPath) {
  sim::AccelSensorSpec acc = sim::AccelSensorSpec::raw_counts();
  sim::GyroSensorSpec gyro = sim::GyroSensorSpec::raw_counts();
  acc.nominal_bias = 0.0;  // signed counts
  gyro.nominal_bias = 0.0;
  sim::MotionPlan plan;
#if defined(__arm__) || defined(__riscv)
  plan.poses = 14;
  plan.rate_hz = 200.0;
#else
  plan.poses = 26;
  plan.rate_hz = 1000.0;
#endif
  plan.record_attitude = false;
  sim::Random rng(31);
  const sim::Recording rec = sim::simulate_motion(plan, acc, gyro, rng);
  CalibratorSettings<float> set;
  set.accel.gravity = static_cast<float>(plan.gravity);
  set.gyro.nominal_scale = static_cast<float>(gyro.nominal_scale);
  expect_paths_agree(
      "simulated", set,
      [&](const auto& take) {
        for (const auto& m : rec.samples) {
          take(frame_of(static_cast<std::uint32_t>(std::llround(m.t * 1e6)), m.acc, m.gyro));
        }
      },
      // 1 kHz with timestamp jitter: the integer path takes the sub-block's mean interval for the
      // second-order terms beta and gamma; the gyro scales move by up to about 0.1 sigma, by
      // compiler (0.09 with GCC, 0.05 with Clang, whose builds end some rests a sub-block apart).
      0.15);
}

// The rest monitor takes frames too: the same rests as from the same counts as floats.
TEST(RawPath, RestMonitorFindsTheSameRests) {
  sim::AccelSensorSpec acc = sim::AccelSensorSpec::raw_counts();
  sim::GyroSensorSpec gyro = sim::GyroSensorSpec::raw_counts();
  acc.nominal_bias = 0.0;
  gyro.nominal_bias = 0.0;
  sim::MotionPlan plan;
  plan.poses = 12;
  plan.record_attitude = false;
  sim::Random rng(37);
  const sim::Recording rec = sim::simulate_motion(plan, acc, gyro, rng);
  RestMonitorSettings<float> ms;
  ms.accel_noise = static_cast<float>(3 * acc.noise * acc.noise);
  ms.gyro_noise = static_cast<float>(3 * gyro.noise * gyro.noise);
  ms.min_rest_seconds = 2.0f;
  std::vector<RestSummary<float>> found[2];
  for (int raw = 0; raw < 2; ++raw) {
    RestMonitor<float> m(ms);
    RestSummary<float> r;
    for (const auto& x : rec.samples) {
      const RawFrame f =
          frame_of(static_cast<std::uint32_t>(std::llround(x.t * 1e6)), x.acc, x.gyro);
      ASSERT_EQ(raw ? m.add_raw(f) : m.add(sample_of<float>(f)), Status::kOk);
      while (m.take(r)) found[raw].push_back(r);
    }
    m.finish();
    while (m.take(r)) found[raw].push_back(r);
  }
  ASSERT_EQ(found[0].size(), found[1].size());
  EXPECT_GE(found[0].size(), 12u);
  // The integer path's moving averages are fixed point: where an average crosses its threshold,
  // its decision may come one sub-block (0.1 s) earlier or later. A rest's ends agree within that,
  // and its means within what the samples of a sub-block at each end can move them: 2 x 3 sigma
  // of a sample x (samples in 0.1 s) / (samples in the rest), per axis.
  const std::uint32_t sub_block_us = 100000;
  for (std::size_t i = 0; i < found[0].size(); ++i) {
    const RestSummary<float>&a = found[0][i], &b = found[1][i];
    EXPECT_LE(std::abs(static_cast<std::int64_t>(a.begin_us) - b.begin_us), sub_block_us) << i;
    EXPECT_LE(std::abs(static_cast<std::int64_t>(a.end_us) - b.end_us), sub_block_us) << i;
    const double edge = 2.0 * 0.1 * plan.rate_hz / std::min(a.samples, b.samples);
    const double acc_tol = 3.0 * std::sqrt(3.0) * acc.noise * edge;
    const double gyro_tol = 3.0 * std::sqrt(3.0) * gyro.noise * edge;
    EXPECT_LE((a.accel_mean - b.accel_mean).norm(), acc_tol) << i;
    EXPECT_LE((a.gyro_mean - b.gyro_mean).norm(), gyro_tol) << i;
  }
}

}  // namespace
}  // namespace imucal
