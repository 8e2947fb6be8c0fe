// SPDX-License-Identifier: MIT
// tools/imucal/sample_store.hpp: the samples of one input, kept for the passes after the first
// (the statistics over the rests, the calibration again with a temperature model, the page) in
// bounded memory. Host only.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "run.hpp"

namespace imucal::cli {

// The device's 32-bit microsecond clock over the input's times: microseconds since the first
// sample, unwrapped (the device sees the low 32 bits, wrapping as its clock would). A step beyond
// kMaxStepUs either way (a logger's clock jumping by days, or set back) is taken as exactly
// kMaxStepUs: past the calibrator's gap limit, so a gap or a clock that went back, and the samples
// after it are timed from there (a 1e9 s jump would otherwise leave every later time beyond what
// the clock can say).
class DeviceClock {
 public:
  static constexpr double kMaxStepUs = 1e9;  // 1000 s: more than any gap limit, < 2^31 us

  std::int64_t operator()(double t);

 private:
  bool started_ = false;
  double base_t_ = 0;   // input time (s) where the current stretch starts
  double base_us_ = 0;  // the device's clock there (us, unwrapped)
  double last_us_ = 0;  // the previous sample, us after base_t_
};

// The tool's sample from the reader's record (an accelerometer alone: gyro readings 0, which the
// calibrator ignores).
Sample make_sample(const Record& r, DeviceClock& clock, bool has_gyro);

// Every sample of the input in order, in at most `budget` bytes: all of them while they fit;
// past the budget, an input that can be read again (a file) lets go of them (kept() false: read
// it again), and one that cannot (stdin, arrays) keeps every stride()-th, the stride doubling
// each time the budget is reached again.
class SampleStore {
 public:
  SampleStore(std::size_t budget, bool rereadable, bool has_temp, bool has_mag);
  SampleStore(const SampleStore&) = delete;
  SampleStore& operator=(const SampleStore&) = delete;

  void add(const Sample& s);
  // The number of samples the input is expected to hold: a file that will not fit is let go of
  // at once (read again), so its samples never take the budget's memory.
  void expect(double samples);
  // Every kept sample, in order, to f(const Sample&).
  template <class F>
  void for_each(F&& f) const {
    Sample s;
    for (std::size_t i = 0; i < count_; ++i) {
      get(i, s);
      f(static_cast<const Sample&>(s));
    }
  }
  bool kept() const { return kept_; }          // false: let go (read the input again)
  long stride() const { return stride_; }      // 1: every sample
  std::size_t size() const { return count_; }  // samples held
  std::size_t bytes() const { return chunks_.size() * kChunkBytes; }

  static constexpr std::size_t kChunkBytes = std::size_t{2} << 20;  // one huge page

 private:
  struct Free {
    void operator()(double* p) const;
  };
  using Chunk = std::unique_ptr<double[], Free>;
  double* slot(std::size_t i) const;
  void get(std::size_t i, Sample& s) const;
  void thin();    // every other sample, the stride doubled
  void let_go();  // none: the input is read again

  std::size_t budget_;
  bool rereadable_, has_temp_, has_mag_;
  std::size_t width_;      // doubles per sample
  std::size_t per_chunk_;  // samples per chunk
  std::vector<Chunk> chunks_;
  std::size_t count_ = 0;  // samples held
  long seen_ = 0;          // samples offered
  long stride_ = 1;
  bool kept_ = true;
};

// The samples the report page draws, in bounded memory: every one of a recording of up to
// kKeepAll samples; of a longer one, in each of kBuckets equal stretches of time, the first
// sample and those with the least and the largest reading on each accelerometer and gyro axis.
// The page draws each pixel column's extremes, so it looks the same.
class PageSamples {
 public:
  static constexpr long kKeepAll = 1L << 17;
  static constexpr int kBuckets = 1 << 13;

  PageSamples(double t_first, double t_last, long count);
  void add(const Sample& s);
  std::vector<Sample> take();  // what was kept, in order

 private:
  void flush();
  bool all_;
  double t_first_, span_;
  long index_ = 0;
  long bucket_ = -1;
  struct Pick {
    long index = -1;
    double value = 0;
    Sample sample;
  };
  Pick first_, low_[6], high_[6];
  std::vector<Sample> out_;
};

}  // namespace imucal::cli
