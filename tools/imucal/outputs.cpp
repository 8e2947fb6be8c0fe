// SPDX-License-Identifier: MIT
// tools/imucal/outputs.cpp: what `imucal calibrate` writes: the summary, the JSON, the C header,
// the comparison with a truth file; and the text and file helpers the commands share.
#include "outputs.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <new>
#include <nlohmann/json.hpp>
#include <sstream>
#include <utility>
#include <vector>

#include "cli.hpp"
#include "imucal/models/accel_model.hpp"
#include "imucal/models/gyro_model.hpp"
#include "imucal/models/mag_model.hpp"

namespace imucal::cli {

const char* const kAccelModel =
    "a_cal = T K (a_raw + b), T = [[1, -alpha_yz, alpha_zy], [0, 1, -alpha_zx], [0, 0, 1]], "
    "K = diag(s_x, s_y, s_z)";
const char* const kGyroModel =
    "w_cal = T K (w_raw + b), T = [[1, -gamma_yz, gamma_zy], [gamma_xz, 1, -gamma_zx], "
    "[-gamma_xy, gamma_yx, 1]], K = diag(s_x, s_y, s_z)";
const char* const kMagModel =
    "m_cal = S (m_raw + h), S 3x3 (uT per raw unit; symmetric unless aligned to the "
    "accelerometer frame: then R S_sym), h the hard iron";
const char* const kMagConvention =
    "h is ADDED to the raw reading, in raw units (a subtracted offset is -h); |m_cal| is the "
    "local field strength in uT; after the alignment m_cal is in the accelerometer's frame";
const char* const kTemperatureModel =
    "b(T) = b0 + b1 (T - T0) + b2 (T - T0)^2 (b2 = 0 for order 1), T in deg C";
const char* const kTemperatureConvention =
    "b(T) replaces the constant ADDED bias b of the sensor's model (a_cal = T K (a_raw + b(T)), "
    "the same for the gyroscope), raw units; valid over the rests' temperature range";
const char* const kConvention =
    "b is ADDED to the raw reading, in raw units (imu_tk and x-io Fusion subtract an offset: "
    "offset = -b); s converts raw units to m/s^2 (accelerometer) or rad/s (gyroscope); "
    "misalignments in rad";

const char* accel_unit_name(AccelUnit u) {
  return u == AccelUnit::kCounts ? "counts" : u == AccelUnit::kG ? "g" : "m/s^2";
}
const char* gyro_unit_name(GyroUnit u) {
  return u == GyroUnit::kCounts ? "counts" : u == GyroUnit::kDps ? "deg/s" : "rad/s";
}
const char* mag_unit_name(MagUnit u) {
  switch (u) {
    case MagUnit::kCounts:
      return "counts";
    case MagUnit::kUt:
      return "uT";
    case MagUnit::kNt:
      return "nT";
    case MagUnit::kGauss:
      return "gauss";
  }
  return "?";
}
const char* time_unit_name(TimeUnit u) {
  return u == TimeUnit::kSeconds ? "s" : u == TimeUnit::kMilliseconds ? "ms" : "us";
}

namespace {

using Json = nlohmann::ordered_json;

// NaN and infinity become JSON null.
Json number(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

void print_mag_summary(const Run& run, const Options& o, std::FILE* out) {
  const MagResult& m = run.mag;
  if (!m.present) {
    std::fprintf(out, "\nmagnetometer   none (%s)\n", m.status.c_str());
    return;
  }
  const char* mu = mag_unit_name(o.mag_unit);
  std::fprintf(out, "\nmagnetometer   %s\n", kMagModel);
  std::fprintf(out, "  status: %s; %ld readings, %d held (one per direction cell), %d fitted, %s\n",
               m.status.c_str(), m.readings, static_cast<int>(m.held.size()), m.samples,
               plural(m.iterations, "iteration", "iterations").c_str());
  if (m.readings == 0) return;
  std::fprintf(out,
               "  coverage %s %% of the directions (needs %.0f %%), field %s uT (accepted %g .. "
               "%g), fit error %s %%\n",
               fmt("%.1f", 100.0 * m.coverage).c_str(), 100.0 * o.mag_min_coverage,
               fmt("%.3f", m.field_ut).c_str(), o.mag_field_min, o.mag_field_max,
               fmt("%.3f", m.fit_error_pct).c_str());
  if (!m.ok) {
    std::fprintf(out, "  NOT calibrated: %s\n", m.status.c_str());
    return;
  }
  std::fprintf(out, "  quality %s, nominal %g uT per %s\n", m.quality.c_str(), m.unit_ut, mu);
  std::fprintf(out, "  h   %s  %s (added)\n",
               vec_pm(m.hard_iron, m.hard_iron_sigma, "% .6g").c_str(), mu);
  for (int r = 0; r < 3; ++r)
    std::fprintf(out, "  S%s [% .7e, % .7e, % .7e]  uT/%s\n", r == 0 ? "  " : "  ",
                 m.soft_iron[r][0], m.soft_iron[r][1], m.soft_iron[r][2], mu);
  std::fprintf(out,
               "  sigma of the symmetric S (S00 S11 S22 S01 S02 S12): %.2e %.2e %.2e %.2e %.2e "
               "%.2e\n",
               m.soft_iron_sigma[0], m.soft_iron_sigma[1], m.soft_iron_sigma[2],
               m.soft_iron_sigma[3], m.soft_iron_sigma[4], m.soft_iron_sigma[5]);
  if (m.aligned) {
    const double angle = std::sqrt(m.rotation[0] * m.rotation[0] + m.rotation[1] * m.rotation[1] +
                                   m.rotation[2] * m.rotation[2]);
    std::fprintf(out,
                 "  aligned to the accelerometer frame over %d rests: dip %.3f +- %.3f deg, "
                 "rotation %.3f deg (rotation vector %s rad)\n",
                 m.rests, m.dip_deg, m.dip_sigma_deg, angle * kDeg,
                 vec_pm(m.rotation, m.rotation_sigma, "% .4f").c_str());
  } else {
    std::fprintf(out, "  not aligned to the accelerometer frame (%d rests): %s\n", m.rests,
                 m.alignment_status.c_str());
  }
}

void print_temperature_summary(const Run& run, const Options& o, std::FILE* out) {
  const TemperatureResult& t = run.temperature;
  if (!t.present) {
    std::fprintf(out, "\ntemperature    no model (%s)\n", t.status.c_str());
    return;
  }
  std::fprintf(out, "\ntemperature    %s, replacing the constant bias\n", kTemperatureModel);
  if (t.status != "ok" && !std::isfinite(t.reference_c)) {
    std::fprintf(out, "  no model: %s (%zu rests with a temperature)\n", t.status.c_str(),
                 t.rest_list.size());
    return;
  }
  std::fprintf(out,
               "  order %d, T0 %.2f deg C, %d rests over %.2f .. %.2f deg C (span needed %g)\n",
               t.order, t.reference_c, t.rests, t.min_c, t.max_c, o.temp_min_span);
  if (t.passes > 0)
    std::fprintf(out,
                 "  the calibration above ran again on the readings with this model applied (%d "
                 "pass%s; its biases are those at T0)\n",
                 t.passes, t.passes == 1 ? "" : "es");
  auto sensor = [&](const char* name, const TemperatureBiasResult& b, const char* unit) {
    std::fprintf(out, "  %s: %s\n", name, b.ok ? "ok" : ("NOT modelled: " + b.status).c_str());
    if (!b.ok) return;
    std::fprintf(out, "    b0  %s  %s\n", vec_pm(b.b0, b.b0_sigma, "% .6e").c_str(), unit);
    std::fprintf(out, "    b1  %s  %s/degC\n", vec_pm(b.b1, b.b1_sigma, "% .6e").c_str(), unit);
    if (t.order >= 2)
      std::fprintf(out, "    b2  %s  %s/degC^2\n", vec_pm(b.b2, b.b2_sigma, "% .6e").c_str(), unit);
  };
  sensor("accelerometer", t.accel, accel_unit_name(o.accel_unit));
  sensor("gyroscope", t.gyro, gyro_unit_name(o.gyro_unit));
}

std::string param_unit(int k, int scale_index, const char* unit, const char* out_unit) {
  if (k < scale_index) return "rad";
  if (k < scale_index + 3) return std::string("(") + out_unit + ")/" + unit;
  return unit;
}

}  // namespace

void print_params(std::FILE* out, const char* const* names, const double* p, const double* sd,
                  int n, int scale_index, const char* unit, const char* out_unit) {
  for (int k = 0; k < n; ++k)
    std::fprintf(out, "  %-9s % .7e  +- %.2e  %s\n", names[k], p[k], sd[k],
                 param_unit(k, scale_index, unit, out_unit).c_str());
}

// "[x, y, z] +- [sx, sy, sz]" with one format.
std::string vec_pm(const double* v, const double* sd, const char* format) {
  std::string r = "[";
  for (int a = 0; a < 3; ++a) r += (a ? ", " : "") + fmt(format, v[a]);
  r += "] +- [";
  for (int a = 0; a < 3; ++a) r += (a ? ", " : "") + fmt("%.2e", sd[a]);
  return r + "]";
}

void print_summary(const Run& run, const Options& o, std::FILE* out) {
  std::fprintf(out, "imucal calibrate (%s%s)\n", run.scalar.c_str(),
               run.scalar == "float" ? ", as on the device" : ", the reference");
  std::string files;
  for (const std::string& f : o.files) files += (files.empty() ? "" : " + ") + f;
  if (run.time_source == "none")
    std::fprintf(out, "input    %s (%s): %ld %s, no time; %ld lines skipped\n", files.c_str(),
                 run.format.c_str(), run.samples, run.mode == "poses" ? "poses" : "samples",
                 run.lines_skipped);
  else
    std::fprintf(out, "input    %s (%s): %ld samples, %.1f s, %.1f Hz; %ld lines skipped\n",
                 files.c_str(), run.format.c_str(), run.samples, run.t_last - run.t_first,
                 run.rate_hz, run.lines_skipped);
  if (run.input_reads > 1)
    std::fprintf(out, "         read %d times: its samples did not fit in --memory (%g MB)\n",
                 run.input_reads, o.memory_mb);
  if (run.kept_every > 1)
    std::fprintf(out,
                 "         longer than --memory (%g MB) holds: the passes after the first saw "
                 "every %ld-th sample\n",
                 o.memory_mb, run.kept_every);
  // Settings read from the input, one line per place they were found.
  std::string where, line;
  for (const std::string& s : o.from_files) {
    const std::size_t at = s.rfind(" (");
    const std::string place = s.substr(at + 2, s.size() - at - 3);
    if (place != where && !line.empty())
      std::fprintf(out, "         from %s: %s\n", where.c_str(), line.c_str());
    if (place != where) line.clear();
    where = place;
    line += (line.empty() ? "" : " ") + s.substr(0, at);
  }
  if (!line.empty()) std::fprintf(out, "         from %s: %s\n", where.c_str(), line.c_str());
  // What the input holds and how it was read.
  std::string parts;
  for (const auto& [has, name] :
       {std::make_pair(run.has_accel, "accelerometer"), std::make_pair(run.has_gyro, "gyroscope"),
        std::make_pair(run.has_mag, "magnetometer")})
    if (has) parts += (parts.empty() ? "" : ", ") + std::string(name);
  std::fprintf(out, "parts    %s%s\n", parts.c_str(),
               run.mode == "poses" ? " (one pose mean per line)" : "");
  if (run.columns_source != "header" && run.columns_source != "imu_tk")
    std::fprintf(out, "columns  %s (%s)\n", run.columns.c_str(),
                 run.columns_source == "assumed" ? "assumed: no header; --columns says otherwise"
                                                 : ("from " + run.columns_source).c_str());
  if (run.time_source == "--rate")
    std::fprintf(out, "time     no t column: sample i at i / %g s (--rate)\n", o.nominal_rate_hz);
  auto inferred = [&](const char* sensor, const std::string& format, double lo, double hi) {
    if (!format.empty())
      std::fprintf(out,
                   "         %s readings are %s counts: at %g or %g taken as saturated (give "
                   "--%s-range to say otherwise)\n",
                   sensor, format.c_str(), lo, hi, sensor);
  };
  inferred("accel", o.accel_range_inferred, o.accel_min, o.accel_max);
  inferred("gyro", o.gyro_range_inferred, o.gyro_min, o.gyro_max);
  if (run.mode == "stream") {
    std::fprintf(out, "stream   %d poses, %d of 6 faces up%s\n", run.poses, run.faces_covered,
                 run.has_gyro ? "" : " (accelerometer alone)");
    if (run.has_gyro) {
      std::fprintf(out, "         %s between poses, stored as %s (the device's fixed memory)\n",
                   plural(run.moves, "turn", "turns").c_str(),
                   plural(run.segments, "gyro segment", "gyro segments").c_str());
      if (run.coarsenings > 0)
        std::fprintf(out,
                     "         segment store full: adjacent segments merged %s to fit it (exact "
                     "sums of the turn statistics; each merge coarsens the integration of one "
                     "turn slightly)\n",
                     plural(run.coarsenings, "time", "times").c_str());
      if (run.moves_dropped > 0)
        std::fprintf(out,
                     "         %s not used for the gyroscope (across a gap, a frozen or saturated "
                     "sensor, a full pose store, or the end while turning)\n",
                     plural(run.moves_dropped, "turn", "turns").c_str());
    }
    if (run.rests_too_short > 0)
      std::fprintf(out, "         %s shorter than --min-rest (%g s): %s\n",
                   plural(run.rests_too_short, "rest", "rests").c_str(), o.min_rest,
                   run.rests_too_short == 1 ? "not a pose" : "not poses");
    for (const StreamEvent& e : run.events)
      std::fprintf(out, "         %s: %ld samples (first at t = %.3f s)\n", e.status.c_str(),
                   e.count, e.first_t);
    std::string counted;
    for (const StreamCount& c : run.stream_counts)
      if (c.count != 0)
        counted +=
            (counted.empty() ? "" : ", ") + std::string(c.name) + " " + std::to_string(c.count);
    std::fprintf(out, "         stream faults: %s\n",
                 counted.empty() ? "none, every sample taken" : counted.c_str());
  } else if (run.mode == "poses") {
    std::fprintf(out, "poses    %d (one per line), %d of 6 faces up\n", run.poses,
                 run.faces_covered);
  }
  // Every rest found, the last one included.
  if (!run.pose_list.empty() && run.mode == "stream") {
    std::fprintf(out, "rests    (each a pose: from .. to, s; samples)\n");
    int split = 0;
    for (std::size_t i = 0; i < run.pose_list.size(); ++i) {
      const PoseResult& pr = run.pose_list[i];
      std::fprintf(out, "  %3zu  %9.2f .. %9.2f  %6d", i + 1, pr.t_begin, pr.t_end, pr.samples);
      if (pr.continues > 0) {
        ++split;
        std::fprintf(out, "   the orientation of rest %d (%.2f deg), after %.2f s of motion",
                     pr.continues, pr.angle_to_previous, pr.gap_before);
      }
      std::fprintf(out, "\n");
    }
    if (split > 0)
      std::fprintf(out,
                   "  %s split by a short motion that left the orientation as it was (a bump): "
                   "each part is a pose; a detector that smooths over the bump (imu_tk's) sees "
                   "%zu rests\n",
                   plural(split, "rest was", "rests were").c_str(),
                   run.pose_list.size() - static_cast<std::size_t>(split));
  }

  const char* au = accel_unit_name(o.accel_unit);
  if (!run.has_accel) {
    std::fprintf(out, "\naccelerometer  not in the input\n");
  } else {
    std::fprintf(
        out, "\naccelerometer  %s\n  status: %s%s\n", kAccelModel, run.accel_status.c_str(),
        !run.accel_ok               ? ""
        : run.accel_iterations == 0 ? " (closed-form start, no refinement needed)"
                                    : (" (closed-form start refined in " +
                                       plural(run.accel_iterations, "Levenberg-Marquardt iteration",
                                              "Levenberg-Marquardt iterations") +
                                       ")")
                                          .c_str());
  }
  if (run.accel_ok) {
    print_params(out, kAccelParamNames, run.accel_params.data(), run.accel_sigma.data(), 9, 3, au,
                 "m/s^2");
    std::fprintf(out, "  residual |g| - |a_cal| per pose, RMS: before %s, after %s m/s^2%s\n",
                 fmt("%.5f", run.accel_pose_rms_before).c_str(),
                 fmt("%.5f", run.accel_pose_rms_after).c_str(),
                 run.have_nominal_accel ? "" : " (before: give the nominal --accel-lsb-per-g)");
    if (run.mode == "stream")
      std::fprintf(out,
                   "  per sample over the rests, RMS: %s m/s^2 (the sensor's own noise about each "
                   "pose: %s)\n",
                   fmt("%.5f", run.accel_sample_rms_after).c_str(),
                   fmt("%.5f", run.accel_noise_floor).c_str());
    if (run.accel_imu_tk_samples > 0)
      std::fprintf(
          out,
          "  as imu_tk states it (half the sum of squares over the first %ld samples "
          "of each pose): %s (m/s^2)^2 over %ld samples, RMS %s m/s^2\n",
          Run::kImuTkSamples, fmt("%.6g", run.accel_imu_tk_cost).c_str(), run.accel_imu_tk_samples,
          fmt("%.5f",
              std::sqrt(2 * run.accel_imu_tk_cost / static_cast<double>(run.accel_imu_tk_samples)))
              .c_str());
    if (std::isfinite(run.accel_noise)) {
      std::fprintf(out, "  noise measured in the rests: %s m/s^2 a sample on each axis",
                   fmt("%.3g", run.accel_noise).c_str());
      if (std::isfinite(run.rate_hz))
        std::fprintf(out, " (white noise %s m/s^2/sqrt(Hz))",
                     fmt("%.3g", run.accel_noise / std::sqrt(run.rate_hz)).c_str());
      std::fprintf(out, "; the sigmas above come from it\n");
    }
    if (std::isfinite(run.accel_fit_to_noise)) {
      const std::string floor =
          run.accel_pose_floor > 0
              ? ", with a floor of " + fmt("%.2g", run.accel_pose_floor) +
                    " m/s^2 a pose mean (bias instability, warming or sway: a long rest counts "
                    "no more than that)"
          : run.accel_fit_to_noise > 2
              ? " (the pose means scatter more than the rests' noise explains, e.g. a drift "
                "between poses; too few poses to fit a floor, the sigmas are widened to match)"
              : " (no floor: each pose mean is as good as its samples make it)";
      std::fprintf(out, "  pose means against that noise: chi2/dof %s%s\n",
                   fmt("%.2f", run.accel_fit_to_noise).c_str(), floor.c_str());
    }
  }
  const char* gu = gyro_unit_name(o.gyro_unit);
  if (!run.has_gyro) {
    std::fprintf(out, "\ngyroscope      not in the input\n");
  } else {
    std::fprintf(out, "\ngyroscope      %s\n  status: %s%s, bias %s\n", kGyroModel,
                 run.gyro_status.c_str(),
                 run.gyro_ok ? (" (" +
                                plural(run.gyro_iterations, "Levenberg-Marquardt iteration",
                                       "Levenberg-Marquardt iterations") +
                                ")")
                                   .c_str()
                             : "",
                 run.gyro_bias_refined ? "refined" : "from the initial rest");
  }
  if (run.gyro_ok) {
    print_params(out, kGyroParamNames, run.gyro_params.data(), run.gyro_sigma.data(), 12, 6, gu,
                 "rad/s");
  }
  if (run.accel_ok && run.has_gyro) {
    std::fprintf(out,
                 "  residual per move (angle of carried vs measured gravity), RMS: before %s, "
                 "after %s deg%s\n",
                 fmt("%.3f", run.gyro_rms_before).c_str(), fmt("%.3f", run.gyro_rms_after).c_str(),
                 run.have_nominal_gyro ? "" : " (before: give the nominal --gyro-lsb-per-dps)");
    if (std::isfinite(run.gyro_imu_tk_cost))
      std::fprintf(out,
                   "  as imu_tk states it (half the sum over the moves of |carried - measured "
                   "gravity direction|^2): %s\n",
                   fmt("%.6g", run.gyro_imu_tk_cost).c_str());
  }
  if (run.has_gyro && std::isfinite(run.gyro_noise)) {
    std::fprintf(out, "  noise measured in the initial rest: %s rad/s a sample on each axis",
                 fmt("%.3g", run.gyro_noise).c_str());
    if (std::isfinite(run.rate_hz))
      std::fprintf(out, " (white noise %s rad/s/sqrt(Hz))",
                   fmt("%.3g", run.gyro_noise / std::sqrt(run.rate_hz)).c_str());
    std::fprintf(out, "\n");
  }
  print_mag_summary(run, o, out);
  print_temperature_summary(run, o, out);
  if (!run.advice.empty()) {
    std::fprintf(out, "\n%s\n", run.usable ? "to do better" : "why, and what to do");
    for (const std::string& a : run.advice) std::fprintf(out, "  - %s\n", a.c_str());
  }
  std::fprintf(out, "\nquality  %s: %s%s\n", run.quality.c_str(),
               run.usable ? "usable" : "NOT usable (see the statuses above)",
               run.quality_reason.empty() ? "" : ("; " + run.quality_reason).c_str());
}

namespace {

bool write_failed(const std::string& path, int error) {
  std::fprintf(stderr, "imucal: cannot write %s: %s\n", path.c_str(), std::strerror(error));
  return false;
}

// Everything of text to fd; the errno of the failure, 0 when all went out.
int write_all(int fd, const std::string& text) {
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    done += static_cast<std::size_t>(n);
  }
  return 0;
}

}  // namespace

bool outputs_apart_from_inputs(const std::vector<std::string>& inputs,
                               const std::vector<NamedPath>& outputs) {
  for (const NamedPath& out : outputs) {
    struct stat o {};
    if (out.path.empty() || out.path == "-" || ::stat(out.path.c_str(), &o) != 0) continue;
    for (const std::string& in : inputs) {
      struct stat i {};
      if (in.empty() || in == "-" || ::stat(in.c_str(), &i) != 0) continue;
      if (i.st_dev != o.st_dev || i.st_ino != o.st_ino) continue;
      std::fprintf(stderr,
                   "imucal: %s %s is the input %s (the same file): refused, it would be "
                   "overwritten\n",
                   out.option, out.path.c_str(), in.c_str());
      return false;
    }
  }
  return true;
}

std::string printed(const std::function<void(std::FILE*)>& print) {
  char* text = nullptr;
  std::size_t size = 0;
  std::FILE* f = open_memstream(&text, &size);
  if (f == nullptr) throw std::bad_alloc();  // the command reports it (exit 2)
  print(f);
  std::fclose(f);
  std::string s(text, size);
  std::free(text);
  return s;
}

std::string fmt(const char* format, double v) {
  if (!std::isfinite(v)) return "n/a";
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

std::string plural(long n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

std::string format_text(const char* format, ...) {
  char buf[1024];
  va_list args;
  va_start(args, format);
  std::vsnprintf(buf, sizeof buf, format, args);
  va_end(args);
  return buf;
}

bool write_text_file(const std::string& path, const std::string& text) {
  if (path == "-") {
    const bool ok = std::fwrite(text.data(), 1, text.size(), stdout) == text.size();
    if (!ok || std::fflush(stdout) != 0) return write_failed("stdout", errno);
    return true;
  }
  struct stat st {};
  const bool exists = ::stat(path.c_str(), &st) == 0;
  if (exists && S_ISDIR(st.st_mode)) return write_failed(path, EISDIR);
  if (exists && !S_ISREG(st.st_mode)) {
    // A device or a pipe (/dev/stdout, a FIFO): written in place, it cannot be replaced.
    const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
    if (fd < 0) return write_failed(path, errno);
    const int error = write_all(fd, text);
    if (::close(fd) != 0 && error == 0) return write_failed(path, errno);
    return error == 0 || write_failed(path, error);
  }
  // A file: written beside it under a temporary name and renamed over it, so a failed or
  // interrupted write leaves the previous file as it was (or no file). Not forced to the disk
  // (no fsync, as cp and sed -i): that would take a millisecond or more, a twentieth of a run;
  // ext4 orders a rename over a file after the new file's data.
  std::string tmp = path + ".XXXXXX";
  const int fd = ::mkstemp(&tmp[0]);
  if (fd < 0) return write_failed(path, errno);
  const mode_t mask = ::umask(0);
  ::umask(mask);
  int error = ::fchmod(fd, exists ? (st.st_mode & 07777) : (0666 & ~mask)) == 0 ? 0 : errno;
  if (error == 0) error = write_all(fd, text);
  if (::close(fd) != 0 && error == 0) error = errno;
  if (error == 0 && ::rename(tmp.c_str(), path.c_str()) != 0) error = errno;
  if (error != 0) {
    ::unlink(tmp.c_str());
    return write_failed(path, error);
  }
  return true;
}

namespace {

Json vec3(const double* v) { return Json::array({number(v[0]), number(v[1]), number(v[2])}); }

// {"x": {"value", "sigma"}, ...}
Json vec_sigma(const double* v, const double* sd) {
  Json r;
  static const char* const kAxes[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) r[kAxes[a]] = {{"value", number(v[a])}, {"sigma", number(sd[a])}};
  return r;
}

Json mag_json(const Run& run, const Options& o) {
  const MagResult& m = run.mag;
  Json j;
  j["model"] = kMagModel;
  j["convention"] = kMagConvention;
  j["unit_in"] = mag_unit_name(o.mag_unit);
  j["unit_out"] = "uT";
  j["present"] = m.present;
  j["status"] = m.status;
  j["usable"] = m.ok;
  j["readings"] = m.readings;
  j["samples_held"] = m.held.size();
  j["samples_fitted"] = m.samples;
  j["iterations"] = m.iterations;
  j["coverage"] = number(m.coverage);
  j["field_ut"] = number(m.field_ut);
  j["fit_error_pct"] = number(m.fit_error_pct);
  j["quality"] = m.quality;
  if (m.ok) {
    Json s = Json::array();
    for (int r = 0; r < 3; ++r) s.push_back(vec3(m.soft_iron[r]));
    j["soft_iron"] = s;
    j["hard_iron"] = vec_sigma(m.hard_iron, m.hard_iron_sigma);
    Json ss;
    for (int k = 0; k < kMagSymEntries; ++k) ss[kMagSymNames[k]] = number(m.soft_iron_sigma[k]);
    j["soft_iron_sigma_symmetric"] = ss;
  }
  Json a;
  a["status"] = m.alignment_status;
  a["aligned"] = m.aligned;
  a["rests"] = m.rests;
  if (m.aligned) {
    a["dip_deg"] = {{"value", number(m.dip_deg)}, {"sigma", number(m.dip_sigma_deg)}};
    a["rotation_rad"] = vec_sigma(m.rotation, m.rotation_sigma);
    const double angle = std::sqrt(m.rotation[0] * m.rotation[0] + m.rotation[1] * m.rotation[1] +
                                   m.rotation[2] * m.rotation[2]);
    a["rotation_angle_deg"] = angle * kDeg;
  }
  j["alignment"] = a;
  return j;
}

Json temperature_json(const Run& run, const Options& o) {
  const TemperatureResult& t = run.temperature;
  Json j;
  j["model"] = kTemperatureModel;
  j["convention"] = kTemperatureConvention;
  j["present"] = t.present;
  j["status"] = t.status;
  j["order"] = t.order;
  j["reference_c"] = number(t.reference_c);
  j["min_c"] = number(t.min_c);
  j["max_c"] = number(t.max_c);
  j["rests_fitted"] = t.rests;
  j["passes"] = t.passes;
  auto sensor = [&](const TemperatureBiasResult& b, const char* unit) {
    Json s;
    s["status"] = b.status;
    s["usable"] = b.ok;
    s["unit"] = unit;
    if (b.ok) {
      s["b0"] = vec_sigma(b.b0, b.b0_sigma);
      s["b1"] = vec_sigma(b.b1, b.b1_sigma);
      if (t.order >= 2) s["b2"] = vec_sigma(b.b2, b.b2_sigma);
    }
    return s;
  };
  j["accelerometer"] = sensor(t.accel, accel_unit_name(o.accel_unit));
  j["gyroscope"] = sensor(t.gyro, gyro_unit_name(o.gyro_unit));
  Json rests = Json::array();
  for (const TemperatureRest& r : t.rest_list)
    rests.push_back({{"temperature_c", number(r.temperature_c)},
                     {"samples", r.samples},
                     {"accel_mean", vec3(r.accel_mean)},
                     {"gyro_mean", vec3(r.gyro_mean)}});
  j["rests"] = rests;
  return j;
}

}  // namespace

std::string run_json(const Run& run, const Options& o) {
  Json j;
  j["imucal"] = "0.1.0";
  Json input;
  input["files"] = o.files;
  input["format"] = run.format;
  input["samples"] = run.samples;
  input["t_first_s"] = run.t_first;
  input["t_last_s"] = run.t_last;
  input["rate_hz"] = number(run.rate_hz);
  input["lines_skipped"] = run.lines_skipped;
  input["reads"] = run.input_reads;
  input["kept_every"] = run.kept_every;
  input["diagnostics"] = run.diagnostics;
  input["diagnostic_count"] = run.diagnostic_count;
  Json events = Json::array();
  for (const StreamEvent& e : run.events)
    events.push_back({{"status", e.status}, {"samples", e.count}, {"first_t_s", e.first_t}});
  input["stream_events"] = events;
  input["columns"] = run.columns;
  input["columns_source"] = run.columns_source;
  input["time"] = run.time_source;
  j["input"] = input;
  j["parts"] = {{"accelerometer", run.has_accel},
                {"gyroscope", run.has_gyro},
                {"magnetometer", run.has_mag},
                {"mode", run.mode}};

  Json config;
  config["scalar"] = run.scalar;
  config["time_unit"] = time_unit_name(o.time_unit);
  config["accel_unit"] = accel_unit_name(o.accel_unit);
  config["gyro_unit"] = gyro_unit_name(o.gyro_unit);
  config["accel_lsb_per_g"] = number(o.accel_lsb_per_g);
  config["accel_zero"] = number(o.accel_zero);
  config["gyro_lsb_per_dps"] = number(o.gyro_lsb_per_dps);
  config["gravity_mps2"] = o.gravity;
  config["initial_rest_s"] = o.initial_rest;
  config["min_rest_s"] = o.min_rest;
  config["refine_gyro_bias"] = o.refine_gyro_bias;
  auto range = [](double lo, double hi) {
    return std::isfinite(lo) ? Json::array({lo, hi}) : Json(nullptr);
  };
  config["accel_range"] = range(o.accel_min, o.accel_max);
  config["gyro_range"] = range(o.gyro_min, o.gyro_max);
  // "given", or the integer format the readings fit ("int16", "uint16"), or null: none.
  auto source = [](double lo, const std::string& inferred) {
    return !std::isfinite(lo) ? Json(nullptr) : inferred.empty() ? Json("given") : Json(inferred);
  };
  config["accel_range_source"] = source(o.accel_min, o.accel_range_inferred);
  config["gyro_range_source"] = source(o.gyro_min, o.gyro_range_inferred);
  config["nominal_rate_hz"] = o.nominal_rate_hz > 0 ? Json(o.nominal_rate_hz) : Json(nullptr);
  config["mag_unit"] = mag_unit_name(o.mag_unit);
  config["mag_lsb_per_ut"] = number(o.mag_lsb_per_ut);
  config["mag_unit_ut"] = number(run.mag.unit_ut);
  config["mag_field_range_ut"] = Json::array({o.mag_field_min, o.mag_field_max});
  config["mag_min_coverage"] = o.mag_min_coverage;
  config["mag_align"] = o.mag_align;
  config["temp_order"] = o.temp_order;
  config["temp_min_span_c"] = o.temp_min_span;
  config["memory_mb"] = o.memory_mb;
  config["from_files"] = o.from_files;
  j["configuration"] = config;

  j["collection"] = {{"poses", run.poses},
                     {"moves", run.moves},
                     {"faces_covered", run.faces_covered},
                     {"segments", run.segments},
                     {"coarsenings", run.coarsenings},
                     {"rests_too_short", run.rests_too_short},
                     {"moves_dropped", run.moves_dropped}};
  Json stream = Json::object();  // the calibrator's counts, every kind
  for (const StreamCount& c : run.stream_counts) stream[c.key] = c.count;
  j["stream"] = stream;
  auto params = [](const char* const* names, const auto& p, const auto& sd, int n) {
    Json out;
    for (int k = 0; k < n; ++k) {
      const auto i = static_cast<std::size_t>(k);
      out[names[k]] = {{"value", number(p[i])}, {"sigma", number(sd[i])}};
    }
    return out;
  };
  Json accel;
  accel["model"] = kAccelModel;
  accel["convention"] = kConvention;
  accel["unit_in"] = accel_unit_name(o.accel_unit);
  accel["status"] = run.accel_status;
  accel["iterations"] = run.accel_iterations;
  if (run.accel_ok)
    accel["parameters"] = params(kAccelParamNames, run.accel_params, run.accel_sigma, 9);
  accel["residual_mps2"] = {{"pose_rms_before", number(run.accel_pose_rms_before)},
                            {"pose_rms_after", number(run.accel_pose_rms_after)},
                            {"sample_rms_after", number(run.accel_sample_rms_after)},
                            {"sample_noise_floor", number(run.accel_noise_floor)},
                            {"imu_tk_cost", number(run.accel_imu_tk_cost)},
                            {"imu_tk_samples", run.accel_imu_tk_samples}};
  accel["noise"] = {{"sample_sigma_mps2", number(run.accel_noise)},
                    {"pose_floor_mps2", number(run.accel_pose_floor)},
                    {"fit_chi2_per_dof", number(run.accel_fit_to_noise)}};
  j["accelerometer"] = accel;
  Json gyro;
  gyro["model"] = kGyroModel;
  gyro["convention"] = kConvention;
  gyro["unit_in"] = gyro_unit_name(o.gyro_unit);
  gyro["status"] = run.gyro_status;
  gyro["iterations"] = run.gyro_iterations;
  gyro["bias"] = run.gyro_bias_refined ? "refined" : "initial rest";
  if (run.gyro_ok)
    gyro["parameters"] = params(kGyroParamNames, run.gyro_params, run.gyro_sigma, 12);
  gyro["residual_deg"] = {{"move_rms_before", number(run.gyro_rms_before)},
                          {"move_rms_after", number(run.gyro_rms_after)}};
  gyro["imu_tk_cost"] = number(run.gyro_imu_tk_cost);
  gyro["noise"] = {{"sample_sigma_rads", number(run.gyro_noise)}};
  j["gyroscope"] = gyro;
  j["magnetometer"] = mag_json(run, o);
  j["temperature"] = temperature_json(run, o);
  j["quality"] = run.quality;
  j["quality_reason"] = run.quality_reason;
  j["usable"] = run.usable;
  j["advice"] = run.advice;

  Json poses = Json::array();
  for (const PoseResult& p : run.pose_list)
    poses.push_back({{"t_begin_s", p.t_begin},
                     {"t_end_s", p.t_end},
                     {"samples", p.samples},
                     {"mean", {p.mean[0], p.mean[1], p.mean[2]}},
                     {"up", {p.up[0], p.up[1], p.up[2]}},
                     {"residual_before_mps2", number(p.residual_before)},
                     {"residual_after_mps2", number(p.residual_after)},
                     {"angle_to_previous_deg", number(p.angle_to_previous)},
                     {"gap_before_s", number(p.gap_before)},
                     {"continues_pose", p.continues}});
  j["poses"] = poses;
  Json moves = Json::array();
  for (const MoveResult& m : run.move_list)
    moves.push_back({{"from_pose", m.from},
                     {"to_pose", m.to},
                     {"segments", m.segments},
                     {"duration_s", m.duration},
                     {"angle_before_deg", number(m.angle_before)},
                     {"angle_after_deg", number(m.angle_after)}});
  j["moves"] = moves;
  return j.dump(2) + "\n";
}

bool write_json(const Run& run, const Options& o, const std::string& path) {
  return write_text_file(path, run_json(run, o));
}

bool write_header(const Run& run, const Options& o, const std::string& path) {
  std::ostringstream h;
  char buf[256];
  auto values = [&](const auto& v, std::size_t from, std::size_t n) {
    std::string s;
    for (std::size_t i = from; i < from + n; ++i) {
      // A C float literal: 9 significant digits, always with a point or an exponent.
      std::snprintf(buf, sizeof buf, "%.9g", v[i]);
      std::string lit = buf;
      if (lit.find_first_of(".e") == std::string::npos) lit += ".0";
      s += (i > from ? ", " : "") + lit + "f";
    }
    return s;
  };
  // M = T K, row-major.
  // M = T K from the library's own model (row-major for the C initialiser).
  const AccelVector<double> pa = Eigen::Map<const AccelVector<double>>(run.accel_params.data());
  const GyroVector<double> pg = Eigen::Map<const GyroVector<double>>(run.gyro_params.data());
  auto row_major = [](const Matrix3<double>& m) {
    std::array<double, 9> a{};
    for (std::size_t r = 0; r < 3; ++r)
      for (std::size_t c = 0; c < 3; ++c)
        a[3 * r + c] = m(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c));
    return a;
  };
  auto rows = [&](const std::array<double, 9>& m) {
    return "{{" + values(m, 0, 3) + "}, {" + values(m, 3, 3) + "}, {" + values(m, 6, 3) + "}}";
  };
  std::string files;
  for (const std::string& f : o.files) files += (files.empty() ? "" : " + ") + f;
  h << "/* imucal calibration (generated by `imucal calibrate`, " << run.scalar << ", quality "
    << run.quality << ")\n"
    << " * from " << files << ": " << run.poses << " poses, " << run.moves << " moves\n";
  const bool both = run.accel_ok && run.gyro_ok;
  if (both)
    h << " *\n"
      << " * accelerometer: " << kAccelModel << "\n"
      << " * gyroscope:     " << kGyroModel << "\n"
      << " * " << kConvention << ".\n"
      << " * Raw units in: accelerometer " << accel_unit_name(o.accel_unit) << ", gyroscope "
      << gyro_unit_name(o.gyro_unit) << ". Out: m/s^2 and rad/s.\n"
      << " *\n"
      << " * Apply with one 3x3 multiply-add per sensor, M = T K precomputed (row-major):\n"
      << " *   a_cal[i] = sum_j IMUCAL_ACCEL_M[i][j] * (a_raw[j] + IMUCAL_ACCEL_B[j])\n"
      << " *   w_cal[i] = sum_j IMUCAL_GYRO_M[i][j]  * (w_raw[j] + IMUCAL_GYRO_B[j])\n"
      << " * The parameters and their one-sigma uncertainties follow in the model's order.\n";
  else if (run.accel_ok)
    h << " *\n"
      << " * accelerometer: " << kAccelModel << "\n"
      << " * " << kConvention << ".\n"
      << " * Raw unit in: " << accel_unit_name(o.accel_unit) << ". Out: m/s^2.\n"
      << " * gyroscope: none (" << run.gyro_status << ")\n"
      << " *\n"
      << " * Apply with one 3x3 multiply-add, M = T K precomputed (row-major):\n"
      << " *   a_cal[i] = sum_j IMUCAL_ACCEL_M[i][j] * (a_raw[j] + IMUCAL_ACCEL_B[j])\n"
      << " * The parameters and their one-sigma uncertainties follow in the model's order.\n";
  else
    h << " *\n * accelerometer and gyroscope: none (" << run.accel_status << ")\n";
  const MagResult& m = run.mag;
  const TemperatureResult& t = run.temperature;
  const bool temp_accel = t.present && t.accel.ok, temp_gyro = t.present && t.gyro.ok;
  if (m.ok)
    h << " *\n"
      << " * magnetometer:  " << kMagModel << "\n"
      << " * " << kMagConvention << ".\n"
      << " * Raw unit in: " << mag_unit_name(o.mag_unit) << ". Out: uT"
      << (m.aligned ? ", in the accelerometer's frame" : " (not aligned to the accelerometer)")
      << ".\n"
      << " *   m_cal[i] = sum_j IMUCAL_MAG_S[i][j] * (m_raw[j] + IMUCAL_MAG_H[j])\n";
  else
    h << " *\n * magnetometer: none (" << m.status << ")\n";
  if (temp_accel || temp_gyro)
    h << " *\n"
      << " * temperature:   " << kTemperatureModel << ".\n"
      << " * " << kTemperatureConvention << " [IMUCAL_TEMP_MIN, IMUCAL_TEMP_MAX].\n"
      << " * Rows of IMUCAL_*_B_T: b0, b1 (per deg C), b2 (per deg C^2); with d = T - "
         "IMUCAL_TEMP_T0\n"
      << " *   b[j] = B_T[0][j] + d * (B_T[1][j] + d * B_T[2][j])   in place of IMUCAL_*_B[j]\n"
      << " * for "
      << (temp_accel && temp_gyro ? "both sensors"
          : temp_accel            ? "the accelerometer only"
                                  : "the gyroscope only")
      << ".\n";
  else
    h << " *\n * temperature model: none (" << t.status << ")\n";
  h << " */\n"
    << "#ifndef IMUCAL_CALIBRATION_H\n#define IMUCAL_CALIBRATION_H\n\n";
  if (run.accel_ok) {
    h << "static const float IMUCAL_ACCEL_M[3][3] = " << rows(row_major(accel_matrix(pa))) << ";\n";
    h << "static const float IMUCAL_ACCEL_B[3] = {" << values(run.accel_params, 6, 3) << "};\n";
    h << "/* alpha_yz, alpha_zy, alpha_zx, s_x, s_y, s_z, b_x, b_y, b_z */\n";
    h << "static const float IMUCAL_ACCEL_PARAMS[9] = {" << values(run.accel_params, 0, 9)
      << "};\n";
    h << "static const float IMUCAL_ACCEL_SIGMA[9] = {" << values(run.accel_sigma, 0, 9) << "};\n";
  }
  if (run.gyro_ok) {
    h << "static const float IMUCAL_GYRO_M[3][3] = " << rows(row_major(gyro_matrix<double>(pg)))
      << ";\n";
    h << "static const float IMUCAL_GYRO_B[3] = {" << values(run.gyro_params, 9, 3) << "};\n\n";
    h << "/* gamma_yz, gamma_zy, gamma_zx, gamma_xz, gamma_xy, gamma_yx, s_x, s_y, s_z, b_x, b_y, "
         "b_z */\n";
    h << "static const float IMUCAL_GYRO_PARAMS[12] = {" << values(run.gyro_params, 0, 12)
      << "};\n";
    h << "static const float IMUCAL_GYRO_SIGMA[12] = {" << values(run.gyro_sigma, 0, 12) << "};\n";
  }
  auto define = [&](const char* name, double v, const char* comment) {
    std::snprintf(buf, sizeof buf, "%.9g", v);
    std::string lit = buf;
    if (lit.find_first_of(".e") == std::string::npos) lit += ".0";
    h << "#define " << name << " " << lit << "f /* " << comment << " */\n";
  };
  if (m.ok) {
    std::array<double, 9> sm{};
    for (std::size_t r = 0; r < 3; ++r)
      for (std::size_t c = 0; c < 3; ++c) sm[3 * r + c] = m.soft_iron[r][c];
    h << "\n/* magnetometer, m_cal = S (m_raw + h): S in uT per raw unit, h in raw units (added) "
         "*/\n";
    h << "static const float IMUCAL_MAG_S[3][3] = " << rows(sm) << ";\n";
    h << "static const float IMUCAL_MAG_H[3] = {" << values(m.hard_iron, 0, 3) << "};\n";
    h << "static const float IMUCAL_MAG_H_SIGMA[3] = {" << values(m.hard_iron_sigma, 0, 3)
      << "};\n";
    define("IMUCAL_MAG_FIELD_UT", m.field_ut, "uT, the local field strength |m_cal|");
    h << "#define IMUCAL_MAG_ALIGNED " << (m.aligned ? 1 : 0)
      << " /* 1: S includes the rotation into the accelerometer frame */\n";
  }
  if (temp_accel || temp_gyro) {
    h << "\n/* temperature model of the added biases: rows b0, b1, b2 (see above) */\n";
    define("IMUCAL_TEMP_T0", t.reference_c, "deg C, the reference temperature");
    define("IMUCAL_TEMP_MIN", t.min_c, "deg C, lowest rest temperature fitted");
    define("IMUCAL_TEMP_MAX", t.max_c, "deg C, highest rest temperature fitted");
    auto bias_rows = [&](const TemperatureBiasResult& b) {
      return "{{" + values(b.b0, 0, 3) + "}, {" + values(b.b1, 0, 3) + "}, {" + values(b.b2, 0, 3) +
             "}}";
    };
    if (temp_accel)
      h << "static const float IMUCAL_ACCEL_B_T[3][3] = " << bias_rows(t.accel) << ";\n";
    if (temp_gyro) h << "static const float IMUCAL_GYRO_B_T[3][3] = " << bias_rows(t.gyro) << ";\n";
  }
  std::snprintf(buf, sizeof buf, "%.9g", o.gravity);
  h << "\n#define IMUCAL_GRAVITY " << buf << "f /* m/s^2, the calibrated norm */\n";
  h << "#define IMUCAL_QUALITY " << run.quality_level << " /* 0 none, 1 poor, 2 fair, 3 good */\n";
  h << "\n#endif /* IMUCAL_CALIBRATION_H */\n";
  return write_text_file(path, h.str());
}

bool compare_with_truth(const Run& run, const std::string& truth_path, std::FILE* out) {
  std::ifstream in(truth_path);
  if (!in) {
    std::fprintf(stderr, "imucal: cannot read %s\n", truth_path.c_str());
    return false;
  }
  const Json truth = Json::parse(in, nullptr, false);
  auto parameters = [&](const char* sensor) -> const Json* {
    if (!truth.is_object() || !truth.contains(sensor) || !truth[sensor].is_object() ||
        !truth[sensor].contains("parameters") || !truth[sensor]["parameters"].is_object())
      return nullptr;
    return &truth[sensor]["parameters"];
  };
  const Json* ta = parameters("accelerometer");
  const Json* tg = parameters("gyroscope");
  if (ta == nullptr || tg == nullptr) {
    std::fprintf(stderr,
                 "imucal: %s is not a truth file of `imucal simulate` (expected "
                 "accelerometer.parameters and gyroscope.parameters)\n",
                 truth_path.c_str());
    return false;
  }
  std::fprintf(out, "\nagainst the truth in %s (error / sigma):\n", truth_path.c_str());
  auto table = [&](const char* what, const Json& t, const char* const* names, const double* p,
                   const double* sd, int n, bool ok, bool present) {
    if (!ok) {
      std::fprintf(out, "  %s: %s\n", what, present ? "not calibrated" : "not in the input");
      return;
    }
    double worst = 0;
    std::fprintf(out, "  %s:", what);
    for (int k = 0; k < n; ++k) {
      if (!t.contains(names[k]) || !t[names[k]].is_number()) continue;
      const double z = (p[k] - t[names[k]].get<double>()) / sd[k];
      worst = std::max(worst, std::abs(z));
      std::fprintf(out, " %s %+.2f", names[k], z);
    }
    std::fprintf(out, "\n  %s: worst %.2f sigma\n", what, worst);
  };
  table("accelerometer", *ta, kAccelParamNames, run.accel_params.data(), run.accel_sigma.data(), 9,
        run.accel_ok, run.has_accel);
  table("gyroscope", *tg, kGyroParamNames, run.gyro_params.data(), run.gyro_sigma.data(), 12,
        run.gyro_ok, run.has_gyro);
  // The magnetometer and the temperature model, when the file has their truth (simulate).
  auto vec3 = [](const Json& j, double* v) {
    if (!j.is_array() || j.size() != 3) return false;
    for (std::size_t i = 0; i < 3; ++i) {
      if (!j[i].is_number()) return false;
      v[i] = j[i].get<double>();
    }
    return true;
  };
  auto z3 = [&](const char* what, const double* est, const double* t, const double* sd) {
    std::fprintf(out, "  %s:", what);
    for (int i = 0; i < 3; ++i) std::fprintf(out, " %+.2f", (est[i] - t[i]) / sd[i]);
    std::fprintf(out, "\n");
  };
  double t3[3];
  if (truth.contains("magnetometer") && truth["magnetometer"].is_object()) {
    const Json& m = truth["magnetometer"];
    if (!run.mag.ok) {
      std::fprintf(out, "  magnetometer: %s\n",
                   run.has_mag ? "not calibrated" : "not in the input");
    } else {
      if (m.contains("hard_iron") && vec3(m["hard_iron"], t3))
        z3("magnetometer hard iron h", run.mag.hard_iron, t3, run.mag.hard_iron_sigma);
      if (m.contains("field_ut") && m["field_ut"].is_number())
        std::fprintf(out, "  magnetometer field: %.3f uT (truth %.3f)\n", run.mag.field_ut,
                     m["field_ut"].get<double>());
      if (run.mag.aligned && m.contains("dip_deg") && m["dip_deg"].is_number())
        std::fprintf(out, "  magnetometer dip: %+.2f\n",
                     (run.mag.dip_deg - m["dip_deg"].get<double>()) / run.mag.dip_sigma_deg);
    }
  }
  if (truth.contains("temperature") && truth["temperature"].is_object()) {
    const Json& t = truth["temperature"];
    const std::pair<const char*, const TemperatureBiasResult*> parts[] = {
        {"accelerometer", &run.temperature.accel}, {"gyroscope", &run.temperature.gyro}};
    for (const auto& [name, r] : parts) {
      const std::string label = std::string("temperature slope b1, ") + name;
      if (!r->ok) {
        std::fprintf(out, "  %s: no model\n", label.c_str());
      } else if (t.contains(name) && t[name].contains("b1") && vec3(t[name]["b1"], t3)) {
        z3(label.c_str(), r->b1, t3, r->b1_sigma);
      }
    }
  }
  return true;
}

}  // namespace imucal::cli
