// SPDX-License-Identifier: MIT
// tools/imucal/sample_store.cpp: see sample_store.hpp.
#include "sample_store.hpp"

#include <sys/mman.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <new>

namespace imucal::cli {

std::int64_t DeviceClock::operator()(double t) {
  if (!started_) {
    started_ = true;
    base_t_ = t;
  }
  double us = (t - base_t_) * 1e6;
  const double step = us - last_us_;
  if (!(std::abs(step) <= kMaxStepUs)) {  // also a non-finite time (never from the readers)
    base_us_ += last_us_ + (step > 0 ? kMaxStepUs : -kMaxStepUs);
    base_t_ = t;
    us = 0;
  }
  last_us_ = us;
  return std::llround(us + base_us_);
}

Sample make_sample(const Record& r, DeviceClock& clock, bool has_gyro) {
  Sample s;
  s.t = r.t;
  s.us = clock(r.t);
  for (int a = 0; a < 3; ++a) {
    s.acc[a] = r.acc[a];
    s.gyro[a] = has_gyro ? r.gyro[a] : 0.0;
    s.mag[a] = r.mag[a];
  }
  s.temp = r.temp;
  return s;
}

// --- SampleStore -------------------------------------------------------------------------------

void SampleStore::Free::operator()(double* p) const { std::free(p); }

SampleStore::SampleStore(std::size_t budget, bool rereadable, bool has_temp, bool has_mag)
    : budget_(std::max(budget, 2 * kChunkBytes)),
      rereadable_(rereadable),
      has_temp_(has_temp),
      has_mag_(has_mag),
      width_(std::size_t{8} + (has_temp ? 1u : 0u) + (has_mag ? 3u : 0u)),
      per_chunk_(kChunkBytes / sizeof(double) / width_) {}

double* SampleStore::slot(std::size_t i) const {
  return chunks_[i / per_chunk_].get() + (i % per_chunk_) * width_;
}

void SampleStore::add(const Sample& s) {
  const long n = seen_++;
  if (!kept_ || n % stride_ != 0) return;
  if (count_ == chunks_.size() * per_chunk_) {
    if (bytes() + kChunkBytes > budget_) {
      if (rereadable_) {  // the file is read again instead
        let_go();
        return;
      }
      thin();
      if (n % stride_ != 0) return;
    }
    if (count_ == chunks_.size() * per_chunk_) {
      // Aligned to a huge page, so a large store costs few page faults where the kernel has them.
      void* p = std::aligned_alloc(kChunkBytes, kChunkBytes);
      if (p == nullptr) throw std::bad_alloc();  // the command reports it (exit 2)
#ifdef MADV_HUGEPAGE
      madvise(p, kChunkBytes, MADV_HUGEPAGE);
#endif
      chunks_.emplace_back(static_cast<double*>(p));
    }
  }
  double* d = slot(count_++);
  d[0] = s.t;
  std::memcpy(d + 1, &s.us, sizeof(double));
  static_assert(sizeof(s.us) == sizeof(double), "the clock takes one slot");
  std::memcpy(d + 2, s.acc, sizeof s.acc);
  std::memcpy(d + 5, s.gyro, sizeof s.gyro);
  std::size_t k = 8;
  if (has_temp_) d[k++] = s.temp;
  if (has_mag_) std::memcpy(d + k, s.mag, sizeof s.mag);
}

void SampleStore::expect(double samples) {
  if (rereadable_ && kept_ &&
      samples * static_cast<double>(width_ * sizeof(double)) > static_cast<double>(budget_))
    let_go();
}

void SampleStore::let_go() {
  chunks_.clear();
  chunks_.shrink_to_fit();
  count_ = 0;
  kept_ = false;
}

void SampleStore::get(std::size_t i, Sample& s) const {
  const double* d = slot(i);
  s.t = d[0];
  std::memcpy(&s.us, d + 1, sizeof(double));
  std::memcpy(s.acc, d + 2, sizeof s.acc);
  std::memcpy(s.gyro, d + 5, sizeof s.gyro);
  std::size_t k = 8;
  s.temp = has_temp_ ? d[k++] : kNaN;
  if (has_mag_) {
    std::memcpy(s.mag, d + k, sizeof s.mag);
  } else {
    s.mag[0] = s.mag[1] = s.mag[2] = kNaN;
  }
}

void SampleStore::thin() {
  const std::size_t kept = (count_ + 1) / 2;
  for (std::size_t i = 1; i < kept; ++i) std::memcpy(slot(i), slot(2 * i), width_ * sizeof(double));
  count_ = kept;
  stride_ *= 2;
  chunks_.resize((count_ + per_chunk_ - 1) / per_chunk_);
}

// --- PageSamples -------------------------------------------------------------------------------

PageSamples::PageSamples(double t_first, double t_last, long count)
    : all_(count <= kKeepAll), t_first_(t_first), span_(t_last - t_first) {
  if (all_) out_.reserve(static_cast<std::size_t>(std::max(count, 0L)));
}

void PageSamples::add(const Sample& s) {
  const long i = index_++;
  if (all_) {
    out_.push_back(s);
    return;
  }
  long b = 0;
  if (span_ > 0 && std::isfinite(s.t))
    b = std::clamp(static_cast<long>((s.t - t_first_) / span_ * kBuckets), 0L,
                   static_cast<long>(kBuckets) - 1);
  if (b != bucket_) {
    flush();
    bucket_ = b;
    first_ = {i, 0, s};
  }
  for (int c = 0; c < 6; ++c) {
    const double v = c < 3 ? s.acc[c] : s.gyro[c - 3];
    if (!std::isfinite(v)) continue;
    if (low_[c].index < 0 || v < low_[c].value) low_[c] = {i, v, s};
    if (high_[c].index < 0 || v > high_[c].value) high_[c] = {i, v, s};
  }
}

void PageSamples::flush() {
  if (first_.index < 0) return;
  const Pick* picks[13] = {&first_};
  int n = 1;
  for (int c = 0; c < 6; ++c) {
    if (low_[c].index >= 0) picks[n++] = &low_[c];
    if (high_[c].index >= 0) picks[n++] = &high_[c];
  }
  for (int k = 1; k < n; ++k)  // in time order (at most 13)
    for (int j = k; j > 0 && picks[j - 1]->index > picks[j]->index; --j)
      std::swap(picks[j - 1], picks[j]);
  long last = -1;
  for (int k = 0; k < n; ++k) {
    if (picks[k]->index == last) continue;
    last = picks[k]->index;
    out_.push_back(picks[k]->sample);
  }
  first_ = Pick{};
  for (int c = 0; c < 6; ++c) low_[c] = high_[c] = Pick{};
}

std::vector<Sample> PageSamples::take() {
  flush();
  return std::move(out_);
}

}  // namespace imucal::cli
