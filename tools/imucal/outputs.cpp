// tools/imucal/outputs.cpp: summary, JSON, C header, truth comparison.
#include "outputs.hpp"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "imucal/accel_model.hpp"
#include "imucal/gyro_model.hpp"

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
  config["from_files"] = o.from_files;
  j["configuration"] = config;

  j["collection"] = {{"poses", run.poses},
                     {"moves", run.moves},
                     {"faces_covered", run.faces_covered},
                     {"segments", run.segments},
                     {"coarsenings", run.coarsenings},
                     {"rests_too_short", run.rests_too_short},
                     {"moves_dropped", run.moves_dropped}};
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

}  // namespace imucal::cli
