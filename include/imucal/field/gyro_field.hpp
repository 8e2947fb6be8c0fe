// SPDX-License-Identifier: MIT
// imucal/field/gyro_field.hpp: the gyroscope's misalignment and scale from natural moves (the
// design's field.md section 4), for the field calibrator.
//
// A move between two rests the field calibrator took gives the protocol's two residual rows
// (solve/gyro_calibration.hpp: r = R^T g_a - g_b across g_b, R the move's rotation through the
// gyro model, g_a and g_b the gravity directions at its ends through the accelerometer's model).
// They are linearised at the current estimate and taken by a Kalman update of the nine
// parameters, which start at the prior: the stored calibration's, or the nominal model with a
// datasheet's tolerances. A parameter the moves do not determine keeps its prior value and sigma.
// A move whose residual lies outside the gate of the prediction (chi-square(2)) is refused: a
// rest that was not one, a gyro that clipped unseen.
//
// A move's noise, per residual component: the two ends' directions (each rest's mean), the
// bias's uncertainty over the move's duration, the accelerometer model's (its scale and
// misalignment sigma times the move's angle) and a floor (a rest's mean direction against the
// attitude where the move starts and ends). The gyro's axes are measured against the
// accelerometer's: while the accelerometer's scale or misalignment sigma exceeds
// accel_shape_max no move is taken (they would teach the accelerometer's errors), and the
// published sigmas include the largest accelerometer sigma the moves were taken with (an error
// common to every move, which more moves do not average away).
//
// The estimate replaces the published one only when it is better: no sigma larger, and either
// the two differ significantly (chi-square(9) on the difference with both covariances) or a
// sigma is at most better_ratio of the published one's. A move is walked as its segments come
// (begin_move(), add_segment(), end_move()): fixed memory whatever its length.
//
// A change of the matrix itself (a knock that bent the board, a sensor remounted) makes the
// moves disagree with the published one: they are refused. The last kChangeMoves refused moves
// are kept (their rows, moved along with the estimate as later moves are taken). When change_moves
// of them were refused within twice as many moves, and one matrix explains them all (the estimate,
// its covariance widened by the datasheet's tolerances, takes each within the gate in turn), the
// matrix changed: that estimate is published at once (kChanged). Refusals at 0.1 % each, that
// many within so few moves, are far beyond 5 sigma of chance; a disturbed rest refuses one move
// and is not explained with the others.
// Fixed memory, no allocation, no exceptions. Header-only.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>

#include "imucal/models/gyro_model.hpp"
#include "imucal/solve/gyro_calibration.hpp"
#include "imucal/solve/ldlt.hpp"
#include "imucal/solve/normal_equations.hpp"
#include "imucal/status.hpp"
#include "imucal/types.hpp"

namespace imucal {

// The refused moves kept to look for a change of the matrix.
constexpr int kChangeMoves = 5;

template <typename Scalar>
struct GyroFieldSettings {
  bool enabled = true;
  // The prior without a stored calibration: the nominal scale with this relative sigma, no
  // misalignment with this sigma (rad). A datasheet's +-3 % and +-2 % read as uniform.
  Scalar scale_sigma = Scalar(0.017);
  Scalar misalignment_sigma = Scalar(0.0115);
  // A move's gyro segments: path angle (rad) and |alpha||beta| (rad^3) bounds, as the
  // protocol's (CalibratorSettings::segment_max_angle, _error).
  Scalar segment_max_angle = Scalar(0.6);
  Scalar segment_max_error = Scalar(1e-3);
  Scalar move_floor = Scalar(5e-4);       // rad, per residual component
  Scalar min_angle = Scalar(0.3);         // rad: a move that turned less is not used
  Scalar accel_shape_max = Scalar(3e-3);  // the accelerometer's scale (relative), misalignment
  Scalar gate_chi2 = Scalar(13.82);       // chi-square(2) at 0.1 %: a move is taken
  Scalar publish_chi2 = Scalar(16.92);    // chi-square(9) at 5 %: the published one is replaced
  Scalar better_ratio = Scalar(0.25);     // ... or a sigma squared is at most this share
  int segments_per_step = 4;              // segments a call folds
  // Refused moves, within twice as many moves, that prove a change (at most kChangeMoves).
  int change_moves = 5;

  bool valid() const {
    const auto positive = [](Scalar x) { return std::isfinite(x) && x > Scalar(0); };
    return positive(scale_sigma) && positive(misalignment_sigma) && positive(segment_max_angle) &&
           positive(segment_max_error) && std::isfinite(move_floor) && move_floor >= Scalar(0) &&
           std::isfinite(min_angle) && min_angle >= Scalar(0) && positive(accel_shape_max) &&
           positive(gate_chi2) && positive(publish_chi2) && positive(better_ratio) &&
           better_ratio < Scalar(1) && segments_per_step >= 1 && change_moves >= 2 &&
           change_moves <= kChangeMoves;
  }
};

enum class GyroFieldEvent : std::uint8_t {
  kNone = 0,     // nothing finished in this call
  kTaken = 1,    // a move was taken, the published model stays
  kRefused = 2,  // a move's residual was outside the gate
  kUpdated = 3,  // a move was taken and the model published
  kChanged = 4,  // a move was refused, and with the refused before it proves a change: published
};

template <typename Scalar>
class GyroField {
 public:
  static constexpr int N = kGyroMatrixParams;
  using Vector = Eigen::Matrix<Scalar, N, 1>;
  using Matrix = Eigen::Matrix<Scalar, N, N>;
  using Settings = GyroFieldSettings<Scalar>;

  // Starts from the prior: the nine parameters (misalignment, scale; the model's units) and
  // their sigmas. kInvalidArgument: settings out of range or a prior that is not finite, or a
  // sigma not positive (nothing is taken then).
  Status start(const Settings& s, const Vector& prior, const Vector& sigma) {
    settings_ = s;
    valid_ =
        s.valid() && all_finite(prior) && all_finite(sigma) && (sigma.array() > Scalar(0)).all();
    walking_ = false;
    moves_ = refused_ = 0;
    kept_ = next_ = 0;
    changes_ = 0;
    has_published_ = false;
    chi2_ = Scalar(0);
    shape_ = Scalar(0);
    reason_ = 0;
    if (!valid_) return Status::kInvalidArgument;
    theta_ = published_ = prior;
    p_.setZero();
    for (int i = 0; i < N; ++i) p_(diagonal(i)) = sigma(i) * sigma(i);
    published_p_ = p_;
    return Status::kOk;
  }

  bool enabled() const { return valid_ && settings_.enabled; }
  // A move is being walked.
  bool walking() const { return walking_; }

  // A move begins: the gravity direction at its start (unit, through the accelerometer's model),
  // the bias's best estimate less the one its segments will include, and the accelerometer
  // model's shape sigma. False (nothing begun) while the accelerometer is not known well enough
  // (accel_shape_max), or when not enabled.
  bool begin_move(const Vector3<Scalar>& ga, const Vector3<Scalar>& bias_shift, Scalar shape) {
    walking_ = false;
    if (!enabled() || !(shape <= settings_.accel_shape_max) || !all_finite(ga) ||
        !all_finite(bias_shift))
      return false;
    problem_.data.bias_shift = bias_shift;
    problem_.refine_bias = false;
    problem_.start_move(ga, cursor_);
    angle_ = duration_ = Scalar(0);
    segments_ = 0;
    move_shape_ = shape;
    walking_ = true;
    return true;
  }

  // The move's next segment (of the rate the bias shift applies to).
  void add_segment(const GyroSegment<Scalar>& seg) {
    if (!walking_) return;
    angle_ += seg.alpha.norm();
    duration_ += seg.duration;
    ++segments_;
    if (problem_.add_segment(parameters(), seg, cursor_) != Status::kOk) walking_ = false;
  }

  // The move is given up (cut, or its ends not both taken).
  void abandon() { walking_ = false; }

  // The move ended: the gravity direction at its end, the two directions' variance (per
  // component, summed) and the bias's variance per axis. A move that turned less than
  // min_angle is not used (kNone); otherwise its rows are gated and taken.
  GyroFieldEvent end_move(const Vector3<Scalar>& gb, Scalar direction_var, Scalar bias_var) {
    if (!walking_) return GyroFieldEvent::kNone;
    walking_ = false;
    const Scalar angle = angle_ * scale();
    if (!(angle >= settings_.min_angle) || !all_finite(gb)) return GyroFieldEvent::kNone;
    Rows rows;
    const Status s = problem_.end_move(parameters(), gb, rows, cursor_);
    if (s != Status::kOk || rows.n != 2 || !all_finite(rows.j) || !all_finite(rows.r)) {
      ++refused_;
      chi2_ = Scalar(0);
      return GyroFieldEvent::kRefused;
    }
    const Scalar floor = settings_.move_floor, bias_angle = duration_ * scale();
    // Each segment's second-order expansion errs by up to ~2e-5 rad within the default bounds.
    // An error of the accelerometer's model moves each end's direction by up to its shape sigma,
    // whatever the path between them: at most twice that on the residual.
    const Scalar turn = angle < Scalar(2) ? angle : Scalar(2);
    noise_ = direction_var + bias_var * bias_angle * bias_angle + floor * floor +
             turn * move_shape_ * turn * move_shape_ +
             Scalar(4e-10) * static_cast<Scalar>(segments_);
    return update(rows);
  }

  // The published parameters and their sigmas (the accelerometer's share included).
  const Vector& published() const { return published_; }
  Vector published_sigmas() const {
    Vector s;
    for (int i = 0; i < N; ++i) {
      // The accelerometer's shape error, common to every move: relative for the scales.
      const Scalar f = i >= kGyroScaleX ? shape_ * published_(i) : shape_;
      s(i) = std::sqrt(published_p_(diagonal(i)) + f * f);
    }
    return s;
  }
  bool has_published() const { return has_published_; }
  // The estimate and its covariance (the moves' own, without the accelerometer's share).
  const Vector& estimate() const { return theta_; }
  Matrix covariance() const { return detail::unpack_symmetric<Scalar, N>(p_.data()); }
  std::uint32_t moves() const { return moves_; }
  std::uint32_t refused() const { return refused_; }
  std::uint32_t changes() const { return changes_; }
  // The statistic of the last decision (the gate's for kRefused and kChanged, the
  // publication's for kUpdated), and why the last publication came: 0 first, 1 significant,
  // 2 better, 3 a change.
  Scalar last_chi2() const { return chi2_; }
  int update_reason() const { return reason_; }

 private:
  // The two rows of a move (GyroProblem's accumulator interface).
  struct Rows {
    Eigen::Matrix<Scalar, 2, kGyroParams> j = Eigen::Matrix<Scalar, 2, kGyroParams>::Zero();
    Eigen::Matrix<Scalar, 2, 1> r = Eigen::Matrix<Scalar, 2, 1>::Zero();
    int n = 0;
    Status add(const typename GyroProblem<Scalar>::Vector& row, Scalar e) {
      if (n < 2) {
        j.row(n) = row.transpose();
        r(n) = e;
      }
      ++n;
      return Status::kOk;
    }
  };

  typename GyroProblem<Scalar>::Vector parameters() const {
    typename GyroProblem<Scalar>::Vector p = GyroProblem<Scalar>::Vector::Zero();
    p.template head<N>() = theta_;
    return p;
  }

  // The rate's unit against rad/s: the mean scale (what a raw path angle is in rad).
  Scalar scale() const {
    return (std::abs(theta_(kGyroScaleX)) + std::abs(theta_(kGyroScaleY)) +
            std::abs(theta_(kGyroScaleZ))) /
           Scalar(3);
  }

  // A move's rows, linearised where the estimate stands (kept ones are moved along with it), and
  // its noise.
  struct Move {
    Eigen::Matrix<Scalar, 2, N> j = Eigen::Matrix<Scalar, 2, N>::Zero();
    Eigen::Matrix<Scalar, 2, 1> r = Eigen::Matrix<Scalar, 2, 1>::Zero();
    Scalar noise = Scalar(0);
    Scalar shape = Scalar(0);  // the accelerometer's shape sigma it was taken with
    std::uint32_t seen = 0;    // its number among the moves ended (taken or refused)
  };

  // One move's Kalman update of (theta, p), the rows linearised at `at`: gated (false, nothing
  // changed, when outside the gate or degenerate; chi2 the gate's statistic, 0 if degenerate).
  bool kalman(const Move& m, const Vector& at, Vector& theta, Matrix& p, Scalar& chi2) const {
    const Eigen::Matrix<Scalar, N, 2> pj = p.lazyProduct(m.j.transpose());
    Eigen::Matrix<Scalar, 2, 2> s = m.j * pj;
    s(0, 0) += m.noise;
    s(1, 1) += m.noise;
    const Scalar det = s(0, 0) * s(1, 1) - s(0, 1) * s(1, 0);
    chi2 = Scalar(0);
    if (!(det > Scalar(0))) return false;
    Eigen::Matrix<Scalar, 2, 2> si;
    si << s(1, 1), -s(0, 1), -s(1, 0), s(0, 0);
    si /= det;
    const Eigen::Matrix<Scalar, 2, 1> r = m.r + m.j * (theta - at);
    chi2 = r.dot(si * r);
    if (!(chi2 <= settings_.gate_chi2)) return false;
    // Joseph's form keeps the covariance symmetric and positive in float. The products with a
    // side of N are coefficient-based (lazyProduct): Eigen's blocked product for them would link
    // the heap allocator it falls back on.
    const Eigen::Matrix<Scalar, N, 2> k = pj * si;
    theta -= k * r;
    const Matrix a = Matrix::Identity() - k.lazyProduct(m.j);
    const Matrix ap = a.lazyProduct(p);
    p = ap.lazyProduct(a.transpose()) + m.noise * k.lazyProduct(k.transpose());
    p = Scalar(0.5) * (p + p.transpose()).eval();
    return true;
  }

  GyroFieldEvent update(const Rows& rows) {
    Move m;
    m.j = rows.j.template leftCols<N>();
    m.r = rows.r;
    m.noise = noise_;
    m.shape = move_shape_;
    m.seen = moves_ + refused_ + 1u;
    const Vector before = theta_;
    Matrix p = covariance();
    if (!kalman(m, theta_, theta_, p, chi2_)) {
      ++refused_;
      return chi2_ > Scalar(0) && changed(m) ? GyroFieldEvent::kChanged : GyroFieldEvent::kRefused;
    }
    detail::pack_symmetric<Scalar, N>(p, p_.data());
    ++moves_;
    if (m.shape > shape_) shape_ = m.shape;
    // The refused moves kept stay linearised where the estimate now stands.
    const Vector step = theta_ - before;
    for (int k = 0; k < kept_; ++k) moves_kept_[k].r += moves_kept_[k].j * step;
    return consider_publishing();
  }

  // A move outside the gate is kept; true when it and the ones kept before it prove that the
  // matrix changed (see the header), which is then published.
  bool changed(const Move& m) {
    moves_kept_[next_] = m;
    next_ = (next_ + 1) % kChangeMoves;
    if (kept_ < kChangeMoves) ++kept_;
    const int need = settings_.change_moves;
    if (kept_ < need) return false;
    // The oldest of the last `need`, and whether they came within twice as many moves.
    const int first = (next_ + kChangeMoves - need) % kChangeMoves;
    if (m.seen - moves_kept_[first].seen >= static_cast<std::uint32_t>(2 * need)) return false;
    Vector theta = theta_;
    Matrix p = covariance();
    for (int i = 0; i < N; ++i) {
      const Scalar t =
          i >= kGyroScaleX ? settings_.scale_sigma * theta_(i) : settings_.misalignment_sigma;
      p(i, i) += t * t;
    }
    Scalar chi2 = Scalar(0), shape = shape_;
    for (int k = 0; k < need; ++k) {
      const Move& kept = moves_kept_[(first + k) % kChangeMoves];
      if (!kalman(kept, theta_, theta, p, chi2)) return false;
      shape = std::fmax(shape, kept.shape);
    }
    if (!all_finite(theta)) return false;
    shape_ = shape;
    theta_ = published_ = theta;
    detail::pack_symmetric<Scalar, N>(p, p_.data());
    published_p_ = p_;
    has_published_ = true;
    reason_ = 3;
    kept_ = next_ = 0;
    ++changes_;
    return true;
  }

  GyroFieldEvent consider_publishing() {
    bool no_worse = true, much_better = false;
    for (int i = 0; i < N; ++i) {
      const Scalar now = p_(diagonal(i)), before = published_p_(diagonal(i));
      no_worse = no_worse && now <= before * Scalar(1.001);
      much_better = much_better || now <= settings_.better_ratio * before;
    }
    if (!no_worse) return GyroFieldEvent::kTaken;
    // chi-square of the difference with both covariances, Jacobi-scaled (the scales and the
    // misalignments differ by orders of magnitude in the model's units).
    Matrix m = covariance() + detail::unpack_symmetric<Scalar, N>(published_p_.data());
    Vector x = theta_ - published_, y;
    for (int i = 0; i < N; ++i) {
      if (!(m(i, i) > Scalar(0))) return GyroFieldEvent::kTaken;
      y(i) = Scalar(1) / std::sqrt(m(i, i));
    }
    m = y.asDiagonal() * m * y.asDiagonal();
    x = x.cwiseProduct(y);
    y = x;
    Scalar d[N];
    if (detail::ldlt_factor(m.data(), N, d, Scalar(1e-6)) != Status::kOk)
      return GyroFieldEvent::kTaken;
    detail::ldlt_solve(m.data(), d, N, y.data());
    const Scalar chi2 = x.dot(y);
    const bool significant = chi2 > settings_.publish_chi2;
    if (!significant && !much_better) return GyroFieldEvent::kTaken;
    reason_ = !has_published_ ? 0 : (significant ? 1 : 2);
    chi2_ = chi2;
    published_ = theta_;
    published_p_ = p_;
    has_published_ = true;
    return GyroFieldEvent::kUpdated;
  }

  Settings settings_{};
  bool valid_ = false, walking_ = false, has_published_ = false;
  Vector theta_ = Vector::Zero(), published_ = Vector::Zero();
  // The estimate's covariance and the published one's, packed (detail::pack_symmetric): each is
  // exactly symmetric (kalman() makes it so), and half the size.
  using Packed = Eigen::Matrix<Scalar, N*(N + 1) / 2, 1>;
  static Eigen::Index diagonal(int i) { return detail::packed_index(N, i, i); }
  Packed p_ = Packed::Zero(), published_p_ = Packed::Zero();
  GyroProblem<Scalar> problem_{};
  typename GyroProblem<Scalar>::Cursor cursor_{};
  Scalar angle_ = Scalar(0), duration_ = Scalar(0);  // the move's path (raw) and duration (s)
  std::uint32_t segments_ = 0;
  Scalar noise_ = Scalar(0);       // the move under way's, per residual component
  Scalar move_shape_ = Scalar(0);  // the accelerometer's shape sigma it was offered with
  Scalar shape_ = Scalar(0);       // the largest of those among the moves taken
  Scalar chi2_ = Scalar(0);
  int reason_ = 0;
  std::uint32_t moves_ = 0, refused_ = 0;
  // The last refused moves (a ring: next_ the next slot, kept_ how many), for a change.
  Move moves_kept_[kChangeMoves]{};
  int kept_ = 0, next_ = 0;
  std::uint32_t changes_ = 0;
};

}  // namespace imucal
