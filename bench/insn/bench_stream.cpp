// bench/insn/bench_stream.cpp: instruction counts of the streaming calibrator on the Arm targets
// (bench/run_insn_bench.sh, QEMU with the counting plugin): the real xsens recording (51,175
// samples, raw counts) fed one sample at a time, each add() its own region, named by how the
// calibrator classified the sample; then the solve, each solve_step() its own region. The
// script sums regions of the same name. Not a test: it reports, it does not judge.
#include <cmath>
#include <cstdio>

#include "imucal/calibrator.hpp"
#include "markers.hpp"
#include "support/xsens_reader.hpp"
#include "support/xsens_settings.hpp"

using namespace imucal;

namespace {
Calibrator<float> calibrator;  // global: no guard, no stack
// The sample is written here before the begin marker (its memory clobber orders the stores),
// so that converting the file's double timestamp (soft-float on the M4F) is not counted.
ImuSample<float> sample;
}  // namespace

int main() {
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
    imucal_bench_begin();
    calibrator.add(sample);
    imucal_bench_end();
    // Named after the fact (the region is already counted; the plugin pairs them in order).
    bench_announce(initial              ? "add(): initial rest, per sample"
                   : calibrator.still() ? "add(): still, per sample"
                                        : "add(): moving, per sample");
  }
  imucal_bench_begin();
  Status st = calibrator.solve();
  imucal_bench_end();
  bench_announce("solve(): close the collection, start the accelerometer");
  while (st == Status::kRunning) {
    const bool gyro_stage = calibrator.solving_gyro();
    imucal_bench_begin();
    st = calibrator.solve_step();
    imucal_bench_end();
    bench_announce(gyro_stage ? "solve_step(): gyro, per step"
                              : "solve_step(): accelerometer, per step");
  }
  const Progress p = calibrator.progress();
  std::printf("RESULT %s: %d poses, %d moves, %d segments, gyro %d iterations, sizeof %u\n",
              to_string(st), p.poses, p.moves, p.segments, calibrator.calibration().gyro.iterations,
              static_cast<unsigned>(sizeof(calibrator)));
  return succeeded(st) ? 0 : 1;
}
