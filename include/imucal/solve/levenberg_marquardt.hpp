// SPDX-License-Identifier: MIT
// imucal/solve/levenberg_marquardt.hpp: a fixed-size Levenberg-Marquardt driver over the normal-
// equations accumulator. It can run to completion or one iteration per step() call, so a solve
// can be time-sliced into a control loop. Never allocates, never throws, never blocks.
//
// A Problem is any type with
//   Status accumulate(const Eigen::Matrix<Scalar, N, 1>& p, NormalEquations<Scalar, N>& ne) const;
// that folds every residual row at parameters p into the (cleared) accumulator ne.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <type_traits>

#include "imucal/solve/normal_equations.hpp"

namespace imucal {

template <typename Scalar>
struct LmSettings {
  int max_iterations = 50;
  Scalar initial_lambda = Scalar(1e-3);  // damping relative to diag(H)
  Scalar max_lambda = Scalar(1e8);
  // Tolerances are relative and unit-free; the defaults suit the scalar's precision.
  Scalar step_tolerance = sizeof(Scalar) >= 8 ? Scalar(1e-10) : Scalar(2e-6);
  Scalar cost_tolerance = sizeof(Scalar) >= 8 ? Scalar(1e-12) : Scalar(1e-6);
  Scalar gradient_tolerance = sizeof(Scalar) >= 8 ? Scalar(1e-10) : Scalar(1e-5);
  // Absolute, in the cost's own units (0: off): a decrease at or below it counts as converged.
  // For a cost that is a chi-square (rows weighted by their known noise), 1e-2 is a step of
  // about 0.1 sigma; a relative tolerance cannot say that when the fit is nearly exact and the
  // cost sits at the scalar's rounding.
  Scalar absolute_cost_tolerance = Scalar(0);
};

template <typename Scalar, int N>
class LevenbergMarquardt {
 public:
  using Vector = Eigen::Matrix<Scalar, N, 1>;
  using Accumulator = NormalEquations<Scalar, N>;

  explicit LevenbergMarquardt(const LmSettings<Scalar>& settings = LmSettings<Scalar>())
      : settings_(settings) {}

  // Evaluates the problem at p0. Returns kRunning when the iteration can proceed. size: as for
  // begin().
  template <class Problem>
  Status start(const Problem& problem, const Vector& p0, int size = N) {
    if (begin(p0, size) != Status::kRunning) return status_;
    return evaluated(problem.accumulate(evaluation_point(), evaluation_accumulator()));
  }
  // A problem of M < N unknowns from its own p0: padded with 0 and solved at size M.
  template <class Problem, int M, typename = std::enable_if_t<(M < N)>>
  Status start(const Problem& problem, const Eigen::Matrix<Scalar, M, 1>& p0) {
    Vector p = Vector::Zero();
    p.template head<M>() = p0;
    return start(problem, p, M);
  }

  // One iteration: one pass over the residuals and one or more N x N factorisations.
  // A step shrunk by heavy damping is never mistaken for convergence (see gauss_newton_done).
  template <class Problem>
  Status step(const Problem& problem) {
    if (!evaluation_pending()) return status_;
    return evaluated(problem.accumulate(evaluation_point(), evaluation_accumulator()));
  }

  template <class Problem>
  Status run(const Problem& problem, const Vector& p0) {
    Status s = start(problem, p0);
    while (s == Status::kRunning) s = step(problem);
    return s;
  }

  // The same iteration with the evaluation left to the caller, who may spread one pass over
  // the residuals across many calls (time slicing):
  //   begin(p0); then, while evaluation_pending(): fold every row at evaluation_point() into
  //   evaluation_accumulator() (already cleared), and report with evaluated(status).
  // size: the parameters fitted, the first `size` of the N (1..N): the rest of p0 stays as it is
  // (0, for a problem whose count is known only at run time: NormalEquations::resize()).
  Status begin(const Vector& p0, int size = N) {
    iterations_ = 0;
    lambda_ = settings_.initial_lambda;
    pending_ = false;
    if (!all_finite(p0)) return status_ = Status::kNonFiniteInput;
    if (settings_.max_iterations < 1 || !(settings_.initial_lambda > Scalar(0)) ||
        !(settings_.max_lambda > settings_.initial_lambda))
      return status_ = Status::kInvalidArgument;
    if (size < 1 || size > N) return status_ = Status::kInvalidArgument;
    p_ = p0;
    current_.resize(size);
    trial_.resize(size);
    at_start_ = true;
    pending_ = true;
    return status_ = Status::kRunning;
  }

  // Not started, with new settings, in place (as a new LevenbergMarquardt(settings)).
  void reset(const LmSettings<Scalar>& settings) {
    settings_ = settings;
    p_.setZero();
    iterations_ = 0;
    lambda_ = predicted_ = step_norm_ = Scalar(0);
    at_start_ = pending_ = false;
    status_ = Status::kNotStarted;
  }

  bool evaluation_pending() const { return status_ == Status::kRunning && pending_; }
  const Vector& evaluation_point() const { return at_start_ ? p_ : trial_p_; }
  Accumulator& evaluation_accumulator() { return at_start_ ? current_ : trial_; }

  // Takes the finished evaluation (or the reason it failed) and either stops or asks for the
  // next one: after an accepted or rejected trial the next damped step is proposed at once.
  Status evaluated(Status accumulate_status) {
    if (!evaluation_pending()) return status_;
    pending_ = false;
    if (at_start_) {
      at_start_ = false;
      if (accumulate_status != Status::kOk) return status_ = accumulate_status;
      status_ = check_gradient();
      return status_ == Status::kRunning ? propose() : status_;
    }
    const Scalar f0 = current_.weighted_sse();
    const Scalar actual = f0 - trial_.weighted_sse();
    if (accumulate_status == Status::kOk && actual > Scalar(0)) {
      const Scalar lambda_used = lambda_;
      p_ = trial_p_;
      current_ = trial_;
      lambda_ = lambda_ / Scalar(10);
      if (lambda_ < Scalar(1e-12)) lambda_ = Scalar(1e-12);
      const bool tiny_step = small_step(step_norm_);
      const Scalar tol = cost_tolerance(f0);
      const bool tiny_gain = actual <= tol && predicted_ <= Scalar(2) * tol;
      // A heavily damped step is small for the wrong reason: then only the undamped
      // Gauss-Newton step at the new point may confirm convergence.
      if ((tiny_step || tiny_gain) && (lambda_used <= Scalar(1) || gauss_newton_done()))
        return status_ = tiny_step ? Status::kConvergedStep : Status::kConvergedCost;
      status_ = check_gradient();
      if (status_ == Status::kRunning && iterations_ >= settings_.max_iterations)
        status_ = Status::kMaxIterations;
      return status_ == Status::kRunning ? propose() : status_;
    }
    // Rejected. Nothing left to gain if even the undamped Gauss-Newton step is negligible
    // here (in float this is how the precision limit shows).
    if (accumulate_status == Status::kOk && gauss_newton_done())
      return status_ = Status::kConvergedCost;
    return more_damping(Status::kOk);
  }

  Status status() const { return status_; }
  const Vector& parameters() const { return p_; }
  // The accumulator evaluated at parameters(): cost, gradient and covariance there.
  const Accumulator& normal_equations() const { return current_; }
  int iterations() const { return iterations_; }
  Scalar lambda() const { return lambda_; }
  const LmSettings<Scalar>& settings() const { return settings_; }

 private:
  Status check_gradient() const {
    return current_.gradient_cosine() <= settings_.gradient_tolerance ? Status::kConvergedGradient
                                                                      : Status::kRunning;
  }

  // The undamped Gauss-Newton step from the current point is tiny, or predicts a negligible
  // decrease: the current point is a minimum of the local model, whatever the damping.
  bool gauss_newton_done() const {
    Vector gn;
    if (current_.solve_damped(Scalar(0), gn) != Status::kOk) return false;
    return small_step(gn.norm()) ||
           current_.predicted_decrease(gn) <= cost_tolerance(current_.weighted_sse());
  }

  Scalar cost_tolerance(Scalar f) const {
    const Scalar relative = settings_.cost_tolerance * f;
    return relative > settings_.absolute_cost_tolerance ? relative
                                                        : settings_.absolute_cost_tolerance;
  }

  // A step of this norm is small against the parameters.
  bool small_step(Scalar step_norm) const {
    const Scalar tol = settings_.step_tolerance;
    return step_norm <= tol * (p_.norm() + tol);
  }

  // Solves for the next trial point (one iteration); a failed solve raises the damping and
  // solves again, without a new evaluation.
  Status propose() {
    for (;;) {
      ++iterations_;
      Vector delta;
      const Status s = current_.solve_damped(lambda_, delta);
      // Damping is relative to diag(H): it cannot cure a column with no information.
      if (s == Status::kRankDeficient) return status_ = s;
      if (s == Status::kOk) {
        predicted_ = current_.predicted_decrease(delta);
        step_norm_ = delta.norm();
        trial_p_ = p_ + delta;
        trial_.clear();
        pending_ = true;
        return status_ = Status::kRunning;
      }
      if (more_damping(s) != Status::kRunning) return status_;
    }
  }

  // A failed solve or a rejected step: more damping, same linearisation. kRunning after a
  // rejected step means a new trial is pending; after a failed solve, solve again.
  Status more_damping(Status solve_status) {
    lambda_ *= Scalar(10);
    if (lambda_ > settings_.max_lambda)
      return status_ = (solve_status == Status::kOk ? Status::kNoProgress : solve_status);
    if (iterations_ >= settings_.max_iterations) return status_ = Status::kMaxIterations;
    if (solve_status == Status::kOk) return propose();
    return status_ = Status::kRunning;
  }

  LmSettings<Scalar> settings_;
  Accumulator current_;
  Accumulator trial_;
  Vector p_ = Vector::Zero();
  Vector trial_p_ = Vector::Zero();
  Scalar step_norm_ = Scalar(0);  // of the step to trial_p_
  Scalar predicted_ = Scalar(0);
  Scalar lambda_ = Scalar(0);
  bool at_start_ = false;
  bool pending_ = false;
  int iterations_ = 0;
  Status status_ = Status::kNotStarted;
};

// The LM stops with kNoProgress when the cost can no longer be evaluated precisely enough to
// see a decrease (in float, when the residuals are small differences of O(1) numbers). If the
// undamped Gauss-Newton step from where it stopped is below a tenth of every parameter's sigma
// (variance * H^-1, as NormalEquations::standard_deviations()), the estimate is as good as the
// arithmetic makes it: kConvergedCost. A tenth is float's own limit: at 1 kHz a pose mean is so
// precise that the cost's rounding (a few tenths of a chi-square unit over 15 poses) hides a
// step of about 0.06 sigma, and float and double are held to agree within 0.1 sigma. Any other
// status is returned as it is.
template <typename Scalar, int N>
Status precision_limited(const LevenbergMarquardt<Scalar, N>& lm, Status s,
                         Scalar variance = Scalar(-1)) {
  if (s != Status::kNoProgress) return s;
  Eigen::Matrix<Scalar, N, 1> gn, sd;
  const NormalEquations<Scalar, N>& ne = lm.normal_equations();
  if (ne.solve_damped(Scalar(0), gn) != Status::kOk ||
      ne.standard_deviations(sd, variance) != Status::kOk)
    return s;
  for (int i = 0; i < N; ++i)
    if (!(std::abs(gn(i)) <= Scalar(0.1) * sd(i))) return s;
  return Status::kConvergedCost;
}

}  // namespace imucal
