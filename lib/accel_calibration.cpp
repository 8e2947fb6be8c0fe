// SPDX-License-Identifier: MIT
// Accelerometer calibration: pose checks, closed-form ellipsoid start, normalised LM, and the
// mapping back to sensor units. Instantiated for float (device) and double (reference).
#include "imucal/solve/accel_calibration.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>

#include "quadric.hpp"

namespace imucal {
namespace {

// A pose mean in the solver's units: centred, and divided by the RMS radius (one reciprocal per
// pass, not three divisions per pose).
template <typename Scalar>
Vector3<Scalar> normalised(const Pose<Scalar>& pose, const Vector3<Scalar>& centre,
                           Scalar inv_scale) {
  return (pose.mean - centre) * inv_scale;
}

// The variance factor of sigma: (chi2 + k) / (dof + k) under the noise model (k = 8 pseudo
// degrees of freedom for the model itself), or -1 (the fit's scatter) without it.
template <typename Scalar>
Scalar sigma_variance(bool noise_model, Scalar chi2, int dof) {
  if (!noise_model) return Scalar(-1);
  constexpr Scalar kModelDof = Scalar(8);
  return (chi2 + kModelDof) / (static_cast<Scalar>(dof) + kModelDof);
}

}  // namespace

template <typename Scalar>
Status check_poses(PoseSpan<Scalar> poses, const AccelSettings<Scalar>& settings,
                   Vector3<Scalar>& centre, Scalar& scale) {
  if (poses.data == nullptr && poses.size != 0) return Status::kInvalidArgument;
  if (!(settings.gravity > Scalar(0)) || !std::isfinite(settings.gravity) ||
      !(settings.min_pose_separation >= Scalar(0)) || !(settings.min_spread_ratio >= Scalar(0)) ||
      !(settings.max_normalised_sigma > Scalar(0)))
    return Status::kInvalidArgument;
  for (int i = 0; i < poses.size; ++i) {
    if (!all_finite(poses[i].mean)) return Status::kNonFiniteInput;
    if (poses[i].samples == 0) return Status::kInvalidArgument;
  }
  // A covariance needs more residuals than parameters: 9 poses would fit exactly, with no sigma.
  if (poses.size < kAccelMinPoses) return Status::kTooFewPoses;

  // Centre on the mean of the means, shifted by the first pose so float sums stay small.
  const Vector3<Scalar> origin = poses[0].mean;
  Vector3<Scalar> sum = Vector3<Scalar>::Zero();
  for (int i = 0; i < poses.size; ++i) sum += poses[i].mean - origin;
  centre = origin + sum / Scalar(poses.size);
  Scalar sq = Scalar(0);
  for (int i = 0; i < poses.size; ++i) sq += (poses[i].mean - centre).squaredNorm();
  scale = std::sqrt(sq / Scalar(poses.size));
  if (!(scale > Scalar(0)) || !std::isfinite(scale)) return Status::kTooFewDistinctPoses;

  // Distinct directions: a pose counts if no earlier counted pose lies within the separation.
  const Scalar sep = settings.min_pose_separation * scale;
  const Scalar sep2 = sep * sep;  // squared distances: no square root per pair
  int distinct = 0;
  for (int i = 0; i < poses.size; ++i) {
    bool is_new = true;
    for (int j = 0; j < i && is_new; ++j) {
      if ((poses[i].mean - poses[j].mean).squaredNorm() < sep2) is_new = false;
    }
    if (is_new) ++distinct;
  }
  if (distinct < kAccelParams) return Status::kTooFewDistinctPoses;

  // Spread without an eigen-solver (whose trigonometry costs ~3 KB of flash): for the scatter S
  // of the normalised means with eigenvalues l1 <= l2 <= l3, det / (m2 tr) with m2 the sum of the
  // principal 2x2 minors lies between l1 / (9 l3) and l1 / l3, and is exactly 0 for coplanar poses.
  Matrix3<Scalar> scatter = Matrix3<Scalar>::Zero();
  const Scalar inv_scale = Scalar(1) / scale;
  for (int i = 0; i < poses.size; ++i) {
    const Vector3<Scalar> x = normalised(poses[i], centre, inv_scale);
    scatter += x * x.transpose();
  }
  const Matrix3<Scalar>& m = scatter;
  const Scalar minors = m(0, 0) * m(1, 1) - m(0, 1) * m(0, 1) + m(0, 0) * m(2, 2) -
                        m(0, 2) * m(0, 2) + m(1, 1) * m(2, 2) - m(1, 2) * m(1, 2);
  const Scalar spread = m.determinant() / (minors * m.trace());  // in [l1/(9 l3), l1/l3]
  if (!std::isfinite(spread) || spread < settings.min_spread_ratio) return Status::kPosesCoplanar;
  return Status::kOk;
}

namespace {

// T K and b (normalised) from the quadric x^T Q x + u^T x = 1, when it is an ellipsoid.
template <typename Scalar>
Status params_from_quadric(const AccelVector<Scalar>& theta, AccelVector<Scalar>& p_normalised) {
  Matrix3<Scalar> q;
  Vector3<Scalar> u;
  detail::quadric_from(theta, q, u);
  Eigen::LLT<Matrix3<Scalar>> llt_q(q);
  if (llt_q.info() != Eigen::Success) return Status::kNotAnEllipsoid;
  const Vector3<Scalar> c = Scalar(-0.5) * llt_q.solve(u);  // ellipsoid centre
  const Scalar r = Scalar(1) + c.dot(q * c);                // (x-c)^T Q (x-c) = r
  if (!(r > Scalar(0)) || !all_finite(c)) return Status::kNotAnEllipsoid;
  Eigen::LLT<Matrix3<Scalar>> llt(q / r);
  if (llt.info() != Eigen::Success) return Status::kNotAnEllipsoid;
  const Matrix3<Scalar> rm = llt.matrixU();  // Q/r = R^T R, R upper triangular = T K
  AccelVector<Scalar> p;
  p(kScaleX) = rm(0, 0);
  p(kScaleY) = rm(1, 1);
  p(kScaleZ) = rm(2, 2);
  p(kAlphaYz) = -rm(0, 1) / rm(1, 1);
  p(kAlphaZy) = rm(0, 2) / rm(2, 2);
  p(kAlphaZx) = -rm(1, 2) / rm(2, 2);
  p(kBiasX) = -c(0);
  p(kBiasY) = -c(1);
  p(kBiasZ) = -c(2);
  if (!all_finite(p)) return Status::kNotAnEllipsoid;
  p_normalised = p;
  return Status::kOk;
}

}  // namespace

template <typename Scalar>
Status fit_ellipsoid(PoseSpan<Scalar> poses, const Vector3<Scalar>& centre, Scalar scale,
                     AccelVector<Scalar>& p_normalised) {
  if (poses.size < kAccelParams) return Status::kTooFewPoses;
  // x^T Q x + u^T x = 1, theta = [Q00 Q11 Q22 Q01 Q02 Q12 u0 u1 u2]: a linear least-squares
  // problem, accumulated in the same normal-equations form (residual phi.theta - 1, at theta=0).
  Scalar mean_n = Scalar(0);
  for (int i = 0; i < poses.size; ++i) mean_n += Scalar(poses[i].samples);
  mean_n /= Scalar(poses.size);
  NormalEquations<Scalar, kSolverCapacity> ne;  // the solvers' capacity: one copy of its code
  ne.resize(kAccelParams);
  const Scalar inv_scale = Scalar(1) / scale;
  for (int i = 0; i < poses.size; ++i) {
    const Vector3<Scalar> x = normalised(poses[i], centre, inv_scale);
    const Status s = ne.add(detail::quadric_row(x), Scalar(-1), Scalar(poses[i].samples) / mean_n);
    if (s != Status::kOk) return s;
  }
  typename NormalEquations<Scalar, kSolverCapacity>::Vector theta;
  Status s = ne.solve_damped(Scalar(0), theta);
  if (s != Status::kOk) return s;
  // Exact on noise-free poses.
  s = params_from_quadric(AccelVector<Scalar>(theta.template head<kAccelParams>()), p_normalised);
  if (s != Status::kNotAnEllipsoid) return s;

  // A term no pose excites (x0 x1 when no pose has gravity between x and y) is set by the noise
  // alone and can make the quadric indefinite. Once more with a weak pull toward the unit sphere
  // (Q = I, u = 0), 1e-4 of the data's information on each coefficient: it settles such a term
  // and moves the others less than the LM run corrects anyway. Poses that lie on a quadric that
  // is not an ellipsoid stay one.
  Scalar trace = Scalar(0);
  for (int k = 0; k < kAccelParams; ++k) trace += ne.h(k, k);
  const Scalar pull = Scalar(1e-4) * trace;
  for (int k = 0; k < kAccelParams; ++k) {
    s = ne.add(AccelVector<Scalar>(AccelVector<Scalar>::Unit(k)), k < 3 ? Scalar(-1) : Scalar(0),
               pull);
    if (s != Status::kOk) return s;
  }
  s = ne.solve_damped(Scalar(0), theta);
  if (s != Status::kOk) return s;
  return params_from_quadric(AccelVector<Scalar>(theta.template head<kAccelParams>()),
                             p_normalised);
}

template <typename Scalar>
Scalar AccelSolver<Scalar>::Problem::weight(int i) const {
  const Pose<Scalar>& pose = poses[i];
  if (!noise_model) return Scalar(pose.samples);
  // var e = (dE/dx) Cov(x) (dE/dx)^T with dE/dx = dE/db = -2 (T K)^T c: the noise of the mean on
  // each axis, noise / samples (normalised), times |dE/db|^2, plus the floor.
  const Vector3<Scalar> x = normalised(pose, centre, Scalar(1) / scale);
  AccelVector<Scalar> j;
  accel_residual(p_weights, x, Scalar(1), &j);
  const Scalar db2 = j(kBiasX) * j(kBiasX) + j(kBiasY) * j(kBiasY) + j(kBiasZ) * j(kBiasZ);
  const Scalar var_mean = pose.noise / (scale * scale * static_cast<Scalar>(pose.samples));
  return Scalar(1) / (var_mean * db2 + floor);
}

template <typename Scalar>
Status AccelSolver<Scalar>::Problem::accumulate(const LmVector& lm_p,
                                                typename Lm::Accumulator& ne) const {
  const AccelVector<Scalar> p = lm_p.template head<kAccelParams>();
  const Scalar inv_scale = Scalar(1) / scale;
  for (int i = 0; i < poses.size; ++i) {
    const Vector3<Scalar> x = normalised(poses[i], centre, inv_scale);
    AccelVector<Scalar> j;
    const Scalar e = accel_residual(p, x, Scalar(1), &j);
    const Status s = ne.add(j, e, weight(i));
    if (s != Status::kOk) return s;
  }
  // A held parameter: a stiff prior row at its nominal value 0 (a sigma of 1e-6 rad).
  for (int k = 0; k < kAccelParams; ++k) {
    if (!(held & (1u << k))) continue;
    AccelVector<Scalar> j = AccelVector<Scalar>::Zero();
    j(k) = Scalar(1);
    const Status s = ne.add(j, p(k), Scalar(1e12));
    if (s != Status::kOk) return s;
  }
  return Status::kOk;
}

template <typename Scalar>
AccelSolver<Scalar>::AccelSolver(const AccelSettings<Scalar>& settings)
    : settings_(settings), lm_(settings.lm) {}

// Residual degrees of freedom: poses less the parameters estimated (a held one is not).
template <typename Scalar>
int AccelSolver<Scalar>::dof() const {
  int held = 0;
  for (int k = 0; k < kAccelParams; ++k) held += (problem_.held >> k) & 1;
  return problem_.poses.size - (kAccelParams - held);
}

// The variance factor of sigma at p. Under the noise model with a floor, the floor is itself
// estimated from the dof residuals (chi2 = dof by construction), so a parameter's error over its
// sigma follows Student's t with dof degrees of freedom, whose variance is dof / (dof - 2): sigma's
// variance is widened by that much times the floor's share of the residuals' variance (1 + f 2 /
// (dof - 2)), which makes error / sigma have unit variance where the floor dominates.
template <typename Scalar>
Scalar AccelSolver<Scalar>::sigma_factor(const AccelVector<Scalar>& p) const {
  const int m = dof();
  const Scalar factor = sigma_variance(problem_.noise_model, chi2(p), m);
  if (!(problem_.floor > Scalar(0)) || m <= 2 || problem_.poses.size == 0) return factor;
  Scalar share = Scalar(0);
  for (int i = 0; i < problem_.poses.size; ++i) share += problem_.floor * problem_.weight(i);
  share /= static_cast<Scalar>(problem_.poses.size);
  return factor * (Scalar(1) + share * Scalar(2) / static_cast<Scalar>(m - 2));
}

template <typename Scalar>
Scalar AccelSolver<Scalar>::chi2(const AccelVector<Scalar>& p) const {
  Scalar sum = Scalar(0);
  const Scalar inv_scale = Scalar(1) / problem_.scale;
  for (int i = 0; i < problem_.poses.size; ++i) {
    const Vector3<Scalar> x = normalised(problem_.poses[i], problem_.centre, inv_scale);
    const Scalar e = accel_residual(p, x, Scalar(1));
    sum += problem_.weight(i) * e * e;
  }
  return sum;
}

// Under the noise model the cost is a chi-square: a decrease below 1e-2 moves the parameters by
// about 0.1 sigma. In float the cost itself is that uncertain (|c|^2 rounds to ~3e-7 of itself,
// a few thousandths of a residual's sigma at a pose's noise), so a relative tolerance alone left
// a near-exact ten-pose fit at maximum damping (kNoProgress) in 4 % of recordings.
template <typename Scalar>
LmSettings<Scalar> AccelSolver<Scalar>::lm_settings() const {
  LmSettings<Scalar> s = settings_.lm;
  if (problem_.noise_model && !(s.absolute_cost_tolerance > Scalar(0)))
    s.absolute_cost_tolerance = Scalar(1e-2);
  return s;
}

// A new LM run from p0, with the settings for the present weights (lm_settings()).
template <typename Scalar>
Status AccelSolver<Scalar>::start_lm(const AccelVector<Scalar>& p0) {
  lm_.reset(lm_settings());
  return lm_.start(problem_, p0);
}

template <typename Scalar>
Status AccelSolver<Scalar>::restart(const AccelVector<Scalar>& from) {
  iterations_before_ += lm_.iterations();
  AccelVector<Scalar> p = from;
  for (int k = 0; k < kAccelParams; ++k)
    if (problem_.held & (1u << k)) p(k) = Scalar(0);
  problem_.p_weights = p;
  const Status s = start_lm(p);
  if (s != Status::kRunning && !succeeded(s)) return status_ = s;
  return status_ = (succeeded(s) ? after_convergence(s) : s);
}

// Whether the poses determine every parameter at p. A misalignment they do not (sigma above
// max_normalised_sigma, from the noise model: without it sigma is not trusted that far) is held
// at 0, the worst first (the others often follow it), and the solve restarts; a scale or bias they
// do not is kUnobservable. True when it decided (status_ set), false when every free parameter is
// determined.
template <typename Scalar>
bool AccelSolver<Scalar>::hold_or_refuse(const AccelVector<Scalar>& p) {
  const Scalar limit = settings_.max_normalised_sigma;
  const Scalar variance = sigma_factor(p);
  LmVector sd;
  const Status s = lm_.normal_equations().standard_deviations(sd, variance);
  if (s != Status::kOk) {
    status_ = s;
    return true;
  }
  int worst = -1;
  bool undetermined = false;
  for (int k = 0; k < kAccelParams; ++k) {
    if ((problem_.held & (1u << k)) || sd(k) <= limit) continue;
    const bool misalignment = k == kAlphaYz || k == kAlphaZy || k == kAlphaZx;
    if (misalignment && settings_.hold_undetermined_misalignment && problem_.noise_model) {
      if (worst < 0 || sd(k) > sd(worst)) worst = k;
    } else {
      undetermined = true;
    }
  }
  if (worst >= 0) {
    problem_.held = static_cast<std::uint16_t>(problem_.held | (1u << worst));
    restart(p);
    return true;
  }
  if (undetermined) {
    status_ = Status::kUnobservable;
    return true;
  }
  return false;
}

// The LM run converged: hold a misalignment the poses do not determine; then, under the noise
// model, check it against the fit (a floor where chi2 exceeds its degrees of freedom) and re-solve
// with the new weights until the floor settles; then done.
template <typename Scalar>
Status AccelSolver<Scalar>::after_convergence(Status lm_status) {
  const AccelVector<Scalar> p = parameters();
  if (hold_or_refuse(p)) return status_;
  // The weights were evaluated at the closed-form start, which can be far off where the poses
  // barely determine a parameter: once more with them at the solution.
  if (problem_.noise_model && !reweighted_) {
    reweighted_ = true;
    return restart(p);
  }
  // The floor: the variance q added to every residual's so that sum e^2 / (v + q) = dof, by
  // Newton's method from q = 0 (the sum is convex and decreasing in q: monotone from below),
  // with the residuals and weights of the latest solution: the first solution, without a floor,
  // fits the long rests too closely, so q is found again after each re-solve (within 10 %, at
  // most 4 times). Only with a few degrees of freedom to tell a floor from chance (4; with fewer
  // the factor (chi2 + 8) / (dof + 8) alone scales sigma).
  constexpr int kFloorMinDof = 4;
  constexpr int kFloorRounds = 4;
  const int m = dof();
  if (!problem_.noise_model || floor_rounds_ >= kFloorRounds || m < kFloorMinDof)
    return status_ = lm_status;
  ++floor_rounds_;
  const Scalar previous = problem_.floor;
  problem_.p_weights = p;
  problem_.floor = Scalar(0);
  const Scalar target = static_cast<Scalar>(m);
  const Scalar inv_scale = Scalar(1) / problem_.scale;
  Scalar q = Scalar(0);
  for (int it = 0; it < 50; ++it) {
    Scalar h = -target, dh = Scalar(0);
    for (int i = 0; i < problem_.poses.size; ++i) {
      const Vector3<Scalar> x = normalised(problem_.poses[i], problem_.centre, inv_scale);
      const Scalar e = accel_residual(p, x, Scalar(1));
      const Scalar v = Scalar(1) / problem_.weight(i) + q;
      h += e * e / v;
      dh -= e * e / (v * v);
    }
    if (!(h > Scalar(0)) || !(dh < Scalar(0)) || !std::isfinite(h)) break;
    const Scalar next = q - h / dh;
    if (!(next > q) || !std::isfinite(next)) break;
    const bool done = next - q <= Scalar(1e-4) * next;
    q = next;
    if (done) break;
  }
  problem_.floor = q;
  const Scalar change = q > previous ? q - previous : previous - q;
  if (!(change > Scalar(0.1) * q)) {
    problem_.floor = previous;  // the weights the solution was found with
    return status_ = lm_status;
  }
  return restart(p);
}

template <typename Scalar>
Status AccelSolver<Scalar>::start(PoseSpan<Scalar> poses) {
  lm_.reset(settings_.lm);
  problem_ = Problem{};
  problem_.poses = poses;
  floor_rounds_ = 0;
  reweighted_ = false;
  iterations_before_ = 0;
  Status s = check_poses(poses, settings_, problem_.centre, problem_.scale);
  if (s != Status::kOk) return status_ = s;
  problem_.noise_model = true;
  for (int i = 0; i < poses.size; ++i)
    problem_.noise_model = problem_.noise_model && poses[i].noise > Scalar(0);
  AccelVector<Scalar> p0;
  s = fit_ellipsoid(poses, problem_.centre, problem_.scale, p0);
  if (s != Status::kOk) return status_ = s;
  problem_.p_weights = p0;
  s = start_lm(p0);
  if (s != Status::kRunning && !succeeded(s)) return status_ = s;
  if (succeeded(s)) return status_ = after_convergence(s);
  // Observability before iterating: the closed-form start is already close to the optimum, so
  // sigma there shows whether the poses determine every parameter (a flat valley would
  // otherwise only end at the iteration cap).
  if (hold_or_refuse(p0)) return status_;
  return status_ = s;
}

template <typename Scalar>
Status AccelSolver<Scalar>::step() {
  if (status_ != Status::kRunning) return status_;
  // At 1 kHz a pose mean is so precise that in float the cost's rounding hides the last decrease
  // (the LM then ends at maximum damping a few hundredths of a sigma from the minimum).
  Status s = lm_.step(problem_);
  if (s == Status::kNoProgress) s = precision_limited(lm_, s, sigma_factor(parameters()));
  if (succeeded(s)) return after_convergence(s);
  return status_ = s;
}

template <typename Scalar>
Status AccelSolver<Scalar>::finish(AccelCalibration<Scalar>& out) const {
  // Every path leaves `out` whole: the estimate only when usable, zeros and the reason otherwise.
  out = AccelCalibration<Scalar>{};
  out.poses = problem_.poses.size;
  out.iterations = iterations();
  out.status = status_;
  if (!succeeded(status_)) return status_;

  const AccelVector<Scalar> pn = parameters();
  const Scalar chi = chi2(pn);
  const int m = dof();
  LmVector sd_lm = LmVector::Zero();
  Status obs = lm_.normal_equations().standard_deviations(sd_lm, sigma_factor(pn));
  const AccelVector<Scalar> sdn = sd_lm.template head<kAccelParams>();
  if (obs == Status::kOk && !(sdn.maxCoeff() <= settings_.max_normalised_sigma))
    obs = Status::kUnobservable;
  if (obs != Status::kOk) return out.status = obs;

  // Back to sensor units: b = scale b' - centre, the rest scaled (sensor_units()).
  const Scalar g = settings_.gravity;
  const Scalar k = problem_.scale;
  const AccelVector<Scalar> units = sensor_units();
  AccelVector<Scalar> p = units.cwiseProduct(pn);
  const AccelVector<Scalar> sd = units.cwiseProduct(sdn);
  for (int i = 0; i < 3; ++i) p(kBiasX + i) -= problem_.centre(i);
  std::uint16_t weak = 0;  // a held parameter is 0, sigma 0 (sensor_units()), and not weak
  for (int i = 0; i < kAccelParams; ++i)
    if (!(problem_.held & (1u << i)) && sdn(i) > settings_.weak_normalised_sigma)
      weak = static_cast<std::uint16_t>(weak | (1u << i));
  Scalar sum_w = Scalar(0), sum_r2 = Scalar(0);
  for (int i = 0; i < problem_.poses.size; ++i) {
    const Vector3<Scalar> x = normalised(problem_.poses[i], problem_.centre, Scalar(1) / k);
    const Vector3<Scalar> c = accel_apply(pn, x);
    const Scalar r = g * (Scalar(1) - c.norm());
    const Scalar w = Scalar(problem_.poses[i].samples);
    sum_w += w;
    sum_r2 += w * r * r;
  }
  const Scalar rms = std::sqrt(sum_r2 / sum_w);
  // The floor as the noise of a mean on one axis: var e = |dE/db|^2 var_axis, |dE/db| ~ 2.
  const Scalar floor = g * std::sqrt(problem_.floor) / Scalar(2);
  const Scalar ratio = problem_.noise_model && m > 0 ? chi / static_cast<Scalar>(m) : Scalar(0);
  if (!all_finite(p) || !all_finite(sd) || !std::isfinite(rms) || !std::isfinite(floor) ||
      !std::isfinite(ratio)) {
    return out.status = Status::kIllConditioned;
  }
  out.params = p;
  out.sigma = sd;
  out.residual_rms = rms;
  out.pose_floor = floor;
  out.fit_to_noise = ratio;
  out.weak = weak;
  out.held = problem_.held;
  return out.status;
}

// What each normalised parameter is multiplied by in sensor units (x = (a - centre) / scale with
// unit gravity): scales by g / scale, biases by scale (then less the centre), misalignments by 1,
// a held parameter by 0.
template <typename Scalar>
AccelVector<Scalar> AccelSolver<Scalar>::sensor_units() const {
  AccelVector<Scalar> d = AccelVector<Scalar>::Ones();
  for (int i = 0; i < 3; ++i) {
    d(kScaleX + i) = settings_.gravity / problem_.scale;
    d(kBiasX + i) = problem_.scale;
  }
  for (int i = 0; i < kAccelParams; ++i)
    if (problem_.held & (1u << i)) d(i) = Scalar(0);
  return d;
}

template <typename Scalar>
Status AccelSolver<Scalar>::covariance(
    Eigen::Matrix<Scalar, kAccelParams, kAccelParams>& cov) const {
  if (!succeeded(status_)) return status_;
  // Column by column into the 9 x 9: no capacity-sized matrix on the stack.
  Eigen::Matrix<Scalar, kAccelParams, kAccelParams> c;
  const Status s = lm_.normal_equations().inverse_columns(
      sigma_factor(parameters()),
      [&c](int col, const LmVector& column) { c.col(col) = column.template head<kAccelParams>(); });
  if (s != Status::kOk) return s;
  const AccelVector<Scalar> d = sensor_units();
  cov = d.asDiagonal() * c * d.asDiagonal();
  return all_finite(cov) ? Status::kOk : Status::kIllConditioned;
}

const char* accel_parameter_name(int k) {
  return k >= 0 && k < kAccelParams ? kAccelParamNames[k] : "?";
}

const char* accel_orientation_hint(int k) {
  switch (k) {
    case kAlphaYz:
      return "hold it with gravity between its x and y axes (tilted about 45 deg about z), "
             "in two or more such poses";
    case kAlphaZy:
      return "hold it with gravity between its x and z axes (tilted about 45 deg about y), "
             "in two or more such poses";
    case kAlphaZx:
      return "hold it with gravity between its y and z axes (tilted about 45 deg about x), "
             "in two or more such poses";
    case kScaleX:
    case kBiasX:
      return "hold it with its x axis straight up and straight down";
    case kScaleY:
    case kBiasY:
      return "hold it with its y axis straight up and straight down";
    case kScaleZ:
    case kBiasZ:
      return "hold it with its z axis straight up and straight down";
    default:
      return "";
  }
}

template class AccelSolver<float>;
template Status check_poses<float>(PoseSpan<float>, const AccelSettings<float>&, Vector3<float>&,
                                   float&);
template Status fit_ellipsoid<float>(PoseSpan<float>, const Vector3<float>&, float,
                                     AccelVector<float>&);
#ifndef IMUCAL_FLOAT_ONLY  // the host's reference type; a float-only build leaves it out
template class AccelSolver<double>;
template Status check_poses<double>(PoseSpan<double>, const AccelSettings<double>&,
                                    Vector3<double>&, double&);
template Status fit_ellipsoid<double>(PoseSpan<double>, const Vector3<double>&, double,
                                      AccelVector<double>&);
#endif

}  // namespace imucal
