// tools/imucal/simulate.cpp: `imucal simulate`: a whole raw recording with known truth (the
// simulator of the tests: rests, coning hand turns with linear acceleration, noise, bias,
// timing jitter), as imucal CSV, and the truth as JSON.
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>

#include "cli.hpp"
#include "imucal/sim/motion_sim.hpp"
#include "outputs.hpp"

namespace imucal::cli {

namespace {

struct SimOptions {
  std::string output, truth;
  std::uint64_t seed = 1;
  int poses = 24;
  double rate = 100;
  bool counts = true;
  double initial_rest = 10;
};

bool parse(const std::vector<std::string>& args, SimOptions& o, std::string& error) {
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (i + 1 >= args.size()) {
      error = "option " + a + " needs a value (or is unknown)";
      return false;
    }
    const std::string& v = args[++i];
    double x = 0;
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
    } else {
      error = "bad option or value: " + a + " " + v +
              " (--seed N, --poses 0..1000, --rate 10..10000, --initial-rest 1..600, "
              "--units counts|si, -o FILE, --truth FILE)";
      return false;
    }
  }
  if (o.output.empty()) {
    error = "give the recording to write with -o FILE (- for stdout)";
    return false;
  }
  return true;
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
  plan.record_attitude = false;
  const sim::AccelSensorSpec acc =
      o.counts ? sim::AccelSensorSpec::raw_counts() : sim::AccelSensorSpec::si();
  const sim::GyroSensorSpec gyro =
      o.counts ? sim::GyroSensorSpec::raw_counts() : sim::GyroSensorSpec::si();
  sim::Random rng(o.seed);
  const sim::Recording rec = sim::simulate_motion(plan, acc, gyro, rng);

  // The file says its own units and nominal scales, so `imucal calibrate FILE` needs no flags.
  std::string text;
  text.reserve(rec.samples.size() * 56 + 512);
  char line[256];
  std::snprintf(line, sizeof line,
                "# imucal simulate --seed %llu --poses %d --rate %g --units %s: %zu samples\n",
                static_cast<unsigned long long>(o.seed), o.poses, o.rate,
                o.counts ? "counts" : "si", rec.samples.size());
  text += line;
  if (o.counts) {
    std::snprintf(line, sizeof line,
                  "# imucal: accel-unit=counts accel-lsb-per-g=%.6g accel-zero=%.0f "
                  "gyro-unit=counts gyro-lsb-per-dps=%.6g gravity=%g initial-rest=%g\n",
                  kStandardGravity / acc.nominal_scale, -acc.nominal_bias,
                  kPi / 180.0 / gyro.nominal_scale, plan.gravity, o.initial_rest);
  } else {
    std::snprintf(line, sizeof line,
                  "# imucal: accel-unit=mps2 gyro-unit=rads gravity=%g initial-rest=%g\n",
                  plan.gravity, o.initial_rest);
  }
  text += line;
  text += "t,ax,ay,az,gx,gy,gz\n";
  // Counts are integers on a real sensor: rounded. Time in s to the microsecond.
  const char* format =
      o.counts ? "%.6f,%.0f,%.0f,%.0f,%.0f,%.0f,%.0f\n" : "%.6f,%.7g,%.7g,%.7g,%.7g,%.7g,%.7g\n";
  for (const sim::MotionSample& s : rec.samples) {
    std::snprintf(line, sizeof line, format, s.t, s.acc(0), s.acc(1), s.acc(2), s.gyro(0),
                  s.gyro(1), s.gyro(2));
    text += line;
  }
  if (!write_text_file(o.output, text)) return 2;

  if (!o.truth.empty()) {
    nlohmann::ordered_json j;
    j["generator"] = "imucal simulate";
    j["seed"] = o.seed;
    j["samples"] = rec.samples.size();
    j["gravity_mps2"] = plan.gravity;
    j["units"] = o.counts ? "counts" : "si";
    nlohmann::ordered_json a, g;
    a["model"] = kAccelModel;
    g["model"] = kGyroModel;
    a["convention"] = g["convention"] = kConvention;
    for (int k = 0; k < 9; ++k) a["parameters"][kAccelNames[k]] = rec.acc.params(k);
    for (int k = 0; k < 12; ++k) g["parameters"][kGyroNames[k]] = rec.gyro.params(k);
    a["noise_per_sample"] = acc.noise;
    g["noise_per_sample"] = gyro.noise;
    j["accelerometer"] = a;
    j["gyroscope"] = g;
    nlohmann::ordered_json rests = nlohmann::ordered_json::array();
    for (const sim::StillInterval& r : rec.rests)
      rests.push_back({rec.samples[r.begin].t, rec.samples[r.end - 1].t});
    j["rests_s"] = rests;
    if (!write_text_file(o.truth, j.dump(2) + "\n")) return 2;
  }
  if (o.output != "-")
    std::fprintf(stderr, "imucal simulate: %zu samples, %zu rests written to %s\n",
                 rec.samples.size(), rec.rests.size(), o.output.c_str());
  return 0;
}

}  // namespace imucal::cli
