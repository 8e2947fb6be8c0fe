// SPDX-License-Identifier: MIT
// Test support (host only): reads the imu_tk `t x y z` text format of the xsens recording, and
// finds still intervals offline (imu_tk's rule: variance over a centred window against k times
// the initial rest). A stand-in until the streaming detector exists; not library code.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include "imucal/models/accel_model.hpp"

namespace imucal::test {

// 16 bytes, so the 51,175-sample recording fits the 2-4 MB RAM of the simulated boards. Raw
// counts are integers below 65536: exact in float.
struct Sample {
  float t;
  Vector3<float> v;
};

struct Interval {
  std::size_t begin;  // first sample
  std::size_t end;    // one past the last sample
};

// The recording's folder: $IMUCAL_XSENS_DIR, else ../shared/data/xsens. Empty if absent.
std::string find_xsens_dir();

// In a gtest test: `dir` the recording's folder; if it is absent the test skips, or fails where
// the build requires the recording (IMUCAL_REQUIRE_XSENS).
#ifdef IMUCAL_REQUIRE_XSENS
#define IMUCAL_XSENS_ABSENT() FAIL() << "xsens recording required but not found"
#else
#define IMUCAL_XSENS_ABSENT() GTEST_SKIP() << "xsens recording not found (set IMUCAL_XSENS_DIR)"
#endif
#define IMUCAL_XSENS_DIR_OR_SKIP(dir)                       \
  const std::string dir = ::imucal::test::find_xsens_dir(); \
  if (dir.empty()) IMUCAL_XSENS_ABSENT()

// False (with a message) on a missing file or a malformed line.
bool read_txyz(const std::string& path, std::vector<Sample>& out, std::string& error);

// Reads xsens_acc.mat and xsens_gyro.mat side by side, one sample per call, storing nothing:
// the streaming tests run in the small RAM of the Arm targets too.
class XsensStream {
 public:
  XsensStream() = default;
  XsensStream(const XsensStream&) = delete;
  XsensStream& operator=(const XsensStream&) = delete;
  ~XsensStream();
  bool open(const std::string& dir);
  // False at the end of the files, or on a malformed line or mismatched timestamps (error()).
  bool next(double& t, Vector3<float>& acc, Vector3<float>& gyro);
  const std::string& error() const { return error_; }
  std::size_t line() const { return line_; }

 private:
  std::FILE* acc_ = nullptr;
  std::FILE* gyro_ = nullptr;
  std::size_t line_ = 0;
  std::string error_;
};

// Still intervals: window of +-half_window samples, threshold k times the variance norm over the
// first init_seconds, `trim` samples cut from both ends, runs then shorter than min_samples
// dropped, the initial rest included.
std::vector<Interval> detect_still(const std::vector<Sample>& acc, double init_seconds, double k,
                                   int half_window, std::size_t trim, std::size_t min_samples);

}  // namespace imucal::test
