// SPDX-License-Identifier: MIT
// imucal/stream/rest_summary.hpp: what the stream layer hands out for each rest it finds: mean raw
// readings, mean temperature, length. SampleBlock::summary() (blocks.hpp) makes it; the
// temperature fit takes it. Plain data, no code.
#pragma once

#include <cstdint>

#include "imucal/types.hpp"

namespace imucal {

// One rest: mean raw readings, mean temperature and length. The streaming calibrator gives one
// per pose (Calibrator::last_rest()); RestMonitor finds them in the field.
template <typename Scalar>
struct RestSummary {
  Vector3<Scalar> accel_mean = Vector3<Scalar>::Zero();  // raw units
  Vector3<Scalar> gyro_mean = Vector3<Scalar>::Zero();   // raw units
  Scalar temperature_c = Scalar(0);
  bool has_temperature = false;
  std::uint32_t samples = 0;
  Scalar duration_s = Scalar(0);
  std::uint32_t begin_us = 0, end_us = 0;  // timestamps of its first and last sample
  // RestMonitor: motion, a cut in the stream or the stream's start came between the rest before
  // and this one. False: this rest continues the one before (split at max_rest_seconds or by a
  // slow tilt), with no motion the detector saw in between.
  bool after_motion = true;
};

}  // namespace imucal
