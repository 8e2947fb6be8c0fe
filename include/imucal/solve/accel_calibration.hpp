// SPDX-License-Identifier: MIT
// imucal/solve/accel_calibration.hpp: accelerometer misalignment, scale and bias from still poses.
// A closed-form ellipsoid fit starts a Levenberg-Marquardt run on the seed's gravity-norm
// residual; no initial guess is asked of the user. Readings are centred and scaled internally,
// so raw ADC counts (~33000) and SI units both work in float. Fixed memory, no allocation, no
// exceptions; solving can be time-sliced (one LM iteration per step()).
#pragma once

#include <cstdint>

#include "imucal/models/accel_model.hpp"
#include "imucal/models/calibration.hpp"
#include "imucal/solve/levenberg_marquardt.hpp"
#include "imucal/solve/pose_store.hpp"
#include "imucal/status.hpp"

namespace imucal {

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
  // Above this normalised sigma (a quarter of the bound: 0.3 deg, 0.5 %, 0.5 % of gravity) a
  // parameter is weak: named in the result (AccelCalibration::weak) for the orientations that
  // would pin it down (accel_orientation_hint()).
  Scalar weak_normalised_sigma = Scalar(0.005);
  // With the poses' noise (Pose::noise), a misalignment the poses do not determine (sigma above
  // max_normalised_sigma) is held at 0, its nominal value, and named (AccelCalibration::held),
  // instead of refusing the calibration; false, or without the noise: refused with
  // kUnobservable, as any scale or bias the poses do not determine is.
  bool hold_undetermined_misalignment = true;
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

// Sigma. When every pose carries its noise (Pose::noise, as the streaming calibrator measures
// it), a pose's residual has the variance its mean's noise gives it, and sigma comes from that
// model: honest with ten poses, where the fit's own scatter has one degree of freedom. The model
// is then checked against the fit: a chi-square above its degrees of freedom means noise the
// rests' scatter does not show (bias instability, a hand's slow sway, a mean over a long rest
// that is not as good as its sample count says), and a floor common to every pose mean
// (pose_floor) is added until they agree, which also caps a long rest's weight; sigma is scaled
// by (chi2 + 8) / (dof + 8): the model where the fit has few degrees of freedom, the fit's scatter
// where it has many. Without the noise, poses are weighted by sample count and sigma is scaled
// by the fit's scatter alone.
// (AccelCalibration, in calibration.hpp, carries the result.)

// Parameter k (AccelIndex) by name (kAccelParamNames: "alpha_yz" .. "b_z"), and the orientations
// that pin it down, in words, for a weak or held one.
const char* accel_parameter_name(int k);
const char* accel_orientation_hint(int k);

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
  int iterations() const { return iterations_before_ + lm_.iterations(); }
  // After a usable finish(): the covariance of the parameters in sensor units, whose diagonal is
  // AccelCalibration::sigma squared (a held parameter's row and column are 0).
  Status covariance(Eigen::Matrix<Scalar, kAccelParams, kAccelParams>& cov) const;

  // The LM's: the 9 unknowns at run-time size 9 in the capacity the gyro's solver shares
  // (kSolverCapacity), the entries beyond them 0.
  using Lm = LevenbergMarquardt<Scalar, kSolverCapacity>;
  using LmVector = typename Lm::Vector;
  static_assert(kAccelParams <= kSolverCapacity, "the accelerometer's unknowns exceed the LM's");

  // The residual problem in normalised units (public for the LM's Problem interface).
  struct Problem {
    PoseSpan<Scalar> poses;
    Vector3<Scalar> centre = Vector3<Scalar>::Zero();
    Scalar scale = Scalar(1);
    bool noise_model = false;                                     // every pose carries its noise
    AccelVector<Scalar> p_weights = AccelVector<Scalar>::Zero();  // weights evaluated here
    Scalar floor = Scalar(0);  // variance added to each residual's (normalised units)
    std::uint16_t held = 0;    // parameters held at 0 by a stiff prior row
    // The weight of pose i: its sample count, or 1 / the variance of its residual.
    Scalar weight(int i) const;
    Status accumulate(const LmVector& p, typename Lm::Accumulator& ne) const;
  };

 private:
  LmSettings<Scalar> lm_settings() const;
  Status restart(const AccelVector<Scalar>& from);
  Status after_convergence(Status lm_status);
  bool hold_or_refuse(const AccelVector<Scalar>& p);
  int dof() const;
  Scalar chi2(const AccelVector<Scalar>& p) const;
  Scalar sigma_factor(const AccelVector<Scalar>& p) const;
  AccelVector<Scalar> sensor_units() const;
  AccelVector<Scalar> parameters() const { return lm_.parameters().template head<kAccelParams>(); }
  Status start_lm(const AccelVector<Scalar>& p0);

  AccelSettings<Scalar> settings_;
  Problem problem_{};
  Lm lm_;
  Status status_ = Status::kNotStarted;
  int floor_rounds_ = 0;
  bool reweighted_ = false;
  int iterations_before_ = 0;  // LM iterations of the runs before the current one
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
