// SPDX-License-Identifier: MIT
#include "imucal/solve/gyro_calibration.hpp"

namespace imucal {

namespace {

// Golden-section ratio (sqrt(5) - 1) / 2.
template <typename Scalar>
constexpr Scalar kGolden = Scalar(0.6180339887498949);

// log(sqrt(2)): the grid step of the scale search.
template <typename Scalar>
constexpr Scalar kGridStep = Scalar(0.34657359027997264);

}  // namespace

template <typename Scalar>
typename GyroSolver<Scalar>::Vector GyroSolver<Scalar>::scaled_identity(Scalar s) const {
  Vector p = Vector::Zero();
  p(kGyroScaleX) = p(kGyroScaleY) = p(kGyroScaleZ) = s;
  return p;
}

template <typename Scalar>
Status GyroSolver<Scalar>::start(const GyroData<Scalar>& data, const Vector3<Scalar>& b0) {
  problem_.data = data;
  problem_.refine_bias = settings_.refine_bias;
  b0_ = b0;
  evaluations_ = 0;
  cursor_ = typename Problem::Cursor{};
  if (!all_finite(b0) || !all_finite(data.bias_shift)) return status_ = Status::kNonFiniteInput;
  if (data.move_count < 0 || data.pose_count < 0 || settings_.segments_per_step < 1 ||
      !(settings_.nominal_scale >= Scalar(0)) || !(settings_.search_min > Scalar(0)) ||
      !(settings_.search_max > settings_.search_min))
    return status_ = Status::kInvalidArgument;
  if (data.move_count < gyro_min_moves(problem_.size())) return status_ = Status::kTooFewMoves;
  for (int k = 0; k < data.move_count; ++k) {
    const GyroMove& m = data.moves[k];
    if (m.from_pose < 0 || m.from_pose >= data.pose_count || m.to_pose < 0 ||
        m.to_pose >= data.pose_count || m.segments < 0 || m.first_segment < 0)
      return status_ = Status::kInvalidArgument;
  }
  if (settings_.nominal_scale > Scalar(0)) return begin_lm(settings_.nominal_scale);
  // No scale given: a grid over log(s) in steps of sqrt(2), then golden section around the best.
  stage_ = Stage::kGrid;
  grid_k_ = 0;
  grid_n_ = 1 + static_cast<int>(detail::log_of(settings_.search_max / settings_.search_min) /
                                 kGridStep<Scalar>);
  best_cost_ = Scalar(-1);
  return status_ = Status::kRunning;
}

template <typename Scalar>
Status GyroSolver<Scalar>::begin_lm(Scalar s) {
  stage_ = Stage::kLm;
  cursor_ = typename Problem::Cursor{};
  return status_ = lm_.begin(scaled_identity(s), problem_.size());
}

template <typename Scalar>
Status GyroSolver<Scalar>::step() {
  if (status_ != Status::kRunning) return status_;
  return stage_ == Stage::kLm ? lm_step() : search_step();
}

template <typename Scalar>
Status GyroSolver<Scalar>::search_step() {
  const Scalar log_min = detail::log_of(settings_.search_min);
  Scalar x = Scalar(0);
  if (stage_ == Stage::kGrid) {
    x = log_min + static_cast<Scalar>(grid_k_) * kGridStep<Scalar>;
  } else {
    x = golden_k_ % 2 == 0 ? x1_ : x2_;
  }
  const Status s =
      problem_.cost_slice(scaled_identity(detail::exp_of(x)), cursor_, settings_.segments_per_step);
  if (s == Status::kRunning) return status_;
  if (s != Status::kOk) return status_ = s;
  const Scalar f = cursor_.cost;
  cursor_ = typename Problem::Cursor{};
  ++evaluations_;
  if (stage_ == Stage::kGrid) {
    if (best_cost_ < Scalar(0) || f < best_cost_) {
      best_cost_ = f;
      best_log_ = x;
    }
    if (++grid_k_ < grid_n_) return status_;
    // Golden section on [best - step, best + step]: evaluate x1 first, then x2.
    stage_ = Stage::kGolden;
    lo_ = best_log_ - kGridStep<Scalar>;
    hi_ = best_log_ + kGridStep<Scalar>;
    x1_ = hi_ - kGolden<Scalar> * (hi_ - lo_);
    x2_ = lo_ + kGolden<Scalar> * (hi_ - lo_);
    golden_k_ = 0;
    return status_;
  }
  // Golden section: golden_k_ 0 and 1 evaluate x1 and x2; afterwards the one new point.
  if (golden_k_ == 0) {
    f1_ = f;
    golden_k_ = 1;
    return status_;
  }
  if (golden_k_ == 1) {
    f2_ = f;
  } else if (golden_k_ % 2 == 0) {
    f1_ = f;
  } else {
    f2_ = f;
  }
  // Shrink the bracket and name the next point to evaluate (even k: x1, odd k: x2).
  if (f1_ < f2_) {
    hi_ = x2_;
    x2_ = x1_;
    f2_ = f1_;
    x1_ = hi_ - kGolden<Scalar> * (hi_ - lo_);
    golden_k_ = 2;
  } else {
    lo_ = x1_;
    x1_ = x2_;
    f1_ = f2_;
    x2_ = lo_ + kGolden<Scalar> * (hi_ - lo_);
    golden_k_ = 3;
  }
  // Stop at a bracket of 0.1 % in scale: the LM does the rest.
  if (hi_ - lo_ < Scalar(1e-3)) return begin_lm(detail::exp_of(Scalar(0.5) * (lo_ + hi_)));
  return status_;
}

template <typename Scalar>
Status GyroSolver<Scalar>::lm_step() {
  if (!lm_.evaluation_pending()) return status_ = lm_.status();
  const Status s = problem_.accumulate_slice(lm_.evaluation_point(), lm_.evaluation_accumulator(),
                                             cursor_, settings_.segments_per_step);
  if (s == Status::kRunning) return status_;
  cursor_ = typename Problem::Cursor{};
  ++evaluations_;
  // Maximum damping where the undamped step is far below every sigma is the precision limit of
  // the cost, not a failure: the accelerometer's rule (precision_limited()). A nearly exact fit
  // ends either way depending on the last bits of its data, so on the target's rounding.
  const Status st = lm_.evaluated(s);
  return status_ = st == Status::kNoProgress ? precision_limited(lm_, st) : st;
}

template <typename Scalar>
Status GyroSolver<Scalar>::finish(GyroCalibration<Scalar>& out) const {
  out = GyroCalibration<Scalar>{};
  out.status = status_;
  out.moves = problem_.data.move_count;
  out.iterations = lm_.iterations();
  out.bias_refined = problem_.refine_bias;
  if (!succeeded(status_)) return out.status;
  const auto& ne = lm_.normal_equations();
  Vector sd;
  const Status cs = ne.standard_deviations(sd);
  if (cs != Status::kOk) return out.status = cs;
  const Vector& p = lm_.parameters();
  // Unobservable: a misalignment or a relative scale, or the bias in rad/s, too uncertain.
  const Scalar limit = settings_.max_normalised_sigma;
  for (int k = 0; k < problem_.size(); ++k)
    if (!(gyro_normalised_sigma<Scalar>(p, sd, k) <= limit))
      return out.status = Status::kUnobservable;
  out.params.template head<kGyroMatrixParams>() = p.template head<kGyroMatrixParams>();
  out.sigma = sd;  // the bias's entries 0 when it is held
  // p's bias entries are 0 when it is held.
  out.params.template tail<3>() = b0_ + problem_.data.bias_shift + p.template tail<3>();
  const Scalar moves = static_cast<Scalar>(problem_.data.move_count);
  out.residual_rms = std::sqrt(ne.weighted_sse() / moves);
  return out.status;
}

template <typename Scalar>
void GyroInputUncertainty<Scalar>::start(const GyroSolver<Scalar>& solver,
                                         const AccelCovariance& cov_a) {
  full_ = solver.problem();
  full_.refine_bias = true;  // the bias columns: J_b for hb
  int k = 0;
  for (int c = 0; c < kAccelParams; ++c)
    for (int r = c; r < kAccelParams; ++r) cov_a_[k++] = cov_a(r, c);
  s_ = typename GyroProblem<Scalar>::Sensitivity{};
}

template <typename Scalar>
Status GyroInputUncertainty<Scalar>::step(const GyroSolver<Scalar>& solver,
                                          const AccelVector<Scalar>& pa, PoseSpan<Scalar> poses,
                                          int max_segments) {
  // db = 0 when the bias is held (the parameters' bias entries are 0 then).
  return full_.sensitivity_slice(solver.parameters(), pa, poses, s_, max_segments);
}

// One column of H^-1 at a time, in plain loops: a 12 x 12 Eigen product would take the general
// path, which links malloc.
template <typename Scalar>
Status GyroInputUncertainty<Scalar>::finish(const GyroSolver<Scalar>& solver,
                                            GyroCalibration<Scalar>& out) const {
  if (!succeeded(out.status)) return out.status;
  const Vector3<Scalar> sb = out.sigma.template tail<3>();
  AccelCovariance cov_a;
  int i = 0;
  for (int c = 0; c < kAccelParams; ++c)
    for (int r = c; r < kAccelParams; ++r) cov_a(r, c) = cov_a(c, r) = cov_a_[i++];
  const int n = solver.problem().size();
  const bool held = !solver.problem().refine_bias;
  Eigen::Matrix<Scalar, kGyroParams, 1> extra = Eigen::Matrix<Scalar, kGyroParams, 1>::Zero();
  // Column k of H^-1 is its row k: x_k = (H^-1 A)_k, extra_k = x_k Cov x_k^T.
  const Status s = solver.normal_equations().inverse_columns(
      Scalar(1), [&](int k, const Eigen::Matrix<Scalar, kGyroParams, 1>& column) {
        Scalar xa[kAccelParams] = {};
        Scalar xb[3] = {};
        for (int j = 0; j < n; ++j) {
          for (int q = 0; q < kAccelParams; ++q) xa[q] += column(j) * s_.a(j, q);
          if (held)
            for (int q = 0; q < 3; ++q) xb[q] += column(j) * s_.hb(j, q);
        }
        Scalar e = Scalar(0);
        for (int r = 0; r < kAccelParams; ++r)
          for (int c = 0; c < kAccelParams; ++c) e += xa[r] * cov_a(r, c) * xa[c];
        for (int q = 0; q < 3; ++q) e += xb[q] * xb[q] * sb(q) * sb(q);
        extra(k) = e;
      });
  if (s != Status::kOk) return s;
  for (int k = 0; k < n; ++k) {
    if (!(extra(k) >= Scalar(0)) || !std::isfinite(extra(k))) return Status::kIllConditioned;
    out.sigma(k) = std::sqrt(out.sigma(k) * out.sigma(k) + extra(k));
  }
  for (int k = 0; k < n; ++k)
    if (!(gyro_normalised_sigma<Scalar>(out.params, out.sigma, k) <=
          solver.settings().max_normalised_sigma))
      return Status::kUnobservable;
  return Status::kOk;
}

template class GyroSolver<float>;
template class GyroInputUncertainty<float>;
#ifndef IMUCAL_FLOAT_ONLY  // the host's reference type; a float-only build leaves it out
template class GyroSolver<double>;
template class GyroInputUncertainty<double>;
#endif

}  // namespace imucal
