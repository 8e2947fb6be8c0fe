// SPDX-License-Identifier: MIT
// imucal/temperature/temperature_fit.hpp: the temperature model of the accelerometer's and the
// gyro's ADDED bias (temperature_model.hpp), fitted from rests at different temperatures:
//
//   b(T) = b0 + b1 (T - T0) + b2 (T - T0)^2     (per axis, raw units; a_cal = T K (a_raw + b(T)))
//
// Fixed memory, whatever the number of rests: every rest is folded at once into normal-equations
// accumulators (math.md section 3) and then forgotten. So rests met long after the first
// calibration (RestMonitor finds them in the field) keep improving the model: call add_rest()
// whenever one comes, solve() whenever a model is wanted; nothing is ever refitted from stored
// data. Never allocates, never throws, never returns NaN as a result.
//
// Gyroscope. At a rest the calibrated rate is taken as zero, so the rest observes the bias
// directly: b(T) = -gyro_mean (raw units). The Earth's rate (7.3e-5 rad/s, 0.004 deg/s) is
// neglected: with rests in varied orientations it adds to the scatter (and so to sigma), for a
// unit that always rests in one orientation it shifts b0 by its projection, as in any rest-based
// gyro bias. Per axis, a linear least-squares fit of [1, s, s^2] (s = (T - T0) / 10 deg C), each
// rest weighted by its sample count, re-centred on the base calibration's bias so that float
// keeps the precision of raw counts.
//
// Accelerometer. A rest does not tell its orientation, only that the calibrated reading has the
// norm of gravity: one scalar equation per rest. With the base calibration's T K = A and bias
// b_base (the linearisation point), c = A (a + b_base) / g, and phi_j = A Delta b_j / g (the
// change of the bias polynomial, mapped through A and normalised by g):
//
//   |c + sum_j phi_j s^j|^2 = 1
//   <=>  1 - |c|^2 = 2 c . sum_j phi_j s^j + kappa(s),   kappa(s) = |sum_j phi_j s^j|^2
//
// kappa is a polynomial of degree 2 order in s. It is fitted as a free polynomial (a nuisance
// parameter, expressed in Chebyshev polynomials of s / 2 for conditioning) instead of being
// tied to phi: the problem becomes exactly linear, so there is no linearisation error, however
// far the bias moves from the base (1 mg/deg C over 40 deg C is 0.4 m/s^2: a single Gauss-Newton
// step at the base would be biased by many sigma) and however long ago the rows were folded in.
// The price is negligible: the kappa columns (the same for every orientation) are nearly
// orthogonal to the phi columns (2 c s^j, c all round the sphere). As a bonus, kappa absorbs a
// wrong gravity value and an isotropic scale drift with temperature, so `gravity` only
// normalises. Unknowns: 3 (order + 1) + 2 order + 1 = 9 (linear) or 14 (quadratic). Then
// b_j = A^-1 phi_j g (b0 = b_base + A^-1 phi_0 g), with sigma from the covariance blocks.
// This needs rests in varied orientations at varied temperatures; all in one orientation (a
// unit mounted in place) leaves the accelerometer part rank deficient (kRankDeficient) while the
// gyro part still succeeds.
//
// Uncertainty: Cov = f_min / (m - n) H^-1, f_min the weighted residual sum of squares at the
// solution (m rows, n unknowns; m > n needed, else kTooFewSamples). The base calibration is taken
// as exact: its own uncertainty (of A, mostly) is not included.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "imucal/models/calibration.hpp"
#include "imucal/models/temperature_model.hpp"
#include "imucal/solve/normal_equations.hpp"
#include "imucal/status.hpp"
#include "imucal/stream/rest_summary.hpp"

namespace imucal {

template <typename Scalar>
struct TemperatureSettings {
  int order = 1;  // 1: linear, 2: quadratic
  // T0 (deg C). NaN: the base calibration's temperature_c (then the base must have one).
  Scalar reference_c = std::numeric_limits<Scalar>::quiet_NaN();
  // The rests' temperatures must span at least this much (max - min), else
  // kTemperatureSpanSmall.
  Scalar min_span_c = Scalar(5);
  // Local gravity, in the base calibration's output units. Only normalises the accelerometer
  // equations (the fit estimates the sphere's radius itself): a value within a few percent is
  // enough. The default is AccelSettings' default.
  Scalar gravity = Scalar(9.80665);
};

// The temperature unit of the internal polynomial: s = (T - T0) / kTemperatureScaleC.
constexpr double kTemperatureScaleC = 10.0;

// MaxOrder: the highest order the fit can be reset to. A device that only wants a linear model
// takes TemperatureFit<float, 1>: half the code and 0.7 KB less RAM (no quadratic sums).
template <typename Scalar, int MaxOrder = 2>
class TemperatureFit {
 public:
  static_assert(MaxOrder == 1 || MaxOrder == 2, "linear or quadratic");
  // Unknowns per order: accelerometer 3 (order + 1) polynomial coefficients and 2 order + 1
  // radius terms; gyroscope order + 1 per axis.
  static constexpr int accel_unknowns(int order) { return 3 * (order + 1) + 2 * order + 1; }
  static constexpr int gyro_unknowns(int order) { return order + 1; }

  TemperatureFit() = default;

  // Forgets every rest and starts again around `base` (kept as the linearisation point: its
  // accelerometer T K and bias, its gyro bias). Both of base's parts must be usable
  // (succeeded(status)) and finite, the settings in range, and T0 known (reference_c or the
  // base's temperature) and within -100..200 deg C (plausibility.hpp, the temperatures a record
  // holds): otherwise kInvalidArgument, and add_rest()/solve() report kNotStarted.
  Status reset(const Calibration<Scalar>& base,
               const TemperatureSettings<Scalar>& settings = TemperatureSettings<Scalar>());

  // Folds in one rest. Refused, nothing changed: before a successful reset (kNotStarted),
  // without a temperature (kInvalidArgument), with a NaN or infinity (kNonFiniteInput), at a
  // temperature outside -100..200 deg C (kTemperatureImplausible: the model's range stays one a
  // record holds, make_record()), with no samples (kTooFewSamples). Weight: the rest's sample
  // count.
  Status add_rest(const RestSummary<Scalar>& rest);

  // Solves both parts from the rests so far (const: more rests may follow). out.accel.status and
  // out.gyro.status tell each part's fate; a part that failed is all zeros. Returns kOk when both
  // succeeded, otherwise the accelerometer's failure if any, else the gyro's. Per part:
  // kTooFewSamples (rests <= unknowns: 9 or 14 for the accelerometer, 2 or 3 for the gyro),
  // kTemperatureSpanSmall, kRankDeficient (accelerometer: orientations not varied enough),
  // kIllConditioned (too close to singular for this scalar type).
  Status solve(TemperatureModel<Scalar>& out) const;

  int rests() const { return rests_; }
  Scalar min_c() const { return rests_ > 0 ? min_c_ : Scalar(0); }
  Scalar max_c() const { return rests_ > 0 ? max_c_ : Scalar(0); }
  int order() const { return order_; }
  Scalar reference_c() const { return reference_c_; }

 private:
  // Normal equations and, alongside, the weighted residual sum of squares at the running
  // solution (sse), updated per row by the recursive least-squares identity
  // sse += w r^2 / (1 + w J^T H^-1 J), r the row's residual at the solution of the rows before.
  // The normal equations' own f is taken at the base and grows with the drift squared; the
  // minimum recovered from it (f + v . delta) loses the noise to cancellation in float.
  template <int N>
  struct Accumulator {
    NormalEquations<Scalar, N> ne;
    Scalar sse = Scalar(0);
    bool sse_valid = false;  // false until the rows determine a solution
  };
  template <int Order>
  struct Sums {
    Accumulator<3 * (Order + 1) + 2 * Order + 1> accel;
    Accumulator<Order + 1> gyro[3];
  };
  template <int N>
  static Status fold(Accumulator<N>& acc, const Eigen::Matrix<Scalar, N, 1>& j, Scalar e, Scalar w);

  template <int Order>
  static Status add_rows(Sums<Order>& sums, const Vector3<Scalar>& c, Scalar s,
                         const Vector3<Scalar>& gyro_e, Scalar w);
  template <int Order>
  void solve_accel(const Sums<Order>& sums, TemperatureBias<Scalar>& out) const;
  template <int Order>
  void solve_gyro(const Sums<Order>& sums, TemperatureBias<Scalar>& out) const;

  struct NoSums {};
  Sums<1> sums1_{};
  std::conditional_t<(MaxOrder >= 2), Sums<2>, NoSums> sums2_{};
  Matrix3<Scalar> a_ = Matrix3<Scalar>::Identity();       // base T K
  Matrix3<Scalar> a_inv_ = Matrix3<Scalar>::Identity();   // its inverse
  Vector3<Scalar> accel_bias_ = Vector3<Scalar>::Zero();  // base accelerometer bias (added)
  Vector3<Scalar> gyro_bias_ = Vector3<Scalar>::Zero();   // base gyro bias (added)
  Scalar gravity_ = Scalar(1);
  Scalar reference_c_ = Scalar(0);
  Scalar min_span_c_ = Scalar(0);
  Scalar min_c_ = Scalar(0), max_c_ = Scalar(0);
  int order_ = 1;
  int rests_ = 0;
  bool ready_ = false;
};

extern template class TemperatureFit<float, 1>;
extern template class TemperatureFit<float, 2>;
extern template class TemperatureFit<double, 1>;
extern template class TemperatureFit<double, 2>;

}  // namespace imucal
