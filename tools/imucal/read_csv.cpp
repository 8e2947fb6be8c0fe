// SPDX-License-Identifier: MIT
// tools/imucal/read_csv.cpp: the imucal CSV reader: the columns named by a header line or given,
// then one sample per line, field by field only where the one-pass read declines a line.
#include <cmath>
#include <string>
#include <vector>

#include "format_reader.hpp"

namespace imucal::cli {

namespace {

bool is_digit(char c) { return c >= '0' && c <= '9'; }

// A line of `columns` fields separated by ';' whose numbers have a decimal comma ("0,5;9,81"),
// as a spreadsheet writes them in a locale with a decimal comma.
bool decimal_commas(std::string_view line, std::size_t columns) {
  std::size_t fields = 1;
  bool comma = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    if (line[i] == ';') ++fields;
    if (line[i] == ',' && i > 0 && i + 1 < line.size() && is_digit(line[i - 1]) &&
        is_digit(line[i + 1]))
      comma = true;
  }
  return comma && fields == columns;
}

}  // namespace

bool CsvReader::start(Diagnostics& diag) {
  LineReader& in = in_[0];
  if (files_ != 1) {
    diag.add({in.name(), 0, 0, "the CSV format reads one file (or - for stdin)"});
    return false;
  }
  std::string_view line;
  if (!content_line(in, line, diag)) {
    if (in.ended() || in.failed()) return false;  // said why
    const std::string expected = std::string("expected a header line naming the columns (") +
                                 kRequiredColumns + "; optional temp, mx, my, mz)";
    diag.add({in.name(), 0, 0,
              in.line_number() == 0 ? "empty: " + expected
              : in.long_lines() > 0
                  ? "no header line: every line was longer than " + std::to_string(in.max_line()) +
                        " characters (skipped)"
                  : "no header line, only comments and blank lines: " + expected});
    return false;
  }
  split_fields(line, fields_);
  double number = 0;
  const bool numeric = !fields_.empty() && parse_number(fields_[0].text, number);
  // The names: --columns, else a `# imucal: columns=` comment, else the header line, else six
  // numeric columns are taken as ax ay az gx gy gz.
  std::string given = given_;
  layout_.source = "--columns";
  if (given.empty()) {
    for (const FileSetting& s : settings_)
      if (s.key == "columns") given = s.value;
    layout_.source = "columns= comment";
  }
  if (given.empty() && numeric && !headerless_.empty()) {
    given = headerless_;
    layout_.source = "assumed";
  }
  std::vector<std::string> names;
  if (!given.empty()) {
    std::vector<Field> parts;
    split_fields(given, parts);
    for (const Field& f : parts) names.push_back(lower(f.text));
  } else if (!numeric) {
    layout_.source = "header";
    for (const Field& f : fields_) names.push_back(lower(f.text));
  } else if (fields_.size() == 6) {
    layout_.source = "assumed";
    names = {"ax", "ay", "az", "gx", "gy", "gz"};
  } else {
    std::string msg = "no header line naming the columns (found numbers, " +
                      std::to_string(fields_.size()) +
                      " per line): give --columns NAMES in the file's order (t, ax, ay, az, gx, "
                      "gy, gz, temp, mx, my, mz; - skips a column), e.g. --columns ";
    if (fields_.size() == 7) {
      msg += "t,ax,ay,az,gx,gy,gz (or ax,ay,az,gx,gy,gz,temp)";
    } else if (fields_.size() == 4) {
      msg +=
          "t,ax,ay,az (an accelerometer alone) or t,mx,my,mz (a magnetometer alone); a pair of "
          "imu_tk files (t x y z): give the accelerometer file and the gyroscope file";
    } else if (fields_.size() == 3) {
      msg += "ax,ay,az (one pose per line; or --poses) or mx,my,mz (a magnetometer alone)";
    } else {
      msg += "t,ax,ay,az,gx,gy,gz";
    }
    // A header too long to be read was skipped before these numbers: say so first.
    if (in.long_lines() > 0)
      msg = "the line(s) before line " + std::to_string(in.line_number()) +
            " were too long to be a header (skipped); " + msg;
    report(in, 1, msg, diag);
    return false;
  }
  std::string error;
  if (!cols_.name(names, layout_.source != "header", layout_, error)) {
    report(in, 0, error, diag);
    return false;
  }
  // With the names given, a first line that is not numbers is a header: skipped. One of
  // numbers is the first sample.
  if (layout_.source != "header" && numeric) {
    pending_ = std::string(line);
    has_pending_ = true;
  }
  data_started_ = true;
  return true;
}

bool CsvReader::next(Record& r, Diagnostics& diag) {
  LineReader& in = in_[0];
  std::string_view line;
  for (;;) {
    if (has_pending_) {  // the first line of a file without a header
      has_pending_ = false;
      line = pending_;
    } else if (!content_line(in, line, diag)) {
      break;
    }
    // Every field a finite number (the common line): read in one pass; else field by field.
    constexpr std::size_t kFast = 16;
    double x[kFast];
    const bool plain = cols_.count <= kFast && plain_numbers(line, x, cols_.count);
    if (!plain) {
      split_fields(line, fields_);
      if (fields_.size() != cols_.count) {
        ++skipped_;
        const bool commas = decimal_commas(line, cols_.count);
        if (commas && ++decimal_comma_lines_ > kListedAlike) continue;  // concluded below
        report(in, 0,
               "expected " + std::to_string(cols_.count) + " fields (" + layout_.names +
                   "), found " + std::to_string(fields_.size()) + ": line skipped" +
                   (commas ? " (decimal commas? ';' separates " + std::to_string(cols_.count) +
                                 " fields)"
                           : ""),
               diag);
        if (commas && decimal_comma_lines_ == kListedAlike)
          report(in, 0,
                 "decimal commas: these lines have " + std::to_string(cols_.count) +
                     " fields between ';' and numbers like 0,5: use '.' as the decimal point "
                     "(the locale of the spreadsheet or logger that wrote the file); further "
                     "such lines are skipped without a message",
                 diag);
        continue;
      }
    }
    bool ok = true;
    auto get = [&](int col, const char* name, double& out) {
      if (ok && col >= 0) {
        if (plain)
          out = x[col];
        else
          ok = number_field(in, fields_[static_cast<std::size_t>(col)], name, out, diag);
      }
    };
    static constexpr const char* kAcc[3] = {"ax", "ay", "az"};
    static constexpr const char* kGyro[3] = {"gx", "gy", "gz"};
    static constexpr const char* kMag[3] = {"mx", "my", "mz"};
    double t = 0;
    get(cols_.t, "t", t);
    for (int a = 0; a < 3; ++a) {
      r.acc[a] = r.gyro[a] = kNaN;  // NaN: no such sensor in the input
      get(cols_.acc[a], kAcc[a], r.acc[a]);
      get(cols_.gyro[a], kGyro[a], r.gyro[a]);
    }
    // The optional columns may be empty or NaN (a magnetometer slower than the IMU, a
    // temperature read now and then): no reading there, the line is still good.
    auto optional = [&](int col, const char* name, double& out) {
      out = kNaN;
      if (!ok || col < 0) return;
      if (plain) {
        out = x[col];
        return;
      }
      const Field& f = fields_[static_cast<std::size_t>(col)];
      if (f.text.empty()) return;
      double v = 0;
      if (parse_number(f.text, v) && std::isnan(v)) return;
      ok = number_field(in, f, name, out, diag);
    };
    optional(cols_.temp, "temp", r.temp);
    for (int a = 0; a < 3; ++a) optional(cols_.mag[a], kMag[a], r.mag[a]);
    // A magnetometer reading is all three axes or none.
    if (!(std::isfinite(r.mag[0]) && std::isfinite(r.mag[1]) && std::isfinite(r.mag[2])))
      r.mag[0] = r.mag[1] = r.mag[2] = kNaN;
    if (cols_.t >= 0) {
      r.t = t * time_scale_;
      if (ok && have_last_ && !(r.t > last_t_)) {  // not after the previous one: reported
        if (plain) split_fields(line, fields_);    // where the time's column is
        ok = after_previous(
            r.t, have_last_, last_t_, in,
            static_cast<long>(fields_[static_cast<std::size_t>(cols_.t)].offset + 1), diag);
      }
    } else {
      // No time column: the good samples are evenly spaced at the rate given.
      r.t = untimed_time();
    }
    if (ok) {
      taken(r.t);
      return true;
    }
    ++skipped_;
  }
  return false;
}

}  // namespace imucal::cli
