// SPDX-License-Identifier: MIT
// tools/imucal/options.cpp: the calibrate/report (and noise, field) options, from the command line
// and from
// `# imucal: key=value` comments in the input (the command line wins).
#include <charconv>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <string_view>

#include "cli.hpp"

namespace imucal::cli {

namespace {

enum class Where { kAnywhere, kCommandLineOnly };

struct Key {
  const char* name;
  bool flag;  // takes no value
  Where where;
};

// Settings that describe the data may come from the file; outputs and modes only from the
// command line.
constexpr Key kKeys[] = {
    {"format", false, Where::kCommandLineOnly},
    {"time-unit", false, Where::kAnywhere},
    {"accel-unit", false, Where::kAnywhere},
    {"gyro-unit", false, Where::kAnywhere},
    {"accel-lsb-per-g", false, Where::kAnywhere},
    {"accel-zero", false, Where::kAnywhere},
    {"gyro-lsb-per-dps", false, Where::kAnywhere},
    {"gravity", false, Where::kAnywhere},
    {"initial-rest", false, Where::kAnywhere},
    {"min-rest", false, Where::kAnywhere},
    {"accel-range", false, Where::kAnywhere},
    {"gyro-range", false, Where::kAnywhere},
    {"rate", false, Where::kAnywhere},
    {"columns", false, Where::kAnywhere},
    {"poses", true, Where::kCommandLineOnly},
    {"mag-unit", false, Where::kAnywhere},
    {"mag-lsb-per-ut", false, Where::kAnywhere},
    {"mag-field-range", false, Where::kAnywhere},
    {"mag-min-coverage", false, Where::kAnywhere},
    {"temp-order", false, Where::kAnywhere},
    {"temp-min-span", false, Where::kAnywhere},
    {"no-mag-align", true, Where::kCommandLineOnly},
    {"refine-gyro-bias", true, Where::kCommandLineOnly},
    {"double", true, Where::kCommandLineOnly},
    {"memory", false, Where::kCommandLineOnly},
    {"quiet", true, Where::kCommandLineOnly},
    {"json", false, Where::kCommandLineOnly},
    {"header", false, Where::kCommandLineOnly},
    {"record", false, Where::kCommandLineOnly},
    {"device-id", false, Where::kCommandLineOnly},
    {"sensor-id", false, Where::kCommandLineOnly},
    {"output", false, Where::kCommandLineOnly},
    {"svg", false, Where::kCommandLineOnly},
    {"truth", false, Where::kCommandLineOnly},
    {"kalibr", false, Where::kCommandLineOnly},
    {"prior", false, Where::kCommandLineOnly},
    {"gyro-noise", false, Where::kAnywhere},
    {"accel-noise", false, Where::kAnywhere},
    {"gyro-zero", false, Where::kAnywhere},
    {"at-temperature", false, Where::kCommandLineOnly},
    {"rest-piece", false, Where::kAnywhere},
};

const Key* find_key(std::string_view name) {
  for (const Key& k : kKeys)
    if (name == k.name) return &k;
  return nullptr;
}

// The physical range of each numeric option (the help states them): a value beyond it is a
// usage error, never a calibration run with it.
struct Bounds {
  const char* key;
  double lo, hi;
  const char* unit;
  const char* what;  // what a value beyond them is not
};
constexpr Bounds kBounds[] = {
    {"accel-lsb-per-g", 1, 1e8, "counts per g", "an accelerometer's scale"},
    {"accel-zero", -2147483648.0, 2147483647.0, "counts", "a 32-bit reading"},
    {"gyro-lsb-per-dps", 0.01, 1e7, "counts per deg/s", "a gyroscope's scale"},
    {"mag-lsb-per-ut", 0.01, 1e6, "counts per uT", "a magnetometer's scale"},
    {"gravity", 9.7, 9.9, "m/s^2", "a gravity on Earth"},
    {"initial-rest", 0.1, 3600, "s", "a still period to start from"},
    {"min-rest", 0.05, 600, "s", "a pose's still period"},
    {"rate", 0.1, 100000, "Hz", "an IMU's sample rate"},
    {"temp-min-span", 0.1, 200, "deg C", "a span of temperatures"},
    {"memory", 4, 1048576, "MB", "a memory to keep samples in"},
    {"gyro-noise", 1e-9, 1, "rad/s", "a gyroscope's noise per sample"},
    {"accel-noise", 1e-9, 10, "m/s^2", "an accelerometer's noise per sample"},
    {"gyro-zero", -2147483648.0, 2147483647.0, "counts", "a 32-bit reading"},
    {"at-temperature", -60, 150, "deg C", "a temperature the stream checks accept"},
    {"rest-piece", 1, 600, "s", "a piece of a rest"},
};

// `value` of option `key` within its Bounds (a key without bounds: any value).
bool within_bounds(const std::string& key, const std::string& value, double v, std::string& error) {
  for (const Bounds& b : kBounds) {
    if (key != b.key) continue;
    if (v >= b.lo && v <= b.hi) return true;
    char range[64];
    std::snprintf(range, sizeof range, "%.9g .. %.9g", b.lo, b.hi);
    error = "--" + key + ": " + value + " is outside " + range + " " + b.unit + ": not " + b.what;
    return false;
  }
  return true;
}

// A number within its option's bounds.
bool bounded(const std::string& key, const std::string& value, double& out, std::string& error) {
  double v = kNaN;
  if (!parse_number(value, v) || !std::isfinite(v)) {
    error = "--" + key + ": expected a number, found '" + value + "'";
    return false;
  }
  if (!within_bounds(key, value, v, error)) return false;
  out = v;
  return true;
}

// "LO,HI": the full scale in raw units, LO < HI (blanks around either number allowed).
bool range(const std::string& key, const std::string& value, double& lo, double& hi,
           std::string& error, const char* unit = "raw units") {
  auto trimmed = [](std::string_view s) {
    while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
    while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
    return s;
  };
  const std::size_t comma = value.find(',');
  double a = kNaN, b = kNaN;
  if (comma == std::string::npos ||
      !parse_number(trimmed(std::string_view(value).substr(0, comma)), a) ||
      !parse_number(trimmed(std::string_view(value).substr(comma + 1)), b) || !std::isfinite(a) ||
      !std::isfinite(b) || !(a < b)) {
    error = "--" + key + ": expected LO,HI (" + unit + ", LO < HI), found '" + value + "'";
    return false;
  }
  lo = a;
  hi = b;
  return true;
}

// An unsigned 32-bit id: decimal, or hexadecimal after 0x.
bool id(const std::string& key, const std::string& value, std::uint32_t& out, std::string& error) {
  const bool hex = value.size() > 2 && value[0] == '0' && (value[1] == 'x' || value[1] == 'X');
  const char* begin = value.data() + (hex ? 2 : 0);
  const char* end = value.data() + value.size();
  std::uint64_t v = 0;
  const auto r = std::from_chars(begin, end, v, hex ? 16 : 10);
  if (begin == end || r.ec != std::errc() || r.ptr != end || v > 0xFFFFFFFFu) {
    error = "--" + key + ": expected an unsigned 32-bit number (decimal or 0x hex), found '" +
            value + "'";
    return false;
  }
  out = static_cast<std::uint32_t>(v);
  return true;
}

bool apply(const std::string& key, const std::string& value, Options& o, std::string& error) {
  auto choice = [&](std::initializer_list<const char*> names, int& index) {
    index = 0;
    for (const char* n : names) {
      if (value == n) return true;
      ++index;
    }
    error = "--" + key + ": expected one of";
    for (const char* n : names) error += std::string(" ") + n;
    error += ", found '" + value + "'";
    return false;
  };
  int i = 0;
  if (key == "format") {
    if (!choice({"auto", "csv", "imutk"}, i)) return false;
    o.format = static_cast<Format>(i);
  } else if (key == "time-unit") {
    if (!choice({"s", "ms", "us"}, i)) return false;
    o.time_unit = static_cast<TimeUnit>(i);
  } else if (key == "accel-unit") {
    if (!choice({"counts", "g", "mps2"}, i)) return false;
    o.accel_unit = static_cast<AccelUnit>(i);
  } else if (key == "gyro-unit") {
    if (!choice({"counts", "dps", "rads"}, i)) return false;
    o.gyro_unit = static_cast<GyroUnit>(i);
  } else if (key == "accel-lsb-per-g") {
    return bounded(key, value, o.accel_lsb_per_g, error);
  } else if (key == "accel-zero") {
    return bounded(key, value, o.accel_zero, error);
  } else if (key == "gyro-lsb-per-dps") {
    return bounded(key, value, o.gyro_lsb_per_dps, error);
  } else if (key == "gravity") {
    return bounded(key, value, o.gravity, error);
  } else if (key == "initial-rest") {
    return bounded(key, value, o.initial_rest, error);
  } else if (key == "min-rest") {
    return bounded(key, value, o.min_rest, error);
  } else if (key == "accel-range") {
    return range(key, value, o.accel_min, o.accel_max, error);
  } else if (key == "gyro-range") {
    return range(key, value, o.gyro_min, o.gyro_max, error);
  } else if (key == "rate") {
    return bounded(key, value, o.nominal_rate_hz, error);
  } else if (key == "memory") {
    return bounded(key, value, o.memory_mb, error);
  } else if (key == "columns") {
    std::vector<Field> names;
    split_fields(value, names);
    if (value.empty() || names.empty()) {
      error = "--columns: expected the column names in the file's order, e.g. ax,ay,az,gx,gy,gz";
      return false;
    }
    o.columns = value;
  } else if (key == "poses") {
    o.pose_file = true;
  } else if (key == "mag-unit") {
    if (!choice({"counts", "ut", "nt", "gauss"}, i)) return false;
    o.mag_unit = static_cast<MagUnit>(i);
  } else if (key == "mag-lsb-per-ut") {
    return bounded(key, value, o.mag_lsb_per_ut, error);
  } else if (key == "mag-field-range") {
    double lo = kNaN, hi = kNaN;
    if (!range(key, value, lo, hi, error, "uT")) return false;
    if (!(lo > 0) || hi > 1000) {
      error =
          "--mag-field-range: expected LO,HI in uT with 0 < LO < HI <= 1000 (the Earth's field "
          "is 22 .. 67 uT), found '" +
          value + "'";
      return false;
    }
    o.mag_field_min = lo;
    o.mag_field_max = hi;
  } else if (key == "mag-min-coverage") {
    double f = kNaN;
    if (!parse_number(value, f) || !(f > 0 && f <= 1)) {
      error = "--mag-min-coverage: expected a fraction in (0, 1], found '" + value + "'";
      return false;
    }
    o.mag_min_coverage = f;
  } else if (key == "no-mag-align") {
    o.mag_align = false;
  } else if (key == "temp-order") {
    if (!choice({"1", "2"}, i)) return false;
    o.temp_order = i + 1;
  } else if (key == "temp-min-span") {
    return bounded(key, value, o.temp_min_span, error);
  } else if (key == "refine-gyro-bias") {
    o.refine_gyro_bias = true;
  } else if (key == "double") {
    o.use_double = true;
  } else if (key == "quiet") {
    o.quiet = true;
  } else if (key == "json") {
    o.json_path = value;
  } else if (key == "header") {
    o.header_path = value;
  } else if (key == "record") {
    o.record_path = value;
  } else if (key == "device-id") {
    return id(key, value, o.device_id, error);
  } else if (key == "sensor-id") {
    return id(key, value, o.sensor_id, error);
  } else if (key == "output" || key == "svg") {
    o.svg_path = value;
  } else if (key == "truth") {
    o.truth_path = value;
  } else if (key == "kalibr") {
    o.kalibr_path = value;
  } else if (key == "prior") {
    o.prior_path = value;
  } else if (key == "gyro-noise") {
    return bounded(key, value, o.gyro_noise, error);
  } else if (key == "accel-noise") {
    return bounded(key, value, o.accel_noise, error);
  } else if (key == "gyro-zero") {
    return bounded(key, value, o.gyro_zero, error);
  } else if (key == "rest-piece") {
    return bounded(key, value, o.rest_piece, error);
  } else if (key == "at-temperature") {
    return bounded(key, value, o.at_temperature, error);
  }
  return true;
}

}  // namespace

bool parse_calibrate_options(const std::vector<std::string>& args, Options& o, std::string& error) {
  bool files_only = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (files_only || a == "-" || a.size() < 2 || a[0] != '-') {
      o.files.push_back(a);
      continue;
    }
    if (a == "--") {
      files_only = true;
      continue;
    }
    std::string key = a == "-o" ? "output" : a.substr(a[1] == '-' ? 2 : 1);
    std::string value;
    bool has_value = false;
    const std::size_t eq = key.find('=');
    if (eq != std::string::npos) {
      value = key.substr(eq + 1);
      key.resize(eq);
      has_value = true;
    }
    const Key* k = find_key(key);
    if (k == nullptr) {
      error = "unknown option '" + a + "' (imucal help lists them)";
      return false;
    }
    if (!k->flag && !has_value) {
      if (i + 1 >= args.size()) {
        error = "option --" + key + " needs a value";
        return false;
      }
      value = args[++i];
    }
    if (!apply(key, value, o, error)) return false;
    o.command_line_keys.push_back(key);
  }
  return true;
}

bool apply_file_settings(const std::vector<FileSetting>& settings, Options& o, std::string& error) {
  for (const FileSetting& s : settings) {
    const std::string where = s.file + ":" + std::to_string(s.line);
    const Key* k = find_key(s.key);
    if (k == nullptr || k->where != Where::kAnywhere) {
      error = where + ": '" + s.key + "' cannot be set in a file (data settings only)";
      return false;
    }
    bool overridden = false;
    for (const std::string& c : o.command_line_keys) overridden = overridden || c == s.key;
    if (overridden) continue;
    std::string e;
    if (!apply(s.key, s.value, o, e)) {
      error = where + ": " + e;
      return false;
    }
    o.from_files.push_back(s.key + "=" + s.value + " (" + where + ")");
  }
  return true;
}

}  // namespace imucal::cli
