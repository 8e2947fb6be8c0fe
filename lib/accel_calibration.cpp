// Accelerometer calibration: pose checks, closed-form ellipsoid start, normalised LM, and the
// mapping back to sensor units. Instantiated for float (device) and double (reference).
#include "imucal/accel_calibration.hpp"

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

// sigma of the normalised parameters, and whether every one is small enough to call it
// calibrated (used at the closed-form start and again at the end).
template <typename Scalar>
Status observable_sigma(const NormalEquations<Scalar, kAccelParams>& ne,
                        const AccelSettings<Scalar>& settings, AccelVector<Scalar>& sd) {
  const Status s = ne.standard_deviations(sd);
  if (s != Status::kOk) return s;
  return sd.maxCoeff() <= settings.max_normalised_sigma ? Status::kOk : Status::kUnobservable;
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

template <typename Scalar>
Status fit_ellipsoid(PoseSpan<Scalar> poses, const Vector3<Scalar>& centre, Scalar scale,
                     AccelVector<Scalar>& p_normalised) {
  if (poses.size < kAccelParams) return Status::kTooFewPoses;
  // x^T Q x + u^T x = 1, theta = [Q00 Q11 Q22 Q01 Q02 Q12 u0 u1 u2]: a linear least-squares
  // problem, accumulated in the same normal-equations form (residual phi.theta - 1, at theta=0).
  Scalar mean_n = Scalar(0);
  for (int i = 0; i < poses.size; ++i) mean_n += Scalar(poses[i].samples);
  mean_n /= Scalar(poses.size);
  NormalEquations<Scalar, kAccelParams> ne;
  const Scalar inv_scale = Scalar(1) / scale;
  for (int i = 0; i < poses.size; ++i) {
    const Vector3<Scalar> x = normalised(poses[i], centre, inv_scale);
    const Status s = ne.add(detail::quadric_row(x), Scalar(-1), Scalar(poses[i].samples) / mean_n);
    if (s != Status::kOk) return s;
  }
  AccelVector<Scalar> theta;
  const Status s = ne.solve_damped(Scalar(0), theta);
  if (s != Status::kOk) return s;

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

template <typename Scalar>
Status AccelSolver<Scalar>::Problem::accumulate(const AccelVector<Scalar>& p,
                                                NormalEquations<Scalar, kAccelParams>& ne) const {
  const Scalar inv_scale = Scalar(1) / scale;
  for (int i = 0; i < poses.size; ++i) {
    const Vector3<Scalar> x = normalised(poses[i], centre, inv_scale);
    AccelVector<Scalar> j;
    const Scalar e = accel_residual(p, x, Scalar(1), &j);
    const Status s = ne.add(j, e, Scalar(poses[i].samples));
    if (s != Status::kOk) return s;
  }
  return Status::kOk;
}

template <typename Scalar>
AccelSolver<Scalar>::AccelSolver(const AccelSettings<Scalar>& settings)
    : settings_(settings), lm_(settings.lm) {}

template <typename Scalar>
Status AccelSolver<Scalar>::start(PoseSpan<Scalar> poses) {
  lm_ = LevenbergMarquardt<Scalar, kAccelParams>(settings_.lm);
  problem_.poses = poses;
  problem_.centre.setZero();
  problem_.scale = Scalar(1);
  Status s = check_poses(poses, settings_, problem_.centre, problem_.scale);
  if (s != Status::kOk) return status_ = s;
  AccelVector<Scalar> p0;
  s = fit_ellipsoid(poses, problem_.centre, problem_.scale, p0);
  if (s != Status::kOk) return status_ = s;
  s = lm_.start(problem_, p0);
  if (s != Status::kRunning && !succeeded(s)) return status_ = s;
  // Observability before iterating: the closed-form start is already close to the optimum, so
  // sigma there shows whether the poses determine every parameter (a flat valley would
  // otherwise only end at the iteration cap).
  AccelVector<Scalar> sd;
  const Status obs = observable_sigma(lm_.normal_equations(), settings_, sd);
  return status_ = (obs == Status::kOk ? s : obs);
}

template <typename Scalar>
Status AccelSolver<Scalar>::step() {
  if (status_ != Status::kRunning) return status_;
  return status_ = lm_.step(problem_);
}

template <typename Scalar>
Status AccelSolver<Scalar>::finish(AccelCalibration<Scalar>& out) const {
  // Every path leaves `out` whole: the estimate only when usable, zeros and the reason otherwise.
  out = AccelCalibration<Scalar>{};
  out.poses = problem_.poses.size;
  out.iterations = lm_.iterations();
  out.status = status_;
  if (!succeeded(status_)) return status_;

  const AccelVector<Scalar>& pn = lm_.parameters();
  AccelVector<Scalar> sdn;
  const Status obs = observable_sigma(lm_.normal_equations(), settings_, sdn);
  if (obs != Status::kOk) return out.status = obs;

  // Back to sensor units: x = (a - centre) / scale and unit gravity, so
  // s = s' g / scale, b = scale b' - centre, misalignments unchanged.
  const Scalar g = settings_.gravity;
  const Scalar k = problem_.scale;
  AccelVector<Scalar> p = pn;
  AccelVector<Scalar> sd = sdn;
  for (int i = 0; i < 3; ++i) {
    p(kScaleX + i) = pn(kScaleX + i) * g / k;
    sd(kScaleX + i) = sdn(kScaleX + i) * g / k;
    p(kBiasX + i) = k * pn(kBiasX + i) - problem_.centre(i);
    sd(kBiasX + i) = k * sdn(kBiasX + i);
  }
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
  if (!all_finite(p) || !all_finite(sd) || !std::isfinite(rms)) {
    return out.status = Status::kIllConditioned;
  }
  out.params = p;
  out.sigma = sd;
  out.residual_rms = rms;
  return out.status;
}

template class AccelSolver<float>;
template class AccelSolver<double>;
template Status check_poses<float>(PoseSpan<float>, const AccelSettings<float>&, Vector3<float>&,
                                   float&);
template Status check_poses<double>(PoseSpan<double>, const AccelSettings<double>&,
                                    Vector3<double>&, double&);
template Status fit_ellipsoid<float>(PoseSpan<float>, const Vector3<float>&, float,
                                     AccelVector<float>&);
template Status fit_ellipsoid<double>(PoseSpan<double>, const Vector3<double>&, double,
                                      AccelVector<double>&);

}  // namespace imucal
