// SPDX-License-Identifier: MIT
// bench/field/metrics.hpp: how the field bench judges an estimator over a life (field.md
// section 7). Once a simulated second, the error of the correction the device would apply,
// |b_hat(t) - b(t)|, from the estimator's first estimate on: its median and 95th percentile,
// overall, during motion (the body not truly still) and at temperatures away from those of the
// true rests so far (where only a temperature model can know the bias); the time to the first
// estimate; the updates and the false ones; the sigma's honesty.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "estimator.hpp"

namespace imucal::field_bench {

// A published update is false when its value is more than 5 sigma from the truth on some axis
// (an estimator that states sigma), else when |error| exceeds the fixed threshold of its
// parameter.
struct FalseUpdateRule {
  double sigmas = 5.0;
  double gyro_mdps = 50.0;  // mdeg/s: above a rest's noise and a good model's error, below the
                            // slowest steady turn (200 mdeg/s)
  double accel_mg = 10.0;   // mg
  double mag_ut = 5.0;      // uT
};

enum class Param { kGyro, kAccel, kMag };
inline const char* param_name(Param p) {
  return p == Param::kGyro ? "gyro" : p == Param::kAccel ? "accel" : "mag";
}
// Display unit per SI unit: mdeg/s per rad/s, mg per m/s^2, uT per uT.
double display_unit(Param p, double gravity);
const char* display_unit_name(Param p);

struct ParamSummary {
  bool any = false;       // an estimate was ever published
  double first_s = -1.0;  // time of the first estimate, s
  double coverage = 0.0;  // share of the seconds with an estimate
  std::size_t n = 0, n_motion = 0, n_away = 0;
  double median = 0.0, p95 = 0.0;                // display units
  double median_motion = 0.0, p95_motion = 0.0;  //
  double median_away = 0.0, p95_away = 0.0;      //
  double away_share = 0.0;  // share of the seconds (from the first estimate) away from rests
  std::uint64_t updates = 0, false_updates = 0;
  bool has_sigma = false;
  double honesty = 0.0;  // RMS of error / sigma over seconds and axes
};

// One parameter of one estimator over a life.
class ParamTrack {
 public:
  ParamTrack(Param p, double gravity, const FalseUpdateRule& rule);
  // The estimate and the truth (SI, subtracted convention) at one second; motion: the body is
  // not truly still; away: the temperature is away from every true rest's so far.
  void second(const Estimate3& e, const Eigen::Vector3d& truth, double t_s, bool motion, bool away);
  ParamSummary summary() const;
  // From now on, write each update (its second, its error per axis and sigma, whether false) to
  // out, one line each: "trace <who> <param> update ...".
  void trace(std::FILE* out, const std::string& who);

 private:
  Param param_;
  double unit_;
  std::FILE* trace_ = nullptr;
  std::string who_;
  double threshold_;  // display units
  double sigmas_;
  std::vector<float> err_, err_motion_, err_away_;
  std::size_t seconds_ = 0, seconds_after_first_ = 0;
  double first_s_ = -1.0;
  std::uint64_t updates_ = 0, seen_updates_ = 0, false_updates_ = 0;
  bool has_sigma_ = false;
  double z2_ = 0.0;
  std::size_t zn_ = 0;
};

// The temperatures of the true rests so far (of 5 s or more), in 0.25 deg C bins.
class RestTemperatures {
 public:
  void mark(double temperature_c);
  // There has been a rest, and none within margin_c of this temperature.
  bool away(double temperature_c, double margin_c) const;

 private:
  static constexpr double kMin = -40.0, kBin = 0.25;
  std::vector<bool> seen_ = std::vector<bool>(640, false);
  bool any_ = false;
};

}  // namespace imucal::field_bench
