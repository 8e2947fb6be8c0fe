// SPDX-License-Identifier: MIT
// Temperature model of the accelerometer's and gyro's added bias: fixed-memory accumulation of
// rests and the linear solves (see temperature_fit.hpp for the equations). Instantiated for
// float (device) and double (reference).
#include "imucal/temperature/temperature_fit.hpp"

#include <Eigen/LU>
#include <cmath>

#include "imucal/models/plausibility.hpp"  // temperature_plausible
#include "imucal/solve/symmetric_eigen3.hpp"

namespace imucal {
namespace {

// Below this smallest eigenvalue of the weighted scatter of the rests' gravity directions (unit
// vectors: 1/3 all round the sphere, noise-sized for one orientation, 0 for one plane) the
// accelerometer's bias is not observable.
template <typename Scalar>
constexpr Scalar kMinDirectionSpread = Scalar(1e-3);

// Largest accepted variance inflation of a bias coefficient: diag(H^-1) diag(H), 1 for a column
// independent of the others. 1e6 means its sigma is 1000 times what the same rests would give if
// it were alone: the orientations at some temperatures do not determine it (kRankDeficient).
template <typename Scalar>
constexpr Scalar kMaxVarianceInflation = Scalar(1e6);

// 1, s, s^2, ... (Order + 1 entries).
template <typename Scalar, int Order>
Eigen::Matrix<Scalar, Order + 1, 1> powers(Scalar s) {
  Eigen::Matrix<Scalar, Order + 1, 1> p;
  p(0) = Scalar(1);
  for (int j = 1; j <= Order; ++j) p(j) = p(j - 1) * s;
  return p;
}

template <typename Scalar>
Scalar inverse_scale_power(int j) {  // 1 / 10^j
  Scalar f = Scalar(1);
  for (int k = 0; k < j; ++k) f /= static_cast<Scalar>(kTemperatureScaleC);
  return f;
}

// The increment of the minimum residual sum of squares when row (j, e, w) joins the rows in
// `ne`: w r^2 / (1 + w j^T H^-1 j), r = e + j . theta, theta the rows' solution. False when the
// rows do not determine a solution yet (or not in this scalar type).
template <typename Scalar, int N>
bool sse_increment(const NormalEquations<Scalar, N>& ne, const Eigen::Matrix<Scalar, N, 1>& j,
                   Scalar e, Scalar w, Scalar& out) {
  using Vector = Eigen::Matrix<Scalar, N, 1>;
  using Matrix = Eigen::Matrix<Scalar, N, N>;
  if (ne.rows() < N) return false;
  Vector scale;
  Matrix a;
  for (int i = 0; i < N; ++i) {
    const Scalar d = ne.h(i, i);
    if (!(d > Scalar(0)) || !std::isfinite(d)) return false;
    scale(i) = Scalar(1) / std::sqrt(d);
  }
  for (int c = 0; c < N; ++c)
    for (int r = c; r < N; ++r) a(r, c) = ne.h(r, c) * scale(r) * scale(c);  // lower triangle
  Vector d;
  if (detail::ldlt_factor(a.data(), N, d.data(), min_pivot_ratio<Scalar>(N)) != Status::kOk)
    return false;
  Vector hv = scale.cwiseProduct(ne.gradient());
  detail::ldlt_solve(a.data(), d.data(), N, hv.data());  // H^-1 v = -theta (scaled)
  Vector hj = scale.cwiseProduct(j);
  detail::ldlt_solve(a.data(), d.data(), N, hj.data());  // H^-1 j (scaled)
  hv = scale.cwiseProduct(hv);
  hj = scale.cwiseProduct(hj);
  const Scalar r = e - j.dot(hv);
  const Scalar gain = w * j.dot(hj);
  const Scalar inc = w * r * r / (Scalar(1) + gain);
  if (!std::isfinite(inc) || !(gain >= Scalar(0))) return false;
  out = inc;
  return true;
}

// A part's result: the base bias added back to b0, usable only if every number is finite.
template <typename Scalar>
void finish_bias(TemperatureBias<Scalar>& r, const Vector3<Scalar>& base_bias,
                 TemperatureBias<Scalar>& out) {
  r.b0 += base_bias;
  if (!all_finite(r.b0) || !all_finite(r.b1) || !all_finite(r.b2) || !all_finite(r.b0_sigma) ||
      !all_finite(r.b1_sigma) || !all_finite(r.b2_sigma)) {
    out.status = Status::kIllConditioned;
    return;
  }
  r.status = Status::kOk;
  out = r;
}

}  // namespace

template <typename Scalar, int MaxOrder>
template <int N>
Status TemperatureFit<Scalar, MaxOrder>::fold(Accumulator<N>& acc,
                                              const Eigen::Matrix<Scalar, N, 1>& j, Scalar e,
                                              Scalar w) {
  Scalar inc = Scalar(0);
  const bool incremental = acc.sse_valid && sse_increment(acc.ne, j, e, w, inc);
  const Status st = acc.ne.add(j, e, w);
  if (st != Status::kOk) return st;
  if (incremental) {
    acc.sse += inc;
    return Status::kOk;
  }
  // Not yet started (or an update that failed). With exactly N rows that determine a solution
  // the minimum is exactly 0; later (rank reached only then, or a failed update) it is taken
  // from f + v . delta, at a time when f is as small as it will ever be.
  acc.sse_valid = false;
  if (acc.ne.rows() == N) {
    Eigen::Matrix<Scalar, N, 1> delta;
    if (acc.ne.solve_damped(Scalar(0), delta) == Status::kOk) {
      acc.sse = Scalar(0);
      acc.sse_valid = true;
    }
  } else if (acc.ne.rows() > N) {
    Eigen::Matrix<Scalar, N, 1> delta;
    if (acc.ne.solve_damped(Scalar(0), delta) == Status::kOk) {
      const Scalar f_min = acc.ne.weighted_sse() + acc.ne.gradient().dot(delta);
      acc.sse = f_min > Scalar(0) ? f_min : Scalar(0);
      acc.sse_valid = std::isfinite(acc.sse);
    }
  }
  return Status::kOk;
}

template <typename Scalar, int MaxOrder>
Status TemperatureFit<Scalar, MaxOrder>::reset(const Calibration<Scalar>& base,
                                               const TemperatureSettings<Scalar>& settings) {
  ready_ = false;
  rests_ = 0;
  min_c_ = max_c_ = Scalar(0);
  sums1_ = Sums<1>{};
  if constexpr (MaxOrder >= 2) sums2_ = Sums<2>{};
  if (settings.order < 1 || settings.order > MaxOrder) return Status::kInvalidArgument;
  if (!std::isfinite(settings.min_span_c) || settings.min_span_c < Scalar(0))
    return Status::kInvalidArgument;
  if (!std::isfinite(settings.gravity) || !(settings.gravity > Scalar(0)))
    return Status::kInvalidArgument;
  Scalar t0 = settings.reference_c;
  if (std::isnan(t0)) {
    if (!base.has_temperature) return Status::kInvalidArgument;
    t0 = base.temperature_c;
  }
  if (!temperature_plausible(t0)) return Status::kInvalidArgument;  // NaN too
  if (!succeeded(base.accel.status) || !succeeded(base.gyro.status))
    return Status::kInvalidArgument;
  if (!all_finite(base.accel.params) || !all_finite(base.gyro.params))
    return Status::kInvalidArgument;
  const Matrix3<Scalar> a = accel_matrix(base.accel.params);
  // Upper triangular: invertible when the three scales are non-zero.
  if (!(a(0, 0) != Scalar(0)) || !(a(1, 1) != Scalar(0)) || !(a(2, 2) != Scalar(0)))
    return Status::kInvalidArgument;
  const Matrix3<Scalar> a_inv = a.inverse();
  if (!all_finite(a_inv)) return Status::kInvalidArgument;

  a_ = a;
  a_inv_ = a_inv;
  accel_bias_ = base.accel.params.template tail<3>();
  gyro_bias_ = base.gyro.params.template tail<3>();
  gravity_ = settings.gravity;
  reference_c_ = t0;
  min_span_c_ = settings.min_span_c;
  order_ = settings.order;
  ready_ = true;
  return Status::kOk;
}

template <typename Scalar, int MaxOrder>
template <int Order>
Status TemperatureFit<Scalar, MaxOrder>::add_rows(Sums<Order>& sums, const Vector3<Scalar>& c,
                                                  Scalar s, const Vector3<Scalar>& gyro_e,
                                                  Scalar w) {
  constexpr int kPhi = 3 * (Order + 1);
  using AccelRow = Eigen::Matrix<Scalar, accel_unknowns(Order), 1>;
  const auto p = powers<Scalar, Order>(s);

  // Accelerometer: e = 1 - |c|^2, row -[2 c (x) p, chebyshev(s / 2)].
  AccelRow j;
  for (int k = 0; k <= Order; ++k)
    for (int i = 0; i < 3; ++i) j(3 * k + i) = Scalar(-2) * c(i) * p(k);
  const Scalar x = s / Scalar(2);
  Scalar t_prev = Scalar(1), t_cur = x;
  j(kPhi) = Scalar(-1);
  for (int d = 1; d <= 2 * Order; ++d) {
    j(kPhi + d) = -t_cur;
    const Scalar t_next = Scalar(2) * x * t_cur - t_prev;
    t_prev = t_cur;
    t_cur = t_next;
  }
  // All rows into a copy, so that a refusal (an overflow guard) leaves nothing changed.
  Sums<Order> next = sums;
  Status st = fold(next.accel, j, Scalar(1) - c.squaredNorm(), w);
  if (st != Status::kOk) return st;
  const Eigen::Matrix<Scalar, Order + 1, 1> jg = -p;
  for (int i = 0; i < 3; ++i) {
    st = fold(next.gyro[i], jg, gyro_e(i), w);
    if (st != Status::kOk) return st;
  }
  sums = next;
  return Status::kOk;
}

template <typename Scalar, int MaxOrder>
Status TemperatureFit<Scalar, MaxOrder>::add_rest(const RestSummary<Scalar>& rest) {
  if (!ready_) return Status::kNotStarted;
  if (!rest.has_temperature) return Status::kInvalidArgument;
  if (!std::isfinite(rest.temperature_c) || !all_finite(rest.accel_mean) ||
      !all_finite(rest.gyro_mean))
    return Status::kNonFiniteInput;
  // The model's range must be one a record holds: a broken sensor's -300 degC would cost it.
  if (!temperature_plausible(rest.temperature_c)) return Status::kTemperatureImplausible;
  if (rest.samples == 0) return Status::kTooFewSamples;

  const Scalar s = (rest.temperature_c - reference_c_) / static_cast<Scalar>(kTemperatureScaleC);
  const Vector3<Scalar> c = a_ * (rest.accel_mean + accel_bias_) / gravity_;
  // The gyro rows observe b(T) - b_base = -gyro_mean - b_base (re-centred for float).
  const Vector3<Scalar> gyro_e = -rest.gyro_mean - gyro_bias_;
  if (!std::isfinite(s) || !all_finite(c) || !all_finite(gyro_e)) return Status::kNonFiniteInput;
  const Scalar w = static_cast<Scalar>(rest.samples);
  Status st;
  if constexpr (MaxOrder >= 2)
    st = order_ == 1 ? add_rows<1>(sums1_, c, s, gyro_e, w) : add_rows<2>(sums2_, c, s, gyro_e, w);
  else
    st = add_rows<1>(sums1_, c, s, gyro_e, w);
  if (st != Status::kOk) return st;
  if (rests_ == 0) {
    min_c_ = max_c_ = rest.temperature_c;
  } else {
    if (rest.temperature_c < min_c_) min_c_ = rest.temperature_c;
    if (rest.temperature_c > max_c_) max_c_ = rest.temperature_c;
  }
  ++rests_;
  return Status::kOk;
}

template <typename Scalar, int MaxOrder>
template <int Order>
void TemperatureFit<Scalar, MaxOrder>::solve_accel(const Sums<Order>& sums,
                                                   TemperatureBias<Scalar>& out) const {
  constexpr int kN = accel_unknowns(Order);
  constexpr int kPhi = 3 * (Order + 1);
  using Ne = NormalEquations<Scalar, kN>;
  const Ne& ne = sums.accel.ne;
  out = TemperatureBias<Scalar>{};
  if (ne.rows() <= kN) {
    out.status = Status::kTooFewSamples;
    return;
  }
  if (max_c_ - min_c_ < min_span_c_) {
    out.status = Status::kTemperatureSpanSmall;
    return;
  }
  // Orientations: the weighted scatter of the gravity directions. H's first 3x3 block is
  // sum w 4 c c^T, its column kPhi (the constant radius term) holds sum w 2 c, H(kPhi, kPhi) =
  // sum w.
  const Scalar sum_w = ne.h(kPhi, kPhi);
  Matrix3<Scalar> spread;
  Vector3<Scalar> mean;
  for (int i = 0; i < 3; ++i) mean(i) = ne.h(i, kPhi) / (Scalar(2) * sum_w);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) spread(r, c) = ne.h(r, c) / (Scalar(4) * sum_w) - mean(r) * mean(c);
  Vector3<Scalar> spread_values;  // ascending
  if (!symmetric_eigen3(spread, spread_values)) {
    out.status = Status::kIllConditioned;
    return;
  }
  if (spread_values(0) < kMinDirectionSpread<Scalar>) {
    out.status = Status::kRankDeficient;
    return;
  }

  typename Ne::Vector delta;
  Status st = ne.solve_damped(Scalar(0), delta);
  if (st != Status::kOk) {
    out.status = st;
    return;
  }
  typename Ne::Matrix cov;
  st = ne.covariance(cov);
  if (st != Status::kOk) {
    out.status = st;
    return;
  }
  // covariance() scales H^-1 by the residual sum of squares where the rows were taken (f, at
  // the base); the linear problem's minimum f_min is the recursive sse (f + v . delta only as a
  // fallback: in float it cancels).
  const Scalar f = ne.weighted_sse();
  Scalar ratio = Scalar(0);
  if (f > Scalar(0)) {
    const Scalar dof = static_cast<Scalar>(ne.rows() - kN);
    for (int i = 0; i < kPhi; ++i) {
      const Scalar inflation = cov(i, i) * ne.h(i, i) * dof / f;
      if (!(inflation <= kMaxVarianceInflation<Scalar>)) {
        out.status = Status::kRankDeficient;
        return;
      }
    }
    const Scalar f_min = sums.accel.sse_valid ? sums.accel.sse : f + ne.gradient().dot(delta);
    ratio = f_min > Scalar(0) ? f_min / f : Scalar(0);
  }

  TemperatureBias<Scalar> r{};
  Vector3<Scalar>* value[3] = {&r.b0, &r.b1, &r.b2};
  Vector3<Scalar>* sigma[3] = {&r.b0_sigma, &r.b1_sigma, &r.b2_sigma};
  for (int k = 0; k <= Order; ++k) {
    const Scalar unit = gravity_ * inverse_scale_power<Scalar>(k);
    const Vector3<Scalar> phi = delta.template segment<3>(3 * k);
    *value[k] = a_inv_ * phi * unit;
    Matrix3<Scalar> block;
    for (int rr = 0; rr < 3; ++rr)
      for (int cc = 0; cc < 3; ++cc) block(rr, cc) = cov(3 * k + rr, 3 * k + cc) * ratio;
    const Matrix3<Scalar> mapped = a_inv_ * block * a_inv_.transpose();
    for (int i = 0; i < 3; ++i) {
      const Scalar v = mapped(i, i);
      (*sigma[k])(i) = std::sqrt(v > Scalar(0) ? v : Scalar(0)) * unit;
    }
  }
  finish_bias(r, accel_bias_, out);
}

template <typename Scalar, int MaxOrder>
template <int Order>
void TemperatureFit<Scalar, MaxOrder>::solve_gyro(const Sums<Order>& sums,
                                                  TemperatureBias<Scalar>& out) const {
  constexpr int kN = Order + 1;
  using Ne = NormalEquations<Scalar, kN>;
  out = TemperatureBias<Scalar>{};
  if (sums.gyro[0].ne.rows() <= kN) {
    out.status = Status::kTooFewSamples;
    return;
  }
  if (max_c_ - min_c_ < min_span_c_) {
    out.status = Status::kTemperatureSpanSmall;
    return;
  }
  TemperatureBias<Scalar> r{};
  Vector3<Scalar>* value[3] = {&r.b0, &r.b1, &r.b2};
  Vector3<Scalar>* sigma[3] = {&r.b0_sigma, &r.b1_sigma, &r.b2_sigma};
  for (int i = 0; i < 3; ++i) {
    const Ne& ne = sums.gyro[i].ne;
    typename Ne::Vector delta, sd;
    Status st = ne.solve_damped(Scalar(0), delta);
    if (st == Status::kOk) st = ne.standard_deviations(sd);
    if (st != Status::kOk) {
      out.status = st;
      return;
    }
    const Scalar f = ne.weighted_sse();
    Scalar ratio = Scalar(0);
    if (f > Scalar(0)) {
      const Scalar f_min = sums.gyro[i].sse_valid ? sums.gyro[i].sse : f + ne.gradient().dot(delta);
      ratio = f_min > Scalar(0) ? f_min / f : Scalar(0);
    }
    const Scalar sd_ratio = std::sqrt(ratio);
    for (int k = 0; k <= Order; ++k) {
      const Scalar unit = inverse_scale_power<Scalar>(k);
      (*value[k])(i) = delta(k) * unit;
      (*sigma[k])(i) = sd(k) * sd_ratio * unit;
    }
  }
  finish_bias(r, gyro_bias_, out);
}

template <typename Scalar, int MaxOrder>
Status TemperatureFit<Scalar, MaxOrder>::solve(TemperatureModel<Scalar>& out) const {
  out = TemperatureModel<Scalar>{};
  out.order = order_;
  out.reference_c = reference_c_;
  out.min_c = min_c();
  out.max_c = max_c();
  out.rests = rests_;
  if (!ready_) {
    out.accel.status = out.gyro.status = Status::kNotStarted;
    return Status::kNotStarted;
  }
  if constexpr (MaxOrder >= 2) {
    if (order_ == 2) {
      solve_accel<2>(sums2_, out.accel);
      solve_gyro<2>(sums2_, out.gyro);
    }
  }
  if (order_ == 1) {
    solve_accel<1>(sums1_, out.accel);
    solve_gyro<1>(sums1_, out.gyro);
  }
  if (!succeeded(out.accel.status)) return out.accel.status;
  if (!succeeded(out.gyro.status)) return out.gyro.status;
  return Status::kOk;
}

template class TemperatureFit<float, 1>;
template class TemperatureFit<float, 2>;
#ifndef IMUCAL_FLOAT_ONLY  // the host's reference type; a float-only build leaves it out
template class TemperatureFit<double, 1>;
template class TemperatureFit<double, 2>;
#endif

}  // namespace imucal
