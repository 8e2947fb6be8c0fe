// SPDX-License-Identifier: MIT
// Magnetometer calibration: closed-form ellipsoid start, geometric Levenberg-Marquardt refinement
// with sigmas, the coverage / field / fit checks, and the alignment to the accelerometer frame.
// Instantiated for float (device) and double (reference).
#include "imucal/magnetometer/mag_calibration.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "imucal/solve/elementary.hpp"
#include "imucal/solve/symmetric_eigen3.hpp"
#include "imucal/stream/gyro_segment.hpp"  // rodrigues_coefficients, skew, rotation_exp
#include "quadric.hpp"

namespace imucal {
namespace {

constexpr int kMaxCellsPerEdge = 16;
constexpr int kMaxCells = 6 * kMaxCellsPerEdge * kMaxCellsPerEdge;
// Spread of the samples (see mag_solve) below which they count as one plane.
template <typename Scalar>
constexpr Scalar kMinPlanarSpread = Scalar(1e-3);

template <typename Scalar>
using MagVector = Eigen::Matrix<Scalar, kMagParams, 1>;
template <typename Scalar>
using AlignVector = Eigen::Matrix<Scalar, kMagAlignParams, 1>;

// Both fits run in the capacity the accelerometer's and gyro's solvers share (kSolverCapacity),
// at run-time size 9 and 4: one copy of the LM and its normal equations in a firmware.
template <typename Scalar>
using Lm = LevenbergMarquardt<Scalar, kSolverCapacity>;
template <typename Scalar>
using Ne = NormalEquations<Scalar, kSolverCapacity>;
template <typename Scalar>
using LmVector = Eigen::Matrix<Scalar, kSolverCapacity, 1>;

template <typename Scalar>
Matrix3<Scalar> sym_matrix(const MagVector<Scalar>& p) {
  Matrix3<Scalar> w;
  w << p(kS00), p(kS01), p(kS02),  //
      p(kS01), p(kS11), p(kS12),   //
      p(kS02), p(kS12), p(kS22);
  return w;
}

// The geometric residual |W (y + h)| - 1 over the normalised samples y = (x - centre) / scale,
// with its analytic Jacobian. p = [W00 W11 W22 W01 W02 W12 h0 h1 h2].
template <typename Scalar>
struct MagProblem {
  const Vector3<Scalar>* samples = nullptr;
  int n = 0;
  Vector3<Scalar> centre = Vector3<Scalar>::Zero();
  Scalar inv_scale = Scalar(1);

  Status accumulate(const LmVector<Scalar>& p, Ne<Scalar>& ne) const {
    const Matrix3<Scalar> w = sym_matrix(MagVector<Scalar>(p.template head<kMagParams>()));
    const Vector3<Scalar> h(p(6), p(7), p(8));
    for (int i = 0; i < n; ++i) {
      const Vector3<Scalar> z = (samples[i] - centre) * inv_scale + h;
      const Vector3<Scalar> c = w * z;
      const Scalar norm = c.norm();
      if (!(norm > Scalar(0))) return Status::kNotAnEllipsoid;
      const Vector3<Scalar> g = c / norm;  // d|c|/dc
      MagVector<Scalar> j;
      // dc/dW_kk = z_k e_k; dc/dW_kl (k != l, symmetric) = z_l e_k + z_k e_l; dc/dh = W.
      j(kS00) = g(0) * z(0);
      j(kS11) = g(1) * z(1);
      j(kS22) = g(2) * z(2);
      j(kS01) = g(0) * z(1) + g(1) * z(0);
      j(kS02) = g(0) * z(2) + g(2) * z(0);
      j(kS12) = g(1) * z(2) + g(2) * z(1);
      const Vector3<Scalar> jh = w * g;  // W symmetric: W^T g = W g
      j(6) = jh(0);
      j(7) = jh(1);
      j(8) = jh(2);
      const Status s = ne.add(j, norm - Scalar(1));
      if (s != Status::kOk) return s;
    }
    return Status::kOk;
  }
};

// Closed-form start: x^T Q x + u^T x = 1 by linear least squares on the normalised samples, then
// W = (Q / r)^(1/2), the symmetric square root, and h = -(ellipsoid centre).
template <typename Scalar>
Status fit_ellipsoid_sym(const MagProblem<Scalar>& prob, MagVector<Scalar>& p0) {
  Ne<Scalar> ne;
  ne.resize(kMagParams);
  for (int i = 0; i < prob.n; ++i) {
    const Vector3<Scalar> x = (prob.samples[i] - prob.centre) * prob.inv_scale;
    const Status s = ne.add(detail::quadric_row(x), Scalar(-1));
    if (s != Status::kOk) return s;
  }
  LmVector<Scalar> theta;
  const Status s = ne.solve_damped(Scalar(0), theta);
  if (s != Status::kOk) return s;
  Matrix3<Scalar> q;
  Vector3<Scalar> u;
  detail::quadric_from(MagVector<Scalar>(theta.template head<kMagParams>()), q, u);
  Vector3<Scalar> l;  // ascending
  Matrix3<Scalar> v;
  if (!symmetric_eigen3(q, l, &v)) return Status::kNotAnEllipsoid;
  if (!all_finite(l) || !(l(0) > Scalar(0))) return Status::kNotAnEllipsoid;
  // Ellipsoid centre c = -Q^-1 u / 2; (x - c)^T Q (x - c) = r = 1 + c^T Q c.
  const Vector3<Scalar> vu = v.transpose() * u;
  Vector3<Scalar> vc;
  for (int k = 0; k < 3; ++k) vc(k) = Scalar(-0.5) * vu(k) / l(k);
  const Vector3<Scalar> c = v * vc;
  Scalar r = Scalar(1);
  for (int k = 0; k < 3; ++k) r += l(k) * vc(k) * vc(k);
  if (!(r > Scalar(0)) || !std::isfinite(r)) return Status::kNotAnEllipsoid;
  Vector3<Scalar> root;
  for (int k = 0; k < 3; ++k) root(k) = std::sqrt(l(k) / r);
  const Matrix3<Scalar> w = v * root.asDiagonal() * v.transpose();
  MagVector<Scalar> p;
  p << w(0, 0), w(1, 1), w(2, 2), w(0, 1), w(0, 2), w(1, 2), -c(0), -c(1), -c(2);
  if (!all_finite(p)) return Status::kNotAnEllipsoid;
  p0 = p;
  return Status::kOk;
}

// Fraction of the 6 n^2 cells hit by the directions W (y_i + h) (= those of S (x_i + h)).
template <typename Scalar>
Scalar calibrated_coverage(const MagProblem<Scalar>& prob, const Matrix3<Scalar>& w,
                           const Vector3<Scalar>& h, int cells_per_edge) {
  std::uint32_t hit[kMaxCells / 32] = {};
  int count = 0;
  for (int i = 0; i < prob.n; ++i) {
    const Vector3<Scalar> d = w * ((prob.samples[i] - prob.centre) * prob.inv_scale + h);
    if (!(d.squaredNorm() > Scalar(0))) continue;
    Scalar u, v;
    const int cell = mag_cell(d, cells_per_edge, u, v);
    const std::uint32_t bit = std::uint32_t(1) << static_cast<unsigned>(cell % 32);
    std::uint32_t& word = hit[cell / 32];
    if ((word & bit) == 0u) {
      word |= bit;
      ++count;
    }
  }
  return Scalar(count) / Scalar(6 * cells_per_edge * cells_per_edge);
}

// The largest sigma of the normalised parameters relative to the ellipsoid's radius: h's in
// radii, W's entries relative to W's mean diagonal (both unit-free).
template <typename Scalar>
Status relative_sigma(const Ne<Scalar>& ne, const MagVector<Scalar>& p, Scalar& spread) {
  LmVector<Scalar> sd;
  const Status s = ne.standard_deviations(sd);
  if (s != Status::kOk) return s;
  const Scalar w_mean = (p(kS00) + p(kS11) + p(kS22)) / Scalar(3);
  if (!(w_mean > Scalar(0))) return Status::kNotAnEllipsoid;
  Scalar worst = Scalar(0);
  for (int k = 0; k < kMagSymEntries; ++k) worst = std::max(worst, sd(k) / w_mean);
  for (int k = 6; k < kMagParams; ++k) worst = std::max(worst, sd(k) * w_mean);
  spread = worst;
  return Status::kOk;
}

template <typename Scalar>
Quality mag_quality(Scalar coverage, Scalar fit_error_pct) {
  if (coverage >= Scalar(0.8) && fit_error_pct <= Scalar(1.5)) return Quality::kGood;
  if (coverage >= Scalar(0.65) && fit_error_pct <= Scalar(3)) return Quality::kFair;
  return Quality::kPoor;
}

template <typename Scalar>
bool settings_valid(const MagSettings<Scalar>& s) {
  return s.unit_ut > Scalar(0) && std::isfinite(s.unit_ut) && s.field_min_ut >= Scalar(0) &&
         s.field_max_ut > s.field_min_ut && std::isfinite(s.field_max_ut) &&
         s.min_coverage >= Scalar(0) && s.min_coverage <= Scalar(1) &&
         s.max_fit_error_pct > Scalar(0) && std::isfinite(s.max_fit_error_pct) &&
         s.max_alignment_sigma > Scalar(0) && s.max_relative_sigma > Scalar(0);
}

// exp([phi]x) and the left Jacobian of SO(3), I + b K + c K^2 (K = [phi]x), from one evaluation
// of the Rodrigues coefficients (gyro_segment.hpp).
template <typename Scalar>
void rotation_exp_and_left_jacobian(const Vector3<Scalar>& phi, Matrix3<Scalar>& r,
                                    Matrix3<Scalar>& jl) {
  Scalar a, b, c;
  rodrigues_coefficients(phi.squaredNorm(), a, b, c);
  const Matrix3<Scalar> k = skew(phi);
  const Matrix3<Scalar> k2 = k * k;
  r = Matrix3<Scalar>::Identity() + a * k + b * k2;
  jl = Matrix3<Scalar>::Identity() + b * k + c * k2;
}

template <typename Scalar>
Vector3<Scalar> rotation_log(const Matrix3<Scalar>& r) {
  const Eigen::Quaternion<Scalar> q(r);
  const Vector3<Scalar> v = q.vec();
  const Scalar s = v.norm();
  if (!(s > Scalar(0))) return Vector3<Scalar>::Zero();
  Scalar angle = Scalar(2) * std::atan2(s, q.w());
  if (angle > Scalar(3.14159265358979323846)) angle -= Scalar(2 * 3.14159265358979323846);
  return v * (angle / s);
}

// The dip residual g_i . R m_i + d over the rests, with R = exp([phi]x) r0, and its exact
// Jacobian.
template <typename Scalar>
struct AlignProblem {
  const Vector3<Scalar>* rest_mag = nullptr;
  const Vector3<Scalar>* rest_acc = nullptr;
  int n = 0;
  Matrix3<Scalar> s_sym = Matrix3<Scalar>::Identity();
  Vector3<Scalar> h = Vector3<Scalar>::Zero();
  const AccelVector<Scalar>* accel = nullptr;
  Matrix3<Scalar> r0 = Matrix3<Scalar>::Identity();

  // Unit up (accelerometer frame) and unit field (magnetometer frame) of rest i.
  Status directions(int i, Vector3<Scalar>& up, Vector3<Scalar>& field) const {
    const Vector3<Scalar> g = accel_apply(*accel, rest_acc[i]);
    const Vector3<Scalar> m = s_sym * (rest_mag[i] + h);
    const Scalar gn = g.norm(), mn = m.norm();
    if (!(gn > Scalar(0)) || !(mn > Scalar(0)) || !std::isfinite(gn) || !std::isfinite(mn))
      return Status::kInvalidArgument;
    up = g / gn;
    field = m / mn;
    return Status::kOk;
  }

  Status accumulate(const LmVector<Scalar>& p, Ne<Scalar>& ne) const {
    const Vector3<Scalar> phi(p(0), p(1), p(2));
    Matrix3<Scalar> e, jl;
    rotation_exp_and_left_jacobian(phi, e, jl);
    const Matrix3<Scalar> r = e * r0;
    for (int i = 0; i < n; ++i) {
      Vector3<Scalar> up, field;
      Status s = directions(i, up, field);
      if (s != Status::kOk) return s;
      const Vector3<Scalar> rm = r * field;
      // d exp([phi]x) = [J_l(phi) dphi]x exp([phi]x), so d(up . R m)/dphi = (Rm x up)^T J_l.
      const Vector3<Scalar> jr = jl.transpose() * rm.cross(up);
      AlignVector<Scalar> j;
      j << jr(0), jr(1), jr(2), Scalar(1);
      s = ne.add(j, up.dot(rm) + p(3));
      if (s != Status::kOk) return s;
    }
    return Status::kOk;
  }
};

}  // namespace

template <typename Scalar>
Status mag_solve(const Vector3<Scalar>* samples, int n, const MagSettings<Scalar>& settings,
                 int cells_per_edge, Scalar raw_coverage, MagCalibration<Scalar>& out) {
  out = MagCalibration<Scalar>{};
  out.samples = n;
  if ((samples == nullptr && n != 0) || n < 0 || cells_per_edge < 1 ||
      cells_per_edge > kMaxCellsPerEdge || !settings_valid(settings))
    return out.status = Status::kInvalidArgument;
  if (std::isfinite(raw_coverage)) out.coverage = raw_coverage;  // until a fit gives the real one
  const int min_samples =
      settings.min_samples > kMagMinSamples ? settings.min_samples : kMagMinSamples;
  // A sample held is a direction cell covered: fewer than min_samples (but enough to count) is
  // poor coverage, which tells the user what to do (turn through more orientations).
  if (n < kMagMinSamples) return out.status = Status::kTooFewSamples;
  if (n < min_samples) return out.status = Status::kPoorCoverage;
  for (int i = 0; i < n; ++i)
    if (!all_finite(samples[i])) return out.status = Status::kNonFiniteInput;

  // Centre on the mean (shifted by the first sample so float sums stay small) and divide by the
  // RMS radius: raw counts in the thousands lose nothing in float.
  MagProblem<Scalar> prob;
  prob.samples = samples;
  prob.n = n;
  const Vector3<Scalar> origin = samples[0];
  Vector3<Scalar> sum = Vector3<Scalar>::Zero();
  for (int i = 0; i < n; ++i) sum += samples[i] - origin;
  prob.centre = origin + sum / Scalar(n);
  Scalar sq = Scalar(0);
  for (int i = 0; i < n; ++i) sq += (samples[i] - prob.centre).squaredNorm();
  const Scalar scale = std::sqrt(sq / Scalar(n));
  if (!(scale > Scalar(0)) || !std::isfinite(scale)) return out.status = Status::kRankDeficient;
  prob.inv_scale = Scalar(1) / scale;

  // All in one plane (turned about one axis only): no ellipsoid is determined. Spread measure
  // as in accel check_poses(): det / (m2 tr) of the scatter lies in [l1 / (9 l3), l1 / l3] for
  // its eigenvalues l1 <= l3 (1/9 all round the sphere, ~0.03 for a hemisphere, 0 for a plane).
  Matrix3<Scalar> scatter = Matrix3<Scalar>::Zero();
  for (int i = 0; i < n; ++i) {
    const Vector3<Scalar> y = (samples[i] - prob.centre) * prob.inv_scale;
    scatter += y * y.transpose();
  }
  const Matrix3<Scalar>& m = scatter;
  const Scalar minors = m(0, 0) * m(1, 1) - m(0, 1) * m(0, 1) + m(0, 0) * m(2, 2) -
                        m(0, 2) * m(0, 2) + m(1, 1) * m(2, 2) - m(1, 2) * m(1, 2);
  const Scalar spread = m.determinant() / (minors * m.trace());
  if (!std::isfinite(spread) || spread < kMinPlanarSpread<Scalar>)
    return out.status = Status::kPoorCoverage;

  MagVector<Scalar> p0;
  Status s = fit_ellipsoid_sym(prob, p0);
  if (s != Status::kOk) return out.status = s;

  // Observability before iterating, as for the accelerometer: near the closed-form start, sigma
  // already shows whether the samples determine the ellipsoid (from a small cap they do not, and
  // the LM would wander along a flat valley to its iteration limit). Refused as poor coverage,
  // with the coverage of the start's calibrated directions for the user.
  Lm<Scalar> lm(settings.lm);
  s = lm.start(prob, p0);
  if (s != Status::kRunning && !succeeded(s)) return out.status = s;
  {
    const Scalar coverage0 = calibrated_coverage(
        prob, sym_matrix(p0), Vector3<Scalar>(p0(6), p0(7), p0(8)), cells_per_edge);
    Scalar rel_sigma = Scalar(0);
    const Status obs = relative_sigma(lm.normal_equations(), p0, rel_sigma);
    if (obs != Status::kOk) return out.status = obs;
    if (rel_sigma > settings.max_relative_sigma) {
      out.coverage = coverage0;
      return out.status = Status::kPoorCoverage;
    }
  }
  while (s == Status::kRunning) s = lm.step(prob);
  s = precision_limited(lm, s);
  out.iterations = lm.iterations();
  if (!succeeded(s)) return out.status = s;
  const MagVector<Scalar> p = lm.parameters().template head<kMagParams>();
  const Matrix3<Scalar> w = sym_matrix(p);
  const Vector3<Scalar> h(p(6), p(7), p(8));
  // The refinement may leave the ellipsoid (it never should near a closed-form start).
  Vector3<Scalar> w_values;
  if (!symmetric_eigen3(w, w_values) || !(w_values(0) > Scalar(0)))
    return out.status = Status::kNotAnEllipsoid;

  // Diagnostics: field strength, fit error, coverage of the calibrated directions.
  const Scalar det = w.determinant();
  const Scalar g = Scalar(1) / std::cbrt(det);  // det(W)^(-1/3)
  const Scalar field = settings.unit_ut * scale * g;
  const Ne<Scalar>& ne = lm.normal_equations();
  const Scalar rms = std::sqrt(ne.weighted_sse() / Scalar(n));
  const Scalar coverage = calibrated_coverage(prob, w, h, cells_per_edge);
  if (!std::isfinite(field) || !std::isfinite(rms) || !std::isfinite(g))
    return out.status = Status::kIllConditioned;
  out.field_ut = field;
  out.fit_error_pct = Scalar(100) * rms;
  out.coverage = coverage;

  // Sigmas: Cov = f/(m - 9) H^-1 in normalised units. h_raw = scale h - centre; S = unit g(W)
  // with g(W) = W det(W)^(-1/3), whose derivative along a symmetric direction E is
  // det^(-1/3) (E - W tr(W^-1 E) / 3).
  // Column by column into the 9 x 9: no capacity-sized matrix on the stack.
  Eigen::Matrix<Scalar, kMagParams, kMagParams> cov;
  s = ne.inverse_columns(Scalar(-1), [&cov](int col, const LmVector<Scalar>& column) {
    cov.col(col) = column.template head<kMagParams>();
  });
  if (s != Status::kOk) return out.status = s;
  if (!all_finite(cov)) return out.status = Status::kIllConditioned;
  const Matrix3<Scalar> w_inv = w.inverse();
  Eigen::Matrix<Scalar, kMagSymEntries, kMagSymEntries> jac;  // d S-entry / d W-entry
  static constexpr int kRow[kMagSymEntries] = {0, 1, 2, 0, 0, 1};
  static constexpr int kCol[kMagSymEntries] = {0, 1, 2, 1, 2, 2};
  for (int e = 0; e < kMagSymEntries; ++e) {
    const int r = kRow[e], c = kCol[e];
    const Scalar trace = (r == c) ? w_inv(r, c) : Scalar(2) * w_inv(r, c);  // tr(W^-1 E)
    for (int a = 0; a < kMagSymEntries; ++a) {
      const Scalar e_entry = (a == e) ? Scalar(1) : Scalar(0);
      jac(a, e) = settings.unit_ut * g * (e_entry - w(kRow[a], kCol[a]) * trace / Scalar(3));
    }
  }
  MagSymVector<Scalar> s_sigma;
  for (int a = 0; a < kMagSymEntries; ++a) {
    Scalar var = Scalar(0);
    for (int k = 0; k < kMagSymEntries; ++k)
      for (int l = 0; l < kMagSymEntries; ++l) var += jac(a, k) * cov(k, l) * jac(a, l);
    s_sigma(a) = std::sqrt(var > Scalar(0) ? var : Scalar(0));
  }
  Vector3<Scalar> h_sigma;
  for (int k = 0; k < 3; ++k) {
    const Scalar var = cov(6 + k, 6 + k);
    h_sigma(k) = scale * std::sqrt(var > Scalar(0) ? var : Scalar(0));
  }
  const Matrix3<Scalar> soft = (settings.unit_ut * g) * w;
  const Vector3<Scalar> hard = scale * h - prob.centre;
  if (!all_finite(s_sigma) || !all_finite(h_sigma) || !all_finite(soft) || !all_finite(hard))
    return out.status = Status::kIllConditioned;

  if (coverage < settings.min_coverage) return out.status = Status::kPoorCoverage;
  if (field < settings.field_min_ut || field > settings.field_max_ut)
    return out.status = Status::kFieldImplausible;
  if (out.fit_error_pct > settings.max_fit_error_pct) return out.status = Status::kFitPoor;

  out.soft_iron = soft;
  out.hard_iron = hard;
  out.soft_iron_sigma = s_sigma;
  out.hard_iron_sigma = h_sigma;
  out.quality = mag_quality(coverage, out.fit_error_pct);
  return out.status = lm.status();
}

template <typename Scalar>
Status mag_align(const Vector3<Scalar>* rest_mag, const Vector3<Scalar>* rest_acc, int n,
                 const MagSettings<Scalar>& settings, const AccelCalibration<Scalar>& accel,
                 MagCalibration<Scalar>& inout) {
  // Back to the symmetric S (undo an earlier alignment) and the alignment fields' defaults.
  Matrix3<Scalar> s_sym = inout.soft_iron;
  if (succeeded(inout.alignment_status))
    s_sym = rotation_exp(inout.alignment_rotation).transpose() * inout.soft_iron;
  const MagCalibration<Scalar> defaults{};
  inout.soft_iron = s_sym;
  inout.dip_deg = defaults.dip_deg;
  inout.dip_sigma_deg = defaults.dip_sigma_deg;
  inout.alignment_rotation = defaults.alignment_rotation;
  inout.alignment_sigma = defaults.alignment_sigma;
  inout.alignment_rests = n > 0 ? n : 0;
  if (!succeeded(inout.status) || !succeeded(accel.status) || !settings_valid(settings) ||
      !all_finite(accel.params) || !all_finite(s_sym) || !all_finite(inout.hard_iron) ||
      ((rest_mag == nullptr || rest_acc == nullptr) && n != 0))
    return inout.alignment_status = Status::kInvalidArgument;
  if (n < kMagMinRests) return inout.alignment_status = Status::kTooFewPoses;

  AlignProblem<Scalar> prob;
  prob.rest_mag = rest_mag;
  prob.rest_acc = rest_acc;
  prob.n = n;
  prob.s_sym = s_sym;
  prob.h = inout.hard_iron;
  prob.accel = &accel.params;
  // Start: no rotation, d = -mean(g . m).
  Scalar mean = Scalar(0);
  for (int i = 0; i < n; ++i) {
    Vector3<Scalar> up, field;
    const Status s = prob.directions(i, up, field);
    if (s != Status::kOk) return inout.alignment_status = s;
    mean += up.dot(field);
  }
  AlignVector<Scalar> p0;
  p0 << Scalar(0), Scalar(0), Scalar(0), -mean / Scalar(n);
  // A rank-deficient start (e.g. every rest with the same up) is refused at once; a merely
  // poorly determined rotation is judged by its sigma at the solution, whatever the LM's end.
  Lm<Scalar> lm(settings.lm);
  Status s = lm.start(prob, p0);
  if (s != Status::kRunning && !succeeded(s)) return inout.alignment_status = s;
  LmVector<Scalar> sd0;
  const Status obs = lm.normal_equations().standard_deviations(sd0);
  if (obs != Status::kOk) return inout.alignment_status = obs;
  while (s == Status::kRunning) s = lm.step(prob);
  s = precision_limited(lm, s);
  const AlignVector<Scalar> p = lm.parameters().template head<kMagAlignParams>();
  // Re-linearise at the solution (phi = 0 about the found R): the exact Jacobian for sigma.
  prob.r0 = rotation_exp(Vector3<Scalar>(p(0), p(1), p(2)));
  const Scalar d = p(3);
  LmVector<Scalar> at = LmVector<Scalar>::Zero();  // phi = 0, then d
  at(3) = d;
  Ne<Scalar> ne;
  ne.resize(kMagAlignParams);
  Status a = prob.accumulate(at, ne);
  LmVector<Scalar> sd;
  if (a == Status::kOk) a = ne.standard_deviations(sd);
  if (a != Status::kOk) return inout.alignment_status = a;
  const Vector3<Scalar> rot_sigma(sd(0), sd(1), sd(2));
  if (!(rot_sigma.maxCoeff() <= settings.max_alignment_sigma))
    return inout.alignment_status = Status::kUnobservable;
  if (!succeeded(s)) return inout.alignment_status = s;
  const Scalar kDeg = Scalar(180) / Scalar(3.14159265358979323846);
  const Scalar dc = d > Scalar(1) ? Scalar(1) : (d < Scalar(-1) ? Scalar(-1) : d);
  const Scalar cos_dip = std::sqrt(Scalar(1) - dc * dc);
  const Scalar dip = std::asin(dc) * kDeg;
  const Scalar dip_sigma =
      cos_dip > Scalar(1e-3) ? sd(3) / cos_dip * kDeg : Scalar(90);  // vertical field: no angle
  const Vector3<Scalar> rotation = rotation_log(prob.r0);
  const Matrix3<Scalar> soft = prob.r0 * s_sym;
  if (!all_finite(rotation) || !all_finite(soft) || !std::isfinite(dip) ||
      !std::isfinite(dip_sigma))
    return inout.alignment_status = Status::kIllConditioned;
  inout.soft_iron = soft;
  inout.alignment_rotation = rotation;
  inout.alignment_sigma = rot_sigma;
  inout.dip_deg = dip;
  inout.dip_sigma_deg = dip_sigma;
  return inout.alignment_status = s;
}

template Status mag_solve<float>(const Vector3<float>*, int, const MagSettings<float>&, int, float,
                                 MagCalibration<float>&);
template Status mag_align<float>(const Vector3<float>*, const Vector3<float>*, int,
                                 const MagSettings<float>&, const AccelCalibration<float>&,
                                 MagCalibration<float>&);
#ifndef IMUCAL_FLOAT_ONLY  // the host's reference type; a float-only build leaves it out
template Status mag_solve<double>(const Vector3<double>*, int, const MagSettings<double>&, int,
                                  double, MagCalibration<double>&);
template Status mag_align<double>(const Vector3<double>*, const Vector3<double>*, int,
                                  const MagSettings<double>&, const AccelCalibration<double>&,
                                  MagCalibration<double>&);
#endif

}  // namespace imucal
