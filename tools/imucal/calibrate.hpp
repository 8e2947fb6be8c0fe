// SPDX-License-Identifier: MIT
// tools/imucal/calibrate.hpp: the parts of `imucal calibrate` that the other commands running a
// recording through the library share (field.cpp): the input's settings settled, the units'
// nominal scales, the device's view of a sample, the calibrator's settings from the options.
#pragma once

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "imucal/calibrator/calibrator.hpp"
#include "run.hpp"

namespace imucal::cli {

// Shows how far the reading is, on a terminal only (stderr), at most every 64k samples.
class ProgressLine {
 public:
  explicit ProgressLine(bool enabled) : enabled_(enabled && isatty(STDERR_FILENO) != 0) {}
  bool due(long samples) const { return enabled_ && (samples & 0xffff) == 0; }
  void show(long samples, double fraction) {
    if (fraction > 0) {
      std::fprintf(stderr, "\r  reading: %3.0f %%, %ld samples", 100.0 * fraction, samples);
    } else {
      std::fprintf(stderr, "\r  reading: %ld samples", samples);
    }
    shown_ = true;
  }
  ~ProgressLine() {
    if (shown_) std::fprintf(stderr, "\r\033[K");
  }

 private:
  bool enabled_;
  bool shown_ = false;
};

// m/s^2 per input unit (NaN: counts without --accel-lsb-per-g).
inline double accel_nominal_scale(const Options& o) {
  switch (o.accel_unit) {
    case AccelUnit::kMps2:
      return 1.0;
    case AccelUnit::kG:
      return kStandardGravity;
    case AccelUnit::kCounts:
      return kStandardGravity / o.accel_lsb_per_g;  // NaN if not given
  }
  return kNaN;
}

// uT per input unit of the magnetometer (NaN: counts without --mag-lsb-per-ut).
inline double mag_unit_ut(const Options& o) {
  switch (o.mag_unit) {
    case MagUnit::kUt:
      return 1.0;
    case MagUnit::kNt:
      return 0.001;
    case MagUnit::kGauss:
      return 100.0;
    case MagUnit::kCounts:
      return 1.0 / o.mag_lsb_per_ut;  // NaN if not given
  }
  return kNaN;
}

// The accelerometer's raw reading at zero acceleration (NaN: counts without --accel-zero).
inline double accel_nominal_zero(const Options& o) {
  return o.accel_unit == AccelUnit::kCounts ? o.accel_zero : 0.0;
}

// rad/s per input unit; 0 when unknown (the calibrator then searches it).
inline double gyro_nominal_scale(const Options& o) {
  switch (o.gyro_unit) {
    case GyroUnit::kRads:
      return 1.0;
    case GyroUnit::kDps:
      return kPi / 180.0;
    case GyroUnit::kCounts:
      return std::isfinite(o.gyro_lsb_per_dps) ? kPi / 180.0 / o.gyro_lsb_per_dps : 0.0;
  }
  return 0.0;
}

// The device's view of one sample (temperature NaN: none).
template <typename Scalar>
ImuSample<Scalar> imu_sample(const Sample& x) {
  ImuSample<Scalar> s;
  s.t_us = static_cast<std::uint32_t>(static_cast<std::uint64_t>(x.us) & 0xffffffffu);
  for (int a = 0; a < 3; ++a) {
    s.acc(a) = static_cast<Scalar>(x.acc[a]);
    s.gyro(a) = static_cast<Scalar>(x.gyro[a]);
  }
  s.temperature = static_cast<Scalar>(x.temp);
  return s;
}

// The streaming calibrator's settings from the options and what the input holds (float and
// double instantiated in calibrate.cpp).
template <typename Scalar>
CalibratorSettings<Scalar> calibrator_settings(const Options& o, const Run& run);

// What the input holds and how it is read (format, parts, columns, where the time comes from,
// the mode) into `run`, from the opened reader and the settled options. No sample is read.
template <typename Scalar>
void describe_input(const SampleReader& reader, const Options& o, Run& run);

// The settings the input itself gives (its `# imucal:` comments, its columns) joined to the
// command's, and checked before any sample is read. False with the reason otherwise.
bool settle_options(SampleReader& reader, Options& o, std::string& error);

// The reader's diagnostics on stderr, "imucal: file:line:column: message", and how many more.
void print_diagnostics(const Diagnostics& diag);

// Files that can be read again from their start (not stdin, a pipe or a terminal).
bool rereadable(const std::vector<std::string>& files);

}  // namespace imucal::cli
