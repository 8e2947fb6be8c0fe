// bench/host/bench_host.cpp: Google Benchmark harness for the accelerometer path on the host,
// float (device type) and double (reference), 40 simulated poses in raw counts.
#include <benchmark/benchmark.h>

#include "imucal/imucal.hpp"
#include "imucal/sim/accel_sim.hpp"

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
  imucal::NormalEquations<Scalar, imucal::kAccelParams> ne;
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

BENCHMARK_TEMPLATE(BM_AccumulateOnePose, float);
BENCHMARK_TEMPLATE(BM_AccumulateOnePose, double);
BENCHMARK_TEMPLATE(BM_FullSolve40, float);
BENCHMARK_TEMPLATE(BM_FullSolve40, double);

}  // namespace
