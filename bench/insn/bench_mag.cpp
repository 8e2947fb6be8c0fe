// SPDX-License-Identifier: MIT
// bench/insn/bench_mag.cpp: instruction counts of the magnetometer calibration on the cross
// targets (bench/run_insn_bench.sh, QEMU with the counting plugin), float as on the device: the
// per-sample collector over a simulated free-hand stream (60 s at 50 Hz, raw counts), the whole
// solve with a full collector, and the alignment from 16 rests. Not a test: it reports, it does not
// judge.
#include <cstdint>
#include <cstdio>

#include "imucal/magnetometer/mag_calibration.hpp"
#include "imucal/sim/accel_sim.hpp"
#include "imucal/sim/mag_sim.hpp"
#include "markers.hpp"

using namespace imucal;

namespace {
constexpr int kStream = 3000;
constexpr int kRests = 16;
// The stream is simulated first (double, slow on the M4F) and kept here, so the measured loop
// only reads it. Volatile: nothing folds away.
volatile float g_stream[kStream][3];
MagCalibrator<float> calibrator;  // a global, as firmware would keep it
MagCalibration<float> result;
}  // namespace

int main() {
  sim::Random rng(2024);
  const sim::MagSensorSpec spec = [] {
    sim::MagSensorSpec s = sim::MagSensorSpec::counts();
    s.misalignment = 0.05;
    return s;
  }();
  const sim::MagTruth truth = sim::draw_mag_truth(spec, rng);
  sim::HandRotation hand(sim::HandRotation::Options{}, sim::mag_world(truth), rng);
  for (int k = 0; k < kStream; ++k) {
    const Vector3<double> m = sim::raw_mag(truth, hand.next(), spec.noise, rng);
    for (int a = 0; a < 3; ++a) g_stream[k][a] = static_cast<float>(m(a));
  }
  MagSettings<float> settings;
  settings.unit_ut = static_cast<float>(spec.unit_ut);
  calibrator.reset(settings);

  // 1. The collector, per sample.
  Status last = Status::kOk;
  for (int k = 0; k < kStream; ++k) {
    const float x = g_stream[k][0], y = g_stream[k][1], z = g_stream[k][2];
    const Vector3<float> m(x, y, z);
    bench_announce("mag: MagCalibrator::add(), per sample (60 s free-hand stream)");
    imucal_bench_begin();
    last = calibrator.add(m);
    imucal_bench_end();
  }

  // 2. The whole solve: closed form, LM, sigmas, coverage and checks.
  bench_announce("mag: solve() with the collector as filled");
  imucal_bench_begin();
  const Status solved = calibrator.solve(result);
  imucal_bench_end();

  // 3. The alignment from 16 rests (means of 200 samples), given the accelerometer's calibration.
  const sim::AccelTruth accel_truth = sim::draw_accel_truth(sim::AccelSensorSpec::si(), rng, 9.81);
  for (int i = 0; i < kRests; ++i) {
    const Matrix3<double> c = hand.random_rotation();
    const Vector3<double> m = sim::raw_mag(truth, c, spec.noise / 14.0, rng);
    const Vector3<double> a =
        sim::noisy_pose_mean(accel_truth, sim::AccelSensorSpec::si(),
                             c.transpose() * Vector3<double>::UnitZ(), 200, rng);
    calibrator.add_rest(m.cast<float>(), a.cast<float>());
  }
  AccelCalibration<float> accel;
  accel.params = accel_truth.params.cast<float>();
  accel.status = Status::kOk;
  bench_announce("mag: align() from 16 rests");
  imucal_bench_begin();
  const Status aligned = calibrator.align(accel, result);
  imucal_bench_end();

  std::printf(
      "RESULT mag: add %s, %d samples held (raw coverage %d %%), solve %s (%d iterations, "
      "coverage %d %%, fit %d.%02d %%), align %s; sizeof(MagCalibrator<float>) = %u "
      "bytes\n",
      to_string(last), calibrator.size(), static_cast<int>(calibrator.raw_coverage() * 100.0f),
      to_string(solved), result.iterations, static_cast<int>(result.coverage * 100.0f),
      static_cast<int>(result.fit_error_pct), static_cast<int>(result.fit_error_pct * 100.0f) % 100,
      to_string(aligned), static_cast<unsigned>(sizeof(MagCalibrator<float>)));
  return succeeded(solved) && succeeded(aligned) ? 0 : 1;
}
