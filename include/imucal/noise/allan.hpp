// SPDX-License-Identifier: MIT
// imucal/noise/allan.hpp: Allan variance of a 3-axis sensor at rest, and the noise terms fitted to
// it (quantisation Q, white noise N = noise density, bias instability B, random walk K), the
// numbers a Kalman filter or VIO needs. Three parts:
//   AllanAccumulator   streaming, fixed memory, one sample at a time (device)
//   overlapping_avar   overlapping Allan variance of a caller's buffer, with edf and 68 % CI
//   fit_noise_terms    weighted least squares of the four terms, non-negative, with sigmas
// Header-only, no allocation, no exceptions. Every fallible call returns a Status.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "imucal/models/accel_model.hpp"
#include "imucal/solve/ldlt.hpp"
#include "imucal/status.hpp"
#include "imucal/stream/compensated_sum.hpp"

namespace imucal {

namespace allan_detail {

template <typename Scalar>
inline bool finite3(const Vector3<Scalar>& v) {
  return std::isfinite(v(0)) && std::isfinite(v(1)) && std::isfinite(v(2));
}

// The farthest a sample may lie from the first one, per axis, in the sensor's unit: past any
// sensor's range (a 32-bit converter's counts reach 4.3e9), and near enough that the squared
// differences of 2^32 cluster means (4e24 each at most) still sum finitely in float, whose
// squares alone overflow from 1.8e19.
constexpr double kMaxSpread = 1e12;

// Sample x against the first sample `ref`: kNonFiniteInput for a NaN or infinity, kGlitch
// farther than kMaxSpread on an axis (their difference may even overflow), else kOk.
template <typename Scalar>
inline Status check_sample(const Vector3<Scalar>& x, const Vector3<Scalar>& ref) {
  if (!finite3(x)) return Status::kNonFiniteInput;
  const Vector3<Scalar> d = x - ref;
  const Scalar limit = static_cast<Scalar>(kMaxSpread);
  for (int a = 0; a < 3; ++a)
    if (!(d(a) <= limit && d(a) >= -limit)) return Status::kGlitch;  // NaN or inf too
  return Status::kOk;
}

}  // namespace allan_detail

// One Allan variance estimate at one averaging time, per axis.
template <typename Scalar>
struct AllanPoint {
  Scalar tau = Scalar(0);    // averaging time (s)
  std::uint32_t m = 0;       // cluster size (samples)
  std::uint32_t count = 0;   // differences summed
  bool overlapping = false;  // an overlapping estimate: neighbouring taus share its data
  Vector3<Scalar> avar = Vector3<Scalar>::Zero();            // Allan variance (unit^2)
  Vector3<Scalar> edf = Vector3<Scalar>::Zero();             // equivalent degrees of freedom
  Vector3<Scalar> adev_lo = Vector3<Scalar>::Zero();         // 68 % CI of the deviation (unit)
  Vector3<Scalar> adev_hi = Vector3<Scalar>::Zero();         //
  Vector3<Scalar> adev() const { return avar.cwiseSqrt(); }  // Allan deviation (unit)
};

// Chi-square quantile for nu degrees of freedom at the standard normal quantile z
// (Wilson-Hilferty cube approximation; nu is taken at least 1, where the cube stays positive
// for |z| <= 1.5).
template <typename Scalar>
Scalar chi2_quantile(Scalar nu, Scalar z) {
  if (!(nu >= Scalar(1))) nu = Scalar(1);
  const Scalar a = Scalar(2) / (Scalar(9) * nu);
  const Scalar c = Scalar(1) - a + z * std::sqrt(a);
  const Scalar c3 = c > Scalar(0) ? c * c * c : Scalar(0);
  return nu * c3;
}

// Fills adev_lo/adev_hi of `p` from avar and edf: the 1-sigma (68.3 %) interval of the deviation,
// avar * edf / chi2(edf) at the 84.1 % and 15.9 % quantiles.
template <typename Scalar>
void set_confidence(AllanPoint<Scalar>& p) {
  for (int a = 0; a < 3; ++a) {
    const Scalar nu = p.edf(a) >= Scalar(1) ? p.edf(a) : Scalar(1);
    const Scalar hi = chi2_quantile(nu, Scalar(1));
    const Scalar lo = chi2_quantile(nu, Scalar(-1));
    p.adev_lo(a) = std::sqrt(p.avar(a) * nu / hi);
    p.adev_hi(a) = lo > Scalar(0) ? std::sqrt(p.avar(a) * nu / lo) : p.avar(a) * Scalar(1e30);
  }
}

// The power-law noise type from the local log-log slope mu of the Allan VARIANCE:
// -2 white phase (quantisation), -1 white rate (noise density), 0 flicker (bias instability),
// +1 random walk of the rate.
enum class AllanNoise : std::uint8_t { kWhitePhase, kWhiteRate, kFlicker, kRandomWalk };

template <typename Scalar>
AllanNoise noise_from_slope(Scalar mu) {
  if (mu < Scalar(-1.5)) return AllanNoise::kWhitePhase;
  if (mu < Scalar(-0.5)) return AllanNoise::kWhiteRate;
  if (mu < Scalar(0.5)) return AllanNoise::kFlicker;
  return AllanNoise::kRandomWalk;
}

// Equivalent degrees of freedom of the OVERLAPPING Allan variance at cluster size m from n rate
// samples (N = n + 1 phase points): the Howe-Allan-Barnes approximations as tabulated in
// W. J. Riley, "Handbook of Frequency Stability Analysis", NIST SP 1065 (2008), section 5.3.
template <typename Scalar>
Scalar overlapping_edf(std::size_t n, std::uint32_t m_in, AllanNoise noise) {
  const Scalar N = static_cast<Scalar>(n + 1);
  const Scalar m = static_cast<Scalar>(m_in);
  Scalar edf = Scalar(1);
  switch (noise) {
    case AllanNoise::kWhitePhase:  // (N+1)(N-2m) / (2(N-m))
      edf = (N + Scalar(1)) * (N - Scalar(2) * m) / (Scalar(2) * (N - m));
      break;
    case AllanNoise::kWhiteRate:  // [3(N-1)/(2m) - 2(N-2)/N] * 4m^2/(4m^2+5)
      edf = (Scalar(3) * (N - Scalar(1)) / (Scalar(2) * m) - Scalar(2) * (N - Scalar(2)) / N) *
            (Scalar(4) * m * m / (Scalar(4) * m * m + Scalar(5)));
      break;
    case AllanNoise::kFlicker:  // m = 1: 2(N-2)^2/(2.3N-4.9); m >= 2: 5N^2/(4m(N+3m))
      edf = m_in == 1
                ? Scalar(2) * (N - Scalar(2)) * (N - Scalar(2)) / (Scalar(2.3) * N - Scalar(4.9))
                : Scalar(5) * N * N / (Scalar(4) * m * (N + Scalar(3) * m));
      break;
    case AllanNoise::kRandomWalk:  // (N-2)/m * ((N-1)^2 - 3m(N-1) + 4m^2) / (N-3)^2
      edf = (N - Scalar(2)) / m *
            ((N - Scalar(1)) * (N - Scalar(1)) - Scalar(3) * m * (N - Scalar(1)) +
             Scalar(4) * m * m) /
            ((N - Scalar(3)) * (N - Scalar(3)));
      break;
  }
  return edf >= Scalar(1) ? edf : Scalar(1);
}

// Equivalent degrees of freedom of the NON-overlapping Allan variance from M differences of
// consecutive cluster means: M / (1 + 2 sum rho_j^2), rho_j the correlation of differences j
// apart: white phase rho = -2/3, 1/6 (M / 1.944); white rate rho = -1/2 (2M / 3); flicker is
// given the white-rate value (conservative); random walk of the rate has independent
// differences (M).
template <typename Scalar>
Scalar nonoverlapping_edf(std::uint32_t count, AllanNoise noise) {
  const Scalar M = static_cast<Scalar>(count);
  Scalar edf = M;
  switch (noise) {
    case AllanNoise::kWhitePhase:
      edf = M / Scalar(1.9444444);
      break;
    case AllanNoise::kWhiteRate:
    case AllanNoise::kFlicker:
      edf = M * Scalar(2) / Scalar(3);
      break;
    case AllanNoise::kRandomWalk:
      break;
  }
  return edf >= Scalar(1) ? edf : Scalar(1);
}

// Streaming non-overlapping Allan variance at octave-spaced averaging times tau_k = 2^k tau0,
// k = 0 .. Levels-1, for a 3-axis sensor sampled at a constant interval tau0. Fixed memory:
// sizeof(AllanAccumulator<float, 16>) == 920 bytes, <float, 8> == 472 (test_allan.cpp asserts
// both). Cluster means are built pairwise from the level below (pairwise summation, so float
// keeps the noise's precision over long clusters), on samples re-centred on the first one (raw
// counts of ~33000 keep their noise digits), and each level's sum of squared differences is
// compensated (compensated_sum.hpp). A sample farther than 1e12 (allan_detail::kMaxSpread) from
// the first one is refused, so the sums stay finite in float. Cost: two levels updated per
// sample on average.
template <typename Scalar, int Levels>
class AllanAccumulator {
  static_assert(Levels >= 1 && Levels <= 31, "1..31 octaves");

 public:
  // Starts (or starts over) with sample interval tau0 (s): kInvalidArgument if not positive.
  Status start(Scalar tau0) {
    if (!(tau0 > Scalar(0)) || !std::isfinite(tau0)) return Status::kInvalidArgument;
    *this = AllanAccumulator();
    tau0_ = tau0;
    return Status::kOk;
  }

  // One 3-axis sample. kNotStarted before start(); refused, nothing changed: kNonFiniteInput
  // on NaN or infinity, kGlitch farther than 1e12 from the first sample on an axis (a value no
  // sensor reads, whose square float cannot sum).
  Status add(const Vector3<Scalar>& x) {
    if (!(tau0_ > Scalar(0))) return Status::kNotStarted;
    if (!have_ref_) {
      if (!allan_detail::finite3(x)) return Status::kNonFiniteInput;
      ref_ = x;
      have_ref_ = true;
    }
    const Status checked = allan_detail::check_sample(x, ref_);
    if (checked != Status::kOk) return checked;
    ++samples_;
    Vector3<Scalar> mean = x - ref_;
    for (int k = 0; k < Levels; ++k) {
      Level& L = level_[k];
      if (L.have_prev) {
        const Vector3<Scalar> d = mean - L.prev;
        for (int a = 0; a < 3; ++a) compensated_add(L.sum_sq[a], L.sum_lo[a], d(a) * d(a));
        ++L.count;
      }
      L.prev = mean;
      L.have_prev = true;
      if (!L.have_half) {  // first half of the next level's cluster: wait for the second
        L.half = mean;
        L.have_half = true;
        break;
      }
      L.have_half = false;
      mean = (L.half + mean) * Scalar(0.5);
    }
    return Status::kOk;
  }

  // A gap in the samples (the caller knows: lost samples, a timestamp jump): the clusters in
  // progress start over; the differences already summed are kept.
  void restart_run() {
    for (Level& L : level_) {
      L.have_prev = false;
      L.have_half = false;
    }
  }

  static constexpr int levels() { return Levels; }
  Scalar tau0() const { return tau0_; }
  std::uint32_t samples() const { return samples_; }
  Scalar tau(int k) const { return tau0_ * static_cast<Scalar>(std::uint32_t(1) << k); }
  std::uint32_t count(int k) const { return (k >= 0 && k < Levels) ? level_[k].count : 0u; }

  // Level k's result: tau, Allan variance per axis, number of differences, edf (non-overlapping,
  // noise type from the slope to the neighbouring levels) and its 68 % interval.
  // kInvalidArgument for k out of range, kTooFewSamples when the level has no difference yet
  // (`out` untouched). Never kOk with a NaN or an infinity (kNonFiniteInput, `out` untouched:
  // the bound add() keeps on the samples rules it out).
  Status result(int k, AllanPoint<Scalar>& out) const {
    if (k < 0 || k >= Levels) return Status::kInvalidArgument;
    if (level_[k].count == 0) return Status::kTooFewSamples;
    AllanPoint<Scalar> p;
    p.tau = tau(k);
    p.m = std::uint32_t(1) << k;
    p.count = level_[k].count;
    p.avar = avar_at(k);
    for (int a = 0; a < 3; ++a) {
      // The noise type from the slope to the neighbouring levels, never going back to a type
      // of shorter taus (Q, N, B, K dominate in that order as tau grows).
      AllanNoise type = AllanNoise::kWhitePhase;
      for (int j = 0; j <= k; ++j) {
        const int j0 = j > 0 ? j - 1 : j;
        const int j1 = (j + 1 < Levels && level_[j + 1].count > 0) ? j + 1 : j;
        Scalar mu = Scalar(-1);
        const Scalar lo = avar_at(j0)(a), hi = avar_at(j1)(a);
        if (j1 > j0 && lo > Scalar(0) && hi > Scalar(0)) {
          mu = std::log(hi / lo) / (static_cast<Scalar>(j1 - j0) * Scalar(0.6931471805599453));
        }
        const AllanNoise t = noise_from_slope(mu);
        if (t > type) type = t;
      }
      p.edf(a) = nonoverlapping_edf<Scalar>(p.count, type);
    }
    set_confidence(p);
    if (!allan_detail::finite3(p.avar) || !allan_detail::finite3(p.edf) ||
        !allan_detail::finite3(p.adev_lo) || !allan_detail::finite3(p.adev_hi))
      return Status::kNonFiniteInput;
    out = p;
    return Status::kOk;
  }

 private:
  struct Level {
    Vector3<Scalar> half = Vector3<Scalar>::Zero();  // first of the pair that makes a cluster
                                                     // of the next level
    Vector3<Scalar> prev = Vector3<Scalar>::Zero();  // the previous cluster mean
    Scalar sum_sq[3] = {};  // sum of squared differences of consecutive cluster means (hi part)
    Scalar sum_lo[3] = {};  // its compensation (lo part)
    std::uint32_t count = 0;
    bool have_prev = false;
    bool have_half = false;
  };

  Vector3<Scalar> avar_at(int k) const {
    const Level& L = level_[k];
    Vector3<Scalar> v;
    const Scalar den = Scalar(2) * static_cast<Scalar>(L.count);
    for (int a = 0; a < 3; ++a) v(a) = (L.sum_sq[a] + L.sum_lo[a]) / den;
    return v;
  }

  Level level_[static_cast<std::size_t>(Levels)];
  Vector3<Scalar> ref_ = Vector3<Scalar>::Zero();  // the first sample: everything relative to it
  Scalar tau0_ = Scalar(0);
  std::uint32_t samples_ = 0;
  bool have_ref_ = false;
};

// Overlapping Allan variance at one cluster size m of n samples, get(i) returning sample i as a
// Vector3<Scalar>: avar = 1 / (2 (n - 2m + 1)) sum_j (mean[j+m, j+2m) - mean[j, j+m))^2, with the
// two window sums slid one sample at a time (O(n), no buffer), on samples re-centred on the first
// and with compensated sums, so float keeps the noise digits of raw counts. kInvalidArgument for
// m == 0; kTooFewSamples when n < 2m (avar and count untouched); kNonFiniteInput on a NaN or
// infinity in the samples read, kGlitch on one farther than 1e12 from the first on an axis
// (allan_detail::kMaxSpread: float's sums of squares would overflow).
template <typename Scalar, typename Get>
Status overlapping_avar_at(Get&& get, std::size_t n, std::uint32_t m, Vector3<Scalar>& avar,
                           std::uint32_t& count) {
  if (m == 0) return Status::kInvalidArgument;
  const std::size_t mm = m;
  if (n < 2 * mm) return Status::kTooFewSamples;
  const Vector3<Scalar> ref = get(std::size_t(0));
  if (!allan_detail::finite3(ref)) return Status::kNonFiniteInput;
  Scalar s1[3] = {}, l1[3] = {}, s2[3] = {}, l2[3] = {}, sq[3] = {}, lq[3] = {};
  for (std::size_t i = 0; i < 2 * mm; ++i) {
    const Vector3<Scalar> x = get(i);
    const Status checked = allan_detail::check_sample(x, ref);
    if (checked != Status::kOk) return checked;
    const Vector3<Scalar> v = x - ref;
    for (int a = 0; a < 3; ++a) {
      if (i < mm) {
        compensated_add(s1[a], l1[a], v(a));
      } else {
        compensated_add(s2[a], l2[a], v(a));
      }
    }
  }
  const Scalar inv_m = Scalar(1) / static_cast<Scalar>(m);
  const std::size_t last = n - 2 * mm;
  for (std::size_t j = 0;; ++j) {
    for (int a = 0; a < 3; ++a) {
      const Scalar d = ((s2[a] - s1[a]) + (l2[a] - l1[a])) * inv_m;
      compensated_add(sq[a], lq[a], d * d);
    }
    if (j == last) break;
    const Vector3<Scalar> x2 = get(j + 2 * mm);
    const Status checked = allan_detail::check_sample(x2, ref);
    if (checked != Status::kOk) return checked;
    const Vector3<Scalar> out1 = get(j) - ref, mid = get(j + mm) - ref, in2 = x2 - ref;
    for (int a = 0; a < 3; ++a) {
      compensated_add(s1[a], l1[a], mid(a));
      compensated_add(s1[a], l1[a], -out1(a));
      compensated_add(s2[a], l2[a], in2(a));
      compensated_add(s2[a], l2[a], -mid(a));
    }
  }
  const Scalar den = Scalar(2) * static_cast<Scalar>(last + 1);
  for (int a = 0; a < 3; ++a) avar(a) = (sq[a] + lq[a]) / den;
  count = static_cast<std::uint32_t>(last + 1);
  return Status::kOk;
}

// The log-spaced cluster sizes: the one after m, the i-th (i >= 1), is 10^(i / per_decade)
// rounded, and at least m + 1.
inline std::uint64_t next_cluster_size(std::uint64_t m, int i, int per_decade) {
  const double next = std::floor(std::pow(10.0, static_cast<double>(i) / per_decade) + 0.5);
  return next > static_cast<double>(m) ? static_cast<std::uint64_t>(next) : m + 1;
}

// The edf and the 68 % interval of overlapping estimates pts[0 .. count) (taus increasing) from n
// samples. The noise type of each point comes from the slope across +-3 points (a factor ~2.4 in
// tau each way at 8 per decade), never going back to a type of shorter taus (Q, N, B, K dominate
// in that order as tau grows): a noisy slope at long taus must not pick white phase noise, whose
// edf is ~n/2.
template <typename Scalar>
void set_overlapping_confidence(AllanPoint<Scalar>* pts, int count, std::size_t n) {
  AllanNoise type[3] = {AllanNoise::kWhitePhase, AllanNoise::kWhitePhase, AllanNoise::kWhitePhase};
  for (int i = 0; i < count; ++i) {
    const int i0 = i >= 3 ? i - 3 : 0, i1 = i + 3 < count ? i + 3 : count - 1;
    for (int a = 0; a < 3; ++a) {
      Scalar mu = Scalar(-1);
      if (i1 > i0 && pts[i0].avar(a) > Scalar(0) && pts[i1].avar(a) > Scalar(0)) {
        mu = std::log(pts[i1].avar(a) / pts[i0].avar(a)) / std::log(pts[i1].tau / pts[i0].tau);
      }
      const AllanNoise t = noise_from_slope(mu);
      if (t > type[a]) type[a] = t;
      pts[i].edf(a) = overlapping_edf<Scalar>(n, pts[i].m, type[a]);
    }
    set_confidence(pts[i]);
  }
}

// Overlapping Allan deviation of n samples taken every tau0 seconds at log-spaced cluster sizes
// m = 1 .. n/10 (`per_decade` sizes per decade, each m at least one more than the last), into
// out[0 .. n_out): tau, avar, edf (overlapping_edf, the noise type from the local slope to the
// neighbouring points) and the 68 % interval. get(i) returns sample i as a Vector3<Scalar>.
// kInvalidArgument for tau0 <= 0, per_decade < 1 or capacity < 1; kTooFewSamples when n < 20
// (n_out = 0); kCapacityExceeded when more sizes than `capacity`: the first `capacity` (the
// shortest taus) are filled; kNonFiniteInput (n_out = 0) on a NaN or infinity in the samples,
// kGlitch (n_out = 0) on one farther than 1e12 from the first.
template <typename Scalar, typename Get>
Status overlapping_allan(Get&& get, std::size_t n, Scalar tau0, int per_decade,
                         AllanPoint<Scalar>* out, int capacity, int& n_out) {
  n_out = 0;
  if (!(tau0 > Scalar(0)) || !std::isfinite(tau0) || per_decade < 1 || capacity < 1 ||
      out == nullptr) {
    return Status::kInvalidArgument;
  }
  const std::size_t m_max = n / 10;
  if (m_max < 2) return Status::kTooFewSamples;
  Status status = Status::kOk;
  std::uint32_t m = 1;
  int count = 0;
  for (int i = 1; m <= m_max; ++i) {
    if (count == capacity) {
      status = Status::kCapacityExceeded;
      break;
    }
    AllanPoint<Scalar> p;
    p.m = m;
    p.tau = tau0 * static_cast<Scalar>(m);
    p.overlapping = true;
    const Status s = overlapping_avar_at<Scalar>(get, n, m, p.avar, p.count);
    if (s != Status::kOk) return s;
    out[count++] = p;
    m = static_cast<std::uint32_t>(next_cluster_size(m, i, per_decade));
  }
  set_overlapping_confidence(out, count, n);
  n_out = count;
  return status;
}

// The same over a strided buffer: sample i, axis a at data[i * stride + a] (stride >= 3).
template <typename Scalar>
Status overlapping_allan(const Scalar* data, std::size_t n, std::size_t stride, Scalar tau0,
                         int per_decade, AllanPoint<Scalar>* out, int capacity, int& n_out) {
  n_out = 0;
  if (data == nullptr || stride < 3) return Status::kInvalidArgument;
  auto get = [data, stride](std::size_t i) {
    const Scalar* p = data + i * stride;
    return Vector3<Scalar>(p[0], p[1], p[2]);
  };
  return overlapping_allan<Scalar>(get, n, tau0, per_decade, out, capacity, n_out);
}

// One fitted noise coefficient: value, 1-sigma, and whether the data show it (in the best
// non-negative subset with a variance coefficient above twice its sigma, i.e. the value's
// relative sigma below 25 %).
template <typename Scalar>
struct NoiseTerm {
  Scalar value = Scalar(0);
  Scalar sigma = Scalar(0);
  bool significant = false;
};

// The IEEE 952 / 1554 noise terms of one axis, from
//   AVAR(tau) = 3 Q^2 / tau^2 + N^2 / tau + (2 ln2 / pi) B^2 + K^2 tau / 3,
// for a rate sensor in unit (rad/s, m/s^2):
template <typename Scalar>
struct NoiseTerms {
  NoiseTerm<Scalar> q;  // quantisation                         (unit s)
  NoiseTerm<Scalar> n;  // white noise: noise density, ARW/VRW   (unit / sqrt(Hz) = unit sqrt(s))
  NoiseTerm<Scalar> b;  // bias instability                     (unit)
  NoiseTerm<Scalar> k;  // rate / acceleration random walk      (unit sqrt(Hz) = unit / sqrt(s))
  Scalar chi2 = Scalar(0);  // weighted residual of the fit
  int dof = 0;              // points - terms in the best subset
  // The classic read-outs: N as the deviation at tau = 1 s on the -1/2 slope line through the
  // point whose local slope is closest to -1/2; B as the smallest deviation / 0.664 and where.
  Scalar classic_n = Scalar(0);
  Scalar classic_b = Scalar(0);
  Scalar classic_b_tau = Scalar(0);
  bool classic_b_at_end = false;  // the smallest deviation is the last point: no floor seen
};

namespace allan_detail {
template <typename Scalar>
Scalar basis(int j, Scalar tau) {
  switch (j) {
    case 0:
      return Scalar(3) / (tau * tau);
    case 1:
      return Scalar(1) / tau;
    case 2:
      return Scalar(0.4412712003053032);  // 2 ln2 / pi
    default:
      return tau / Scalar(3);
  }
}
}  // namespace allan_detail

// Weighted least squares of the four non-negative coefficients (Q^2, N^2, B^2, K^2) to the points
// pts[0 .. n_points) of one axis (0, 1, 2). Weight of a point: edf / (2 AVAR^2) (the chi-square
// variance of an Allan variance), AVAR from the data first and then twice from the fitted model,
// divided, for overlapping estimates, by the number of them within a factor 2 of its tau either
// way (they share their data; without this the sigmas would be too small). Non-negativity: every
// subset of the four terms is solved and the best feasible one kept. Sigmas from the inverse
// normal matrix, scaled up by chi2/dof when that exceeds 1. kInvalidArgument for a bad axis or
// fewer than 2 points; kNonFiniteInput for a non-finite or non-positive tau, AVAR or edf.
template <typename Scalar>
Status fit_noise_terms(const AllanPoint<Scalar>* pts, int n_points, int axis,
                       NoiseTerms<Scalar>& out) {
  using Mat4 = Eigen::Matrix<Scalar, 4, 4>;
  using Vec4 = Eigen::Matrix<Scalar, 4, 1>;
  using allan_detail::basis;
  if (pts == nullptr || n_points < 2 || axis < 0 || axis > 2) return Status::kInvalidArgument;
  Scalar a0 = Scalar(0);  // the largest AVAR: the fit runs in units of it
  for (int i = 0; i < n_points; ++i) {
    const Scalar t = pts[i].tau, v = pts[i].avar(axis), e = pts[i].edf(axis);
    if (!std::isfinite(t) || !std::isfinite(v) || !std::isfinite(e) || !(t > Scalar(0)) ||
        !(v > Scalar(0)) || !(e > Scalar(0))) {
      return Status::kNonFiniteInput;
    }
    if (v > a0) a0 = v;
  }
  // Column scales: each basis function's largest value over the taus, in units of a0, so the
  // normal matrix has a unit-sized diagonal whatever the taus.
  Vec4 col;
  for (int j = 0; j < 4; ++j) {
    Scalar mx = Scalar(0);
    for (int i = 0; i < n_points; ++i) mx = std::max(mx, basis(j, pts[i].tau));
    col(j) = mx / a0;
  }
  auto scaled_basis = [&](int j, int i) { return basis(j, pts[i].tau) / a0 / col(j); };
  auto model_at = [&](const Vec4& x, int i) {
    Scalar m = Scalar(0);
    for (int j = 0; j < 4; ++j) m += x(j) * scaled_basis(j, i);
    return m;
  };
  Vec4 x_prev = Vec4::Zero();
  auto weight = [&](int pass, int i) {
    Scalar model = pts[i].avar(axis) / a0;
    if (pass > 0) {
      const Scalar m = model_at(x_prev, i);
      if (m > Scalar(0)) model = m;
    }
    int near = 1;
    if (pts[i].overlapping) {
      near = 0;
      for (int l = 0; l < n_points; ++l) {
        const Scalar q = pts[l].tau / pts[i].tau;
        if (pts[l].overlapping && q >= Scalar(0.5) && q <= Scalar(2)) ++near;
      }
    }
    return pts[i].edf(axis) / (Scalar(2) * model * model * static_cast<Scalar>(near));
  };
  Vec4 best_x = Vec4::Zero();
  Mat4 best_cov = Mat4::Zero();
  int best_mask = 0;
  Scalar best_chi2 = Scalar(-1);
  for (int pass = 0; pass < 3; ++pass) {
    best_chi2 = Scalar(-1);
    for (int mask = 1; mask < 16; ++mask) {
      Mat4 A = Mat4::Zero();
      Vec4 b = Vec4::Zero();
      for (int i = 0; i < n_points; ++i) {
        const Scalar wi = weight(pass, i);
        Vec4 f;
        for (int j = 0; j < 4; ++j) f(j) = (mask >> j) & 1 ? scaled_basis(j, i) : Scalar(0);
        A.noalias() += (wi * f) * f.transpose();
        b += (wi * pts[i].avar(axis) / a0) * f;
      }
      for (int j = 0; j < 4; ++j) {
        if (!((mask >> j) & 1)) A(j, j) = Scalar(1);
      }
      Vec4 pivots;
      if (detail::ldlt_factor(A.data(), 4, pivots.data(), Scalar(0)) != Status::kOk) continue;
      Vec4 x = b;
      detail::ldlt_solve(A.data(), pivots.data(), 4, x.data());
      bool feasible = true;
      for (int j = 0; j < 4; ++j) {
        if ((mask >> j) & 1) feasible = feasible && x(j) >= Scalar(0) && std::isfinite(x(j));
      }
      if (!feasible) continue;
      Scalar chi2 = Scalar(0);
      for (int i = 0; i < n_points; ++i) {
        const Scalar d = pts[i].avar(axis) / a0 - model_at(x, i);
        chi2 += weight(pass, i) * d * d;
      }
      if (best_chi2 < Scalar(0) || chi2 < best_chi2) {
        best_chi2 = chi2;
        best_x = x;
        best_mask = mask;
        for (int c = 0; c < 4; ++c) {
          Vec4 column = Vec4::Unit(c);
          detail::ldlt_solve(A.data(), pivots.data(), 4, column.data());
          best_cov.col(c) = column;
        }
      }
    }
    if (best_chi2 < Scalar(0)) return Status::kIllConditioned;
    x_prev = best_x;
  }
  NoiseTerms<Scalar> r;
  int terms = 0;
  for (int j = 0; j < 4; ++j) terms += (best_mask >> j) & 1;
  r.chi2 = best_chi2;
  r.dof = n_points - terms;
  const Scalar inflate = r.dof > 0 && best_chi2 > static_cast<Scalar>(r.dof)
                             ? best_chi2 / static_cast<Scalar>(r.dof)
                             : Scalar(1);
  NoiseTerm<Scalar>* term[4] = {&r.q, &r.n, &r.b, &r.k};
  // The coefficient of basis j in AVAR units: x_j a0 / max_j = x_j / col_j.
  for (int j = 0; j < 4; ++j) {
    if (!((best_mask >> j) & 1)) continue;
    const Scalar cj = best_x(j) / col(j);                            // in AVAR units
    const Scalar sj = std::sqrt(best_cov(j, j) * inflate) / col(j);  // its sigma
    NoiseTerm<Scalar>& t = *term[j];
    t.value = std::sqrt(cj);
    t.sigma = cj > Scalar(0) ? sj / (Scalar(2) * t.value) : std::sqrt(sj);
    t.significant = cj > Scalar(2) * sj;
  }
  // Classic read-outs.
  int best_n = -1;
  Scalar best_dev = Scalar(1e30);
  for (int i = 0; i + 1 < n_points; ++i) {
    const Scalar s = Scalar(0.5) * std::log(pts[i + 1].avar(axis) / pts[i].avar(axis)) /
                     std::log(pts[i + 1].tau / pts[i].tau);
    const Scalar dev = std::fabs(s + Scalar(0.5));
    if (dev <= Scalar(0.15)) {
      best_n = i;
      break;
    }
    if (dev < best_dev) {
      best_dev = dev;
      best_n = i;
    }
  }
  if (best_n >= 0) {
    const int i = best_n;
    r.classic_n = Scalar(0.5) * (std::sqrt(pts[i].avar(axis) * pts[i].tau) +
                                 std::sqrt(pts[i + 1].avar(axis) * pts[i + 1].tau));
  }
  int i_min = 0;
  for (int i = 1; i < n_points; ++i) {
    if (pts[i].avar(axis) < pts[i_min].avar(axis)) i_min = i;
  }
  r.classic_b = std::sqrt(pts[i_min].avar(axis)) / Scalar(0.6642824702679265);
  r.classic_b_tau = pts[i_min].tau;
  r.classic_b_at_end = i_min == n_points - 1;
  out = r;
  return Status::kOk;
}

}  // namespace imucal
