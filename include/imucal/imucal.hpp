// SPDX-License-Identifier: MIT
// imucal/imucal.hpp: the umbrella header. imucal calibrates MEMS inertial sensors on the device:
// fixed memory, float arithmetic, no heap, no exceptions, no RTTI, no blocking calls.
#pragma once

#include "imucal/calibrator/calibrator.hpp"
#include "imucal/corrector.hpp"
#include "imucal/field/field_calibrator.hpp"
#include "imucal/field/field_store.hpp"
#include "imucal/magnetometer/mag_calibration.hpp"
#include "imucal/models/accel_model.hpp"
#include "imucal/models/gyro_model.hpp"
#include "imucal/models/mag_model.hpp"
#include "imucal/models/temperature_model.hpp"
#include "imucal/noise/allan.hpp"
#include "imucal/solve/accel_calibration.hpp"
#include "imucal/solve/gyro_calibration.hpp"
#include "imucal/solve/levenberg_marquardt.hpp"
#include "imucal/solve/normal_equations.hpp"
#include "imucal/solve/pose_store.hpp"
#include "imucal/status.hpp"
#include "imucal/store/record.hpp"
#include "imucal/store/record_store.hpp"
#include "imucal/stream/gyro_segment.hpp"
#include "imucal/stream/rest_monitor.hpp"
#include "imucal/temperature/temperature_fit.hpp"
#include "imucal/version.hpp"
