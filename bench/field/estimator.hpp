// SPDX-License-Identifier: MIT
// bench/field/estimator.hpp: what the field bench asks of a calibrator that runs on a life
// (sim/life_sim.hpp): samples in, once a simulated second the corrections it would apply.
// Host code (a bench, not the library): it may allocate.
//
// Convention: every estimate is an SI offset SUBTRACTED from the nominally scaled reading,
// gyro_si = s_g * counts - gyro_bias, as Android's CHRE applies it. imucal's model ADDS its bias
// in raw units (w_cal = T K (w_raw + b)): its adapter reports -s_g * b (s_g: the sheet's
// gyro_rad_s_per_count), the same for the accelerometer (-s_a * b) and the hard iron
// (-mag_ut_per_count * h). The truth is converted the same way (LifeTruth::gyro_offset_si ...).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "imucal/sim/life_sim.hpp"

namespace imucal::field_bench {

// One estimated 3-vector.
struct Estimate3 {
  bool valid = false;  // a value is published (the device would apply it)
  Eigen::Vector3d value = Eigen::Vector3d::Zero();
  bool has_sigma = false;  // the estimator states a 1-sigma per axis
  Eigen::Vector3d sigma = Eigen::Vector3d::Zero();
  // Updates so far: how many times the estimator accepted a new estimate and published it
  // (monotonic). The bench checks the published value at each second in which this grew.
  std::uint64_t updates = 0;
};

struct Estimate {
  Estimate3 gyro_bias;   // rad/s
  Estimate3 accel_bias;  // m/s^2
  Estimate3 hard_iron;   // uT
};

class Estimator {
 public:
  virtual ~Estimator() = default;
  // A reference estimator (the oracle) is told the truth; a calibrator under test never is.
  virtual bool reads_truth() const { return false; }
  // Every sample in order; truth is null unless reads_truth().
  virtual void feed(const sim::LifeSample& s, const sim::LifeTruth* truth) = 0;
  // Called once a simulated second, after the sample that starts the second.
  virtual Estimate estimate() = 0;
  // From now on, write each of its decisions as it makes them to out, one line each starting
  // with "trace <name> " (field_bench --trace); one that cannot tell its decisions writes none.
  virtual void trace(std::FILE* /*out*/, const char* /*name*/) {}
};

// Makes an estimator for a device; sheet holds what the device knows (nominal scales, rates),
// never the truth.
using EstimatorFactory = std::unique_ptr<Estimator> (*)(const sim::DeviceSheet& sheet);

struct EstimatorEntry {
  const char* name;
  const char* description;
  EstimatorFactory make;
};

// The estimators this build has (estimators.cpp).
const std::vector<EstimatorEntry>& estimators();

// The estimators of this build, each a factory in its own file.
std::unique_ptr<Estimator> make_oracle_estimator(const sim::DeviceSheet& sheet);
#ifdef IMUCAL_FIELD_BENCH_CHRE
std::unique_ptr<Estimator> make_chre_estimator(const sim::DeviceSheet& sheet);
#endif
#ifdef IMUCAL_FIELD_BENCH_IMUCAL
std::unique_ptr<Estimator> make_imucal_estimator(const sim::DeviceSheet& sheet);
#endif

}  // namespace imucal::field_bench
