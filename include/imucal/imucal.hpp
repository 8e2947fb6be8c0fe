// imucal/imucal.hpp: the umbrella header. imucal calibrates MEMS inertial sensors on the device:
// fixed memory, float arithmetic, no heap, no exceptions, no RTTI, no blocking calls.
#pragma once

#include "imucal/accel_calibration.hpp"
#include "imucal/accel_model.hpp"
#include "imucal/allan.hpp"
#include "imucal/calibrator.hpp"
#include "imucal/corrector.hpp"
#include "imucal/gyro_calibration.hpp"
#include "imucal/gyro_model.hpp"
#include "imucal/gyro_segment.hpp"
#include "imucal/levenberg_marquardt.hpp"
#include "imucal/mag_calibration.hpp"
#include "imucal/mag_model.hpp"
#include "imucal/normal_equations.hpp"
#include "imucal/pose_store.hpp"
#include "imucal/record.hpp"
#include "imucal/record_store.hpp"
#include "imucal/rest_monitor.hpp"
#include "imucal/status.hpp"
#include "imucal/temperature_fit.hpp"
#include "imucal/temperature_model.hpp"
