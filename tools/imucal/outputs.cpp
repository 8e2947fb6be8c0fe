// tools/imucal/outputs.cpp: summary, JSON, C header, truth comparison, and `imucal record`
// (a stored calibration record, decoded and printed).
#include "outputs.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "cli.hpp"
#include "imucal/accel_model.hpp"
#include "imucal/gyro_model.hpp"
#include "imucal/record.hpp"

namespace imucal::cli {

const char* const kAccelModel =
    "a_cal = T K (a_raw + b), T = [[1, -alpha_yz, alpha_zy], [0, 1, -alpha_zx], [0, 0, 1]], "
    "K = diag(s_x, s_y, s_z)";
const char* const kGyroModel =
    "w_cal = T K (w_raw + b), T = [[1, -gamma_yz, gamma_zy], [gamma_xz, 1, -gamma_zx], "
    "[-gamma_xy, gamma_yx, 1]], K = diag(s_x, s_y, s_z)";
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
const char* time_unit_name(TimeUnit u) {
  return u == TimeUnit::kSeconds ? "s" : u == TimeUnit::kMilliseconds ? "ms" : "us";
}

namespace {

using Json = nlohmann::ordered_json;

// NaN and infinity become JSON null.
Json number(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

std::string param_unit(int k, int scale_index, const char* unit, const char* out_unit) {
  if (k < scale_index) return "rad";
  if (k < scale_index + 3) return std::string("(") + out_unit + ")/" + unit;
  return unit;
}

void print_params(std::FILE* out, const char* const* names, const double* p, const double* sd,
                  int n, int scale_index, const char* unit, const char* out_unit) {
  for (int k = 0; k < n; ++k)
    std::fprintf(out, "  %-9s % .7e  +- %.2e  %s\n", names[k], p[k], sd[k],
                 param_unit(k, scale_index, unit, out_unit).c_str());
}

std::string fmt(const char* format, double v) {
  if (!std::isfinite(v)) return "n/a";
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

}  // namespace

void print_summary(const Run& run, const Options& o, std::FILE* out) {
  std::fprintf(out, "imucal calibrate (%s%s)\n", run.scalar.c_str(),
               run.scalar == "float" ? ", as on the device" : ", the reference");
  std::string files;
  for (const std::string& f : o.files) files += (files.empty() ? "" : " + ") + f;
  std::fprintf(out, "input    %s (%s): %ld samples, %.1f s, %.1f Hz; %ld lines skipped\n",
               files.c_str(), run.format.c_str(), run.samples, run.t_last - run.t_first,
               run.rate_hz, run.lines_skipped);
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
  std::fprintf(out,
               "stream   %d poses, %d moves, %d of 6 faces, %d segments (%d coarsenings), %d rests "
               "too short, %d moves dropped\n",
               run.poses, run.moves, run.faces_covered, run.segments, run.coarsenings,
               run.rests_too_short, run.moves_dropped);
  for (const StreamEvent& e : run.events)
    std::fprintf(out, "         %s: %ld samples (first at t = %.3f s)\n", e.status.c_str(), e.count,
                 e.first_t);
  std::string counted;
  for (const StreamCount& c : run.stream_counts)
    if (c.count != 0)
      counted +=
          (counted.empty() ? "" : ", ") + std::string(c.name) + " " + std::to_string(c.count);
  std::fprintf(out, "         calibrator counts: %s\n", counted.empty() ? "none" : counted.c_str());

  const char* au = accel_unit_name(o.accel_unit);
  std::fprintf(out, "\naccelerometer  %s\n  status: %s, %d iterations\n", kAccelModel,
               run.accel_status.c_str(), run.accel_iterations);
  if (run.accel_ok) {
    print_params(out, kAccelNames, run.accel_params.data(), run.accel_sigma.data(), 9, 3, au,
                 "m/s^2");
    std::fprintf(out, "  residual |g| - |a_cal| per pose, RMS: before %s, after %s m/s^2%s\n",
                 fmt("%.5f", run.accel_pose_rms_before).c_str(),
                 fmt("%.5f", run.accel_pose_rms_after).c_str(),
                 run.have_nominal_accel ? "" : " (before: give the nominal --accel-lsb-per-g)");
    std::fprintf(out,
                 "  per sample over the rests, RMS: %s m/s^2 (the sensor's own noise about each "
                 "pose: %s)\n",
                 fmt("%.5f", run.accel_sample_rms_after).c_str(),
                 fmt("%.5f", run.accel_noise_floor).c_str());
  }
  const char* gu = gyro_unit_name(o.gyro_unit);
  std::fprintf(out, "\ngyroscope      %s\n  status: %s, %d iterations, bias %s\n", kGyroModel,
               run.gyro_status.c_str(), run.gyro_iterations,
               run.gyro_bias_refined ? "refined" : "from the initial rest");
  if (run.gyro_ok) {
    print_params(out, kGyroNames, run.gyro_params.data(), run.gyro_sigma.data(), 12, 6, gu,
                 "rad/s");
  }
  if (run.accel_ok) {
    std::fprintf(out,
                 "  residual per move (angle of carried vs measured gravity), RMS: before %s, "
                 "after %s deg%s\n",
                 fmt("%.3f", run.gyro_rms_before).c_str(), fmt("%.3f", run.gyro_rms_after).c_str(),
                 run.have_nominal_gyro ? "" : " (before: give the nominal --gyro-lsb-per-dps)");
  }
  std::fprintf(out, "\nquality  %s: %s\n", run.quality.c_str(),
               run.usable ? "usable" : "NOT usable (see the statuses above)");
}

bool write_text_file(const std::string& path, const std::string& text) {
  if (path == "-") {
    std::fwrite(text.data(), 1, text.size(), stdout);
    return true;
  }
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) {
    std::fprintf(stderr, "imucal: cannot write %s: %s\n", path.c_str(), std::strerror(errno));
    return false;
  }
  const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  if (std::fclose(f) != 0 || !ok) {
    std::fprintf(stderr, "imucal: cannot write %s\n", path.c_str());
    return false;
  }
  return true;
}

bool write_json(const Run& run, const Options& o, const std::string& path) {
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
  input["diagnostics"] = run.diagnostics;
  input["diagnostic_count"] = run.diagnostic_count;
  Json events = Json::array();
  for (const StreamEvent& e : run.events)
    events.push_back({{"status", e.status}, {"samples", e.count}, {"first_t_s", e.first_t}});
  input["stream_events"] = events;
  j["input"] = input;

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
  config["nominal_rate_hz"] = o.nominal_rate_hz > 0 ? Json(o.nominal_rate_hz) : Json(nullptr);
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
  if (run.accel_ok) accel["parameters"] = params(kAccelNames, run.accel_params, run.accel_sigma, 9);
  accel["residual_mps2"] = {{"pose_rms_before", number(run.accel_pose_rms_before)},
                            {"pose_rms_after", number(run.accel_pose_rms_after)},
                            {"sample_rms_after", number(run.accel_sample_rms_after)},
                            {"sample_noise_floor", number(run.accel_noise_floor)}};
  j["accelerometer"] = accel;
  Json gyro;
  gyro["model"] = kGyroModel;
  gyro["convention"] = kConvention;
  gyro["unit_in"] = gyro_unit_name(o.gyro_unit);
  gyro["status"] = run.gyro_status;
  gyro["iterations"] = run.gyro_iterations;
  gyro["bias"] = run.gyro_bias_refined ? "refined" : "initial rest";
  if (run.gyro_ok) gyro["parameters"] = params(kGyroNames, run.gyro_params, run.gyro_sigma, 12);
  gyro["residual_deg"] = {{"move_rms_before", number(run.gyro_rms_before)},
                          {"move_rms_after", number(run.gyro_rms_after)}};
  j["gyroscope"] = gyro;
  j["quality"] = run.quality;
  j["usable"] = run.usable;

  Json poses = Json::array();
  for (const PoseResult& p : run.pose_list)
    poses.push_back({{"t_begin_s", p.t_begin},
                     {"t_end_s", p.t_end},
                     {"samples", p.samples},
                     {"mean", {p.mean[0], p.mean[1], p.mean[2]}},
                     {"up", {p.up[0], p.up[1], p.up[2]}},
                     {"residual_before_mps2", number(p.residual_before)},
                     {"residual_after_mps2", number(p.residual_after)}});
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
  return write_text_file(path, j.dump(2) + "\n");
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
    << " * from " << files << ": " << run.poses << " poses, " << run.moves << " moves\n"
    << " *\n"
    << " * accelerometer: " << kAccelModel << "\n"
    << " * gyroscope:     " << kGyroModel << "\n"
    << " * " << kConvention << ".\n"
    << " * Raw units in: accelerometer " << accel_unit_name(o.accel_unit) << ", gyroscope "
    << gyro_unit_name(o.gyro_unit) << ". Out: m/s^2 and rad/s.\n"
    << " *\n"
    << " * Apply with one 3x3 multiply-add per sensor, M = T K precomputed (row-major):\n"
    << " *   a_cal[i] = sum_j IMUCAL_ACCEL_M[i][j] * (a_raw[j] + IMUCAL_ACCEL_B[j])\n"
    << " *   w_cal[i] = sum_j IMUCAL_GYRO_M[i][j]  * (w_raw[j] + IMUCAL_GYRO_B[j])\n"
    << " * The parameters and their one-sigma uncertainties follow in the model's order.\n"
    << " */\n"
    << "#ifndef IMUCAL_CALIBRATION_H\n#define IMUCAL_CALIBRATION_H\n\n";
  h << "static const float IMUCAL_ACCEL_M[3][3] = " << rows(row_major(accel_matrix(pa))) << ";\n";
  h << "static const float IMUCAL_ACCEL_B[3] = {" << values(run.accel_params, 6, 3) << "};\n";
  h << "static const float IMUCAL_GYRO_M[3][3] = " << rows(row_major(gyro_matrix<double>(pg)))
    << ";\n";
  h << "static const float IMUCAL_GYRO_B[3] = {" << values(run.gyro_params, 9, 3) << "};\n\n";
  h << "/* alpha_yz, alpha_zy, alpha_zx, s_x, s_y, s_z, b_x, b_y, b_z */\n";
  h << "static const float IMUCAL_ACCEL_PARAMS[9] = {" << values(run.accel_params, 0, 9) << "};\n";
  h << "static const float IMUCAL_ACCEL_SIGMA[9] = {" << values(run.accel_sigma, 0, 9) << "};\n";
  h << "/* gamma_yz, gamma_zy, gamma_zx, gamma_xz, gamma_xy, gamma_yx, s_x, s_y, s_z, b_x, b_y, "
       "b_z */\n";
  h << "static const float IMUCAL_GYRO_PARAMS[12] = {" << values(run.gyro_params, 0, 12) << "};\n";
  h << "static const float IMUCAL_GYRO_SIGMA[12] = {" << values(run.gyro_sigma, 0, 12) << "};\n";
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
                   const double* sd, int n, bool ok) {
    if (!ok) {
      std::fprintf(out, "  %s: not calibrated\n", what);
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
  table("accelerometer", *ta, kAccelNames, run.accel_params.data(), run.accel_sigma.data(), 9,
        run.accel_ok);
  table("gyroscope", *tg, kGyroNames, run.gyro_params.data(), run.gyro_sigma.data(), 12,
        run.gyro_ok);
  return true;
}

namespace {

// The whole file ("-": stdin). False, with the reason, if it cannot be read.
bool read_bytes(const std::string& path, std::vector<std::uint8_t>& out, std::string& error) {
  std::FILE* f = path == "-" ? stdin : std::fopen(path.c_str(), "rb");
  if (f == nullptr) {
    error = std::strerror(errno);
    return false;
  }
  std::uint8_t buf[4096];
  std::size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) out.insert(out.end(), buf, buf + n);
  const bool ok = std::ferror(f) == 0;
  if (!ok) error = std::strerror(errno);
  if (f != stdin) std::fclose(f);
  return ok;
}

void print_record(const CalibrationRecord& r, const std::string& path, std::size_t length,
                  std::size_t file_size, std::FILE* out) {
  const Calibration<float>& c = r.calibration;
  static const char* const kQuality[4] = {"none", "poor", "fair", "good"};
  std::fprintf(out, "imucal record %s: %zu bytes, format version %u, CRC-32 correct\n",
               path.c_str(), length, static_cast<unsigned>(r.version));
  if (file_size > length)
    std::fprintf(out, "         the %zu bytes after it ignored (as in a flash slot)\n",
                 file_size - length);
  std::fprintf(out, "device   id %lu (0x%08lx), sensor id %lu (0x%08lx)\n",
               static_cast<unsigned long>(r.device_id), static_cast<unsigned long>(r.device_id),
               static_cast<unsigned long>(r.sensor_id), static_cast<unsigned long>(r.sensor_id));
  const bool has_accel = (r.parts & kRecordAccel) != 0, has_gyro = (r.parts & kRecordGyro) != 0;
  std::fprintf(out, "parts    %s%s%s\n", has_accel ? "accelerometer" : "",
               has_accel && has_gyro ? ", " : "", has_gyro ? "gyroscope" : "");
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
    std::array<double, 9> p{}, sd{};
    for (int k = 0; k < 9; ++k) {
      p[static_cast<std::size_t>(k)] = static_cast<double>(a.params(k));
      sd[static_cast<std::size_t>(k)] = static_cast<double>(a.sigma(k));
    }
    std::fprintf(out, "\naccelerometer  %s\n  %d poses\n", kAccelModel, a.poses);
    print_params(out, kAccelNames, p.data(), sd.data(), 9, 3, "raw", "m/s^2");
    std::fprintf(out, "  residual |g| - |a_cal| per pose, RMS: %s m/s^2\n",
                 fmt("%.5f", static_cast<double>(a.residual_rms)).c_str());
  }
  if (has_gyro) {
    const GyroCalibration<float>& g = c.gyro;
    std::array<double, 12> p{}, sd{};
    for (int k = 0; k < 12; ++k) {
      p[static_cast<std::size_t>(k)] = static_cast<double>(g.params(k));
      sd[static_cast<std::size_t>(k)] = static_cast<double>(g.sigma(k));
    }
    std::fprintf(out, "\ngyroscope      %s\n  %d moves, bias %s\n", kGyroModel, g.moves,
                 g.bias_refined ? "refined" : "from the initial rest");
    print_params(out, kGyroNames, p.data(), sd.data(), 12, 6, "raw", "rad/s");
    const double rms = static_cast<double>(g.residual_rms);
    std::fprintf(out, "  residual per move (sine of the gravity angle), RMS: %s (%s deg)\n",
                 fmt("%.3e", rms).c_str(),
                 fmt("%.3f", std::asin(std::min(rms, 1.0)) * kDeg).c_str());
  }
  std::fprintf(out, "\nquality  %s\n", kQuality[static_cast<int>(c.quality) & 3]);
  std::fprintf(out,
               "raw: the unit the recording was calibrated in (the record does not name it); b "
               "is added to the raw reading\n");
}

}  // namespace

int record_command(const std::vector<std::string>& args) {
  if (args.size() != 1 || (args[0].size() > 1 && args[0][0] == '-')) {
    std::fprintf(stderr,
                 "imucal record: give one record file (or - for stdin): imucal record FILE\n");
    return 2;
  }
  const std::string& path = args[0];
  std::vector<std::uint8_t> bytes;
  std::string error;
  if (!read_bytes(path, bytes, error)) {
    std::fprintf(stderr, "imucal: cannot read %s: %s\n", path.c_str(), error.c_str());
    return 2;
  }
  static const std::uint8_t kNothing = 0;  // decode_record refuses a null pointer
  const std::uint8_t* data = bytes.empty() ? &kNothing : bytes.data();
  CalibrationRecord record;
  std::size_t offset = 0;
  const Status st = decode_record(data, bytes.size(), record, &offset);
  if (st != Status::kOk) {
    std::fprintf(stderr, "imucal: %s: %s, at byte %zu (of %zu)\n", path.c_str(), to_string(st),
                 offset, bytes.size());
    return 1;
  }
  const std::size_t length = static_cast<std::size_t>(bytes[6] | (bytes[7] << 8));
  print_record(record, path, length, bytes.size(), stdout);
  return 0;
}

}  // namespace imucal::cli
