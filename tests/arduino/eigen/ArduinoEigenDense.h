// SPDX-License-Identifier: MIT
// A stand-in for the Arduino "Eigen" library's entry header (tools/arduino/build_sketch.sh): as
// that library does, it includes the core, replaces the core's macros that Eigen's code would
// trip over (abs, B0, B1) and includes Eigen from its ArduinoEigen/Eigen folder (here a link to
// Debian's Eigen 3.4).
#pragma once

#include <Arduino.h>

#ifdef abs
#undef abs
#endif
#ifdef B0
#undef B0
#endif
#ifdef B1
#undef B1
#endif

#include "ArduinoEigen/Eigen/Dense"
