// SPDX-License-Identifier: MIT
// tools/imucal/simulate.cpp: `imucal simulate`: a whole raw recording with known truth (the
// simulator of the tests: rests, coning hand turns with linear acceleration, noise, bias,
// timing jitter; a magnetometer with hard and soft iron; a temperature that ramps while the
// biases drift with it), as imucal CSV, and the truth as JSON.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>

#include "cli.hpp"
#include "imucal/models/accel_model.hpp"
#include "imucal/models/gyro_model.hpp"
#include "imucal/sim/mag_sim.hpp"
#include "imucal/sim/motion_sim.hpp"
#include "outputs.hpp"

namespace imucal::cli {

namespace {

enum class SimMagUnit { kAsUnits, kUt, kCounts };

struct SimOptions {
  std::string output, truth;
  std::uint64_t seed = 1;
  int poses = 24;
  double rate = 100;
  bool counts = true;
  double initial_rest = 10;
  // Magnetometer: columns mx, my, mz (none with --no-mag), in uT or counts (default: as --units).
  bool mag = true;
  SimMagUnit mag_unit = SimMagUnit::kAsUnits;
  double mag_misalignment = 0.02;  // rad, uniform +- per axis of the rotation to the accel frame
  // Temperature: column temp (none with --no-temp), ramping linearly from temp_from to temp_to
  // over the recording; the biases drift with it, |slope| per axis uniform in [0.5, 1] times
  // these (physical units per deg C).
  bool temp = true;
  double temp_from = 22, temp_to = 30;
  double gyro_drift_dps = 0.03;  // deg/s per deg C
  double accel_drift_mg = 1;     // mg per deg C
};

// "A,B" with both finite.
bool parse_pair(const std::string& v, double& a, double& b) {
  const std::size_t comma = v.find(',');
  if (comma == std::string::npos) return false;
  return parse_number(v.substr(0, comma), a) && parse_number(v.substr(comma + 1), b) &&
         std::isfinite(a) && std::isfinite(b);
}

bool parse(const std::vector<std::string>& args, SimOptions& o, std::string& error) {
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--no-mag") {
      o.mag = false;
      continue;
    }
    if (a == "--no-temp") {
      o.temp = false;
      continue;
    }
    if (i + 1 >= args.size()) {
      error = "option " + a + " needs a value (or is unknown)";
      return false;
    }
    const std::string& v = args[++i];
    double x = 0, x2 = 0;
    const bool numeric = parse_number(v, x) && std::isfinite(x);
    if (a == "-o" || a == "--output") {
      o.output = v;
    } else if (a == "--truth") {
      o.truth = v;
    } else if (a == "--seed" && numeric && x >= 0 && x < 1e18 && x == std::floor(x)) {
      o.seed = static_cast<std::uint64_t>(x);
    } else if (a == "--poses" && numeric && x >= 0 && x <= 1000 && x == std::floor(x)) {
      o.poses = static_cast<int>(x);
    } else if (a == "--rate" && numeric && x >= 10 && x <= 10000) {
      o.rate = x;
    } else if (a == "--initial-rest" && numeric && x >= 1 && x <= 600) {
      o.initial_rest = x;
    } else if (a == "--units" && (v == "counts" || v == "si")) {
      o.counts = v == "counts";
    } else if (a == "--mag-unit" && (v == "ut" || v == "counts")) {
      o.mag_unit = v == "ut" ? SimMagUnit::kUt : SimMagUnit::kCounts;
    } else if (a == "--mag-misalignment" && numeric && x >= 0 && x <= 0.5) {
      o.mag_misalignment = x;
    } else if (a == "--temp-ramp" && parse_pair(v, x, x2) && x >= -60 && x <= 150 && x2 >= -60 &&
               x2 <= 150) {
      o.temp_from = x;
      o.temp_to = x2;
    } else if (a == "--gyro-drift" && numeric && x >= 0 && x <= 10) {
      o.gyro_drift_dps = x;
    } else if (a == "--accel-drift" && numeric && x >= 0 && x <= 100) {
      o.accel_drift_mg = x;
    } else {
      error = "bad option or value: " + a + " " + v +
              " (--seed N, --poses 0..1000, --rate 10..10000, --initial-rest 1..600, "
              "--units counts|si, --mag-unit ut|counts, --mag-misalignment 0..0.5 (rad), "
              "--no-mag, --temp-ramp FROM,TO (deg C, -60..150), --gyro-drift 0..10 (deg/s per "
              "deg C), --accel-drift 0..100 (mg per deg C), --no-temp, -o FILE, --truth FILE)";
      return false;
    }
  }
  if (o.output.empty()) {
    error = "give the recording to write with -o FILE (- for stdout)";
    return false;
  }
  return true;
}

std::string printf_like(const char* format, double v) {
  char buf[64];
  const int n = std::snprintf(buf, sizeof buf, format, v);
  return n > 0 ? std::string(buf, static_cast<std::size_t>(std::min(n, 63))) : std::string();
}

nlohmann::ordered_json vector_json(const Vector3<double>& v) { return {v(0), v(1), v(2)}; }

nlohmann::ordered_json matrix_json(const Matrix3<double>& m) {
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (int r = 0; r < 3; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2)});
  return rows;
}

}  // namespace

int simulate_command(const std::vector<std::string>& args) {
  SimOptions o;
  std::string error;
  if (!parse(args, o, error)) {
    std::fprintf(stderr, "imucal simulate: %s\n", error.c_str());
    return 2;
  }
  sim::MotionPlan plan;
  plan.rate_hz = o.rate;
  plan.initial_rest_s = o.initial_rest;
  plan.poses = o.poses;
  plan.rest_min_s = 2.0;
  plan.rest_max_s = 4.0;
  plan.move_min_s = 1.5;
  plan.move_max_s = 2.5;
  plan.record_attitude = o.mag;  // the magnetometer reads the field at the true attitude
  const sim::AccelSensorSpec acc =
      o.counts ? sim::AccelSensorSpec::raw_counts() : sim::AccelSensorSpec::si();
  const sim::GyroSensorSpec gyro =
      o.counts ? sim::GyroSensorSpec::raw_counts() : sim::GyroSensorSpec::si();
  sim::Random rng(o.seed);
  sim::Recording rec = sim::simulate_motion(plan, acc, gyro, rng);
  const std::size_t n = rec.samples.size();

  // The magnetometer and the temperature draw from their own generator, so the motion, the
  // accelerometer and the gyro are those of the same seed without them.
  sim::Random extra(o.seed ^ 0x6d61672b74656d70ull);
  const bool mag_counts =
      o.mag_unit == SimMagUnit::kCounts || (o.mag_unit == SimMagUnit::kAsUnits && o.counts);
  sim::MagSensorSpec mag_spec =
      mag_counts ? sim::MagSensorSpec::counts() : sim::MagSensorSpec::microtesla();
  mag_spec.misalignment = o.mag_misalignment;
  const sim::MagTruth mag = sim::draw_mag_truth(mag_spec, extra);

  // Drift slopes, raw units per deg C, ADDED bias: |slope| uniform in [0.5, 1] x the option.
  const double gyro_per_dps = kPi / 180.0 / gyro.nominal_scale;             // raw per deg/s
  const double accel_per_mg = 1e-3 * kStandardGravity / acc.nominal_scale;  // raw per mg
  Vector3<double> gyro_slope, accel_slope;
  for (int i = 0; i < 3; ++i) {
    const double u = extra.uniform(0.5, 1.0), sign = extra.uniform() < 0.5 ? -1.0 : 1.0;
    gyro_slope(i) = sign * u * o.gyro_drift_dps * gyro_per_dps;
  }
  for (int i = 0; i < 3; ++i) {
    const double u = extra.uniform(0.5, 1.0), sign = extra.uniform() < 0.5 ? -1.0 : 1.0;
    accel_slope(i) = sign * u * o.accel_drift_mg * accel_per_mg;
  }
  // The temperature: a linear ramp over the recording. T0 = its mean over every sample (the
  // calibration's temperature, Calibration::temperature_c): the truth's biases are b(T0).
  const double t_end = n > 0 ? rec.samples.back().t : 0.0;
  auto temperature_at = [&](double t) {
    return t_end > 0 ? o.temp_from + (o.temp_to - o.temp_from) * t / t_end : o.temp_from;
  };
  double t0 = o.temp_from;
  if (n > 0) {
    double sum = 0;
    for (const sim::MotionSample& s : rec.samples) sum += temperature_at(s.t);
    t0 = sum / static_cast<double>(n);
  }
  constexpr double kTempNoise = 0.05;  // deg C per reading
  if (o.temp) {
    for (sim::MotionSample& s : rec.samples) {
      const double d = temperature_at(s.t) - t0;
      s.acc -= accel_slope * d;  // raw = ... - b(T), b(T) = b(T0) + b1 (T - T0)
      s.gyro -= gyro_slope * d;
    }
  }

  // The file says its own units and nominal scales, so `imucal calibrate FILE` needs no flags.
  std::string text;
  text.reserve(n * 96 + 512);
  char line[512];
  std::snprintf(line, sizeof line,
                "# imucal simulate --seed %llu --poses %d --rate %g --units %s: %zu samples\n",
                static_cast<unsigned long long>(o.seed), o.poses, o.rate,
                o.counts ? "counts" : "si", n);
  text += line;
  if (o.mag || o.temp) {
    std::string extras = "#";
    if (o.mag)
      extras +=
          std::string(" magnetometer (mx, my, mz) in ") + (mag_counts ? "counts" : "uT") + ";";
    if (o.temp)
      extras += " temperature (temp, deg C) ramping " + printf_like("%g", o.temp_from) + " to " +
                printf_like("%g", o.temp_to) + ", the biases drifting with it;";
    extras.back() = '\n';
    text += extras;
  }
  if (o.counts) {
    std::snprintf(line, sizeof line,
                  "# imucal: accel-unit=counts accel-lsb-per-g=%.6g accel-zero=%.0f "
                  "gyro-unit=counts gyro-lsb-per-dps=%.6g gravity=%g initial-rest=%g",
                  kStandardGravity / acc.nominal_scale, -acc.nominal_bias,
                  kPi / 180.0 / gyro.nominal_scale, plan.gravity, o.initial_rest);
  } else {
    std::snprintf(line, sizeof line,
                  "# imucal: accel-unit=mps2 gyro-unit=rads gravity=%g initial-rest=%g",
                  plan.gravity, o.initial_rest);
  }
  text += line;
  if (o.mag) {
    text += mag_counts ? " mag-unit=counts mag-lsb-per-ut=" + printf_like("%.6g", 1.0 / mag.unit_ut)
                       : std::string(" mag-unit=ut");
  }
  text += "\nt,ax,ay,az,gx,gy,gz";
  if (o.temp) text += ",temp";
  if (o.mag) text += ",mx,my,mz";
  text += "\n";
  // Counts are integers on a real sensor: rounded. Time in s to the microsecond.
  const char* format =
      o.counts ? "%.6f,%.0f,%.0f,%.0f,%.0f,%.0f,%.0f" : "%.6f,%.7g,%.7g,%.7g,%.7g,%.7g,%.7g";
  for (std::size_t k = 0; k < n; ++k) {
    const sim::MotionSample& s = rec.samples[k];
    int len = std::snprintf(line, sizeof line, format, s.t, s.acc(0), s.acc(1), s.acc(2), s.gyro(0),
                            s.gyro(1), s.gyro(2));
    if (o.temp && len > 0 && static_cast<std::size_t>(len) < sizeof line)
      len += std::snprintf(line + len, sizeof line - static_cast<std::size_t>(len), ",%.2f",
                           temperature_at(s.t) + kTempNoise * extra.normal());
    if (o.mag && len > 0 && static_cast<std::size_t>(len) < sizeof line) {
      const Vector3<double> m = sim::raw_mag(mag, rec.attitude[k], mag_spec.noise, extra);
      len += std::snprintf(line + len, sizeof line - static_cast<std::size_t>(len),
                           mag_counts ? ",%.0f,%.0f,%.0f" : ",%.2f,%.2f,%.2f", m(0), m(1), m(2));
    }
    text += line;
    text += '\n';
  }
  if (!write_text_file(o.output, text)) return 2;

  if (!o.truth.empty()) {
    nlohmann::ordered_json j;
    j["generator"] = "imucal simulate";
    j["seed"] = o.seed;
    j["samples"] = n;
    j["gravity_mps2"] = plan.gravity;
    j["units"] = o.counts ? "counts" : "si";
    nlohmann::ordered_json a, g;
    a["model"] = kAccelModel;
    g["model"] = kGyroModel;
    a["convention"] = g["convention"] = kConvention;
    for (int k = 0; k < 9; ++k) a["parameters"][kAccelParamNames[k]] = rec.acc.params(k);
    for (int k = 0; k < 12; ++k) g["parameters"][kGyroParamNames[k]] = rec.gyro.params(k);
    a["noise_per_sample"] = acc.noise;
    g["noise_per_sample"] = gyro.noise;
    j["accelerometer"] = a;
    j["gyroscope"] = g;
    nlohmann::ordered_json rests = nlohmann::ordered_json::array();
    for (const sim::StillInterval& r : rec.rests)
      rests.push_back({rec.samples[r.begin].t, rec.samples[r.end - 1].t});
    j["rests_s"] = rests;
    if (o.mag) {
      nlohmann::ordered_json m;
      m["model"] =
          "m_cal = S (m_raw + h): h (hard iron) ADDED to the raw reading in raw units, S (soft "
          "iron) from raw units to uT, symmetric with det(S) = unit_ut^3, so |m_cal| = field_ut";
      m["unit"] = mag_counts ? "counts" : "uT";
      m["unit_ut"] = mag.unit_ut;
      m["soft_iron"] = matrix_json(mag.S_true);
      m["hard_iron"] = vector_json(mag.h_true);
      m["field_ut"] = mag.field_ut;
      m["dip_deg"] = mag.dip_deg;
      m["world_field"] = "field_ut (cos dip, 0, -sin dip), world z up (gravity -z)";
      // m_body = R m_mag: the calibration aligned to the accelerometer is R S.
      m["rotation_rad"] = vector_json(sim::mag_sim_log(mag.R_true));
      m["soft_iron_aligned"] = matrix_json(mag.R_true * mag.S_true);
      m["noise_per_sample"] = mag_spec.noise;
      j["magnetometer"] = m;
    }
    if (o.temp) {
      nlohmann::ordered_json t;
      t["model"] =
          "b(T) = b0 + b1 (T - T0) for the ADDED biases (raw units; b0 = the sensors' b above, "
          "b1 per deg C)";
      t["reference_c"] = t0;
      t["ramp_c"] = {o.temp_from, o.temp_to};
      t["noise_c"] = kTempNoise;
      t["accelerometer"]["b0"] = vector_json(rec.acc.params.tail<3>());
      t["accelerometer"]["b1"] = vector_json(accel_slope);
      t["gyroscope"]["b0"] = vector_json(rec.gyro.params.tail<3>());
      t["gyroscope"]["b1"] = vector_json(gyro_slope);
      j["temperature"] = t;
    }
    if (!write_text_file(o.truth, j.dump(2) + "\n")) return 2;
  }
  if (o.output != "-")
    std::fprintf(stderr, "imucal simulate: %zu samples, %zu rests written to %s\n", n,
                 rec.rests.size(), o.output.c_str());
  return 0;
}

}  // namespace imucal::cli
