// SPDX-License-Identifier: MIT
#include "support/reference_calibration.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>

namespace imucal::test {
namespace {

// The library is built with EIGEN_NO_MALLOC, and that definition reaches every test that links
// it: so no heap-sized Eigen objects here either, only sizes bounded at compile time (n <= 12).
using ParamVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kGyroParams, 1>;
using ParamMatrix =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kGyroParams, kGyroParams>;
using JacobianBlock = Eigen::Matrix<double, 3, Eigen::Dynamic, 0, 3, kGyroParams>;  // one move
using V3 = Vector3<double>;

constexpr int kMaxLmIterations = 100;
constexpr double kStepTolerance = 1e-10;  // largest |step| over the parameters' typical size
constexpr double kCostTolerance = 1e-14;  // relative decrease of the cost
constexpr double kDiffStep = 1e-6;        // central differences, relative to the typical size

bool finite_positive(double x) { return std::isfinite(x) && x > 0; }

bool valid(const ReferenceSettings& st) {
  return finite_positive(st.gravity) && finite_positive(st.init_seconds) &&
         finite_positive(st.window_seconds) && finite_positive(st.k) &&
         std::isfinite(st.trim_seconds) && st.trim_seconds >= 0 &&
         std::isfinite(st.min_rest_seconds) && st.min_rest_seconds >= 0 &&
         finite_positive(st.gyro_nominal_scale) && finite_positive(st.max_gap_seconds);
}

// A step that can be integrated across: not backwards, not a dropout.
bool step_ok(const std::vector<RawSample>& s, std::size_t j, double max_gap) {
  const double dt = s[j + 1].t - s[j].t;
  return dt >= 0 && dt <= max_gap;
}

// One past the last sample of the initial rest [t0, t0 + init_seconds).
std::size_t initial_end(const std::vector<RawSample>& s, double init_seconds) {
  std::size_t e = 0;
  while (e < s.size() && s[e].t - s[0].t < init_seconds) ++e;
  return e;
}

// M = T K from the 9 matrix parameters, written out here rather than taken from gyro_model.hpp
// so that a layout slip in either shows up as a disagreement.
Eigen::Matrix3d matrix_from(const ParamVector& x) {
  const double g_yz = x(0), g_zy = x(1), g_zx = x(2), g_xz = x(3), g_xy = x(4), g_yx = x(5);
  Eigen::Matrix3d t;
  t << 1, -g_yz, g_zy,  //
      g_xz, 1, -g_zx,   //
      -g_xy, g_yx, 1;
  return t * V3(x(6), x(7), x(8)).asDiagonal();
}

// q' = 1/2 q (x) (0, w)
Eigen::Quaterniond derivative(const Eigen::Quaterniond& q, const V3& w) {
  Eigen::Quaterniond d = q * Eigen::Quaterniond(0, w(0), w(1), w(2));
  d.coeffs() *= 0.5;
  return d;
}

Eigen::Quaterniond plus(const Eigen::Quaterniond& q, double h, const Eigen::Quaterniond& d) {
  Eigen::Quaterniond r;
  r.coeffs() = q.coeffs() + h * d.coeffs();
  return r;
}

struct Move {
  std::size_t first;  // last sample of rest k
  std::size_t last;   // first sample of rest k+1
  V3 g0;              // unit gravity direction in rest k (calibrated accelerometer)
  V3 g1;              // ... and in rest k+1
};

// Tedaldi's gravity-direction residual over every move, for parameter vector x (9 or 12).
class GyroProblem {
 public:
  GyroProblem(const std::vector<RawSample>& s, std::vector<Move> moves, const V3& fixed_bias,
              double nominal, bool refine_bias)
      : s_(s),
        moves_(std::move(moves)),
        fixed_bias_(fixed_bias),
        nominal_(nominal),
        n_(refine_bias ? kGyroParams : kGyroMatrixParams) {}

  int parameters() const { return n_; }
  int moves() const { return static_cast<int>(moves_.size()); }
  const Move& move(std::size_t k) const { return moves_[k]; }

  V3 bias(const ParamVector& x) const {
    return n_ == kGyroParams ? V3(x(kGyroBiasX), x(kGyroBiasY), x(kGyroBiasZ)) : fixed_bias_;
  }

  // R_k^T g_k for every move, so that residuals and angles share one integration.
  void predicted(const ParamVector& x, std::vector<V3>& out) const {
    const Eigen::Matrix3d m = matrix_from(x);
    const V3 b = bias(x);
    out.resize(moves_.size());
    for (std::size_t k = 0; k < moves_.size(); ++k) {
      const Move& mv = moves_[k];
      out[k] = rk4_rotation(s_, mv.first, mv.last, m, b).transpose() * mv.g0;
    }
  }

  void residuals(const ParamVector& x, std::vector<V3>& r) const {
    predicted(x, r);
    for (std::size_t k = 0; k < moves_.size(); ++k) r[k] -= moves_[k].g1;
  }

  // The scale at which a change of parameter j matters: misalignments are dimensionless (1),
  // scales relative to themselves, a bias change relative to 1 rad/s worth of raw units.
  double typical(const ParamVector& x, int j) const {
    if (j < kGyroScaleX) return 1.0;
    if (j < kGyroBiasX) return std::abs(x(j)) > 0 ? std::abs(x(j)) : nominal_;
    return 1.0 / nominal_;
  }

  // Central differences: the residual is smooth and cheap enough that an analytic Jacobian
  // would only add a second thing to get wrong in the yardstick.
  void jacobian(const ParamVector& x, std::vector<JacobianBlock>& jac) const {
    jac.assign(moves_.size(), JacobianBlock(3, n_));
    ParamVector xp = x, xm = x;
    std::vector<V3> rp, rm;
    for (int j = 0; j < n_; ++j) {
      const double h = kDiffStep * typical(x, j);
      xp(j) = x(j) + h;
      xm(j) = x(j) - h;
      residuals(xp, rp);
      residuals(xm, rm);
      const double step = xp(j) - xm(j);  // the step actually represented
      for (std::size_t k = 0; k < moves_.size(); ++k) jac[k].col(j) = (rp[k] - rm[k]) / step;
      xp(j) = x(j);
      xm(j) = x(j);
    }
  }

  // J^T J and J^T r, one move (3 rows) at a time. lazyProduct: coefficient-wise, no workspace.
  void normal_equations(const std::vector<JacobianBlock>& jac, const std::vector<V3>& r,
                        ParamMatrix& h, ParamVector& grad) const {
    h.setZero(n_, n_);
    grad.setZero(n_);
    for (std::size_t k = 0; k < moves_.size(); ++k) {
      h.noalias() += jac[k].transpose().lazyProduct(jac[k]);
      grad.noalias() += jac[k].transpose().lazyProduct(r[k]);
    }
  }

  double max_scaled(const ParamVector& x, const ParamVector& delta) const {
    double m = 0;
    for (int j = 0; j < n_; ++j) m = std::max(m, std::abs(delta(j)) / typical(x, j));
    return m;
  }

 private:
  const std::vector<RawSample>& s_;
  std::vector<Move> moves_;
  V3 fixed_bias_;
  double nominal_;
  int n_;
};

double sum_squares(const std::vector<V3>& r) {
  double sum = 0;
  for (const V3& v : r) sum += v.squaredNorm();
  return sum;
}

// Dense Levenberg-Marquardt (Marquardt's diagonal scaling, lambda up/down by 10).
Status levenberg_marquardt(const GyroProblem& pb, ParamVector& x, int& iterations) {
  iterations = 0;
  std::vector<V3> r, r_trial;
  std::vector<JacobianBlock> jac;
  ParamMatrix h;
  ParamVector grad;
  pb.residuals(x, r);
  double cost = sum_squares(r);
  if (!std::isfinite(cost)) return Status::kNonFiniteInput;
  if (cost == 0) return Status::kConvergedCost;
  double lambda = 1e-3;
  bool fresh = false;  // h and grad belong to x
  while (iterations < kMaxLmIterations) {
    if (!fresh) {
      pb.jacobian(x, jac);
      pb.normal_equations(jac, r, h, grad);
      if (!h.allFinite() || !grad.allFinite()) return Status::kNonFiniteInput;
      if (!(h.diagonal().minCoeff() > 0)) return Status::kRankDeficient;
      fresh = true;
    }
    ++iterations;
    ParamMatrix damped = h;
    damped.diagonal() *= 1 + lambda;
    const Eigen::LDLT<ParamMatrix> ldlt(damped);
    const ParamVector delta = ldlt.solve(-grad);
    if (ldlt.info() != Eigen::Success || !delta.allFinite()) {
      lambda *= 10;
      if (lambda > 1e16) return Status::kRankDeficient;
      continue;
    }
    const ParamVector trial = x + delta;
    pb.residuals(trial, r_trial);
    const double trial_cost = sum_squares(r_trial);
    // Only a lightly damped step measures closeness to the minimum: a heavily damped one is
    // small because of lambda.
    const bool tiny_step = lambda <= 1 && pb.max_scaled(x, delta) < kStepTolerance;
    if (std::isfinite(trial_cost) && trial_cost < cost) {
      const bool tiny_gain = cost - trial_cost < kCostTolerance * cost;
      x = trial;
      r.swap(r_trial);
      cost = trial_cost;
      fresh = false;
      lambda = std::max(lambda / 10, 1e-15);
      if (tiny_step) return Status::kConvergedStep;
      if (tiny_gain) return Status::kConvergedCost;
    } else {
      // At the minimum a negligible Gauss-Newton step may not decrease the cost by rounding.
      if (tiny_step) return Status::kConvergedStep;
      lambda *= 10;
      if (lambda > 1e16) return Status::kNoProgress;
    }
  }
  return Status::kMaxIterations;
}

}  // namespace

Eigen::Matrix3d rk4_rotation(const std::vector<RawSample>& s, std::size_t i0, std::size_t i1,
                             const Eigen::Matrix3d& m, const V3& b) {
  if (i0 >= i1 || i1 >= s.size()) return Eigen::Matrix3d::Identity();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  V3 w0 = m * (s[i0].gyro + b);
  for (std::size_t j = i0; j < i1; ++j) {
    const double dt = s[j + 1].t - s[j].t;
    const V3 w1 = m * (s[j + 1].gyro + b);
    const V3 wm = 0.5 * (w0 + w1);  // the linear rate at mid-step
    const Eigen::Quaterniond k1 = derivative(q, w0);
    const Eigen::Quaterniond k2 = derivative(plus(q, 0.5 * dt, k1), wm);
    const Eigen::Quaterniond k3 = derivative(plus(q, 0.5 * dt, k2), wm);
    const Eigen::Quaterniond k4 = derivative(plus(q, dt, k3), w1);
    q.coeffs() += dt / 6 * (k1.coeffs() + 2 * k2.coeffs() + 2 * k3.coeffs() + k4.coeffs());
    q.normalize();  // RK4 does not preserve the unit norm; renormalising is what imu_tk does
    w0 = w1;
  }
  return q.toRotationMatrix();
}

std::vector<RestInterval> detect_rests(const std::vector<RawSample>& s,
                                       const ReferenceSettings& st) {
  std::vector<RestInterval> out;
  const std::size_t n = s.size();
  if (n < 2 || !valid(st)) return out;
  const std::size_t init_end = initial_end(s, st.init_seconds);

  // Prefix sums of the readings less the initial mean: raw counts near 33000 squared would
  // lose the variance (a few counts^2) to cancellation over a long recording.
  V3 centre = V3::Zero();
  for (std::size_t i = 0; i < init_end; ++i) centre += s[i].acc;
  centre /= static_cast<double>(init_end);
  std::vector<V3> p1(n + 1, V3::Zero()), p2(n + 1, V3::Zero());
  for (std::size_t i = 0; i < n; ++i) {
    const V3 d = s[i].acc - centre;
    p1[i + 1] = p1[i] + d;
    p2[i + 1] = p2[i] + d.cwiseProduct(d);
  }
  auto variance_norm = [&](std::size_t b, std::size_t e) {
    const double c = static_cast<double>(e - b);
    const V3 m = (p1[e] - p1[b]) / c;
    return ((p2[e] - p2[b]) / c - m.cwiseProduct(m)).cwiseMax(0.0).norm();
  };
  // Floor: noise-free simulated data would otherwise have a zero threshold that rounding in
  // the prefix sums can never meet. 1e-9 of the gravity reading per axis is below any sensor.
  const double floor_sd = 1e-9 * centre.norm();
  const double threshold =
      st.k * std::max(init_end >= 2 ? variance_norm(0, init_end) : 0.0, floor_sd * floor_sd);

  // The gyro cue (when gyro_k > 0): mean |w - w0|^2 over the same window against gyro_k times
  // its initial-rest value, w0 the initial-rest mean rate.
  V3 w0 = V3::Zero();
  for (std::size_t i = 0; i < init_end; ++i) w0 += s[i].gyro;
  w0 /= static_cast<double>(init_end);
  std::vector<double> e1(n + 1, 0.0);
  for (std::size_t i = 0; i < n; ++i) e1[i + 1] = e1[i] + (s[i].gyro - w0).squaredNorm();
  const double gyro_threshold = st.gyro_k * e1[init_end] / static_cast<double>(init_end);
  auto gyro_still = [&](std::size_t b, std::size_t e) {
    return st.gyro_k <= 0.0 || (e1[e] - e1[b]) / static_cast<double>(e - b) <= gyro_threshold;
  };

  std::vector<char> still(n, 0);
  const double half = 0.5 * st.window_seconds;
  std::size_t lo = 0, hi = 0;
  for (std::size_t i = 0; i < n; ++i) {
    while (lo < i && s[lo].t < s[i].t - half) ++lo;
    if (hi < i) hi = i;
    while (hi + 1 < n && s[hi + 1].t <= s[i].t + half) ++hi;
    still[i] = i < init_end ||
               (hi > lo && variance_norm(lo, hi + 1) <= threshold && gyro_still(lo, hi + 1));
  }

  std::size_t i = 0;
  while (i < n) {
    if (!still[i]) {
      ++i;
      continue;
    }
    std::size_t j = i + 1;
    while (j < n && still[j] && step_ok(s, j - 1, st.max_gap_seconds)) ++j;
    // Trim [i, j) by time; the initial rest keeps its start (the unit was still before t0).
    std::size_t b = i, e = j;
    if (i != 0) {
      while (b < j && s[b].t < s[i].t + st.trim_seconds) ++b;
    }
    while (e > b && s[e - 1].t > s[j - 1].t - st.trim_seconds) --e;
    if (e > b && s[e - 1].t - s[b].t >= st.min_rest_seconds) out.push_back({b, e});
    i = j;
  }
  return out;
}

ReferenceResult reference_calibrate(const std::vector<RawSample>& s, const ReferenceSettings& st) {
  ReferenceResult res;
  if (!valid(st)) {
    res.status = Status::kInvalidArgument;
    return res;
  }
  for (const RawSample& x : s) {
    if (!std::isfinite(x.t) || !x.acc.allFinite() || !x.gyro.allFinite()) {
      res.status = Status::kNonFiniteInput;
      return res;
    }
  }
  const std::size_t init_end = initial_end(s, st.init_seconds);
  if (init_end < 2) {
    res.status = Status::kTooFewPoses;
    return res;
  }

  // Accelerometer: one pose per rest, with its noise, through the library; with
  // a k range, the k whose fit has the lowest residual RMS (imu_tk).
  std::vector<Pose<double>> poses;
  Status acc_status = Status::kTooFewPoses;
  const double k_last = st.k_max > st.k ? st.k_max : st.k;
  for (double k = st.k; k <= k_last + 1e-9; k += 1.0) {
    ReferenceSettings trial = st;
    trial.k = k;
    const std::vector<RestInterval> rests =
        st.given_rests != nullptr ? *st.given_rests : detect_rests(s, trial);
    if (rests.size() < static_cast<std::size_t>(kAccelMinPoses)) continue;
    std::vector<Pose<double>> trial_poses;
    trial_poses.reserve(rests.size());
    for (const RestInterval& iv : rests) {
      V3 sum = V3::Zero();
      double diff2 = 0.0;  // squared sample-to-sample differences: white noise, drift excluded
      for (std::size_t i = iv.begin; i < iv.end; ++i) {
        sum += s[i].acc;
        if (i > iv.begin) diff2 += (s[i].acc - s[i - 1].acc).squaredNorm();
      }
      const std::size_t count = iv.end - iv.begin;
      // The pose's noise (Pose::noise) as the library measures it: one sample, one axis.
      const double noise = count > 1 ? diff2 / (6.0 * static_cast<double>(count - 1)) : 0.0;
      trial_poses.push_back(
          {sum / static_cast<double>(count), static_cast<std::uint32_t>(count), noise});
    }
    AccelSettings<double> acc_settings;
    acc_settings.gravity = st.gravity;
    AccelCalibration<double> acc;
    const Status ts = calibrate_accelerometer(
        PoseSpan<double>{trial_poses.data(), static_cast<int>(trial_poses.size())}, acc_settings,
        acc);
    if (!succeeded(ts)) {
      if (!succeeded(acc_status)) acc_status = ts;
      continue;
    }
    if (succeeded(acc_status) && acc.residual_rms >= res.acc.residual_rms) continue;
    acc_status = ts;
    res.acc = acc;
    res.rests = rests;
    res.k = k;
    poses = std::move(trial_poses);
  }
  if (!succeeded(acc_status)) {
    res.status = acc_status;
    return res;
  }

  // Gyro bias from every rest, the initial one included (at rest the rate is -b): the bias is
  // added, so it is minus the mean rate over all rest samples.
  V3 mean_rate = V3::Zero();
  double rest_samples = 0.0;
  for (const auto& r : res.rests)
    for (std::size_t i = r.begin; i < r.end; ++i) {
      mean_rate += s[i].gyro;
      rest_samples += 1.0;
    }
  const V3 bias0 = -mean_rate / rest_samples;

  std::vector<Move> moves;
  for (std::size_t k = 0; k + 1 < res.rests.size(); ++k) {
    const std::size_t first = res.rests[k].end - 1, last = res.rests[k + 1].begin;
    bool ok = true;
    for (std::size_t j = first; j < last && ok; ++j) ok = step_ok(s, j, st.max_gap_seconds);
    if (!ok) continue;
    const V3 c0 = accel_apply(res.acc.params, poses[k].mean);
    const V3 c1 = accel_apply(res.acc.params, poses[k + 1].mean);
    moves.push_back({first, last, c0.normalized(), c1.normalized()});
  }
  const GyroProblem problem(s, std::move(moves), bias0, st.gyro_nominal_scale, st.refine_gyro_bias);
  const int n = problem.parameters();
  res.moves = problem.moves();
  res.gyro.segment<3>(kGyroBiasX) = bias0;
  // Each move informs 2 directions (the third residual is second order): the covariance needs
  // more of them than parameters.
  if (2 * res.moves <= n) {
    res.status = Status::kTooFewResiduals;
    return res;
  }

  ParamVector x = ParamVector::Zero(n);
  x.segment<3>(kGyroScaleX).setConstant(st.gyro_nominal_scale);
  if (n == kGyroParams) x.segment<3>(kGyroBiasX) = bias0;
  res.status = levenberg_marquardt(problem, x, res.iterations);
  if (res.status == Status::kRankDeficient || res.status == Status::kNonFiniteInput) return res;
  res.gyro.head(n) = x;

  std::vector<V3> predicted;
  problem.predicted(x, predicted);
  std::vector<V3> r(predicted.size());
  double sum_angle2 = 0;
  for (std::size_t k = 0; k < predicted.size(); ++k) {
    const V3& a = predicted[k];
    const V3& g1 = problem.move(k).g1;
    const double angle = std::atan2(a.cross(g1).norm(), a.dot(g1));
    sum_angle2 += angle * angle;
    r[k] = a - g1;
  }
  res.gyro_rms_rad = std::sqrt(sum_angle2 / static_cast<double>(res.moves));

  // Cov = (J^T J)^-1 SSE / (2 moves - n) at the final estimate.
  std::vector<JacobianBlock> jac;
  problem.jacobian(x, jac);
  ParamMatrix h;
  ParamVector grad;
  problem.normal_equations(jac, r, h, grad);
  const Eigen::LDLT<ParamMatrix> ldlt(h);
  const ParamMatrix inv = ldlt.solve(ParamMatrix::Identity(n, n));
  if (ldlt.info() != Eigen::Success || !inv.allFinite() || !(inv.diagonal().minCoeff() > 0)) {
    res.status = Status::kRankDeficient;
    return res;
  }
  const double dof = static_cast<double>(2 * res.moves - n);
  res.gyro_sigma.head(n) = (inv.diagonal() * (sum_squares(r) / dof)).cwiseSqrt();
  return res;
}

}  // namespace imucal::test
