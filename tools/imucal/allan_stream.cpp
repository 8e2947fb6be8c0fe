// SPDX-License-Identifier: MIT
// tools/imucal/allan_stream.cpp: see allan_stream.hpp.
#include "allan_stream.hpp"

#include <cmath>

#include "imucal/stream/compensated_sum.hpp"

namespace imucal::cli {

AllanStream::AllanStream(int per_decade) {
  // overlapping_allan's sizes (next_cluster_size), up to what a 32-bit cluster size holds.
  std::uint64_t m = 1;
  for (int i = 1; m < (std::uint64_t{1} << 32); ++i) {
    Size s;
    s.m = m;
    s.level = 0;
    s.q = m;
    if (m >= 2 * static_cast<std::uint64_t>(kL)) {
      while ((m >> (s.level + 1)) >= static_cast<std::uint64_t>(kL)) ++s.level;
      const std::uint64_t b = std::uint64_t{1} << s.level;
      s.q = (m + b / 2) / b;
      s.m = s.q * b;
    }
    s.inv_m = 1.0 / static_cast<double>(s.m);
    sizes_.push_back(s);
    m = next_cluster_size(m, i, per_decade);
  }
  levels_.resize(static_cast<std::size_t>(sizes_.back().level) + 1);
  for (std::size_t k = 0; k < sizes_.size(); ++k)
    levels_[static_cast<std::size_t>(sizes_[k].level)].sizes.push_back(static_cast<int>(k));
  for (Level& l : levels_) l.entries = 1;  // S[0] = 0, in the ring once it is made
}

void AllanStream::push(Level& level, const double* hi, const double* lo) {
  if (level.hi.empty()) {  // a level's ring is made when its second entry comes: few for short
    level.hi.assign(3 * kRing, 0.0);
    level.lo.assign(3 * kRing, 0.0);
  }
  const std::uint64_t e = level.entries++;
  const std::uint64_t mask = kRing - 1;
  for (int a = 0; a < 3; ++a) {
    level.hi[3 * (e & mask) + static_cast<std::size_t>(a)] = hi[a];
    level.lo[3 * (e & mask) + static_cast<std::size_t>(a)] = lo[a];
  }
  for (int k : level.sizes) {
    Size& s = sizes_[static_cast<std::size_t>(k)];
    if (e < 2 * s.q) continue;
    const std::size_t i2 = 3 * (e & mask), i1 = 3 * ((e - s.q) & mask),
                      i0 = 3 * ((e - 2 * s.q) & mask);
    for (std::size_t a = 0; a < 3; ++a) {
      // The later window's sum less the earlier's, hi and lo parts apart: mean difference.
      const double dh =
          (level.hi[i2 + a] - level.hi[i1 + a]) - (level.hi[i1 + a] - level.hi[i0 + a]);
      const double dl =
          (level.lo[i2 + a] - level.lo[i1 + a]) - (level.lo[i1 + a] - level.lo[i0 + a]);
      const double d = (dh + dl) * s.inv_m;
      compensated_add(s.sum[a], s.lo[a], d * d);
    }
    ++s.count;
  }
}

void AllanStream::add(const Vector3<double>& x) {
  if (n_ == 0)
    for (int a = 0; a < 3; ++a) ref_[a] = x(a);
  for (int a = 0; a < 3; ++a) compensated_add(s_hi_[a], s_lo_[a], x(a) - ref_[a]);
  ++n_;
  for (std::size_t j = 0; j < levels_.size(); ++j) {
    if ((n_ & ((std::size_t{1} << j) - 1)) != 0) break;  // S[n] every 2^j samples
    push(levels_[j], s_hi_, s_lo_);
  }
}

Status AllanStream::finish(double tau0, AllanPoint<double>* out, int capacity, int& n_out) const {
  n_out = 0;
  if (!(tau0 > 0) || !std::isfinite(tau0) || capacity < 1 || out == nullptr)
    return Status::kInvalidArgument;
  const std::uint64_t m_max = n_ / 10;
  if (m_max < 2) return Status::kTooFewSamples;
  Status status = Status::kOk;
  int count = 0;
  for (const Size& s : sizes_) {
    if (s.m > m_max || s.count == 0) break;
    if (count == capacity) {
      status = Status::kCapacityExceeded;
      break;
    }
    AllanPoint<double> p;
    p.m = static_cast<std::uint32_t>(s.m);
    p.tau = tau0 * static_cast<double>(s.m);
    p.overlapping = true;
    p.count = static_cast<std::uint32_t>(s.count);
    for (int a = 0; a < 3; ++a)
      p.avar(a) = (s.sum[a] + s.lo[a]) / (2.0 * static_cast<double>(s.count));
    out[count++] = p;
  }
  set_overlapping_confidence(out, count, n_);
  n_out = count;
  return status;
}

}  // namespace imucal::cli
