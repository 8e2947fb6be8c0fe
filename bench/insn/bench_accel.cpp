// SPDX-License-Identifier: MIT
// bench/insn/bench_accel.cpp: instruction counts of the accelerometer path on the cross
// targets (run by bench/run_insn_bench.sh under QEMU with the counting plugin). 40 simulated poses
// in raw 16-bit counts, float, as on the device. Not a test: it reports, it does not judge.
#include <cstdint>
#include <cstdio>

#include "imucal/imucal.hpp"
#include "imucal/sim/accel_sim.hpp"
#include "markers.hpp"

using namespace imucal;

int main() {
  sim::Random rng(2024);
  const sim::AccelSensorSpec spec = sim::AccelSensorSpec::raw_counts();
  const sim::AccelTruth truth = sim::draw_accel_truth(spec, rng, 9.81);
  static PoseStore<float, 40> poses;
  while (!poses.full()) {
    const Vector3<double> m =
        sim::noisy_pose_mean(truth, spec, sim::random_direction(rng), 300, rng);
    poses.add(m.cast<float>(), 300);
  }
  AccelSettings<float> settings;
  settings.gravity = 9.81f;

  // 1. One pose row: residual, Jacobian and the fold into the accumulator, sized to the 9
  // unknowns as the solver's.
  static NormalEquations<float, kSolverCapacity> ne;
  ne.resize(kAccelParams);
  AccelVector<float> p;
  p << 0.0f, 0.0f, 0.0f, 1.0f, 1.0f, 1.0f, 0.0f, 0.0f, 0.0f;
  const Vector3<float> x(0.3f, -0.5f, 0.8f);
  bench_announce("accel: residual + Jacobian + accumulate, one pose");
  imucal_bench_begin();
  AccelVector<float> j;
  const float e = accel_residual(p, x, 1.0f, &j);
  ne.add(j, e, 300.0f);
  imucal_bench_end();

  // 2. Checks, closed-form ellipsoid start and the first accumulation, 40 poses.
  static AccelSolver<float> solver(settings);
  bench_announce("accel: start (checks + ellipsoid fit + first pass), 40 poses");
  imucal_bench_begin();
  Status s = solver.start(poses.span());
  imucal_bench_end();

  // 3. One accepted LM iteration (damped 9x9 solve + one pass over 40 poses), from a start
  // perturbed away from the closed-form fit (which is often already within one step).
  static AccelSolver<float>::Problem problem;
  problem.poses = poses.span();
  float scale = 1.0f;
  check_poses(poses.span(), settings, problem.centre, scale);
  problem.scale = scale;
  AccelVector<float> p0;
  fit_ellipsoid(poses.span(), problem.centre, scale, p0);
  for (int k = 0; k < kAccelParams; ++k) p0(k) += 0.01f;
  static AccelSolver<float>::Lm lm;
  lm.start(problem, p0);
  bench_announce("accel: one accepted LM iteration, 40 poses");
  imucal_bench_begin();
  const Status it = lm.step(problem);
  imucal_bench_end();
  std::printf("iteration: %s, lambda %d e-6\n", to_string(it),
              static_cast<int>(lm.lambda() * 1e6f));

  // 4. The whole solve, 40 poses, from the poses to the calibration with sigmas.
  static AccelCalibration<float> cal;
  bench_announce("accel: full solve incl. covariance, 40 poses");
  imucal_bench_begin();
  const Status full = calibrate_accelerometer(poses.span(), settings, cal);
  imucal_bench_end();

  std::printf("status %s, %d iterations\n", to_string(full), cal.iterations);
  return succeeded(full) && (s == Status::kRunning || succeeded(s)) && ne.rows() == 1 ? 0 : 1;
}
