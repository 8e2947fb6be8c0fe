// SPDX-License-Identifier: MIT
// bench/host/bench_host.cpp: Google Benchmark harness on the host, float (device type) and double
// (reference): the accelerometer path on 40 simulated poses in raw counts, and the streaming
// calibrator on a simulated recording (30 rests, raw counts): per sample, and the whole solve.
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "imucal/imucal.hpp"
#include "imucal/sim/accel_sim.hpp"
#include "imucal/sim/motion_sim.hpp"

namespace {

template <typename Scalar>
imucal::PoseStore<Scalar, 40> make_poses() {
  imucal::sim::Random rng(2024);
  const auto spec = imucal::sim::AccelSensorSpec::raw_counts();
  const auto truth = imucal::sim::draw_accel_truth(spec, rng, 9.81);
  imucal::PoseStore<Scalar, 40> poses;
  while (!poses.full())
    poses.add(
        imucal::sim::noisy_pose_mean(truth, spec, imucal::sim::random_direction(rng), 300, rng)
            .template cast<Scalar>(),
        300);
  return poses;
}

template <typename Scalar>
void BM_AccumulateOnePose(benchmark::State& state) {
  imucal::NormalEquations<Scalar, imucal::kSolverCapacity> ne;  // as the solver's: sized to 9
  ne.resize(imucal::kAccelParams);
  imucal::AccelVector<Scalar> p;
  p << 0, 0, 0, 1, 1, 1, 0, 0, 0;
  const imucal::Vector3<Scalar> x(Scalar(0.3), Scalar(-0.5), Scalar(0.8));
  for (auto _ : state) {
    imucal::AccelVector<Scalar> j;
    const Scalar e = imucal::accel_residual(p, x, Scalar(1), &j);
    benchmark::DoNotOptimize(ne.add(j, e, Scalar(300)));
  }
}

template <typename Scalar>
void BM_FullSolve40(benchmark::State& state) {
  const auto poses = make_poses<Scalar>();
  imucal::AccelSettings<Scalar> settings;
  settings.gravity = Scalar(9.81);
  for (auto _ : state) {
    imucal::AccelCalibration<Scalar> cal;
    benchmark::DoNotOptimize(imucal::calibrate_accelerometer(poses.span(), settings, cal));
    benchmark::DoNotOptimize(cal);
  }
}

const imucal::sim::Recording& recording() {
  static const imucal::sim::Recording rec = [] {
    imucal::sim::Random rng(11);
    imucal::sim::MotionPlan plan;
    plan.record_attitude = false;
    return imucal::sim::simulate_motion(plan, imucal::sim::AccelSensorSpec::raw_counts(),
                                        imucal::sim::GyroSensorSpec::raw_counts(), rng);
  }();
  return rec;
}

template <typename Scalar>
imucal::CalibratorSettings<Scalar> stream_settings() {
  imucal::CalibratorSettings<Scalar> s;
  s.accel.gravity = Scalar(9.81);
  s.gyro.nominal_scale = Scalar(1.0 / 4770.0);
  return s;
}

template <typename Scalar>
std::vector<imucal::ImuSample<Scalar>> samples() {
  std::vector<imucal::ImuSample<Scalar>> out;
  for (const auto& m : recording().samples) {
    imucal::ImuSample<Scalar> s;
    s.t_us = static_cast<std::uint32_t>(std::llround(m.t * 1e6));
    s.acc = m.acc.cast<Scalar>();
    s.gyro = m.gyro.cast<Scalar>();
    out.push_back(s);
  }
  return out;
}

// add() per sample over the whole recording (initial rest, rests and moves, in their mix).
template <typename Scalar>
void BM_CalibratorPerSample(benchmark::State& state) {
  const auto input = samples<Scalar>();
  static imucal::Calibrator<Scalar> cal;
  for (auto _ : state) {
    cal = imucal::Calibrator<Scalar>(stream_settings<Scalar>());
    for (const auto& s : input) benchmark::DoNotOptimize(cal.add(s));
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(input.size()));
}

// solve_all() after the stream: accelerometer and gyro (9 parameters).
template <typename Scalar>
void BM_CalibratorSolve(benchmark::State& state) {
  const auto input = samples<Scalar>();
  static imucal::Calibrator<Scalar> collected, cal;
  collected = imucal::Calibrator<Scalar>(stream_settings<Scalar>());
  for (const auto& s : input) collected.add(s);
  for (auto _ : state) {
    cal = collected;
    benchmark::DoNotOptimize(cal.solve_all());
  }
}

BENCHMARK_TEMPLATE(BM_AccumulateOnePose, float);
BENCHMARK_TEMPLATE(BM_AccumulateOnePose, double);
BENCHMARK_TEMPLATE(BM_FullSolve40, float);
BENCHMARK_TEMPLATE(BM_FullSolve40, double);
BENCHMARK_TEMPLATE(BM_CalibratorPerSample, float)->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_CalibratorPerSample, double)->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_CalibratorSolve, float)->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_CalibratorSolve, double)->Unit(benchmark::kMillisecond);

}  // namespace
