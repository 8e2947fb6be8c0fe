// SPDX-License-Identifier: MIT
// bench/field/estimators.cpp: the estimators the field bench can run, by name.
#include "estimator.hpp"

namespace imucal::field_bench {

const std::vector<EstimatorEntry>& estimators() {
  static const std::vector<EstimatorEntry> list = {
#ifdef IMUCAL_FIELD_BENCH_IMUCAL
      {"imucal", "imucal's field calibrator (bench/field/imucal_estimator.cpp)",
       make_imucal_estimator},
#endif
#ifdef IMUCAL_FIELD_BENCH_CHRE
      {"chre", "Android CHRE: gyro_cal + over_temp_cal, accel_cal, mag_cal with Android's settings",
       make_chre_estimator},
#endif
      {"oracle",
       "told when the board is truly still: the mean gyro of each true rest (its last 10 s), held",
       make_oracle_estimator},
  };
  return list;
}

}  // namespace imucal::field_bench
