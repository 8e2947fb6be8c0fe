// imucal/accel_calibration.hpp: accelerometer misalignment, scale and bias from still poses.
// A closed-form ellipsoid fit starts a Levenberg-Marquardt run on the seed's gravity-norm
// residual; no initial guess is asked of the user. Readings are centred and scaled internally,
// so raw ADC counts (~33000) and SI units both work in float. Fixed memory, no allocation, no
// exceptions; solving can be time-sliced (one LM iteration per step()).
#pragma once

#include "imucal/accel_model.hpp"
#include "imucal/levenberg_marquardt.hpp"
#include "imucal/pose_store.hpp"
#include "imucal/status.hpp"

namespace imucal {

// Fewest poses accepted: one more than the parameters, so that every parameter gets a sigma.
constexpr int kAccelMinPoses = kAccelParams + 1;

template <typename Scalar>
struct AccelSettings {
  Scalar gravity = Scalar(9.80665);  // m/s^2: local gravity magnitude, the calibrated norm
  // Two poses closer than this (as a fraction of the gravity radius, ~0.05 = 3 degrees) count
  // as one direction when checking that enough distinct directions were seen.
  Scalar min_pose_separation = Scalar(0.05);
  // Spread of the pose directions below which they count as one plane (the model is then not
  // observable). The measure lies between l1/(9 l3) and l1/l3 for the eigenvalues l1 <= l3 of
  // the directions' scatter: 1/9 for directions all round the sphere, 0 for one plane.
  Scalar min_spread_ratio = Scalar(1e-3);
  // Largest accepted standard deviation of any parameter in normalised units (misalignment in
  // rad, scale relative to nominal, bias as a fraction of gravity). Larger means the poses do not
  // determine that parameter, and the result is refused with kUnobservable.
  Scalar max_normalised_sigma = Scalar(0.02);
  LmSettings<Scalar> lm = default_lm();

  // In float the residual g^2 - |c|^2 cancels to about 3e-4 of itself (g^2 ~ 96 against pose
  // residuals of a few mm/s^2), so the cost carries ~1e-4 of rounding noise: a decrease below
  // 1e-6 of it cannot be confirmed, and whether the LM stopped as converged or at maximum damping
  // depended on the target's rounding (the Xsens recording: converged on x86, kNoProgress on the
  // M4F). 1e-5 stops within ~0.03 sigma of the minimum (as the gyro's, gyro_calibration.hpp).
  static LmSettings<Scalar> default_lm() {
    LmSettings<Scalar> s;
    if (sizeof(Scalar) < 8) s.cost_tolerance = Scalar(1e-5);
    return s;
  }
};

template <typename Scalar>
struct AccelCalibration {
  AccelVector<Scalar> params =
      AccelVector<Scalar>::Zero();  // seed order, sensor units in, m/s^2 out
  AccelVector<Scalar> sigma = AccelVector<Scalar>::Zero();  // one standard deviation each
  Scalar residual_rms = Scalar(0);  // m/s^2: sample-weighted RMS of |g| - |a_cal| over poses
  int poses = 0;
  int iterations = 0;
  Status status = Status::kNotStarted;
};

// The solve in steps. start() validates the poses, normalises them and computes the closed-form
// start; step() runs one LM iteration; finish() maps the result back to sensor units. The pose
// memory must stay unchanged between start() and finish().
template <typename Scalar>
class AccelSolver {
 public:
  explicit AccelSolver(const AccelSettings<Scalar>& settings = AccelSettings<Scalar>());

  Status start(PoseSpan<Scalar> poses);
  Status step();  // kRunning while more steps are needed
  // The final status. `out` holds the estimate only if succeeded(status); otherwise zeros.
  Status finish(AccelCalibration<Scalar>& out) const;
  Status status() const { return status_; }
  int iterations() const { return lm_.iterations(); }

  // The residual problem in normalised units (public for the LM's Problem interface).
  struct Problem {
    PoseSpan<Scalar> poses;
    Vector3<Scalar> centre = Vector3<Scalar>::Zero();
    Scalar scale = Scalar(1);
    Status accumulate(const AccelVector<Scalar>& p,
                      NormalEquations<Scalar, kAccelParams>& ne) const;
  };

 private:
  AccelSettings<Scalar> settings_;
  Problem problem_{};
  LevenbergMarquardt<Scalar, kAccelParams> lm_;
  Status status_ = Status::kNotStarted;
};

// Closed-form start (math.md section 2): algebraic ellipsoid fit x^T Q x + u^T x = 1 on the
// normalised pose means x = (a - centre) / scale, then Cholesky Q = R^T R. Result in the
// normalised units (unit gravity): p such that T K (x + b) has unit norm.
template <typename Scalar>
Status fit_ellipsoid(PoseSpan<Scalar> poses, const Vector3<Scalar>& centre, Scalar scale,
                     AccelVector<Scalar>& p_normalised);

// Checks that the poses can determine the 9 parameters: count, finiteness, distinct
// directions, not all in one plane (see min_spread_ratio). Also returns the centre and scale
// used to normalise.
template <typename Scalar>
Status check_poses(PoseSpan<Scalar> poses, const AccelSettings<Scalar>& settings,
                   Vector3<Scalar>& centre, Scalar& scale);

// Run to completion (the same steps as the time-sliced form, in one call).
template <typename Scalar>
Status calibrate_accelerometer(PoseSpan<Scalar> poses, const AccelSettings<Scalar>& settings,
                               AccelCalibration<Scalar>& out) {
  AccelSolver<Scalar> solver(settings);
  Status s = solver.start(poses);
  while (s == Status::kRunning) s = solver.step();
  return solver.finish(out);
}

extern template class AccelSolver<float>;
extern template class AccelSolver<double>;

}  // namespace imucal
