// tools/imucal_poses.cpp: the host front door until the full `imucal` CLI exists.
//   imucal_poses simulate [SEED] [COUNT] > poses.csv   simulated raw-count poses, truth in comments
//   imucal_poses calibrate poses.csv [GRAVITY]        calibrate in float (device) and double
// A pose file is CSV: `mean_x,mean_y,mean_z,samples` per still pose (raw sensor units); lines
// starting with # are comments. Exit code 0 only when the float calibration is usable.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "imucal/imucal.hpp"
#include "imucal/sim/accel_sim.hpp"

namespace {

constexpr int kCapacity = 256;
const char* const kNames[imucal::kAccelParams] = {"alpha_yz", "alpha_zy", "alpha_zx", "s_x", "s_y",
                                                  "s_z",      "b_x",      "b_y",      "b_z"};

int simulate(std::uint64_t seed, int count) {
  imucal::sim::Random rng(seed);
  const auto spec = imucal::sim::AccelSensorSpec::raw_counts();
  const auto truth = imucal::sim::draw_accel_truth(spec, rng);
  std::printf("# imucal simulated accelerometer poses (raw 16-bit counts), seed %llu\n",
              static_cast<unsigned long long>(seed));
  std::printf("# model: a_cal = T K (a_raw + b); gravity %.5f m/s^2; noise %.2f counts/sample\n",
              truth.gravity, spec.noise);
  std::printf("# truth:");
  for (int k = 0; k < imucal::kAccelParams; ++k)
    std::printf(" %s=%.9g", kNames[k], truth.params(k));
  std::printf("\nmean_x,mean_y,mean_z,samples\n");
  for (int i = 0; i < count; ++i) {
    const auto n = static_cast<std::uint32_t>(150 + rng.next() % 251);
    const auto m =
        imucal::sim::noisy_pose_mean(truth, spec, imucal::sim::random_direction(rng), n, rng);
    std::printf("%.4f,%.4f,%.4f,%u\n", m(0), m(1), m(2), n);
  }
  return 0;
}

bool parse_truth(const std::string& line, imucal::AccelVector<double>& truth) {
  const auto at = line.find("# truth:");
  if (at == std::string::npos) return false;
  std::istringstream ss(line.substr(at + 8));
  std::string item;
  int found = 0;
  while (ss >> item) {
    const auto eq = item.find('=');
    for (int k = 0; k < imucal::kAccelParams && eq != std::string::npos; ++k) {
      if (item.compare(0, eq, kNames[k]) == 0) {
        truth(k) = std::strtod(item.c_str() + eq + 1, nullptr);
        ++found;
      }
    }
  }
  return found == imucal::kAccelParams;
}

int calibrate(const char* path, double gravity) {
  std::ifstream in(path);
  if (!in) {
    std::fprintf(stderr, "%s: cannot open\n", path);
    return 2;
  }
  imucal::PoseStore<double, kCapacity> dposes;
  imucal::PoseStore<float, kCapacity> fposes;
  imucal::AccelVector<double> truth;
  bool have_truth = false;
  std::string line;
  int lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.empty() || line[0] == '#') {
      have_truth = have_truth || parse_truth(line, truth);
      continue;
    }
    if (line.rfind("mean_x", 0) == 0) continue;
    double x, y, z;
    unsigned n;
    if (std::sscanf(line.c_str(), "%lf,%lf,%lf,%u", &x, &y, &z, &n) != 4) {
      std::fprintf(stderr, "%s:%d: expected mean_x,mean_y,mean_z,samples; line skipped\n", path,
                   lineno);
      continue;
    }
    const imucal::Status s = dposes.add(imucal::Vector3<double>(x, y, z), n);
    if (s != imucal::Status::kOk) {
      std::fprintf(stderr, "%s:%d: pose refused: %s\n", path, lineno, imucal::to_string(s));
      continue;
    }
    fposes.add(
        imucal::Vector3<float>(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)),
        n);
  }
  imucal::AccelSettings<double> ds;
  ds.gravity = gravity;
  imucal::AccelSettings<float> fs;
  fs.gravity = static_cast<float>(gravity);
  imucal::AccelCalibration<double> d;
  imucal::AccelCalibration<float> f;
  const imucal::Status dstat = imucal::calibrate_accelerometer(dposes.span(), ds, d);
  const imucal::Status fstat = imucal::calibrate_accelerometer(fposes.span(), fs, f);
  std::printf("%s: %d poses, gravity %.5f m/s^2\n", path, dposes.size(), gravity);
  std::printf(
      "model: a_cal = T K (a_raw + b), T = [[1,-alpha_yz,alpha_zy],[0,1,-alpha_zx],[0,0,1]], "
      "K = diag(s); b is ADDED (offset = -b)\n");
  std::printf("float (device path): %s after %d iterations; double (reference): %s\n",
              imucal::to_string(fstat), f.iterations, imucal::to_string(dstat));
  if (!imucal::succeeded(fstat)) return 1;
  std::printf("\n%-9s %16s %12s %16s %10s%s\n", "parameter", "float", "sigma", "double",
              "|f-d|/sig", have_truth ? "   truth            (err/sigma)" : "");
  for (int k = 0; k < imucal::kAccelParams; ++k) {
    const double fv = static_cast<double>(f.params(k)), sig = static_cast<double>(f.sigma(k));
    std::printf("%-9s %16.9g %12.3g %16.9g %10.3f", kNames[k], fv, sig, d.params(k),
                std::abs(fv - d.params(k)) / d.sigma(k));
    if (have_truth) std::printf("   %-16.9g (%+.2f)", truth(k), (fv - truth(k)) / sig);
    std::printf("\n");
  }
  std::printf("\nresidual RMS of |g| - |a_cal| over the pose means: %.6f m/s^2 (float)\n",
              static_cast<double>(f.residual_rms));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string cmd = argc > 1 ? argv[1] : "";
  if (cmd == "simulate") {
    return simulate(argc > 2 ? std::strtoull(argv[2], nullptr, 10) : 1,
                    argc > 3 ? std::atoi(argv[3]) : 30);
  }
  if (cmd == "calibrate" && argc > 2)
    return calibrate(argv[2], argc > 3 ? std::atof(argv[3]) : 9.80665);
  std::fprintf(stderr,
               "usage: imucal_poses simulate [SEED] [COUNT] > poses.csv\n"
               "       imucal_poses calibrate poses.csv [GRAVITY_M_S2]\n");
  return 2;
}
