// SPDX-License-Identifier: MIT
// imucal/field/accel_field.hpp: the accelerometer's model kept right from the rests of normal use
// (the design's field.md section 3; docs/field.md): the protocol's problem with a prior.
//
// The unknowns are the protocol's nine (misalignment, scale, bias: accel_model.hpp) and the
// bias's slope and curvature against temperature, b(T) = b + s d + q d^2 with d = T - T0. Each
// rest is a pose: its mean reading x (in units of gravity) gives the protocol's gravity-norm
// residual e = 1 - |T K (x + b(T))|^2 and its Jacobian (accel_residual()). With the stored
// calibration (or the nominal model) theta0 and its sigmas as the prior, each Gauss-Newton step
// solves, in the library's normal-equations accumulator,
//
//     (S0^-1 + sum_i J_i' W_i J_i) delta = S0^-1 (theta0 - theta) - sum_i J_i' W_i e_i
//
// (the prior enters as one row per unknown: e = theta_k - theta0_k with weight 1 / sigma0_k^2),
// so that what the orientations seen do not determine keeps its prior value and sigma: one
// orientation for a year refines only what one orientation can.
//
// Bounded memory: rests are kept in Cells cells, one per pose (rests within 2 degrees of one
// direction) and temperature band; a cell keeps the weighted mean reading and temperature of its
// rests. Its weight in the solve is capped at the pose floor's (a year on one desk is one
// well-measured pose, not a million), and ages: halved every half_life_days, so that a slow
// change is followed and an old orientation does not pin the solution forever. When all cells
// are used, a new pose takes the place of the lightest cell in its direction (of the 26
// directions of a cube's faces, edges and corners) and band, else of the lightest one.
// A solution is believed only once the cells check it: they outnumber the parameters they
// determine, their chi-square fits, and no unknown is more than prior_sigmas from the prior (nine
// cells fit the nine unknowns exactly, and the gravity-norm problem then has more than one exact
// solution; a few cells in one orientation can be fitted by a bias across gravity far out).
//
// Solves are time-sliced: step() does one row, one factorisation, one covariance column or one
// cell's judgement per call. A new pose is solved for at once, more rests of known poses every
// resolve_seconds.
// Acceptance is judged where the rests determine the model: at each cell, the residual each model
// predicts and its variance (j' C j with the full covariances). The solution replaces the
// published model when it is no worse at any determined cell and either differs significantly
// (chi-square over those cells with both variances) or is much better at one (variance at most
// better_ratio of the published one's: a new direction or temperature band).
// A rest that disagrees beyond the gate with the published model, the last solution or its own
// pose's cell is held, and a second one after motion or confirm_seconds later that disagrees too
// confirms a change (a knock): the cells are cleared, and the bias's prior and the published
// bias's sigma widen by change_sigma until the cells support a new solution.
// Plain data with its arithmetic; fixed memory, no allocation, no exceptions. Header-only.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "imucal/field/bias_filter.hpp"
#include "imucal/models/accel_model.hpp"
#include "imucal/models/calibration.hpp"
#include "imucal/models/temperature_model.hpp"
#include "imucal/solve/normal_equations.hpp"
#include "imucal/status.hpp"
#include "imucal/types.hpp"

namespace imucal {

// The accelerometer part's settings (physical units: m/s^2, rad, deg C).
template <typename Scalar>
struct AccelFieldSettings {
  bool enabled = true;
  Scalar accel_per_m_s2 = std::numeric_limits<Scalar>::quiet_NaN();  // raw units per m/s^2
  Scalar gravity = Scalar(9.80665);                                  // m/s^2
  // The prior without a stored calibration: the nominal model with these sigmas.
  Scalar bias_sigma = Scalar(0.49);          // m/s^2 (50 mg)
  Scalar scale_sigma = Scalar(0.03);         // relative
  Scalar misalignment_sigma = Scalar(0.02);  // rad
  Scalar slope_sigma = Scalar(0.0098);       // m/s^2 per deg C (1 mg/degC)
  Scalar curvature_sigma = Scalar(4.9e-4);   // m/s^2 per deg C^2 (0.05 mg/degC^2)
  // What no rest mean is better than (the pose floor: bias walk, the model's misfit): caps a
  // cell's weight. m/s^2.
  Scalar floor = Scalar(0.0049);  // 0.5 mg
  Scalar band_c = Scalar(5);      // a cell's temperature band (deg C)
  Scalar half_life_days = Scalar(30);
  Scalar change_sigma = Scalar(0.29);   // a knock's step of the bias: its prior sigma (30 mg)
  Scalar confirm_seconds = Scalar(60);  // a held rest is confirmed this long after, or after motion
  Scalar gate_chi2 = Scalar(10.83);     // chi-square(1) at 0.1 %: a rest that agrees
  Scalar better_ratio = Scalar(0.25);
  // A parameter counts as determined by the rests when its sigma is below this share of its
  // prior sigma.
  Scalar determined_ratio = Scalar(0.5);
  int iterations = 4;  // Gauss-Newton steps per solve
  // A rest whose mean reading, through the published model, is further than this from gravity
  // (relative; plus three times the published bias's sigma, as a norm) is no rest of this
  // accelerometer as set up (a wrong scale, a zero reading not taken off): refused.
  Scalar max_norm_error = Scalar(0.3);
  // The cells must outnumber the parameters they determine by this many before a solution is
  // believed (more where the prior is far from the truth and the problem far from linear: a
  // magnetometer's hard iron, where a few directions are fitted as well by a mirrored centre).
  Scalar min_dof = Scalar(1);
  // A solution with an unknown further than this many of its prior sigmas from the prior is not
  // published (the prior's tolerances are bounds a part meets).
  Scalar prior_sigmas = Scalar(4);
  // Rests of poses already in the cells are solved for at most this often (s); a new pose at once.
  Scalar resolve_seconds = Scalar(600);
};

enum class AccelFieldEvent : std::uint8_t {
  kNone = 0,
  kUpdated = 1,         // the published model changed (reason: first, significant, better, change)
  kHeld = 2,            // a rest outside the gate: held until a later one confirms or drops it
  kUnconfirmed = 3,     // a held rest that a later agreeing rest dropped
  kChangeDetected = 4,  // two rests apart disagree alike: the cells are cleared, the prior widened
  kImplausible = 5,     // a rest whose reading is no gravity under the published model (|a| off
                        // by more than max_norm_error and the bias's sigma): a wrong scale or
                        // zero reading, refused
};

// How well an accelerometer model is known, without units: the largest of its misalignments'
// and relative scales' sigmas and of bias_g (its bias's sigma per axis, against gravity).
// Infinity for a scale that is not positive; NaN for a NaN.
template <typename Scalar>
Scalar accel_shape_sigma(const AccelVector<Scalar>& params, const AccelVector<Scalar>& sigma,
                         const Vector3<Scalar>& bias_g) {
  Scalar shape = bias_g.cwiseAbs().maxCoeff();
  for (int i = 0; i < 3; ++i) {
    const Scalar s = std::abs(params(kScaleX + i));
    const Scalar scale =
        s > Scalar(0) ? std::abs(sigma(kScaleX + i)) / s : std::numeric_limits<Scalar>::infinity();
    shape = std::fmax(shape, std::fmax(std::abs(sigma(kAlphaYz + i)), scale));
  }
  return all_finite(sigma) && all_finite(bias_g) ? shape : std::numeric_limits<Scalar>::quiet_NaN();
}

template <typename Scalar, int Cells = 16>
class AccelField {
 public:
  static constexpr int kTemperatureParams = 6;  // slope and curvature per axis
  static constexpr int kParams = kAccelParams + kTemperatureParams;
  enum Index : int { kSlopeX = kAccelParams, kCurvatureX = kAccelParams + 3 };
  using Vector = Eigen::Matrix<Scalar, kParams, 1>;
  using Settings = AccelFieldSettings<Scalar>;
  static_assert(Cells >= 2 && Cells <= 255, "a small number of cells");
  static constexpr std::size_t kCells = static_cast<std::size_t>(Cells);

  // Starts from the prior: the calibration's accelerometer part (sensor units, as the protocol
  // gives it) and the temperature model's accelerometer part, each where usable; otherwise the
  // nominal model. kInvalidArgument: settings out of range (nothing is taken then).
  Status start(const Settings& settings, const AccelCalibration<Scalar>* prior = nullptr,
               const TemperatureModel<Scalar>* model = nullptr, Scalar reference_c = Scalar(25)) {
    settings_ = settings;
    valid_ = settings.enabled && check(settings);
    n_cells_ = 0;
    phase_ = Phase::kIdle;
    again_ = false;
    candidate_ = false;
    solve_status_ = Status::kNotStarted;
    solution_ok_ = false;
    has_published_ = false;
    event_reason_ = 0;
    min_c_ = std::numeric_limits<Scalar>::infinity();
    max_c_ = -std::numeric_limits<Scalar>::infinity();
    aged_us_ = 0;
    if (!valid_) return settings.enabled ? Status::kInvalidArgument : Status::kOk;
    g_counts_ = settings.accel_per_m_s2 * settings.gravity;
    change2_ =
        (settings.change_sigma / settings.gravity) * (settings.change_sigma / settings.gravity);
    const Scalar floor = settings.floor / settings.gravity;
    weight_cap_ = Scalar(1) / (Scalar(4) * floor * floor);
    resolve_us_ = static_cast<std::uint64_t>(settings.resolve_seconds * Scalar(1e6));
    solved_us_ = 0;
    forget_hour_ = std::exp2(Scalar(-1) / (Scalar(24) * settings.half_life_days));
    reference_c_ = std::isfinite(reference_c) ? reference_c : Scalar(25);
    // The nominal model, normalised: unit scales, no misalignment, no bias.
    theta0_.setZero();
    theta0_.template segment<3>(kScaleX).setOnes();
    sigma0_.template segment<3>(kAlphaYz).setConstant(settings.misalignment_sigma);
    sigma0_.template segment<3>(kScaleX).setConstant(settings.scale_sigma);
    sigma0_.template segment<3>(kBiasX).setConstant(settings.bias_sigma / settings.gravity);
    sigma0_.template segment<3>(kSlopeX).setConstant(settings.slope_sigma / settings.gravity);
    sigma0_.template segment<3>(kCurvatureX)
        .setConstant(settings.curvature_sigma / settings.gravity);
    Status result = Status::kOk;
    if (prior != nullptr && succeeded(prior->status)) {
      if (all_finite(prior->params) && all_finite(prior->sigma)) {
        for (int k = 0; k < kAccelParams; ++k) {
          const Scalar unit = k >= kBiasX ? Scalar(1) / g_counts_
                                          : (k >= kScaleX ? settings.accel_per_m_s2 : Scalar(1));
          theta0_(k) = prior->params(k) * unit;
          // A sigma of 0 is a parameter the protocol held: it keeps its prior sigma, as does
          // one beyond it (a record that knows less than the settings, or a corrupted one).
          sigma0_(k) = stated_sigma(prior->sigma(k) * unit, sigma0_(k));
        }
      } else {
        result = Status::kNonFiniteInput;
      }
    }
    if (model != nullptr && succeeded(model->accel.status) && std::isfinite(model->reference_c) &&
        all_finite(model->accel.b0) && all_finite(model->accel.b1) && all_finite(model->accel.b2)) {
      reference_c_ = model->reference_c;
      const Scalar unit = Scalar(1) / g_counts_;
      theta0_.template segment<3>(kBiasX) = model->accel.b0 * unit;
      theta0_.template segment<3>(kSlopeX) = model->accel.b1 * unit;
      theta0_.template segment<3>(kCurvatureX) = model->accel.b2 * unit;
      for (int i = 0; i < 3; ++i) {
        sigma0_(kSlopeX + i) = stated_sigma(model->accel.b1_sigma(i) * unit, sigma0_(kSlopeX + i));
        sigma0_(kCurvatureX + i) =
            stated_sigma(model->accel.b2_sigma(i) * unit, sigma0_(kCurvatureX + i));
      }
      if (model->min_c <= model->max_c) {
        min_c_ = model->min_c;
        max_c_ = model->max_c;
      }
    }
    theta_ = published_ = theta0_;
    published_sigma_ = sigma_ = sigma0_;
    for (Scalar& c : published_cov_) c = Scalar(0);
    for (int k = 0; k < kParams; ++k) published_cov_[index(k, k)] = sigma0_(k) * sigma0_(k);
    has_published_ = prior != nullptr && succeeded(prior->status) && result == Status::kOk;
    return result;
  }

  // One rest piece: its mean reading (raw), the variance of that mean per axis (raw^2), its
  // temperature (NaN: none), when it ended (elapsed microseconds) and
  // its group (rests between two motions share one). Returns what the piece did (kNone: taken).
  // other_chi2: a disagreement with the published model the caller measured otherwise (the
  // magnetometer's dip against gravity), judged with the piece's own.
  AccelFieldEvent add(const Vector3<Scalar>& mean_raw, Scalar mean_variance, Scalar t,
                      std::uint64_t time_us, std::uint32_t group, Scalar other_chi2 = Scalar(0)) {
    if (!valid_ || !all_finite(mean_raw) || !std::isfinite(mean_variance))
      return AccelFieldEvent::kNone;
    if (mean_variance < Scalar(0)) return AccelFieldEvent::kImplausible;  // no mean of readings
    Pose p = pose(mean_raw, mean_variance, t);
    // Through the published model, allowing for its bias's sigma (a magnetometer's hard iron is
    // as large as the field until it is known).
    const Scalar norm2 = Scalar(1) - residual(published_, p.x, t, nullptr);
    const Scalar allowance =
        settings_.max_norm_error + Scalar(3) * published_sigma_.template segment<3>(kBiasX).norm();
    if (std::isnan(norm2) ||
        !(std::fabs(std::sqrt(norm2 > Scalar(0) ? norm2 : Scalar(0)) - Scalar(1)) <= allowance))
      return AccelFieldEvent::kImplausible;
    p.time_us = time_us;
    p.group = group;
    age(time_us);
    // Against the published model: a rest far outside is held until another confirms it.
    Scalar chi2 = disagreement(p);
    if (other_chi2 > chi2) chi2 = other_chi2;
    last_chi2_ = chi2;
    // A rest that ended before the held one (the caller judges rests a piece late, and may hold
    // a single reading meanwhile) neither confirms nor drops it.
    const bool later = candidate_ && time_us >= candidate_pose_.time_us;
    if (chi2 > settings_.gate_chi2) {
      if (later && (group != candidate_pose_.group ||
                    seconds(time_us - candidate_pose_.time_us) >= settings_.confirm_seconds)) {
        change(p);
        return AccelFieldEvent::kChangeDetected;
      }
      if (!candidate_) candidate_pose_ = p;
      candidate_ = true;
      return AccelFieldEvent::kHeld;
    }
    AccelFieldEvent e = AccelFieldEvent::kNone;
    if (later) {
      candidate_ = false;
      e = AccelFieldEvent::kUnconfirmed;
    }
    take(p);
    return e;
  }

  // Whether a reading (raw; the variance of its mean per axis, raw^2) disagrees with the
  // published model alone, at the reference temperature: add() would not take it. A cheap look
  // between the readings it is given (the residual against the reading's variance alone first:
  // most agree by that bound already); false for one not finite.
  bool disagrees(const Vector3<Scalar>& mean_raw, Scalar mean_variance) const {
    if (!valid_ || !all_finite(mean_raw) || !std::isfinite(mean_variance)) return false;
    const Pose p = pose(mean_raw, mean_variance, std::numeric_limits<Scalar>::quiet_NaN());
    const Scalar e = residual(published_, p.x, p.t, nullptr);
    if (!(e * e * p.w > settings_.gate_chi2)) return false;
    typename Ne::Vector j;
    return against_published(p, j, nullptr) > settings_.gate_chi2;
  }
  // The chi-square(1) beyond which a rest disagrees with the model.
  Scalar gate() const { return settings_.gate_chi2; }
  // A rest that disagreed is held, until a later one confirms or drops it (the sigma is widened).
  bool holding() const { return candidate_; }

  // One slice of a pending solve (a row, a factorisation, or the sigmas); kOk when nothing is
  // pending. Returns kUpdated from the slice that published.
  AccelFieldEvent step() {
    switch (phase_) {
      case Phase::kIdle:
        return AccelFieldEvent::kNone;
      case Phase::kRows: {
        // The cells there when the pass began: one a rest adds meanwhile waits for the next
        // solve (again_), so that the prior's rows are each added once.
        if (row_ < pass_cells_) {
          add_cell_row(cells_[row_]);
        } else {
          const int k = static_cast<int>(row_ - pass_cells_);  // the prior's rows
          typename Ne::Vector j = Ne::Vector::Zero();
          j(k) = Scalar(1);
          const Scalar s = sigma0_(k);
          ne_.add(j, theta_(k) - theta0_(k), Scalar(1) / (s * s));
        }
        if (++row_ == pass_cells_ + static_cast<std::size_t>(kParams)) phase_ = Phase::kSolve;
        return AccelFieldEvent::kNone;
      }
      case Phase::kSolve: {
        typename Ne::Vector delta;
        solve_status_ = ne_.solve_damped(Scalar(0), delta);
        if (solve_status_ != Status::kOk) {
          theta_ = published_;  // nothing usable: start again from what is published
          phase_ = Phase::kIdle;
          return AccelFieldEvent::kNone;
        }
        theta_ += delta;
        if (++iteration_ < settings_.iterations) {
          begin_rows();
        } else {
          phase_ = Phase::kSigma;
          row_ = 0;
        }
        return AccelFieldEvent::kNone;
      }
      case Phase::kSigma: {
        // One column of the covariance per slice (a factorisation and a solve each: the largest
        // slice stays that of a Gauss-Newton step).
        const int c = static_cast<int>(row_);
        typename Ne::Vector col;
        solve_status_ = ne_.inverse_column(c, Scalar(1), col);
        if (solve_status_ != Status::kOk) return after_solve();
        for (int r = c; r < kParams; ++r) solution_cov_[index(r, c)] = col(r);
        if (++row_ < static_cast<std::size_t>(kParams)) return AccelFieldEvent::kNone;
        phase_ = Phase::kIdle;
        for (int k = 0; k < kParams; ++k) {
          const Scalar v = solution_cov_[index(k, k)];
          sigma_(k) = std::sqrt(v > Scalar(0) ? v : Scalar(0));
        }
        if (!all_finite(sigma_)) {
          solve_status_ = Status::kIllConditioned;
          return after_solve();
        }
        solution_ok_ = true;
        judge_ = Judgement{};
        row_ = 0;
        phase_ = Phase::kJudge;
        return AccelFieldEvent::kNone;
      }
      case Phase::kJudge: {
        if (row_ < n_cells_) {
          judge_cell(cells_[row_++]);
          return AccelFieldEvent::kNone;
        }
        phase_ = Phase::kIdle;
        const AccelFieldEvent e = consider_publishing();
        after_solve();
        return e;
      }
    }
    return AccelFieldEvent::kNone;
  }

  bool busy() const { return phase_ != Phase::kIdle; }
  // Every cell is in use.
  bool full() const { return n_cells_ == kCells; }
  // A cell holds a reading in the direction of this one (of the 26 directions of a cube's faces,
  // edges and corners; raw).
  bool covers(const Vector3<Scalar>& mean_raw) const {
    const std::uint8_t dir = direction(mean_raw);
    for (std::size_t i = 0; i < n_cells_; ++i)
      if (cells_[i].direction == dir) return true;
    return false;
  }
  bool enabled() const { return valid_; }
  bool published() const { return has_published_; }
  std::size_t cells() const { return n_cells_; }
  // Why the last kUpdated happened: 0 first, 1 significant, 2 better, 3 change.
  int update_reason() const { return event_reason_; }
  Scalar last_chi2() const { return last_chi2_; }
  // How the last solve ended (kNotStarted before any; the accumulator's kIllConditioned,
  // kRankDeficient or kNonFiniteInput when it could not solve: the published model stays).
  Status solve_status() const { return solve_status_; }
  // The cells' chi-square at the last solve (their weighted squared residuals).
  Scalar fit_chi2() const { return fit_chi2_; }
  // The last solve's parameters and sigmas (normalised, as published_parameters()).
  const Vector& solution() const { return theta_; }
  const Vector& solution_sigmas() const { return sigma_; }

  // The bias the device applies at temperature t (raw, added; NaN: at the reference), the model
  // clamped to the temperatures seen plus margin, and its sigma per axis (widened by change_sigma
  // while a rest that disagrees is held, or when the caller doubts it: a reading it looked at
  // disagreed). False before the first publication (then the prior's).
  bool bias(Scalar t, Scalar margin, Vector3<Scalar>& out, Vector3<Scalar>* sigma = nullptr,
            bool doubted = false) const {
    const Scalar d = clamped_offset(t, margin);
    const Scalar d2 = d * d;
    out = g_counts_ *
          (published_.template segment<3>(kBiasX) + d * published_.template segment<3>(kSlopeX) +
           d2 * published_.template segment<3>(kCurvatureX));
    if (sigma != nullptr) {
      const Vector3<Scalar> v = bias_variance(t, doubted);
      for (int i = 0; i < 3; ++i) (*sigma)(i) = g_counts_ * std::sqrt(v(i));
    }
    return has_published_;
  }

  // How well the published model is known at temperature t: accel_shape_sigma() of its
  // parameters, with the bias's sigma at t.
  Scalar shape_sigma(Scalar t) const {
    return accel_shape_sigma<Scalar>(published_.template head<kAccelParams>(),
                                     published_sigma_.template head<kAccelParams>(),
                                     bias_variance(t).cwiseSqrt());
  }

  // The published model in sensor units: the calibration's accelerometer part (the bias at the
  // reference temperature) and the temperature model's accelerometer part.
  void model(AccelCalibration<Scalar>& cal, TemperatureBias<Scalar>& temperature) const {
    for (int k = 0; k < kAccelParams; ++k) {
      const Scalar unit = k >= kBiasX
                              ? g_counts_
                              : (k >= kScaleX ? Scalar(1) / settings_.accel_per_m_s2 : Scalar(1));
      cal.params(k) = published_(k) * unit;
      cal.sigma(k) = published_sigma_(k) * unit;
    }
    temperature.b0 = g_counts_ * published_.template segment<3>(kBiasX);
    temperature.b1 = g_counts_ * published_.template segment<3>(kSlopeX);
    temperature.b2 = g_counts_ * published_.template segment<3>(kCurvatureX);
    temperature.b0_sigma = g_counts_ * published_sigma_.template segment<3>(kBiasX);
    temperature.b1_sigma = g_counts_ * published_sigma_.template segment<3>(kSlopeX);
    temperature.b2_sigma = g_counts_ * published_sigma_.template segment<3>(kCurvatureX);
    temperature.status = has_published_ ? Status::kOk : Status::kNotStarted;
  }

  Scalar reference_c() const { return reference_c_; }
  bool seen_temperature() const { return min_c_ <= max_c_; }
  Scalar min_c() const { return min_c_; }
  Scalar max_c() const { return max_c_; }
  // The published parameters and sigmas, normalised (scales relative, biases in units of
  // gravity).
  const Vector& published_parameters() const { return published_; }
  const Vector& published_sigmas() const { return published_sigma_; }
  const Vector& prior_sigmas() const { return sigma0_; }

 private:
  using Ne = NormalEquations<Scalar, kParams>;
  enum class Phase : std::uint8_t { kIdle, kRows, kSolve, kSigma, kJudge };

  // The comparison of a solution with the published model, a cell at a time.
  struct Judgement {
    Scalar chi2 = Scalar(0), best = Scalar(1);
    int determined = 0;
    bool worse = false;
  };

  // The published bias's variance per axis at t itself (it grows beyond the range; g^2; infinite
  // at an infinite or absurd temperature).
  Vector3<Scalar> bias_variance(Scalar t, bool doubted = false) const {
    const Scalar u = offset(t);
    if (!(std::fabs(u) <= kMaxTemperatureOffset<Scalar>))
      return Vector3<Scalar>::Constant(std::numeric_limits<Scalar>::infinity());
    const Scalar h[3] = {Scalar(1), u, u * u};
    Vector3<Scalar> out;
    for (int i = 0; i < 3; ++i) {
      const int k[3] = {kBiasX + i, kSlopeX + i, kCurvatureX + i};
      Scalar v = Scalar(0);
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) v += h[a] * h[b] * published_cov_[index(k[a], k[b])];
      // While a rest that disagrees is held (a change, until confirmed or dropped), the sigma
      // covers a change's step.
      if (candidate_ || doubted) v += change2_;
      out(i) = v > Scalar(0) ? v : Scalar(0);
    }
    return out;
  }

  // A solve ended: the next one, if cells changed meanwhile.
  AccelFieldEvent after_solve() {
    phase_ = Phase::kIdle;
    if (again_) {
      again_ = false;
      begin_solve();
    }
    return AccelFieldEvent::kNone;
  }

  struct Pose {
    Vector3<Scalar> x = Vector3<Scalar>::Zero();  // mean reading, units of gravity
    Scalar w = Scalar(0);                         // weight of its residual
    Scalar t = Scalar(0);                         // temperature (NaN: none)
    std::uint64_t time_us = 0;
    std::uint32_t group = 0;
  };

  struct Cell {
    Vector3<Scalar> x = Vector3<Scalar>::Zero();  // weighted mean reading, units of gravity
    Scalar w = Scalar(0);                         // summed weight (aged)
    Scalar t = Scalar(0);                         // weighted mean temperature (NaN: none)
    std::uint8_t direction = 0, band = 0;
  };

  static bool check(const Settings& s) {
    const auto positive = [](Scalar x) { return std::isfinite(x) && x > Scalar(0); };
    const auto non_negative = [](Scalar x) { return std::isfinite(x) && x >= Scalar(0); };
    return positive(s.accel_per_m_s2) && positive(s.gravity) && positive(s.bias_sigma) &&
           positive(s.scale_sigma) && positive(s.misalignment_sigma) && positive(s.slope_sigma) &&
           positive(s.curvature_sigma) && positive(s.floor) && positive(s.band_c) &&
           positive(s.half_life_days) && positive(s.change_sigma) &&
           non_negative(s.confirm_seconds) && positive(s.gate_chi2) && positive(s.better_ratio) &&
           positive(s.max_norm_error) && positive(s.prior_sigmas) &&
           non_negative(s.resolve_seconds) && s.resolve_seconds <= Scalar(1e9) &&
           s.better_ratio < Scalar(1) && positive(s.determined_ratio) && s.iterations >= 1 &&
           std::isfinite(s.min_dof) && s.min_dof >= Scalar(1);
  }

  static Scalar seconds(std::uint64_t us) { return static_cast<Scalar>(us / 1000u) * Scalar(1e-3); }

  Scalar clamped_offset(Scalar t, Scalar margin) const {
    return clamped_temperature_offset(t, reference_c_, min_c_, max_c_, margin);
  }

  // The nine model parameters with the bias at temperature t, and d = t - T0.
  static AccelVector<Scalar> at(const Vector& theta, Scalar d) {
    AccelVector<Scalar> p = theta.template head<kAccelParams>();
    p.template segment<3>(kBiasX) +=
        d * (theta.template segment<3>(kSlopeX) + d * theta.template segment<3>(kCurvatureX));
    return p;
  }

  Scalar offset(Scalar t) const { return temperature_offset(t, reference_c_); }

  // The residual of x at temperature t and its Jacobian row over all the unknowns.
  Scalar residual(const Vector& theta, const Vector3<Scalar>& x, Scalar t,
                  typename Ne::Vector* j) const {
    const Scalar d = offset(t);
    AccelVector<Scalar> j9;
    const Scalar e = accel_residual(at(theta, d), x, Scalar(1), j != nullptr ? &j9 : nullptr);
    if (j != nullptr) {
      j->template head<kAccelParams>() = j9;
      j->template segment<3>(kSlopeX) = d * j9.template segment<3>(kBiasX);
      j->template segment<3>(kCurvatureX) = (d * d) * j9.template segment<3>(kBiasX);
    }
    return e;
  }

  // The chi-square(1) of a pose against the published model, with the model's variance and the
  // pose's.
  // The largest of three: against the published model; against the last solution of the cells
  // (what the rests so far say, before it is published or believed); and against the cell of the
  // same pose (a rest within 2 degrees in the same band: what it read before, the model carrying
  // the small difference of direction and temperature). The last two see a step long before a
  // model is published.
  Scalar disagreement(const Pose& p) const {
    typename Ne::Vector j;
    Scalar against_model = Scalar(0);
    if (solution_ok_) {
      const Scalar es = residual(theta_, p.x, p.t, &j);
      against_model =
          es * es / (Scalar(1) / p.w + quadratic(solution_cov_, j) + curvature(solution_cov_));
    }
    Scalar e = Scalar(0);
    const Scalar published = against_published(p, j, &e);
    if (published > against_model) against_model = published;
    const std::size_t i = find_cell(p);
    if (i == n_cells_) return against_model;
    const Cell& c = cells_[i];
    typename Ne::Vector jc;
    const Scalar d = e - residual(published_, c.x, c.t, &jc);
    const Scalar wc = c.w < weight_cap_ ? c.w : weight_cap_;
    const Scalar against_cell =
        d * d / (Scalar(1) / p.w + Scalar(1) / wc + quadratic(published_cov_, j - jc));
    return against_cell > against_model ? against_cell : against_model;
  }

  // A pose's chi-square(1) against the published model; j and e: its Jacobian row and residual.
  Scalar against_published(const Pose& p, typename Ne::Vector& j, Scalar* e_out) const {
    const Scalar e = residual(published_, p.x, p.t, &j);
    if (e_out != nullptr) *e_out = e;
    return e * e / (Scalar(1) / p.w + quadratic(published_cov_, j) + curvature(published_cov_));
  }

  // A mean reading (raw) and its variance per axis (raw^2) as a pose at temperature t.
  Pose pose(const Vector3<Scalar>& mean_raw, Scalar mean_variance, Scalar t) const {
    Pose p;
    p.x = mean_raw / g_counts_;
    const Scalar floor2 = Scalar(1) / (Scalar(4) * weight_cap_);
    p.w = Scalar(1) / (Scalar(4) * (mean_variance / (g_counts_ * g_counts_) + floor2));
    p.t = t;
    return p;
  }

  // The cell of a pose's direction (within 2 degrees) and temperature band; n_cells_ if none.
  std::size_t find_cell(const Pose& p) const {
    const std::uint8_t b = band(p.t);
    const Scalar near = Scalar(0.99939);  // cos 2 deg
    std::size_t i = 0;
    while (i < n_cells_ &&
           !(cells_[i].band == b && cells_[i].x.dot(p.x) > near * cells_[i].x.norm() * p.x.norm()))
      ++i;
    return i;
  }

  // Packed lower triangle of a symmetric kParams x kParams matrix (the accumulator's layout).
  static constexpr int kPacked = kParams * (kParams + 1) / 2;
  static std::size_t index(int r, int c) {
    return static_cast<std::size_t>(r >= c ? detail::packed_index(kParams, r, c)
                                           : detail::packed_index(kParams, c, r));
  }
  // j' C j for a packed C, column by column from the diagonal down (a column's entries are
  // consecutive), over j's entries up to its last nonzero one (at the reference temperature, and
  // always for the magnetometer, the slope's and curvature's are zero).
  static Scalar quadratic(const Scalar* c, const typename Ne::Vector& j) {
    int n = kParams;
    while (n > 0 && j(n - 1) == Scalar(0)) --n;
    Scalar sum = Scalar(0);
    for (int col = 0; col < n; ++col) {
      const Scalar* column = c + index(col, col);
      Scalar off = Scalar(0);
      for (int r = col + 1; r < n; ++r) off += j(r) * column[r - col];
      sum += j(col) * (j(col) * column[0] + Scalar(2) * off);
    }
    return sum;
  }
  // The residual's variance beyond j' C j from its curvature in the bias (e = 1 - |x + b|^2 is
  // quadratic in b: 2 tr((C_bb)^2) more): what a linear prediction misses when the bias is as
  // uncertain as the reading is large (a magnetometer's hard iron before it is known). The
  // difference of two readings' residuals is linear in b, and has none.
  static Scalar curvature(const Scalar* c) {
    Scalar sum = Scalar(0);
    for (int r = kBiasX; r < kBiasX + 3; ++r)
      for (int k = kBiasX; k < kBiasX + 3; ++k) sum += c[index(r, k)] * c[index(r, k)];
    return Scalar(2) * sum;
  }
  Scalar prior_quadratic(const typename Ne::Vector& j) const {
    Scalar sum = Scalar(0);
    for (int k = 0; k < kParams; ++k) sum += j(k) * j(k) * sigma0_(k) * sigma0_(k);
    return sum;
  }

  // The 26 directions of a cube (faces, edges, corners): each axis of the unit vector as
  // below, about or above -/+ sin 22.5 deg.
  static std::uint8_t direction(const Vector3<Scalar>& x) {
    const Scalar n = x.norm();
    const Scalar lim = Scalar(0.3827) * n;
    int code = 0;
    for (int i = 0; i < 3; ++i) code = code * 3 + (x(i) > lim ? 2 : (x(i) < -lim ? 0 : 1));
    return static_cast<std::uint8_t>(code);
  }

  std::uint8_t band(Scalar t) const {
    if (std::isnan(t)) return 255;
    Scalar b = std::floor((t + Scalar(60)) / settings_.band_c);
    if (b < Scalar(0)) b = Scalar(0);
    if (b > Scalar(254)) b = Scalar(254);
    return static_cast<std::uint8_t>(b);
  }

  // Each cell's weight halves every half_life_days, by whole hours: after h hours it is
  // multiplied by forget_hour_^h, the power formed by squaring (a year without a rest is 14
  // squarings, not 8,760 passes over the cells).
  void age(std::uint64_t time_us) {
    constexpr std::uint64_t kHourUs = 3600000000u;
    if (aged_us_ == 0 || time_us < aged_us_) {
      aged_us_ = time_us;
      return;
    }
    std::uint64_t hours = (time_us - aged_us_) / kHourUs;
    if (hours == 0) return;
    aged_us_ += hours * kHourUs;
    Scalar factor = Scalar(1), power = forget_hour_;
    for (; hours != 0; hours >>= 1) {
      if ((hours & 1u) != 0) factor *= power;
      power *= power;
    }
    for (std::size_t i = 0; i < n_cells_; ++i) cells_[i].w *= factor;
  }

  void take(const Pose& p) {
    // A cell is one pose: rests within 2 degrees of its direction, in its temperature band (the
    // norm of a mean of readings apart is not gravity's: 3 degrees apart would read 0.3 mg low).
    const std::uint8_t dir = direction(p.x), b = band(p.t);
    std::size_t i = find_cell(p);
    const bool new_cell = i == n_cells_;
    if (new_cell) {
      if (n_cells_ < kCells) {
        ++n_cells_;
      } else {  // the lightest cell of its direction and band gives way, else the lightest
        bool same = false;
        i = 0;
        for (std::size_t k = 0; k < n_cells_; ++k) {
          const bool s = cells_[k].direction == dir && cells_[k].band == b;
          if ((s && !same) || (s == same && cells_[k].w < cells_[i].w)) i = k;
          same = same || s;
        }
      }
      cells_[i] = Cell{};
      cells_[i].direction = dir;
      cells_[i].band = b;
      cells_[i].t = p.t;
    }
    restarted_ = false;
    Cell& c = cells_[i];
    const Scalar share = p.w / (c.w + p.w);
    c.x += share * (p.x - c.x);
    if (!std::isnan(p.t)) c.t = std::isnan(c.t) ? p.t : c.t + share * (p.t - c.t);
    c.w += p.w;
    if (!std::isnan(p.t)) {
      if (p.t < min_c_) min_c_ = p.t;
      if (p.t > max_c_) max_c_ = p.t;
    }
    // A new pose is solved for at once; more rests of the poses already there (a desk for hours)
    // move the solution little, and are solved for every resolve_seconds.
    if (new_cell || changed_ || p.time_us - solved_us_ >= resolve_us_) {
      solved_us_ = p.time_us;
      begin_solve();
    }
  }

  // Two poses apart that disagree with the published model: a change. The cells (from before
  // it) are cleared, the bias's prior becomes the published model with its sigma widened by
  // change_sigma, and the later pose is taken.
  void change(const Pose& p) {
    candidate_ = false;
    n_cells_ = 0;
    theta0_ = published_;
    sigma0_ = published_sigma_;
    // What the rests determine from now on is judged against this widened prior.
    const Scalar c = settings_.change_sigma / settings_.gravity;
    for (int i = 0; i < 3; ++i) {
      const Scalar s = sigma0_(kBiasX + i);
      sigma0_(kBiasX + i) = std::sqrt(s * s + c * c);
    }
    solution_ok_ = false;  // it described the cells before the change
    // The published model stays what the device applies until the cells support a new one, with
    // its bias's sigma widened alike: honest meanwhile, and the rests that follow agree with it.
    for (int i = 0; i < 3; ++i) {
      published_cov_[index(kBiasX + i, kBiasX + i)] += c * c;
      published_sigma_(kBiasX + i) = std::sqrt(published_cov_[index(kBiasX + i, kBiasX + i)]);
    }
    changed_ = true;
    phase_ = Phase::kIdle;
    // The confirming rest only: the held one may be the disturbed end of the event itself.
    take(p);
  }

  void begin_solve() {
    if (phase_ != Phase::kIdle) {
      again_ = true;  // the solve under way uses the cells as they were; one more follows
      return;
    }
    iteration_ = 0;
    solution_ok_ = false;  // theta_ and solution_cov_ are the new solve's from here on
    begin_rows();
  }

  void begin_rows() {
    fit_chi2_ = Scalar(0);
    // Positive definite by construction (the prior's rows): a ratio of ten epsilon guards only
    // against rounding (one orientation leaves a bias and its scale as good as collinear but for
    // the prior, pivots of about 1e-5 of the largest in float).
    ne_.set_min_pivot_ratio(Scalar(10) * std::numeric_limits<Scalar>::epsilon());
    ne_.clear();
    row_ = 0;
    pass_cells_ = static_cast<std::uint16_t>(n_cells_);
    phase_ = Phase::kRows;
  }

  void add_cell_row(const Cell& c) {
    typename Ne::Vector j;
    const Scalar e = residual(theta_, c.x, c.t, &j);
    const Scalar w = c.w < weight_cap_ ? c.w : weight_cap_;
    if (ne_.add(j, e, w) == Status::kOk) fit_chi2_ += w * e * e;
  }

  // The comparison is made where the rests determine the model: at each cell, the residual each
  // model predicts, with its variance (j' C j). A cell whose prediction the solution's variance
  // puts well below the prior's (determined_ratio) is a direction the data determine; a bias
  // and a scale that one orientation leaves collinear are judged by their combination there.
  void judge_cell(const Cell& c) {
    typename Ne::Vector j;
    const Scalar e = residual(theta_, c.x, c.t, &j);
    const Scalar vn = quadratic(solution_cov_, j);
    const Scalar ratio2 = settings_.determined_ratio * settings_.determined_ratio;
    if (!(vn < ratio2 * prior_quadratic(j))) return;
    ++judge_.determined;
    const Scalar d = residual(published_, c.x, c.t, nullptr) - e;
    const Scalar vp = quadratic(published_cov_, j);
    judge_.chi2 += d * d / (vn + vp);
    // Not worse: the same rests give the same variance, up to the caps and rounding.
    if (vn > Scalar(1.1) * vp) judge_.worse = true;
    const Scalar r = vn / vp;
    if (r < judge_.best) judge_.best = r;
  }

  AccelFieldEvent consider_publishing() {
    const Scalar chi2 = judge_.chi2, best = judge_.best;
    const int determined = judge_.determined;
    const bool worse = judge_.worse;
    if (determined == 0) return AccelFieldEvent::kNone;
    // The fit must be checked by the cells before it is believed: the parameters the cells
    // determine (each unknown's share of information from the data, 1 - sigma^2 / sigma0^2) leave
    // at least one cell over, and the cells' chi-square is within what that many degrees of
    // freedom allow (99.9 %). Nine cells fit nine unknowns exactly, and the gravity-norm problem
    // then has more than one exact solution: a local sigma says nothing of which one it found.
    Scalar used = Scalar(0);
    for (int k = 0; k < kParams; ++k) {
      const Scalar share = Scalar(1) - (sigma_(k) * sigma_(k)) / (sigma0_(k) * sigma0_(k));
      used += share > Scalar(0) ? share : Scalar(0);
    }
    const Scalar dof = static_cast<Scalar>(n_cells_) - used;
    if (!(dof >= settings_.min_dof)) return AccelFieldEvent::kNone;
    // Nor is a solution believed that the prior calls implausible: an unknown more than
    // prior_sigmas from it (a few cells in nearly one orientation can be fitted by a bias across
    // gravity far out, where the norm's curvature makes it look determined).
    for (int k = 0; k < kParams; ++k)
      if (!(std::fabs(theta_(k) - theta0_(k)) <= settings_.prior_sigmas * sigma0_(k)))
        return AccelFieldEvent::kNone;
    if (fit_chi2_ > dof + Scalar(3.3) * std::sqrt(Scalar(2) * dof) + Scalar(4)) {
      // A minimum the cells refuse: once per set of cells, start again from the prior.
      if (!restarted_ && n_cells_ >= static_cast<std::size_t>(kAccelParams + 1)) {
        restarted_ = true;
        theta_ = theta0_;
        again_ = true;
      }
      return AccelFieldEvent::kNone;
    }
    int reason = -1;
    if (changed_) {
      reason = 3;
    } else if (!has_published_) {
      reason = 0;
    } else if (!worse && chi2 > chi2_bound(determined)) {
      reason = 1;
    } else if (!worse && best <= settings_.better_ratio) {
      reason = 2;  // as good everywhere, and much better somewhere (a new direction, a new band)
    }
    if (reason < 0) return AccelFieldEvent::kNone;
    changed_ = false;
    published_ = theta_;
    published_sigma_ = sigma_;
    for (int k = 0; k < kPacked; ++k) published_cov_[k] = solution_cov_[k];
    has_published_ = true;
    event_reason_ = reason;
    last_chi2_ = chi2;
    return AccelFieldEvent::kUpdated;
  }

  // Chi-square at 5 % for k degrees of freedom.
  static Scalar chi2_bound(int k) {
    static constexpr float kBound[kParams] = {3.84f,  5.99f,  7.81f,  9.49f,  11.07f,
                                              12.59f, 14.07f, 15.51f, 16.92f, 18.31f,
                                              19.68f, 21.03f, 22.36f, 23.68f, 25.00f};
    return static_cast<Scalar>(kBound[(k < 1 ? 1 : (k > kParams ? kParams : k)) - 1]);
  }

  Settings settings_{};
  bool valid_ = false;
  Scalar g_counts_ = Scalar(1);  // raw units per g
  Scalar change2_ = Scalar(0);   // a change's step, squared (normalised)
  Scalar weight_cap_ = Scalar(1), forget_hour_ = Scalar(1);
  Scalar reference_c_ = Scalar(25);
  Scalar min_c_ = std::numeric_limits<Scalar>::infinity();
  Scalar max_c_ = -std::numeric_limits<Scalar>::infinity();
  // The prior (since start or the last change, which widens its bias's sigma).
  Vector theta0_ = Vector::Zero(), sigma0_ = Vector::Ones();
  Vector theta_ = Vector::Zero(), sigma_ = Vector::Ones();  // the solve
  Vector published_ = Vector::Zero(), published_sigma_ = Vector::Ones();
  Scalar published_cov_[kPacked] = {};  // the published model's covariance, packed
  Scalar solution_cov_[kPacked] = {};   // the solution's, while it is judged
  Judgement judge_{};
  bool has_published_ = false, changed_ = false;
  bool restarted_ = false;       // the solve started again from the prior since the cells changed
  bool solution_ok_ = false;     // theta_ and solution_cov_ hold a solve's result
  Scalar fit_chi2_ = Scalar(0);  // the cells' weighted squared residuals at the last solve
  std::uint64_t solved_us_ = 0, resolve_us_ = 0;  // the last solve's rest, and the interval
  Cell cells_[kCells] = {};
  std::size_t n_cells_ = 0;
  Ne ne_{};
  Phase phase_ = Phase::kIdle;
  bool again_ = false;
  std::uint16_t pass_cells_ = 0;  // the cells the solve's pass of rows takes
  std::size_t row_ = 0;
  int iteration_ = 0;
  bool candidate_ = false;
  Pose candidate_pose_{};
  std::uint64_t aged_us_ = 0;
  int event_reason_ = 0;
  Scalar last_chi2_ = Scalar(0);
  Status solve_status_ = Status::kNotStarted;
};

// No cells: the model compiled out (a field calibrator built without a magnetometer,
// FieldCalibrator's MagCells = 0). It is never enabled: start() refuses settings that enable it
// (kInvalidArgument) and takes nothing; everything else says there is no model.
template <typename Scalar>
class AccelField<Scalar, 0> {
 public:
  static constexpr int kTemperatureParams = 6;
  static constexpr int kParams = kAccelParams + kTemperatureParams;
  using Vector = Eigen::Matrix<Scalar, kParams, 1>;
  using Settings = AccelFieldSettings<Scalar>;
  static constexpr std::size_t kCells = 0;

  Status start(const Settings& settings, const AccelCalibration<Scalar>* = nullptr,
               const TemperatureModel<Scalar>* = nullptr, Scalar = Scalar(25)) {
    return settings.enabled ? Status::kInvalidArgument : Status::kOk;
  }
  AccelFieldEvent add(const Vector3<Scalar>&, Scalar, Scalar, std::uint64_t, std::uint32_t,
                      Scalar = Scalar(0)) {
    return AccelFieldEvent::kNone;
  }
  bool disagrees(const Vector3<Scalar>&, Scalar) const { return false; }
  Scalar gate() const { return Scalar(0); }
  bool holding() const { return false; }
  AccelFieldEvent step() { return AccelFieldEvent::kNone; }
  bool busy() const { return false; }
  bool full() const { return false; }
  bool covers(const Vector3<Scalar>&) const { return false; }
  bool enabled() const { return false; }
  bool published() const { return false; }
  std::size_t cells() const { return 0; }
  int update_reason() const { return 0; }
  Scalar last_chi2() const { return Scalar(0); }
  bool bias(Scalar, Scalar, Vector3<Scalar>& out, Vector3<Scalar>* sigma = nullptr,
            bool = false) const {
    out.setZero();
    if (sigma != nullptr) sigma->setZero();
    return false;
  }
  void model(AccelCalibration<Scalar>&, TemperatureBias<Scalar>& temperature) const {
    temperature.status = Status::kNotStarted;
  }
  Vector published_parameters() const { return Vector::Zero(); }
  Vector published_sigmas() const { return Vector::Zero(); }
};

}  // namespace imucal
