// SPDX-License-Identifier: MIT
// bench/insn/bench_field_lean.cpp: the calibrator of bench_field_lean.hpp.
#include "bench_field_lean.hpp"

#include "markers.hpp"

using namespace imucal;

namespace bench_lean {
namespace {
FieldCalibrator<float, 8, 0, false> calibrator;  // global: no guard, no stack
}  // namespace

Status start(const FieldSettings<float>& settings, const Calibration<float>* prior,
             const TemperatureModel<float>* model) {
  return calibrator.start(settings, prior, model);
}

Status add_raw(const RawFrame& frame, float temperature, bool counted) {
  if (counted) imucal_bench_begin();
  const Status st = calibrator.add_raw(frame, temperature);
  if (counted) imucal_bench_end();
  return st;
}

const FieldCounts& counts() { return calibrator.counts(); }
bool solving() { return calibrator.accel_field().busy(); }
void drop_events() {
  FieldEvent<float> e;
  while (calibrator.take_event(e)) {
  }
}
std::size_t size() { return sizeof(calibrator); }

}  // namespace bench_lean
