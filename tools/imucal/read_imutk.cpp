// SPDX-License-Identifier: MIT
// tools/imucal/read_imutk.cpp: imu_tk's two files of `t x y z` lines, the accelerometer's and
// the gyroscope's, paired by timestamp.
#include <cmath>
#include <cstdio>
#include <string>

#include "format_reader.hpp"

namespace imucal::cli {

ImuTkReader::ImuTkReader() { layout_.accel = layout_.gyro = layout_.time = true; }

bool ImuTkReader::start(Diagnostics& diag) {
  if (files_ != 2) {
    diag.add({in_[0].name(), 0, 0,
              "the imu_tk format needs two files: the accelerometer's and the gyroscope's"});
    return false;
  }
  // The settings comments at the top of either file, before the first sample.
  for (int i = 0; i < 2; ++i) {
    std::string_view line;
    if (!content_line(in_[i], line, diag)) {
      if (!in_[i].ended() && !in_[i].failed())  // else said why
        diag.add({in_[i].name(), 0, 0, "no samples: expected lines of `t x y z`"});
      return false;
    }
    pending_[i] = std::string(line);
    has_pending_[i] = true;
  }
  data_started_ = true;
  return true;
}

// The next good `t x y z` line of file `which`.
bool ImuTkReader::next_txyz(int which, double& t, double v[3], long& line_no, Diagnostics& diag) {
  LineReader& in = in_[which];
  std::string_view line;
  for (;;) {
    if (has_pending_[which]) {
      has_pending_[which] = false;
      line = pending_[which];
    } else if (!content_line(in, line, diag)) {
      break;
    }
    double x[4];
    bool ok = plain_numbers(line, x, 4);  // the common line; else field by field, saying why
    if (!ok) {
      split_fields(line, fields_);
      if (fields_.size() != 4) {
        report(in, 0,
               "expected 4 fields (t x y z), found " + std::to_string(fields_.size()) +
                   ": line skipped",
               diag);
        ++skipped_;
        continue;
      }
      ok = true;
      static constexpr const char* kNames[4] = {"t", "x", "y", "z"};
      for (int k = 0; k < 4 && ok; ++k)
        ok = number_field(in, fields_[static_cast<std::size_t>(k)], kNames[k], x[k], diag);
    }
    ok = ok && after_previous(x[0] * time_scale_, have_[which], t_[which], in, 1, diag);
    if (!ok) {
      ++skipped_;
      continue;
    }
    t = x[0] * time_scale_;
    for (int a = 0; a < 3; ++a) v[a] = x[a + 1];
    line_no = in.line_number();
    return true;
  }
  return false;
}

// Pairs the two files by timestamp (within half a microsecond); an unmatched line is reported.
bool ImuTkReader::next(Record& r, Diagnostics& diag) {
  if (!primed_) {
    primed_ = true;
    for (int i = 0; i < 2; ++i) have_[i] = next_txyz(i, t_[i], v_[i], vline_[i], diag);
  }
  while (have_[0] && have_[1]) {
    const double tol = 5e-7 + 1e-12 * std::abs(t_[0]);
    if (std::abs(t_[0] - t_[1]) <= tol) {
      r.t = t_[0];
      for (int a = 0; a < 3; ++a) {
        r.acc[a] = v_[0][a];
        r.gyro[a] = v_[1][a];
        r.mag[a] = kNaN;
      }
      r.temp = kNaN;
      for (int i = 0; i < 2; ++i) have_[i] = next_txyz(i, t_[i], v_[i], vline_[i], diag);
      ++matched_;
      return true;
    }
    const int early = t_[0] < t_[1] ? 0 : 1;
    if (matched_ == 0 && unmatched_++ == 0) {
      first_unmatched_[0] = t_[0];
      first_unmatched_[1] = t_[1];
    }
    char msg[200];
    std::snprintf(msg, sizeof msg, "no %s sample at time %.9g s (next there: %.9g s): line skipped",
                  early == 0 ? "gyroscope" : "accelerometer", t_[early], t_[1 - early]);
    diag.add({in_[early].name(), vline_[early], 1, msg});
    ++skipped_;
    have_[early] = next_txyz(early, t_[early], v_[early], vline_[early], diag);
  }
  for (int i = 0; i < 2; ++i) {
    if (!have_[i]) continue;
    // The other file ended: count what is left unmatched here.
    long left = 0;
    while (have_[i]) {
      ++left;
      have_[i] = next_txyz(i, t_[i], v_[i], vline_[i], diag);
    }
    diag.add({in_[i].name(), 0, 0,
              std::to_string(left) + " line(s) after the other file's last sample: skipped"});
    skipped_ += left;
  }
  if (matched_ == 0 && unmatched_ > 0) {
    char msg[240];
    std::snprintf(msg, sizeof msg,
                  "no timestamp of one file matches the other's (they start at %.9g s and "
                  "%.9g s): imu_tk's two files must be sampled together, one line per sample",
                  first_unmatched_[0], first_unmatched_[1]);
    diag.add({in_[0].name(), 0, 0, msg});
    unmatched_ = 0;
  }
  return false;
}

}  // namespace imucal::cli
