// bench/insn/bench_stream.cpp: instruction counts of the streaming calibrator on the cross
// targets (bench/run_insn_bench.sh, QEMU with the counting plugin): the real xsens recording
// (51,175 samples, raw counts) fed one sample at a time, each add() its own region, named by how
// the calibrator classified the sample; then the solve, each solve_step() its own region. The
// script sums regions of the same name. Not a test: it reports, it does not judge.
// It also reports the deepest stack use of add() and of solve() + solve_step() ("STACK" lines:
// bytes below main's stack pointer, stack_paint.hpp), painted before and measured after each
// call, outside the counted regions.
#include <cmath>
#include <cstdio>

#include "imucal/calibrator/calibrator.hpp"
#include "markers.hpp"
#include "stack_paint.hpp"
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

// Prints the stack series just measured (stack_paint.hpp) as "STACK <name>: <bytes> B".
[[gnu::noinline]] void report_stack(const char* name) {
  const bench::StackSeries s = bench::stack_series_result();
  if (s.measures == 0) {
    std::printf("STACK %s: not measured (no paint routine for this core)\n", name);
  } else if (s.sp_moved) {
    std::printf("STACK %s: not measured (main's SP moved between the calls)\n", name);
  } else if (s.window_overflow) {
    std::printf("STACK %s: not measured (something went deeper than the %u B window)\n", name,
                static_cast<unsigned>(s.window));
  } else {
    std::printf("STACK %s: %u B\n", name, static_cast<unsigned>(s.max_bytes));
  }
}
}  // namespace

int main() {
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
  report_stack("add()");
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
  report_stack("solve()/solve_step()");
  const Progress p = calibrator.progress();
  std::printf("RESULT %s: %d poses, %d moves, %d segments, gyro %d iterations, sizeof %u\n",
              to_string(st), p.poses, p.moves, p.segments, calibrator.calibration().gyro.iterations,
              static_cast<unsigned>(sizeof(calibrator)));
  // The smaller configurations docs/porting.md lists.
  std::printf(
      "RESULT sizeof Calibrator<float, 32, 400> %u, <float, 24, 630> %u, <float, 24, 315> %u\n",
      static_cast<unsigned>(sizeof(Calibrator<float, 32, 400>)),
      static_cast<unsigned>(sizeof(Calibrator<float, 24, 630>)),
      static_cast<unsigned>(sizeof(Calibrator<float, 24, 315>)));
  return succeeded(st) ? 0 : 1;
}
