// SPDX-License-Identifier: MIT
// bench/insn/bench_stream.cpp: instruction counts of the streaming calibrator on the cross
// targets (bench/run_insn_bench.sh, QEMU with the counting plugin): the real xsens recording
// (51,175 samples, raw counts) fed one sample at a time, each add() its own region, named by how
// the calibrator classified the sample; then the solve, each solve_step() its own region. Then the
// integer path on the same recording: add_raw() a frame at a time, and add_fifo() in batches of
// 25 frames; and add_raw() on a 1 kHz stream of rests and turns made here. The script sums
// regions of the same name. Not a test: it reports, it does not judge.
// It also reports the deepest stack use of add() and of solve() + solve_step() ("STACK" lines:
// bytes below main's stack pointer, stack_paint.hpp), painted before and measured after each
// call, outside the counted regions.
#include <cmath>
#include <cstdio>

#include "imucal/calibrator/calibrator.hpp"
#include "imucal/stream/rest_monitor.hpp"
#include "markers.hpp"
#include "stack_paint.hpp"
#include "support/fifo_bytes.hpp"
#include "support/xsens_reader.hpp"
#include "support/xsens_settings.hpp"

using namespace imucal;

namespace {
Calibrator<float> calibrator;  // global: no guard, no stack
// The sample is written here before the begin marker (its memory clobber orders the stores),
// so that converting the file's double timestamp (soft-float on the M4F) is not counted.
ImuSample<float> sample;

// Painted per call, not once before the loop: that would count the loop's other calls too
// (reading the file, printf). For the 51,175 add() calls only this much below main's SP is
// repainted each time (the rest, painted once, is checked at the end for anything deeper).
constexpr std::uintptr_t kAddStackWindow = 4096;

// The recording as signed 16-bit frames (unsigned counts less 32768).
RawFrame frame_of(double t, const Vector3<float>& acc, const Vector3<float>& gyro) {
  RawFrame f;
  f.t_us = static_cast<std::uint32_t>(std::llround(t * 1e6));
  for (int i = 0; i < 3; ++i) {
    f.acc[i] = static_cast<std::int16_t>(std::lround(acc(i) - 32768.0f));
    f.gyro[i] = static_cast<std::int16_t>(std::lround(gyro(i) - 32768.0f));
  }
  return f;
}

CalibratorSettings<float> signed_xsens_settings() {
  CalibratorSettings<float> s = test::xsens_calibrator_settings();
  s.accel_zero_hint = Vector3<float>::Zero();
  return s;
}

constexpr std::uint32_t kBatch = 25;
std::uint8_t g_fifo[kBatch * 12];  // a FIFO's bytes: accelerometer then gyro, little-endian
RawFrame g_frame;

// A 1 kHz stream of 16-bit counts made here: 6 s still, then 2 s turns about changing axes at up
// to 3 rad/s between 3 s rests, 60 s in all, white noise of a few counts (xorshift).
struct Fast {
  std::uint32_t k = 0, state = 2463534242u;
  float noise() {
    state ^= state << 13;
    state ^= state >> 17;
    state ^= state << 5;
    return static_cast<float>(state & 0xFFFF) / 65536.0f * 6.0f - 3.0f;
  }
  bool next(RawFrame& f) {
    if (k >= 60000) return false;
    const int cycle = k < 6000 ? -1 : static_cast<int>((k - 6000) / 5000);
    const float in = k < 6000 ? 0.0f : static_cast<float>((k - 6000) % 5000) * 1e-3f;
    const float rate = cycle >= 0 && in < 2.0f ? 3.0f * std::sin(1.5707963f * in) : 0.0f;
    f.t_us = 1000u * k;
    for (int i = 0; i < 3; ++i) {
      const bool axis = cycle >= 0 && (cycle % 3) == i;
      f.gyro[i] =
          static_cast<std::int16_t>(std::lround(4770.0f * (axis ? rate : 0.0f) + 2 * noise()));
      f.acc[i] = static_cast<std::int16_t>(std::lround(
          (i == 2 ? 4000.0f : 100.0f) * std::cos(0.3f * static_cast<float>(cycle + 1)) + noise()));
    }
    ++k;
    return true;
  }
};

// The integer path: the recording a frame at a time and in FIFO batches, then the 1 kHz stream.
bool raw_paths() {
  calibrator.reset(signed_xsens_settings());
  test::XsensStream in;
  if (!in.open(test::find_xsens_dir())) return false;
  double t = 0;
  Vector3<float> acc, gyro;
  while (in.next(t, acc, gyro)) {
    g_frame = frame_of(t, acc, gyro);
    const bool initial = calibrator.progress().phase == Phase::kInitialRest;
#ifdef IMUCAL_BENCH_PROFILE_STILL
    const bool counted = !initial && calibrator.still();  // still before and, mostly, after
#else
    const bool counted = true;
#endif
    if (counted) imucal_bench_begin();
    calibrator.add_raw(g_frame);
    if (counted) imucal_bench_end();
    if (!counted) continue;
    bench_announce(initial              ? "add_raw(): initial rest, per frame"
                   : calibrator.still() ? "add_raw(): still, per frame"
                                        : "add_raw(): moving, per frame");
  }
  const int poses_raw = calibrator.progress().poses;
#ifdef IMUCAL_BENCH_PROFILE_STILL
  return poses_raw > 30;  // the still frames' regions only
#endif
  calibrator.reset(signed_xsens_settings());
  test::XsensStream again;
  if (!again.open(test::find_xsens_dir())) return false;
  FifoLayout layout;  // accelerometer then gyro, little-endian, 12 bytes a frame
  FifoTiming timing;
  std::uint32_t n = 0;
  while (again.next(t, acc, gyro)) {
    const RawFrame f = frame_of(t, acc, gyro);
    if (n == 0) timing.first_us = f.t_us;
    test::put_fifo_frame(g_fifo, n++, FifoLayout{}, f);
    if (n < kBatch) continue;
    timing.period_q8 = 2560000u;  // 100 Hz
    const bool initial = calibrator.progress().phase == Phase::kInitialRest;
    imucal_bench_begin();
    calibrator.add_fifo(g_fifo, kBatch, layout, timing);
    imucal_bench_end();
    bench_announce(initial ? "add_fifo(): 25 frames, initial rest" : "add_fifo(): 25 frames");
    n = 0;
  }
  const int poses_fifo = calibrator.progress().poses;
  CalibratorSettings<float> fast_settings;
  fast_settings.gyro.nominal_scale = 1.0f / 4770.0f;
  calibrator.reset(fast_settings);
  Fast fast;
  while (fast.next(g_frame)) {
    const bool initial = calibrator.progress().phase == Phase::kInitialRest;
    imucal_bench_begin();
    calibrator.add_raw(g_frame);
    imucal_bench_end();
    bench_announce(initial ? "add_raw() at 1 kHz: initial rest, per frame"
                           : "add_raw() at 1 kHz: after it, per frame");
  }
  std::printf("RESULT integer path: %d poses frame by frame, %d in FIFO batches; 1 kHz: %d poses\n",
              poses_raw, poses_fifo, calibrator.progress().poses);
  return poses_raw > 30 && poses_fifo > 30;
}

}  // namespace

int main() {
#ifdef IMUCAL_BENCH_RAW_FIRST
  // Built with this defined, the integer path runs alone: its first 51,175 regions are the
  // recording's add_raw() calls, for bench/insn_profile.py; with IMUCAL_BENCH_PROFILE_STILL as
  // well, its first regions are those of the frames that come while the calibrator is still after
  // the initial rest.
  return raw_paths() ? 0 : 1;
#endif
  // The add() series starts here rather than just before the loop: there, the call changed the
  // register allocation of the add() code GCC inlines into main, and with it the counts (by one
  // instruction either way on some samples). Here they come out the same as without measuring.
  bench::stack_series_start(kAddStackWindow);
  calibrator.reset(test::xsens_calibrator_settings());
  test::XsensStream in;
  if (!in.open(test::find_xsens_dir())) {
    std::printf("%s\n", in.error().c_str());
    return 1;
  }
  double t = 0;
  Vector3<float> acc, gyro;
  while (in.next(t, acc, gyro)) {
    sample.t_us = static_cast<std::uint32_t>(std::llround(t * 1e6));
    sample.acc = acc;
    sample.gyro = gyro;
    const bool initial = calibrator.progress().phase == Phase::kInitialRest;
    bench::stack_paint();
    imucal_bench_begin();
    calibrator.add(sample);
    imucal_bench_end();
    bench::stack_measure();
    // Named after the fact (the region is already counted; the plugin pairs them in order).
    bench_announce(initial              ? "add(): initial rest, per sample"
                   : calibrator.still() ? "add(): still, per sample"
                                        : "add(): moving, per sample");
  }
  bench::report_stack("add()");
  bench::stack_series_start(0);  // all of the free stack, every time
  bench::stack_paint();
  imucal_bench_begin();
  Status st = calibrator.solve();
  imucal_bench_end();
  bench::stack_measure();
  bench_announce("solve(): close the collection, start the accelerometer");
  while (st == Status::kRunning) {
    const bool gyro_stage = calibrator.solving_gyro();
    bench::stack_paint();
    imucal_bench_begin();
    st = calibrator.solve_step();
    imucal_bench_end();
    bench::stack_measure();
    bench_announce(gyro_stage ? "solve_step(): gyro, per step"
                              : "solve_step(): accelerometer, per step");
  }
  bench::report_stack("solve()/solve_step()");
  const Progress p = calibrator.progress();
  const Status solved = st;
  std::printf("RESULT %s: %d poses, %d moves, %d segments, gyro %d iterations, sizeof %u\n",
              to_string(st), p.poses, p.moves, p.segments, calibrator.calibration().gyro.iterations,
              static_cast<unsigned>(sizeof(calibrator)));
  // The smaller configurations docs/porting.md lists.
  std::printf(
      "RESULT sizeof Calibrator<float, 32, 400> %u, <float, 24, 630> %u, <float, 24, 315> %u\n",
      static_cast<unsigned>(sizeof(Calibrator<float, 32, 400>)),
      static_cast<unsigned>(sizeof(Calibrator<float, 24, 630>)),
      static_cast<unsigned>(sizeof(Calibrator<float, 24, 315>)));
  std::printf("RESULT sizeof RestMonitor<float> %u\n",
              static_cast<unsigned>(sizeof(RestMonitor<float>)));
  return succeeded(solved) && raw_paths() ? 0 : 1;
}
