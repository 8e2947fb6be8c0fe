// SPDX-License-Identifier: MIT
// Runs a RestMonitor over a simulated stream (sim::TemperatureStream) and collects the rests it
// hands out, each with the index of the true rest it came from; bad samples can be slipped in
// along the way. Host and targets (header-only, GoogleTest assertions).
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <vector>

#include "imucal/sim/temperature_sim.hpp"
#include "imucal/stream/rest_monitor.hpp"

namespace imucal {
namespace test {

template <typename S>
RestMonitorSettings<S> monitor_settings(const sim::AccelSensorSpec& acc,
                                        const sim::GyroSensorSpec& gyro,
                                        const Vector3<double>& gyro_zero) {
  RestMonitorSettings<S> m;
  // The sums over the axes of the per-axis noise variances (what Calibrator measures), and the
  // raw gyro reading at zero rate when the monitor starts (minus the calibration's bias).
  m.accel_noise = static_cast<S>(3.0 * acc.noise * acc.noise);
  m.gyro_noise = static_cast<S>(3.0 * gyro.noise * gyro.noise);
  m.gyro_rest_reading = gyro_zero.cast<S>();
  return m;
}

template <typename S>
ImuSample<S> cast_sample(const ImuSample<double>& s) {
  ImuSample<S> o;
  o.t_us = s.t_us;
  o.acc = s.acc.cast<S>();
  o.gyro = s.gyro.cast<S>();
  o.temperature = static_cast<S>(s.temperature);
  return o;
}

struct FoundRest {
  RestSummary<double> summary;
  int rest_index;
};

// Feeds the whole stream to a monitor; returns the rests with the index of the true rest each
// came from. Bad samples are slipped in at a few places: they must be refused and change nothing.
template <typename S>
std::vector<FoundRest> run_monitor(sim::TemperatureStream& stream, RestMonitor<S>& monitor,
                                   bool inject_faults) {
  std::vector<FoundRest> found;
  const auto collect = [&]() {
    RestSummary<S> r;
    while (monitor.take(r)) {
      FoundRest f;
      f.summary.accel_mean = r.accel_mean.template cast<double>();
      f.summary.gyro_mean = r.gyro_mean.template cast<double>();
      f.summary.temperature_c = static_cast<double>(r.temperature_c);
      f.summary.has_temperature = r.has_temperature;
      f.summary.samples = r.samples;
      f.summary.duration_s = static_cast<double>(r.duration_s);
      f.summary.begin_us = r.begin_us;
      f.summary.end_us = r.end_us;
      f.rest_index = stream.rest_index();
      found.push_back(f);
    }
  };
  ImuSample<double> s;
  std::uint32_t k = 0, prev_t = 0;
  while (stream.next(s)) {
    const ImuSample<S> x = cast_sample<S>(s);
    if (inject_faults && k > 0 && k % 997 == 0) {
      ImuSample<S> bad = x;
      bad.acc(static_cast<int>(k % 3u)) = std::numeric_limits<S>::quiet_NaN();
      EXPECT_EQ(monitor.add(bad), Status::kNonFiniteInput);
      bad = x;
      bad.gyro(0) = std::numeric_limits<S>::infinity();
      EXPECT_EQ(monitor.add(bad), Status::kNonFiniteInput);
      bad = x;
      bad.t_us = prev_t - 5000;
      EXPECT_EQ(monitor.add(bad), Status::kTimeBackwards);
      bad.t_us = prev_t;
      EXPECT_EQ(monitor.add(bad), Status::kTimeRepeated);
    }
    EXPECT_EQ(monitor.add(x), Status::kOk) << "sample " << k;
    collect();
    prev_t = x.t_us;
    ++k;
  }
  monitor.finish();
  collect();
  return found;
}

}  // namespace test
}  // namespace imucal
