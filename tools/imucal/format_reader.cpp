// SPDX-License-Identifier: MIT
// tools/imucal/format_reader.cpp: what the format readers share: the time of a sample, the
// columns' names, the text files' lines, comments and fields.
#include "format_reader.hpp"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <tuple>
#include <utility>

namespace imucal::cli {

std::string lower(std::string_view s) {
  std::string r(s);
  for (char& c : r) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return r;
}

std::string quoted(std::string_view s) {
  constexpr std::size_t kShown = 24;
  std::string r = "'";
  for (std::size_t i = 0; i < s.size() && i < kShown; ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (std::isprint(c)) {
      r += static_cast<char>(c);
    } else {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      r += hex;
    }
  }
  if (s.size() > kShown) r += "...";
  return r + "'";
}

namespace {

// "# imucal: key=value key=value" -> settings, separated by blanks, commas or semicolons. A
// piece without '=' continues the previous value after a comma: "accel-range=0,65535".
// False if the comment is not a settings comment. With out == nullptr it only tells.
bool parse_settings(std::string_view line, const LineReader& in, std::vector<FileSetting>* out) {
  std::string_view rest = line.substr(1);
  while (!rest.empty() && (rest.front() == ' ' || rest.front() == '\t')) rest.remove_prefix(1);
  constexpr std::string_view kTag = "imucal:";
  if (rest.substr(0, kTag.size()) != kTag) return false;
  if (out == nullptr) return true;
  rest.remove_prefix(kTag.size());
  auto separator = [](char c) { return c == ' ' || c == '\t' || c == ',' || c == ';'; };
  const std::size_t first = out->size();
  std::size_t i = 0;
  while (i < rest.size()) {
    while (i < rest.size() && separator(rest[i])) ++i;
    if (i >= rest.size()) break;
    const std::size_t start = i;
    while (i < rest.size() && !separator(rest[i])) ++i;
    const std::string_view piece = rest.substr(start, i - start);
    const std::size_t eq = piece.find('=');
    if (eq == std::string_view::npos && out->size() > first) {
      out->back().value += "," + std::string(piece);
      continue;
    }
    FileSetting s;
    s.key = std::string(piece.substr(0, eq));
    s.value = eq == std::string_view::npos ? "" : std::string(piece.substr(eq + 1));
    s.file = in.name();
    s.line = in.line_number();
    out->push_back(std::move(s));
  }
  return true;
}

constexpr const char* kAxisNames[3] = {"x", "y", "z"};

}  // namespace

// --- FormatReader ----------------------------------------------------------------------------

void FormatReader::set_time_unit(TimeUnit time) {
  time_scale_ = time == TimeUnit::kSeconds ? 1.0 : time == TimeUnit::kMilliseconds ? 1e-3 : 1e-6;
}

std::string FormatReader::time_not_after(double t, double previous) {
  char msg[120];
  std::snprintf(msg, sizeof msg, "time %.9g s is not after the previous sample's %.9g s", t,
                previous);
  return msg;
}

double FormatReader::untimed_time() const {
  return rate_hz_ > 0 ? static_cast<double>(index_) / rate_hz_ : static_cast<double>(index_);
}

void FormatReader::taken(double t) {
  have_last_ = true;
  last_t_ = t;
  ++index_;
}

// --- ColumnMap -------------------------------------------------------------------------------

bool ColumnMap::name(const std::vector<std::string>& names, bool strict, InputLayout& layout,
                     std::string& error) {
  count = names.size();
  for (std::size_t c = 0; c < names.size(); ++c) {
    const std::string& n = names[c];
    const int ci = static_cast<int>(c);
    int* slot = nullptr;
    if (n == "t" || n == "time") slot = &t;
    if (n == "temp" || n == "temperature") slot = &temp;
    for (int a = 0; a < 3; ++a) {
      if (n == std::string("a") + kAxisNames[a]) slot = &acc[a];
      if (n == std::string("g") + kAxisNames[a] || n == std::string("w") + kAxisNames[a])
        slot = &gyro[a];
      if (n == std::string("m") + kAxisNames[a]) slot = &mag[a];
    }
    if (slot == nullptr) {
      if (strict && n != "-" && n != "_") {
        error = "--columns: unknown column name " + quoted(n) +
                " (known: t, ax, ay, az, gx, gy, gz, temp, mx, my, mz; - or _ skips a column)";
        return false;
      }
      continue;  // unknown columns are ignored
    }
    if (*slot >= 0) {
      error = "column " + quoted(n) + " named twice";
      return false;
    }
    *slot = ci;
  }
  // A sensor is all three axes or none.
  for (const auto& [cols, prefix, what] :
       {std::make_tuple(acc, "a", "accelerometer"), std::make_tuple(gyro, "g", "gyroscope"),
        std::make_tuple(mag, "m", "magnetometer")}) {
    const int n = (cols[0] >= 0) + (cols[1] >= 0) + (cols[2] >= 0);
    if (n == 0 || n == 3) continue;
    std::string missing;
    for (int a = 0; a < 3; ++a)
      if (cols[a] < 0)
        missing += (missing.empty() ? "" : ", ") + std::string(prefix) + kAxisNames[a];
    error = std::string("the ") + what + " needs all three axes: no column " + missing +
            " (expected " + kRequiredColumns + ", or a sensor alone)";
    return false;
  }
  if (acc[0] < 0 && mag[0] < 0) {
    error = std::string(
                "no column ax, ay, az (accelerometer) nor mx, my, mz (magnetometer): expected ") +
            kRequiredColumns + ", or t, mx, my, mz for a magnetometer alone";
    return false;
  }
  if (gyro[0] >= 0 && acc[0] < 0) {
    error =
        "gx, gy, gz without ax, ay, az: the gyroscope is calibrated against gravity, it needs "
        "the accelerometer";
    return false;
  }
  layout.accel = acc[0] >= 0;
  layout.gyro = gyro[0] >= 0;
  layout.mag = mag[0] >= 0;
  layout.temp = temp >= 0;
  layout.time = t >= 0;
  layout.names.clear();
  for (std::size_t c = 0; c < names.size(); ++c)
    layout.names += (c ? ", " : "") + (names[c].empty() ? std::string("-") : names[c]);
  return true;
}

// --- TextReader ------------------------------------------------------------------------------

void TextReader::report(const LineReader& in, long column, std::string message, Diagnostics& diag) {
  diag.add({in.name(), in.line_number(), column, std::move(message)});
}

bool TextReader::content_line(LineReader& in, std::string_view& line, Diagnostics& diag) {
  while (in.next(line, diag)) {
    std::size_t i = 0;
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    if (i == line.size()) continue;
    if (line[i] == '#') {
      if (!data_started_) {
        parse_settings(line.substr(i), in, &settings_);
      } else if (parse_settings(line.substr(i), in, nullptr)) {
        report(in, static_cast<long>(i + 1),
               "settings after the data started are ignored: put `# imucal:` lines before the "
               "header (or the first sample)",
               diag);
      }
      continue;
    }
    return true;
  }
  return false;
}

bool TextReader::number_field(const LineReader& in, const Field& f, const char* name, double& out,
                              Diagnostics& diag) {
  if (!parse_number(f.text, out)) {
    report(in, static_cast<long>(f.offset + 1),
           std::string("expected a number for ") + name + ", found " + quoted(f.text) +
               ": line skipped",
           diag);
    return false;
  }
  if (!std::isfinite(out)) {
    report(in, static_cast<long>(f.offset + 1),
           std::string(name) + " is not finite (" + std::string(f.text) + "): line skipped", diag);
    return false;
  }
  return true;
}

bool TextReader::after_previous(double t, bool have, double previous, const LineReader& in,
                                long column, Diagnostics& diag) {
  if (!have || t > previous) return true;
  report(in, column, time_not_after(t, previous) + ": line skipped", diag);
  return false;
}

bool TextReader::failed() const {
  for (int i = 0; i < files_; ++i)
    if (in_[i].failed()) return true;
  return false;
}

double TextReader::fraction_read() const {
  std::uint64_t done = 0, total = 0;
  for (int i = 0; i < files_; ++i) {
    if (in_[i].size() == 0) return 0;
    done += in_[i].bytes_read();
    total += in_[i].size();
  }
  return total == 0 ? 0 : static_cast<double>(done) / static_cast<double>(total);
}

}  // namespace imucal::cli
