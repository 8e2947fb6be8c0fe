// SPDX-License-Identifier: MIT
// bench/insn/bench_field_lean.hpp: bench_field_insn's calibrator built without the gyro's matrix
// and the magnetometer (FieldCalibrator<float, 8, 0, false>), compiled in a translation unit of
// its own (bench_field_lean.cpp), as a firmware builds one configuration: the other calibrators'
// code in bench_field.cpp is compiled (inlined) as it is without it.
#pragma once

#include <cstddef>
#include <cstdint>

#include "imucal/field/field_calibrator.hpp"

namespace bench_lean {

imucal::Status start(const imucal::FieldSettings<float>& settings,
                     const imucal::Calibration<float>* prior,
                     const imucal::TemperatureModel<float>* model);
// add_raw(), a counted region of its own if counted.
imucal::Status add_raw(const imucal::RawFrame& frame, float temperature, bool counted);
const imucal::FieldCounts& counts();
bool solving();      // a model's solve is under way
void drop_events();  // every event waiting is taken
std::size_t size();  // sizeof the calibrator

}  // namespace bench_lean
