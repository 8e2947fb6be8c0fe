#include "imucal/status.hpp"

namespace imucal {

const char* to_string(Status s) {
  switch (s) {
    case Status::kOk:
      return "ok";
    case Status::kRunning:
      return "running";
    case Status::kConvergedStep:
      return "converged (step below tolerance)";
    case Status::kConvergedGradient:
      return "converged (gradient below tolerance)";
    case Status::kConvergedCost:
      return "converged (cost no longer decreasing)";
    case Status::kMaxIterations:
      return "stopped at the iteration limit";
    case Status::kNoProgress:
      return "no progress (damping at maximum)";
    case Status::kNotStarted:
      return "solver not started";
    case Status::kNonFiniteInput:
      return "non-finite input (NaN or infinity)";
    case Status::kInvalidArgument:
      return "invalid argument";
    case Status::kCapacityExceeded:
      return "capacity exceeded";
    case Status::kTooFewPoses:
      return "too few poses";
    case Status::kTooFewDistinctPoses:
      return "too few distinct poses";
    case Status::kPosesCoplanar:
      return "poses coplanar (turned about one axis only)";
    case Status::kTooFewResiduals:
      return "too few residuals for a covariance";
    case Status::kRankDeficient:
      return "rank-deficient normal equations";
    case Status::kIllConditioned:
      return "ill-conditioned normal equations";
    case Status::kNotAnEllipsoid:
      return "fitted quadric is not an ellipsoid";
    case Status::kUnobservable:
      return "a parameter is not observable from these poses";
  }
  return "unknown status";
}

}  // namespace imucal
