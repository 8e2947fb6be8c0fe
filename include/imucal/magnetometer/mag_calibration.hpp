// SPDX-License-Identifier: MIT
// imucal/magnetometer/mag_calibration.hpp: magnetometer hard- and soft-iron calibration from
// free-hand rotation (model in mag_model.hpp). A cheap per-sample collector keeps at most one raw
// sample per direction cell; solve() fits an ellipsoid in closed form, refines it by
// Levenberg-Marquardt on the geometric residual and checks coverage, field strength and fit error;
// align() rotates the result into the accelerometer's frame from static poses (constant dip). Fixed
// memory, no allocation, no exceptions; every refusal says why.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "imucal/models/mag_model.hpp"
#include "imucal/solve/accel_calibration.hpp"
#include "imucal/solve/levenberg_marquardt.hpp"
#include "imucal/status.hpp"

namespace imucal {

// Parameters of the geometric refinement, in the solver's normalised units (samples centred and
// divided by their RMS radius): the six entries of W (MagSymIndex order), then h.
constexpr int kMagParams = 9;
// Parameters of the alignment: a rotation increment (3, rad) and d = sin(dip).
constexpr int kMagAlignParams = 4;
// Fewest rests align() accepts: one more than its parameters, so that each gets a sigma.
constexpr int kMagMinRests = kMagAlignParams + 1;
// Fewest samples solve() accepts whatever the settings (each parameter needs a sigma).
constexpr int kMagMinSamples = kMagParams + 1;

template <typename Scalar>
struct MagSettings {
  Scalar unit_ut = Scalar(1);  // uT per raw unit, nominal (1: the data are already in uT)
  // Accepted field strength, uT (the Earth's is ~22..67 uT); outside: kFieldImplausible.
  Scalar field_min_ut = Scalar(20);
  Scalar field_max_ut = Scalar(70);
  // Fewest direction cells (fraction of all, calibrated directions) holding a sample; below:
  // kPoorCoverage.
  Scalar min_coverage = Scalar(0.5);
  // Fewest samples held (= direction cells covered): fewer is kPoorCoverage (fewer than
  // kMagMinSamples, 10: kTooFewSamples).
  int min_samples = 30;
  Scalar max_fit_error_pct = Scalar(5);  // RMS of |m_cal|/field - 1, %; above: kFitPoor
  // Largest accepted sigma of any fitted parameter relative to the field (h as a fraction of the
  // radius, the soft iron's entries relative to its scale), at the closed-form start; above:
  // kPoorCoverage (the directions held do not determine the ellipsoid, e.g. a small cap).
  Scalar max_relative_sigma = Scalar(0.02);
  // Largest accepted sigma of the alignment rotation (rad, any axis); above: kUnobservable.
  Scalar max_alignment_sigma = Scalar(0.05);
  LmSettings<Scalar> lm{};
};

// The direction cell of d (any length but zero) on a cube map with n x n squares per face: the
// dominant axis k and its sign give the face (2 k + [d_k < 0]); the two other coordinates (in
// axis order) divided by |d_k|, u and v in [-1, 1], give the square (iu, iv). Cells 0 .. 6 n^2 - 1.
template <typename Scalar>
struct MagCellCoords {
  int cell, k, iu, iv;
  Scalar along;  // |d_k|
  Scalar u, v;
  bool negative;  // d_k < 0
};

template <typename Scalar>
inline MagCellCoords<Scalar> mag_cell_coords(const Vector3<Scalar>& d, int n) {
  MagCellCoords<Scalar> c;
  const Scalar ax = std::abs(d(0)), ay = std::abs(d(1)), az = std::abs(d(2));
  Scalar big = az, du = d(0), dv = d(1);
  c.k = 2;
  if (ax >= ay && ax >= az) {
    c.k = 0;
    big = ax;
    du = d(1);
    dv = d(2);
  } else if (ay >= az) {
    c.k = 1;
    big = ay;
    dv = d(2);
  }
  c.negative = d(c.k) < Scalar(0);
  c.along = big;
  const Scalar inv = Scalar(1) / big;
  c.u = du * inv;
  c.v = dv * inv;
  // u in [-1, 1]: (u + 1) n / 2 in [0, n]; only u = 1 exactly needs the clamp.
  const Scalar half = Scalar(0.5) * Scalar(n);
  c.iu = static_cast<int>((c.u + Scalar(1)) * half);
  c.iv = static_cast<int>((c.v + Scalar(1)) * half);
  if (c.iu >= n) c.iu = n - 1;
  if (c.iv >= n) c.iv = n - 1;
  c.cell = ((2 * c.k + (c.negative ? 1 : 0)) * n + c.iu) * n + c.iv;
  return c;
}

template <typename Scalar>
inline int mag_cell(const Vector3<Scalar>& d, int n, Scalar& u, Scalar& v) {
  const MagCellCoords<Scalar> c = mag_cell_coords(d, n);
  u = c.u;
  v = c.v;
  return c.cell;
}

// Collects raw magnetometer samples while the user turns the device, and solves.
//
// Collector (add()): the directions d = m_raw - centre, with centre the midpoint of the running
// per-axis minimum and maximum, are binned into kCells = 6 CellsPerEdge^2 cells: the dominant
// axis and its sign pick a cube face, the two other coordinates divided by the dominant one's
// magnitude (each in [-1, 1]) pick one of CellsPerEdge x CellsPerEdge squares on it (gnomonic
// cube map; the corner cells cover ~2-3x less solid angle than the middle ones). A cell holds
// one sample. When a new sample falls into a cell already held, the one of the two nearer the
// cell's centre (in those face coordinates, both measured about the current centre) is kept: a
// sample that no longer belongs to the cell because the centre has moved since it was taken is
// always replaced, so early samples taken about a poor centre are renewed as the user turns on.
// Samples closer to the centre than half the largest half-range seen are not held (the centre
// is not known yet; nothing useful). Cost: one division, a handful of compares and a few
// multiplications (~160 instructions on a Cortex-M4F, bench/insn/bench_mag.cpp); the centre is
// recomputed only when the min/max box grows.
//
// Glitches: a reading that would stretch the box, on its longest side, beyond 3 field strengths
// in raw units (3 field_max_ut / unit_ut; an undistorted sensor's readings span 2) and beyond twice
// its extent so far (so the box still grows with the turning under a unit_ut 30 times too large;
// beyond, readings turn into glitches and solve() says kFieldImplausible) is a wild
// one, e.g. a saturated read (32767 counts): refused (kGlitch) and counted (glitches()), the box
// and the samples held unchanged. Until a sample is held, a glitch starts the box again from that
// reading instead (the wild reading may have been the first).
//
// solve() fits all the samples held, whatever centre they were binned about.
template <typename Scalar, int CellsPerEdge = 4, int MaxRests = 32>
class MagCalibrator {
 public:
  static_assert(CellsPerEdge >= 1 && CellsPerEdge <= 16, "cells per cube-face edge");
  static_assert(MaxRests >= kMagMinRests, "room for the rests the alignment needs");
  static_assert(MaxRests <= 0x7FFF, "rests counted in 16 bits");
  static constexpr int kCells = 6 * CellsPerEdge * CellsPerEdge;
  using scalar_type = Scalar;

  explicit MagCalibrator(const MagSettings<Scalar>& settings = MagSettings<Scalar>())
      : settings_(settings) {
    reset();
  }

  void reset() {
    for (int i = 0; i < kCells; ++i) slot_[i] = -1;
    size_ = 0;
    rests_ = 0;
    glitches_ = 0;
    // An empty box: the first sample grows it to itself (and is not held: no direction yet).
    min_.setConstant(std::numeric_limits<Scalar>::infinity());
    max_.setConstant(-std::numeric_limits<Scalar>::infinity());
    centre_.setZero();
    near2_ = Scalar(0);
  }
  void reset(const MagSettings<Scalar>& settings) {
    settings_ = settings;
    reset();
  }
  const MagSettings<Scalar>& settings() const { return settings_; }

  // One raw reading. kNonFiniteInput (nothing changed) for NaN or infinity; kGlitch for a wild
  // reading (see the class comment; nothing held changes); otherwise kOk, whether or not the
  // sample is held.
  Status add(const Vector3<Scalar>& m_raw) {
    const Scalar x = m_raw(0), y = m_raw(1), z = m_raw(2);
    // 0 * x is NaN for NaN and infinity, 0 otherwise: one test for the three axes.
    const Scalar zero = Scalar(0);
    if (!(zero * x + zero * y + zero * z == zero)) return Status::kNonFiniteInput;
    // The box grows rarely once the user has turned all round; then the centre moves.
    if (x < min_(0) || y < min_(1) || z < min_(2) || x > max_(0) || y > max_(1) || z > max_(2)) {
      Vector3<Scalar> lo = min_.cwiseMin(m_raw), hi = max_.cwiseMax(m_raw);
      const bool glitch = (hi - lo).maxCoeff() > glitch_extent();
      if (glitch) {
        ++glitches_;
        if (size_ > 0) return Status::kGlitch;
        lo = hi = m_raw;  // nothing held yet: the box starts again from this reading
      }
      min_ = lo;
      max_ = hi;
      centre_ = Scalar(0.5) * (min_ + max_);
      const Scalar half_range = Scalar(0.5) * (max_ - min_).maxCoeff();
      near2_ = Scalar(0.25) * half_range * half_range;
      if (glitch) return Status::kGlitch;
    }
    const Vector3<Scalar> d = m_raw - centre_;
    // |d| <= half the largest half-range: too near the centre to give a direction.
    if (d.squaredNorm() <= near2_) return Status::kOk;
    const MagCellCoords<Scalar> c = mag_cell_coords(d, CellsPerEdge);
    const int slot = slot_[c.cell];
    if (slot < 0) {
      samples_[size_] = m_raw;
      slot_[c.cell] = static_cast<std::int16_t>(size_);
      ++size_;
      return Status::kOk;
    }
    // Taken: keep the one nearer the cell's middle (cu, cv), both about the current centre. For
    // the held sample e, on the same face: (e_a / t - cu)^2 + ... with t = +-e_k, compared after
    // multiplying both sides by t^2 (no division).
    const Vector3<Scalar> e = samples_[slot] - centre_;
    const Scalar t = c.negative ? -e(c.k) : e(c.k);
    if (!(t > Scalar(0))) {  // no longer even on this face's side
      samples_[slot] = m_raw;
      return Status::kOk;
    }
    const Scalar cu = centre_of(c.iu), cv = centre_of(c.iv);
    const Scalar eu = e(c.k == 0 ? 1 : 0) - cu * t;
    const Scalar ev = e(c.k == 2 ? 1 : 2) - cv * t;
    const Scalar nu = c.u - cu, nv = c.v - cv;
    if (eu * eu + ev * ev > (nu * nu + nv * nv) * (t * t)) samples_[slot] = m_raw;
    return Status::kOk;
  }

  // A static pose for align(): the means of the raw magnetometer and accelerometer readings over
  // a rest. kNonFiniteInput or kCapacityExceeded (nothing changed) otherwise kOk.
  Status add_rest(const Vector3<Scalar>& mag_mean_raw, const Vector3<Scalar>& accel_mean_raw) {
    if (!all_finite(mag_mean_raw) || !all_finite(accel_mean_raw)) return Status::kNonFiniteInput;
    if (rests_ >= MaxRests) return Status::kCapacityExceeded;
    rest_mag_[rests_] = mag_mean_raw;
    rest_acc_[rests_] = accel_mean_raw;
    ++rests_;
    return Status::kOk;
  }

  // Fits the samples held. out.status (also returned) says whether the result is usable
  // (succeeded()) and otherwise why not, checked in this order: kTooFewSamples (fewer than
  // kMagMinSamples); kPoorCoverage if fewer than settings.min_samples are held (a sample held is
  // a cell covered; turning about one axis only usually ends here, the samples filling only the
  // cells along one circle); kPoorCoverage if the samples lie in one
  // plane; the closed-form fit found no ellipsoid (kNotAnEllipsoid, kRankDeficient,
  // kIllConditioned); kPoorCoverage if at that start a parameter's sigma exceeds
  // max_relative_sigma (e.g. a small cap: the samples do not determine the ellipsoid); the
  // refinement did not converge (its LM status); kPoorCoverage (calibrated directions cover
  // fewer than min_coverage of the cells); kFieldImplausible; kFitPoor. A refused result keeps
  // the defaults (identity, zero) in soft_iron, hard_iron and the sigmas, but the numbers that
  // were computed (samples, iterations, coverage, field_ut, fit_error_pct) are filled, so the
  // reason can be seen; when no fit exists, coverage is raw_coverage(). Quality on success:
  // kGood if coverage >= 0.8 and fit error <= 1.5 %, kFair if coverage >= 0.65 and fit error
  // <= 3 %, else kPoor. Never NaN. The alignment fields are reset (kNotStarted). A fit refused
  // (other than for invalid settings) while more readings were refused as glitches than samples
  // are held is kFieldImplausible: the readings show a field beyond 3 field_max_ut (a wrong
  // unit_ut, or a magnet near the sensor), whatever the few samples held lack.
  Status solve(MagCalibration<Scalar>& out) const;

  // Optional: rotates a usable calibration into the accelerometer's frame, from the rests (>= 5,
  // in diverse orientations). g_i = unit(accel_apply(accel.params, a_i)) points UP at rest (the
  // accelerometer reads +g up) and m_i = unit(S_sym (m_i + h)) is the calibrated field direction
  // in the magnetometer's frame; the field's dip is the same at every rest:
  //   g_i . R m_i = -sin(dip)   (dip > 0 when the field points below the horizon, as in the
  //   northern hemisphere)
  // R (accelerometer <- magnetometer) and sin(dip) are found by LM. A rotation about the vertical
  // cannot be seen from one rest, only from several that tilt the body differently. On success
  // inout.soft_iron = R S_sym and every alignment field is set; otherwise only
  // inout.alignment_status says why (kInvalidArgument: inout or accel not usable; kTooFewPoses;
  // kRankDeficient / kIllConditioned / kUnobservable: the rests do not determine R). Calling it
  // again on an aligned result starts again from the symmetric S. Returns alignment_status.
  Status align(const AccelCalibration<Scalar>& accel, MagCalibration<Scalar>& inout) const;

  int size() const { return size_; }
  const Vector3<Scalar>& sample(int i) const { return samples_[i]; }  // 0 <= i < size()
  int rests() const { return rests_; }
  // Wild readings refused (kGlitch) since reset().
  std::uint32_t glitches() const { return glitches_; }
  // Fraction of the cells holding a sample (binned about the running centre): progress.
  Scalar raw_coverage() const { return Scalar(size_) / Scalar(kCells); }

  // The cell of direction d (see mag_cell()).
  static int cell_of(const Vector3<Scalar>& d, Scalar& u, Scalar& v) {
    return mag_cell(d, CellsPerEdge, u, v);
  }

 private:
  static Scalar centre_of(int i) {  // face coordinate of the middle of grid square i
    return (Scalar(i) + Scalar(0.5)) * (Scalar(2) / Scalar(CellsPerEdge)) - Scalar(1);
  }

  // The longest side the box may stretch to with one reading: 3 field strengths in raw units, or
  // twice its longest side so far if more (no limit from settings that give no field in raw
  // units; an empty box's side is -infinity).
  Scalar glitch_extent() const {
    Scalar limit = Scalar(3) * settings_.field_max_ut / settings_.unit_ut;
    if (!(limit > Scalar(0))) limit = std::numeric_limits<Scalar>::infinity();
    const Scalar grown = Scalar(2) * (max_ - min_).maxCoeff();
    return grown > limit ? grown : limit;
  }

  // The per-sample state first: small offsets from `this` (one load instruction each on Thumb-2).
  Vector3<Scalar> min_ = Vector3<Scalar>::Zero(), max_ = Vector3<Scalar>::Zero();
  Vector3<Scalar> centre_ = Vector3<Scalar>::Zero();  // midpoint of min_ and max_
  Scalar near2_ = Scalar(0);  // squared distance from the centre below which nothing is held
  std::int16_t size_ = 0;     // 16 bits each (kCells, MaxRests): room for glitches_
  std::int16_t rests_ = 0;
  std::uint32_t glitches_ = 0;
  std::int16_t slot_[static_cast<std::size_t>(kCells)];  // index into samples_, -1: empty
  Vector3<Scalar> samples_[static_cast<std::size_t>(kCells)];
  MagSettings<Scalar> settings_;
  Vector3<Scalar> rest_mag_[static_cast<std::size_t>(MaxRests)];
  Vector3<Scalar> rest_acc_[static_cast<std::size_t>(MaxRests)];
};

// The solver behind MagCalibrator::solve() and align(), on plain arrays (the calibrator's memory).
template <typename Scalar>
Status mag_solve(const Vector3<Scalar>* samples, int n, const MagSettings<Scalar>& settings,
                 int cells_per_edge, Scalar raw_coverage, MagCalibration<Scalar>& out);
template <typename Scalar>
Status mag_align(const Vector3<Scalar>* rest_mag, const Vector3<Scalar>* rest_acc, int n,
                 const MagSettings<Scalar>& settings, const AccelCalibration<Scalar>& accel,
                 MagCalibration<Scalar>& inout);

template <typename Scalar, int CellsPerEdge, int MaxRests>
Status MagCalibrator<Scalar, CellsPerEdge, MaxRests>::solve(MagCalibration<Scalar>& out) const {
  const Status s = mag_solve(samples_, size_, settings_, CellsPerEdge, raw_coverage(), out);
  if (!succeeded(s) && s != Status::kInvalidArgument && glitches_ > std::uint32_t(size_))
    return out.status = Status::kFieldImplausible;
  return s;
}

template <typename Scalar, int CellsPerEdge, int MaxRests>
Status MagCalibrator<Scalar, CellsPerEdge, MaxRests>::align(const AccelCalibration<Scalar>& accel,
                                                            MagCalibration<Scalar>& inout) const {
  return mag_align(rest_mag_, rest_acc_, rests_, settings_, accel, inout);
}

extern template Status mag_solve<float>(const Vector3<float>*, int, const MagSettings<float>&, int,
                                        float, MagCalibration<float>&);
extern template Status mag_solve<double>(const Vector3<double>*, int, const MagSettings<double>&,
                                         int, double, MagCalibration<double>&);
extern template Status mag_align<float>(const Vector3<float>*, const Vector3<float>*, int,
                                        const MagSettings<float>&, const AccelCalibration<float>&,
                                        MagCalibration<float>&);
extern template Status mag_align<double>(const Vector3<double>*, const Vector3<double>*, int,
                                         const MagSettings<double>&,
                                         const AccelCalibration<double>&, MagCalibration<double>&);

}  // namespace imucal
