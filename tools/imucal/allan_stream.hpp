// SPDX-License-Identifier: MIT
// tools/imucal/allan_stream.hpp: the overlapping Allan variance of a stream of any length in
// bounded memory, one sample at a time (the host's `imucal noise`). Host only.
//
// The cluster sizes m are those of overlapping_allan (imucal/noise/allan.hpp): log-spaced,
// `per_decade` a decade, up to n / 10. Below 2L samples every start is used, exactly that
// estimator. From 2L on, m is rounded to a multiple of b = 2^j with m / b in [L, 2L), and the
// starts are every b samples: the cumulative sums are kept at every b-th sample only, a ring of 4L
// + 1 a level. The clusters overlap by all but 1/L of their length, so the estimate and its degrees
// of freedom are those of full overlap to a fraction of their interval. Memory: levels x 8L doubles
// x 3 axes (under 2 MB for any length), whatever the number of samples.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "imucal/noise/allan.hpp"

namespace imucal::cli {

class AllanStream {
 public:
  static constexpr int kL = 256;

  explicit AllanStream(int per_decade);
  void add(const Vector3<double>& x);  // the next sample (finite)
  std::size_t samples() const { return n_; }
  // The points with m <= n / 10, tau = m tau0, with edf and 68 % intervals, into out[0 .. n_out)
  // (at most `capacity`, the shortest taus first): kTooFewSamples under 20 samples,
  // kCapacityExceeded when more sizes than `capacity`.
  Status finish(double tau0, AllanPoint<double>* out, int capacity, int& n_out) const;

 private:
  struct Size {
    std::uint64_t m;                               // cluster size, samples
    std::uint64_t q;                               // m / b: the lag in the level's ring
    int level;                                     // b = 2^level
    double inv_m;                                  // 1 / m
    double sum[3] = {0, 0, 0}, lo[3] = {0, 0, 0};  // squared mean differences (compensated)
    std::uint64_t count = 0;
  };
  struct Level {
    std::vector<double> hi, lo;  // cumulative sums every b samples: ring of kRing x 3 (hi + lo)
    std::uint64_t entries = 0;   // cumulative sums given to it so far
    std::vector<int> sizes;      // the sizes it serves
  };
  static constexpr std::uint64_t kRing = 8 * kL;  // > 4L: the longest lag, 2q < 4L, and one
  void push(Level& level, const double* hi, const double* lo);

  std::vector<Size> sizes_;
  std::vector<Level> levels_;
  double ref_[3] = {0, 0, 0};                         // the first sample: everything relative to it
  double s_hi_[3] = {0, 0, 0}, s_lo_[3] = {0, 0, 0};  // the cumulative sum (compensated)
  std::size_t n_ = 0;
};

}  // namespace imucal::cli
