// SPDX-License-Identifier: MIT
// imucal/solve/gyro_calibration.hpp: gyroscope misalignment, scale and (optionally) bias from the
// moves between still poses: Tedaldi's gravity-direction residual (math.md section 4), the
// rotation of each move re-evaluated from fixed-memory segment statistics, solved by the same
// Levenberg-Marquardt driver and accumulator as the accelerometer.
//
// For move k from pose a to pose b, with R the body-frame rotation over the move and g the unit
// gravity directions measured by the calibrated accelerometer,
//
//   r_k = R^T g_a - g_b
//
// Only the two components of r_k perpendicular to g_b are accumulated: the third is
// -angle^2/2, second order, and carries no information at the solution; dropping it gives each
// move its true two degrees of freedom, which the covariance needs.
//
// The segment statistics are of u = w_raw + b0, the raw rate corrected by the initial-rest bias
// b0 (both in sensor units, bias ADDED as in the seed). The bias is b0 + bias_shift (GyroData),
// plus db when refined.
#pragma once

#include <Eigen/Core>
#include <climits>
#include <cmath>

#include "imucal/models/accel_model.hpp"
#include "imucal/models/calibration.hpp"
#include "imucal/models/gyro_model.hpp"
#include "imucal/solve/levenberg_marquardt.hpp"
#include "imucal/solve/normal_equations.hpp"
#include "imucal/solve/pose_store.hpp"
#include "imucal/status.hpp"
#include "imucal/stream/gyro_segment.hpp"

namespace imucal {

// One move: the consecutive segments [first_segment, first_segment + segments) integrated from
// the end of pose from_pose to the start of pose to_pose.
struct GyroMove {
  int first_segment = 0;
  int segments = 0;
  int from_pose = 0;
  int to_pose = 0;
};

// What the gyro run reads; the memory belongs to the caller (the calibrator's stores).
template <typename Scalar>
struct GyroData {
  const GyroSegment<Scalar>* segments = nullptr;
  const GyroMove* moves = nullptr;
  int move_count = 0;
  const Vector3<Scalar>* up = nullptr;  // unit gravity direction of each pose (calibrated)
  int pose_count = 0;
  // Added to b0 before anything is fitted: the bias is b0 + bias_shift (+ the refined db).
  Vector3<Scalar> bias_shift = Vector3<Scalar>::Zero();
};

// The residual problem over all moves, with the bias held at b0 + bias_shift (9 parameters: the
// entries of the vectors from kGyroBiasX on are 0) or refined (12). One code for both: the
// accumulator is sized at run time (size()). Evaluation can be sliced: a cursor carries the
// partial rotation of the move in progress.
template <typename Scalar>
class GyroProblem {
 public:
  static constexpr int N = kGyroParams;
  static_assert(N == kSolverCapacity, "the accelerometer's solver shares the gyro's capacity");
  using Vector = Eigen::Matrix<Scalar, N, 1>;
  using Accumulator = NormalEquations<Scalar, N>;

  // Where an evaluation pass stands: move, segment, and the rotated gravity v = R^T g_a with its
  // derivatives (columns: the 9 entries of M column-major, then db).
  struct Cursor {
    int move = 0;
    int segment = 0;
    bool begun = false;
    Vector3<Scalar> v = Vector3<Scalar>::Zero();
    Eigen::Matrix<Scalar, 3, N> dv = Eigen::Matrix<Scalar, 3, N>::Zero();
    Scalar cost = Scalar(0);  // the cost-only pass sums here
  };

  GyroData<Scalar> data{};
  bool refine_bias = false;  // the bias columns are computed (and, in a solve, fitted)

  // The parameters fitted: 9, or 12 with the bias.
  int size() const { return refine_bias ? kGyroParams : kGyroMatrixParams; }

  // Folds the rows of at most max_segments segments (whole moves at the end of each) into ne
  // (a NormalEquations, or anything with the same add(row, residual)). kRunning while moves
  // remain, kOk when the pass is complete, or why a row was refused.
  template <class Acc>
  Status accumulate_slice(const Vector& p, Acc& ne, Cursor& c, int max_segments) const {
    return pass<true>(p, &ne, c, max_segments);
  }

  // The LM's Problem interface: one whole pass.
  template <class Acc>
  Status accumulate(const Vector& p, Acc& ne) const {
    Cursor c;
    Status s;
    while ((s = accumulate_slice(p, ne, c, INT_MAX)) == Status::kRunning) {
    }
    return s;
  }

  // The cost only (sum of squared residual components), sliced the same way; the sum is in
  // c.cost once the return is kOk.
  Status cost_slice(const Vector& p, Cursor& c, int max_segments) const {
    return pass<false, Accumulator>(p, nullptr, c, max_segments);
  }

  // A move walked as its segments come, without keeping them (the field calibrator): start_move()
  // with its start's gravity direction, add_segment() for each segment in order, end_move() with
  // its end's: the same two rows as accumulate() over the stored move. data.bias_shift and
  // refine_bias apply as there; data's segments and moves are not used.
  void start_move(const Vector3<Scalar>& ga, Cursor& c) const {
    c = Cursor{};
    c.v = ga;
    c.begun = true;
  }
  Status add_segment(const Vector& p, const GyroSegment<Scalar>& seg, Cursor& c) const {
    if (!all_finite(p)) return Status::kNonFiniteInput;
    const Matrix3<Scalar> m = gyro_matrix<Scalar>(p);
    advance<true>(seg, m, GyroSegment<Scalar>::cofactor(m), data.bias_shift + p.template tail<3>(),
                  refine_bias, c);
    return Status::kOk;
  }
  template <class Acc>
  Status end_move(const Vector& p, const Vector3<Scalar>& gb, Acc& ne, Cursor& c) const {
    return finish_move<true>(p, gb, &ne, c);
  }

  // The state of a sensitivity pass (sensitivity_slice()).
  struct Sensitivity {
    Cursor c{};
    Matrix3<Scalar> rt = Matrix3<Scalar>::Identity();  // R^T of the move so far
    Eigen::Matrix<Scalar, N, kAccelParams> a = Eigen::Matrix<Scalar, N, kAccelParams>::Zero();
    Eigen::Matrix<Scalar, kGyroMatrixParams, 3> hb =
        Eigen::Matrix<Scalar, kGyroMatrixParams, 3>::Zero();
  };

  // What the inputs held fixed do to the solution, sliced as accumulate_slice() (each pass costs
  // about one LM evaluation). Sums over the rows: a = J^T dr/dp_a, where the accelerometer's
  // parameters p_a move the gravity directions, dr/dp_a = e^T (R^T D_a - D_b) for the move from
  // pose a to pose b, e the row's direction and D = d(up)/dp_a (3 x 9) at the pose's raw mean
  // (accel_direction_jacobian(); pa: the accelerometer's parameters, poses: its poses); and
  // hb = J_M^T J_b, the block of the information matrix that couples M to the bias. Needs the
  // bias columns (refine_bias), whether the solve fitted the bias or not.
  Status sensitivity_slice(const Vector& p, const AccelVector<Scalar>& pa, PoseSpan<Scalar> poses,
                           Sensitivity& s, int max_segments) const {
    if (!refine_bias) return Status::kInvalidArgument;
    return walk<true>(p, s.c, max_segments, &s.rt, [&](const GyroMove& mv) {
      if (mv.from_pose >= poses.size || mv.to_pose >= poses.size) return Status::kInvalidArgument;
      const Eigen::Matrix<Scalar, 3, kAccelParams> dr =
          s.rt * accel_direction_jacobian(pa, poses[mv.from_pose].mean) -
          accel_direction_jacobian(pa, poses[mv.to_pose].mean);
      Vector3<Scalar> e[2];
      tangent_basis(data.up[mv.to_pose], e[0], e[1]);
      for (const Vector3<Scalar>& ei : e) {
        const Vector j = parameter_row(p, Vector(ei.transpose() * s.c.dv));
        const Eigen::Matrix<Scalar, 1, kAccelParams> row = ei.transpose() * dr;
        s.a += j * row;
        s.hb += j.template head<kGyroMatrixParams>() * j.template tail<3>().transpose();
      }
      return all_finite(s.a) && all_finite(s.hb) ? Status::kOk : Status::kNonFiniteInput;
    });
  }

 private:
  template <bool kJacobian, class Acc>
  Status pass(const Vector& p, Acc* ne, Cursor& c, int max_segments) const {
    return walk<kJacobian>(p, c, max_segments, nullptr, [&](const GyroMove& mv) {
      return finish_move<kJacobian>(p, data.up[mv.to_pose], ne, c);
    });
  }

  // Integrates the moves from the cursor on, at most max_segments segments (kRunning when the
  // budget ends first), and calls end(move) at each move's end (its status: kOk to go on). With
  // rotation, *rotation is R^T of the move so far.
  template <bool kJacobian, class End>
  Status walk(const Vector& p, Cursor& c, int max_segments, Matrix3<Scalar>* rotation,
              const End& end) const {
    if (!all_finite(p)) return Status::kNonFiniteInput;
    const Matrix3<Scalar> m = gyro_matrix<Scalar>(p);
    const Matrix3<Scalar> cof = GyroSegment<Scalar>::cofactor(m);
    // The bias entries of p are 0 when it is held.
    const Vector3<Scalar> db = data.bias_shift + p.template tail<3>();
    int budget = max_segments;
    while (c.move < data.move_count) {
      const GyroMove& mv = data.moves[c.move];
      if (!c.begun) {
        c.v = data.up[mv.from_pose];
        c.dv.setZero();
        c.segment = 0;
        c.begun = true;
        if (rotation != nullptr) rotation->setIdentity();
      }
      for (; c.segment < mv.segments; ++c.segment) {
        if (budget-- <= 0) return Status::kRunning;
        advance<kJacobian>(data.segments[mv.first_segment + c.segment], m, cof, db, refine_bias, c,
                           rotation);
      }
      const Status s = end(mv);
      if (s != Status::kOk) return s;
      c.begun = false;
      ++c.move;
    }
    return Status::kOk;
  }

  // v <- E^T v for the segment's rotation E = exp([Omega]x), and (with kJacobian)
  // dv <- E^T (dv + [v]x J_l(Omega) dOmega): d(exp(-[Omega]x) v)/dOmega = E^T [v]x J_l(Omega).
  // With rotation, also rotation <- E^T rotation (R^T of the move so far). Without bias columns,
  // those of dv stay 0 and are not computed.
  template <bool kJacobian>
  static void advance(const GyroSegment<Scalar>& seg, const Matrix3<Scalar>& m,
                      const Matrix3<Scalar>& cof, const Vector3<Scalar>& db, bool bias_columns,
                      Cursor& c, Matrix3<Scalar>* rotation = nullptr) {
    const Vector3<Scalar> ab = seg.alpha + seg.duration * db;
    const Vector3<Scalar> bb = seg.beta + seg.gamma.cross(db);
    const Vector3<Scalar> omega = m * ab + Scalar(0.5) * (cof * bb);
    Scalar ka, kb, kc;
    rodrigues_coefficients(omega.squaredNorm(), ka, kb, kc);
    const Matrix3<Scalar> w = skew(omega);
    const Matrix3<Scalar> w2 = w * w;
    // E^T = exp(-[Omega]x) = I - a [Omega]x + b [Omega]x^2
    const Matrix3<Scalar> et = Matrix3<Scalar>::Identity() - ka * w + kb * w2;
    if constexpr (kJacobian) {
      const Matrix3<Scalar> jl = Matrix3<Scalar>::Identity() + kb * w + kc * w2;
      const Matrix3<Scalar> g = skew(c.v) * jl;
      // dOmega/dM: column block j is ab(j) I + 1/2 D_j, with the cofactor's derivative
      // D_0 = b1 [m2]x - b2 [m1]x, D_1 = b2 [m0]x - b0 [m2]x, D_2 = b0 [m1]x - b1 [m0]x.
      const Matrix3<Scalar> s0 = skew(Vector3<Scalar>(m.col(0)));
      const Matrix3<Scalar> s1 = skew(Vector3<Scalar>(m.col(1)));
      const Matrix3<Scalar> s2 = skew(Vector3<Scalar>(m.col(2)));
      const Scalar h = Scalar(0.5);
      Eigen::Matrix<Scalar, 3, kGyroMatrixParams> d;
      d.template block<3, 3>(0, 0) = ab(0) * g + h * (g * (bb(1) * s2 - bb(2) * s1));
      d.template block<3, 3>(0, 3) = ab(1) * g + h * (g * (bb(2) * s0 - bb(0) * s2));
      d.template block<3, 3>(0, 6) = ab(2) * g + h * (g * (bb(0) * s1 - bb(1) * s0));
      auto dm = c.dv.template leftCols<kGyroMatrixParams>();
      dm = et * (dm + d);
      if (bias_columns) {
        // dOmega/ddb = T M + 1/2 cof(M) [C]x (alpha_b = alpha + T db, beta_b = B + C x db)
        const Matrix3<Scalar> db_col = g * (seg.duration * m + h * (cof * skew(seg.gamma)));
        auto dbias = c.dv.template rightCols<3>();
        dbias = et * (dbias + db_col);
      }
    }
    c.v = et * c.v;
    if (rotation != nullptr) *rotation = et * *rotation;
  }

  // Two rows per move: the components of r = v - g_b along a basis (e1, e2) perpendicular to
  // g_b. The Jacobian columns for the entries of M map to the 9 parameters through M = T K.
  template <bool kJacobian, class Acc>
  static Status finish_move(const Vector& p, const Vector3<Scalar>& gb, Acc* ne, Cursor& c) {
    Vector3<Scalar> e1, e2;
    tangent_basis(gb, e1, e2);
    const Vector3<Scalar> r = c.v - gb;
    const Scalar r1 = e1.dot(r), r2 = e2.dot(r);
    if constexpr (!kJacobian) {
      c.cost += r1 * r1 + r2 * r2;
      return std::isfinite(c.cost) ? Status::kOk : Status::kNonFiniteInput;
    } else {
      Status s = ne->add(parameter_row(p, Vector(e1.transpose() * c.dv)), r1);
      if (s == Status::kOk) s = ne->add(parameter_row(p, Vector(e2.transpose() * c.dv)), r2);
      return s;
    }
  }

  // d/dq from d/dM (column-major entries, index 3 col + row) for M = T K.
  static Vector parameter_row(const Vector& p, const Vector& jm) {
    Vector j = jm;  // the bias columns carry over
    j(kGammaYz) = -p(kGyroScaleY) * jm(3);
    j(kGammaZy) = p(kGyroScaleZ) * jm(6);
    j(kGammaZx) = -p(kGyroScaleZ) * jm(7);
    j(kGammaXz) = p(kGyroScaleX) * jm(1);
    j(kGammaXy) = -p(kGyroScaleX) * jm(2);
    j(kGammaYx) = p(kGyroScaleY) * jm(5);
    j(kGyroScaleX) = jm(0) + p(kGammaXz) * jm(1) - p(kGammaXy) * jm(2);
    j(kGyroScaleY) = -p(kGammaYz) * jm(3) + jm(4) + p(kGammaYx) * jm(5);
    j(kGyroScaleZ) = p(kGammaZy) * jm(6) - p(kGammaZx) * jm(7) + jm(8);
    return j;
  }

  static void tangent_basis(const Vector3<Scalar>& g, Vector3<Scalar>& e1, Vector3<Scalar>& e2) {
    int k = 0;  // the axis least aligned with g gives a well-conditioned cross product
    if (std::abs(g(1)) < std::abs(g(k))) k = 1;
    if (std::abs(g(2)) < std::abs(g(k))) k = 2;
    e1 = g.cross(Vector3<Scalar>::Unit(k)).normalized();
    e2 = g.cross(e1);
  }
};

template <typename Scalar>
struct GyroSettings {
  // rad/s per sensor unit, if known (datasheet). 0: found from the data by a 1-D search over a
  // common scale in [search_min, search_max] (a grid in steps of sqrt(2), then golden section).
  Scalar nominal_scale = Scalar(0);
  Scalar search_min = Scalar(1e-6);
  Scalar search_max = Scalar(10);
  bool refine_bias = false;  // 9 parameters (Tedaldi: bias from the initial rest) or 12
  // Segments folded per step() (time slicing): bounds the work of one call.
  // 32: ~0.1 M instructions a step on a Cortex-M4F (bench_stream), 0.6 ms at 168 MHz.
  int segments_per_step = 32;
  // Largest accepted sigma: misalignment in rad, scale relative, bias in rad/s. Larger means
  // the moves do not determine that parameter (kUnobservable).
  Scalar max_normalised_sigma = Scalar(0.02);
  LmSettings<Scalar> lm = default_lm();

  // In float the cost of a long move goes through hundreds of rotations: its rounding noise is
  // ~1e-6 of the cost, so a decrease below 1e-5 cannot be told from noise (and damping would
  // otherwise climb to its maximum, kNoProgress, at the minimum).
  static LmSettings<Scalar> default_lm() {
    LmSettings<Scalar> s;
    if (sizeof(Scalar) < 8) s.cost_tolerance = Scalar(1e-5);
    return s;
  }
};

// A gyro parameter's sigma in comparable units: misalignment in rad, scale relative to itself,
// bias in rad/s (times its axis' scale). p and sd: the parameters and their sigmas (9 or 12).
template <typename Scalar, class P, class S>
Scalar gyro_normalised_sigma(const P& p, const S& sd, int k) {
  if (k >= kGyroBiasX) return sd(k) * std::abs(p(kGyroScaleX + (k - kGyroBiasX)));
  if (k >= kGyroScaleX) return sd(k) / std::abs(p(k));
  return sd(k);
}

// Fewest moves: two rows each, more rows than parameters.
constexpr int gyro_min_moves(int n) { return n / 2 + 1; }

// The gyro solve in bounded steps: the scale search (when no nominal scale is given) and then
// the LM, each step folding at most segments_per_step segments. settings.refine_bias says whether
// the bias is fitted (12 parameters) or held (9: the vectors' bias entries are 0).
template <typename Scalar>
class GyroSolver {
 public:
  using Problem = GyroProblem<Scalar>;
  using Vector = typename Problem::Vector;

  explicit GyroSolver(const GyroSettings<Scalar>& settings = GyroSettings<Scalar>())
      : settings_(settings), lm_(settings.lm) {}

  // b0: the initial-rest bias the segments were corrected with (sensor units, added).
  Status start(const GyroData<Scalar>& data, const Vector3<Scalar>& b0);
  Status step();
  Status finish(GyroCalibration<Scalar>& out) const;
  // The solution, its problem and its normal equations (after a usable finish()).
  const Problem& problem() const { return problem_; }
  const Vector& parameters() const { return lm_.parameters(); }
  const NormalEquations<Scalar, kGyroParams>& normal_equations() const {
    return lm_.normal_equations();
  }
  const GyroSettings<Scalar>& settings() const { return settings_; }
  Status status() const { return status_; }
  int iterations() const { return lm_.iterations(); }
  int evaluations() const { return evaluations_; }

 private:
  enum class Stage : std::uint8_t { kGrid, kGolden, kLm };
  Vector scaled_identity(Scalar s) const;
  Status begin_lm(Scalar s);
  Status search_step();
  Status lm_step();

  GyroSettings<Scalar> settings_;
  Problem problem_{};
  LevenbergMarquardt<Scalar, kGyroParams> lm_;
  typename Problem::Cursor cursor_{};
  Vector3<Scalar> b0_ = Vector3<Scalar>::Zero();
  Stage stage_ = Stage::kLm;
  // Scale search on log(s): grid point k, best so far; golden bracket [lo, hi] with x1 < x2.
  int grid_k_ = 0;
  int grid_n_ = 0;
  Scalar best_log_ = Scalar(0), best_cost_ = Scalar(0);
  Scalar lo_ = Scalar(0), hi_ = Scalar(0), x1_ = Scalar(0), x2_ = Scalar(0);
  Scalar f1_ = Scalar(0), f2_ = Scalar(0);
  int golden_k_ = 0;
  int evaluations_ = 0;
  Status status_ = Status::kNotStarted;
};

// What the inputs the gyro solve holds fixed carry into its sigma (first order, the two-step
// covariance of Murphy and Topel): Cov += H^-1 A Cov_in A^T H^-1, for the accelerometer's
// parameters (through every pose's gravity direction) and, when the bias is held at the rests'
// mean rate (N = 9), for that bias (through every move's rotation). The solver's own sigma holds
// the gravity directions exact; on a warming accelerometer, whose bias the poses see change, its
// misalignments' errors are 1.3 to 1.6 times that sigma (RMS over simulated recordings). A pass of
// bounded steps over the segments, as the solve's; its memory (under 1 KB in float) can share the
// accelerometer solver's, which is done by then.
template <typename Scalar>
class GyroInputUncertainty {
 public:
  using AccelCovariance = Eigen::Matrix<Scalar, kAccelParams, kAccelParams>;

  // solver: finished and usable; cov_a: the accelerometer's covariance in sensor units.
  void start(const GyroSolver<Scalar>& solver, const AccelCovariance& cov_a);

  // Folds at most max_segments segments: kRunning while moves remain, kOk when done. The same
  // solver as start()'s; pa and poses: the accelerometer's parameters and the poses the gyro's
  // moves join (their raw means give each gravity direction's d(up)/dp_a).
  Status step(const GyroSolver<Scalar>& solver, const AccelVector<Scalar>& pa,
              PoseSpan<Scalar> poses, int max_segments);

  // Widens out.sigma (the solver's own finish(); with the bias held, out.sigma's bias entries are
  // the held bias's sigma) by what the pass found; kUnobservable if a widened sigma passes the
  // solver's max_normalised_sigma.
  Status finish(const GyroSolver<Scalar>& solver, GyroCalibration<Scalar>& out) const;

 private:
  GyroProblem<Scalar> full_{};  // the solver's problem with the bias columns computed
  Scalar cov_a_[kAccelParams * (kAccelParams + 1) / 2] = {};  // lower triangle, by column
  typename GyroProblem<Scalar>::Sensitivity s_{};
};

extern template class GyroSolver<float>;
extern template class GyroSolver<double>;
extern template class GyroInputUncertainty<float>;
extern template class GyroInputUncertainty<double>;

}  // namespace imucal
