// SPDX-License-Identifier: MIT
// tools/imucal/record.cpp: `imucal record`: a stored calibration record (calibrate --record, or a
// flash slot's bytes), decoded and printed.
#include "imucal/store/record.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "cli.hpp"
#include "imucal/models/accel_model.hpp"
#include "imucal/models/gyro_model.hpp"
#include "outputs.hpp"

namespace imucal::cli {

namespace {

// The file's bytes ("-": stdin), at most `most` of them: a longer file gives most + 1 (and is no
// record; an endless one, /dev/zero, ends there). False, with the reason, if it cannot be read.
bool read_bytes(const std::string& path, std::size_t most, std::vector<std::uint8_t>& out,
                std::string& error) {
  std::FILE* f = path == "-" ? stdin : std::fopen(path.c_str(), "rb");
  if (f == nullptr) {
    error = std::strerror(errno);
    return false;
  }
  out.resize(most + 1);
  std::size_t got = 0, n = 0;
  while (got < out.size() && (n = std::fread(out.data() + got, 1, out.size() - got, f)) > 0)
    got += n;
  out.resize(got);
  const bool ok = std::ferror(f) == 0;
  if (!ok) error = std::strerror(errno);
  if (f != stdin) std::fclose(f);
  return ok;
}

// A stored sensor's parameters and sigmas (float, raw units in), one line each.
template <int N>
void print_stored(std::FILE* out, const char* const* names, const Eigen::Matrix<float, N, 1>& p,
                  const Eigen::Matrix<float, N, 1>& sd, int scale_index, const char* out_unit) {
  std::array<double, static_cast<std::size_t>(N)> v{}, s{};
  for (int k = 0; k < N; ++k) {
    v[static_cast<std::size_t>(k)] = static_cast<double>(p(k));
    s[static_cast<std::size_t>(k)] = static_cast<double>(sd(k));
  }
  print_params(out, names, v.data(), s.data(), N, scale_index, "raw", out_unit);
}

void print_record(const CalibrationRecord& r, const std::string& path, std::size_t length,
                  std::size_t file_size, std::FILE* out) {
  const Calibration<float>& c = r.calibration;
  std::fprintf(out, "imucal record %s: %zu bytes, format version %u, CRC-32 correct\n",
               path.c_str(), length, static_cast<unsigned>(r.version));
  if (file_size > length)
    std::fprintf(out, "         the %zu bytes after it ignored (as in a flash slot)\n",
                 file_size - length);
  std::fprintf(out, "device   id %lu (0x%08lx), sensor id %lu (0x%08lx)\n",
               static_cast<unsigned long>(r.device_id), static_cast<unsigned long>(r.device_id),
               static_cast<unsigned long>(r.sensor_id), static_cast<unsigned long>(r.sensor_id));
  const bool has_accel = (r.parts & kRecordAccel) != 0, has_gyro = (r.parts & kRecordGyro) != 0;
  const bool has_mag = (r.parts & kRecordMag) != 0;
  const bool has_temp = (r.parts & kRecordTemperature) != 0;
  std::string parts;
  for (const auto& [bit, name] :
       {std::make_pair(has_accel, "accelerometer"), std::make_pair(has_gyro, "gyroscope"),
        std::make_pair(has_mag, "magnetometer"), std::make_pair(has_temp, "temperature model")})
    if (bit) parts += (parts.empty() ? "" : ", ") + std::string(name);
  std::fprintf(out, "parts    %s\n", parts.c_str());
  if (r.unknown_sections > 0)
    std::fprintf(out, "         %d section(s) of a newer format skipped\n", r.unknown_sections);
  std::fprintf(out, "rate     %s (measured over the initial rest)\n",
               c.sample_rate_hz > 0 ? fmt("%.2f Hz", static_cast<double>(c.sample_rate_hz)).c_str()
                                    : "unknown");
  std::fprintf(
      out, "temp     %s\n",
      c.has_temperature
          ? fmt("%.2f deg C (mean at calibration)", static_cast<double>(c.temperature_c)).c_str()
          : "unknown");
  if (has_accel) {
    const AccelCalibration<float>& a = c.accel;
    std::fprintf(out, "\naccelerometer  %s\n  %d poses\n", kAccelModel, a.poses);
    print_stored(out, kAccelParamNames, a.params, a.sigma, kScaleX, "m/s^2");
    std::fprintf(out, "  residual |g| - |a_cal| per pose, RMS: %s m/s^2\n",
                 fmt("%.5f", static_cast<double>(a.residual_rms)).c_str());
  }
  if (has_gyro) {
    const GyroCalibration<float>& g = c.gyro;
    std::fprintf(out, "\ngyroscope      %s\n  %d moves, bias %s\n", kGyroModel, g.moves,
                 g.bias_refined ? "refined" : "from the initial rest");
    print_stored(out, kGyroParamNames, g.params, g.sigma, kGyroScaleX, "rad/s");
    const double rms = static_cast<double>(g.residual_rms);
    std::fprintf(out, "  residual per move (sine of the gravity angle), RMS: %s (%s deg)\n",
                 fmt("%.3e", rms).c_str(),
                 fmt("%.3f", std::asin(std::min(rms, 1.0)) * kDeg).c_str());
  }
  if (has_mag) {
    const MagCalibration<float>& m = r.mag;
    std::fprintf(out, "\nmagnetometer   %s\n", kMagModel);
    std::fprintf(out, "  %d samples, quality %s, field %s uT, fit error %s %%, coverage %s %%\n",
                 m.samples, to_string(m.quality),
                 fmt("%.3f", static_cast<double>(m.field_ut)).c_str(),
                 fmt("%.3f", static_cast<double>(m.fit_error_pct)).c_str(),
                 fmt("%.1f", 100.0 * static_cast<double>(m.coverage)).c_str());
    double hv[3], hs[3];
    for (int a = 0; a < 3; ++a) {
      hv[a] = static_cast<double>(m.hard_iron(a));
      hs[a] = static_cast<double>(m.hard_iron_sigma(a));
    }
    std::fprintf(out, "  h   %s  raw (added)\n", vec_pm(hv, hs, "% .6g").c_str());
    for (int i = 0; i < 3; ++i)
      std::fprintf(out, "  S   [% .7e, % .7e, % .7e]  uT/raw\n",
                   static_cast<double>(m.soft_iron(i, 0)), static_cast<double>(m.soft_iron(i, 1)),
                   static_cast<double>(m.soft_iron(i, 2)));
    if (succeeded(m.alignment_status))
      std::fprintf(out, "  aligned to the accelerometer frame: dip %.3f +- %.3f deg\n",
                   static_cast<double>(m.dip_deg), static_cast<double>(m.dip_sigma_deg));
    else
      std::fprintf(out, "  not aligned to the accelerometer frame\n");
  }
  if (has_temp) {
    const TemperatureModel<float>& t = r.temperature;
    std::fprintf(out, "\ntemperature    %s, replacing the constant bias\n", kTemperatureModel);
    std::fprintf(out, "  order %d, T0 %.2f deg C, %d rests over %.2f .. %.2f deg C\n", t.order,
                 static_cast<double>(t.reference_c), t.rests, static_cast<double>(t.min_c),
                 static_cast<double>(t.max_c));
    auto sensor = [&](const char* name, const TemperatureBias<float>& b) {
      if (!succeeded(b.status)) {
        std::fprintf(out, "  %s: not modelled\n", name);
        return;
      }
      std::fprintf(out, "  %s:\n", name);
      auto row = [&](const char* what, const Vector3<float>& v, const Vector3<float>& sd,
                     const char* unit) {
        double x[3], y[3];
        for (int a = 0; a < 3; ++a) {
          x[a] = static_cast<double>(v(a));
          y[a] = static_cast<double>(sd(a));
        }
        std::fprintf(out, "    %s  %s  %s\n", what, vec_pm(x, y, "% .6e").c_str(), unit);
      };
      row("b0", b.b0, b.b0_sigma, "raw");
      row("b1", b.b1, b.b1_sigma, "raw/degC");
      if (t.order >= 2) row("b2", b.b2, b.b2_sigma, "raw/degC^2");
    };
    sensor("accelerometer", t.accel);
    sensor("gyroscope", t.gyro);
  }
  std::fprintf(out, "\nquality  %s\n", to_string(c.quality));
  std::fprintf(out,
               "raw: the unit the recording was calibrated in (the record does not name it); b "
               "is added to the raw reading\n");
}

}  // namespace

int read_record_file(const std::string& path, CalibrationRecord& record, std::string& error,
                     std::size_t* length, std::size_t* file_size) {
  std::vector<std::uint8_t> bytes;
  if (!read_bytes(path, kRecordMaxBytes, bytes, error)) {
    error = "cannot read " + path + ": " + error;
    return 2;
  }
  // A file longer than any record is none; its first bytes still say what they are.
  const bool longer = bytes.size() > kRecordMaxBytes;
  if (longer) bytes.resize(kRecordMaxBytes);
  const std::string size = longer ? "more than " + std::to_string(kRecordMaxBytes) + " bytes"
                                  : std::to_string(bytes.size());
  static const std::uint8_t kNothing = 0;  // decode_record refuses a null pointer
  const std::uint8_t* data = bytes.empty() ? &kNothing : bytes.data();
  std::size_t offset = 0;
  const Status st = decode_record(data, bytes.size(), record, &offset);
  if (st != Status::kOk) {
    error = format_text("%s: %s, at byte %zu (of %s)", path.c_str(), to_string(st), offset,
                        size.c_str());
    return 1;
  }
  if (longer) {
    error = format_text(
        "%s: a record followed by more bytes, %s in all: longer than a flash slot "
        "(kRecordMaxBytes), not a record's file",
        path.c_str(), size.c_str());
    return 1;
  }
  if (length != nullptr) *length = static_cast<std::size_t>(bytes[6] | (bytes[7] << 8));
  if (file_size != nullptr) *file_size = bytes.size();
  return 0;
}

int record_command(const std::vector<std::string>& args) {
  if (args.size() != 1 || (args[0].size() > 1 && args[0][0] == '-')) {
    std::fprintf(stderr,
                 "imucal record: give one record file (or - for stdin): imucal record FILE\n");
    return 2;
  }
  const std::string& path = args[0];
  CalibrationRecord record;
  std::string error;
  std::size_t length = 0, file_size = 0;
  const int code = read_record_file(path, record, error, &length, &file_size);
  if (code != 0) {
    std::fprintf(stderr, "imucal: %s\n", error.c_str());
    return code;
  }
  print_record(record, path, length, file_size, stdout);
  return 0;
}

}  // namespace imucal::cli
