// SPDX-License-Identifier: MIT
// imucal/status.hpp: the one status type every fallible imucal call returns, and what it means.
// Never allocates, never throws; to_string() returns a static string.
//
// Each status keeps its number in every version (new ones are appended): a number a firmware
// logged reads the same later.
#pragma once

#include <cstdint>

#include "imucal/config.hpp"

namespace imucal {

enum class Status : std::uint8_t {
  kOk = 0,
  // Levenberg-Marquardt progress and why it stopped.
  kRunning = 1,            // one iteration done, not converged yet: call step() again
  kConvergedStep = 2,      // the step fell below the step tolerance
  kConvergedGradient = 3,  // the residual is orthogonal to every Jacobian column (to tolerance)
  kConvergedCost = 4,      // the cost no longer decreases by more than the cost tolerance
  kMaxIterations = 5,      // iteration cap reached before convergence (estimate not trusted)
  kNoProgress = 6,         // damping at its maximum and still no decrease of the cost
  kNotStarted = 7,         // step() called before start()
  // Input.
  kNonFiniteInput = 8,        // NaN or infinity in a reading, weight or parameter
  kInvalidArgument = 9,       // a count, weight or setting out of its range
  kCapacityExceeded = 10,     // a fixed-capacity store is full; nothing was overwritten
  kTooFewPoses = 11,          // fewer poses than parameters
  kTooFewDistinctPoses = 12,  // enough poses, but too many of them point the same way
  kPosesCoplanar = 13,        // all poses in one plane (e.g. turned about a single axis)
  kTooFewResiduals = 14,      // covariance asked with no more residuals than parameters
  // Numerics.
  kRankDeficient = 15,   // the normal matrix is singular (a parameter is not observable)
  kIllConditioned = 16,  // the normal matrix is too close to singular for this scalar type
  kNotAnEllipsoid = 17,  // the closed-form fit found a quadric that is not an ellipsoid
  kUnobservable = 18,    // solved, but a parameter's sigma is too large to call it calibrated
  // The sample stream (streaming calibrator).
  kTimeRepeated = 19,   // the same timestamp as the previous sample: the sample is refused
  kTimeBackwards = 20,  // a timestamp before the previous one: the sample is refused
  kClockReset = 21,     // the clock went back and stayed back: taken, handled as a gap
  kTimestampGap = 22,   // samples missing: the move across the gap is dropped, poses are kept
  kSensorFrozen = 23,   // a sensor repeats the same reading: samples refused until it recovers
  kInitialRestDisturbed = 24,  // the unit moved during the initial rest: it starts again
  kRestTooShort = 25,          // a rest ended before it was long enough to become a pose
  kEndedInMotion = 26,         // the stream stopped during a move: that move is not used
  kTooFewMoves = 27,           // fewer usable moves between poses than the gyro model needs
  kBusy = 28,                  // the calibrator is solving: samples are not taken meanwhile
  kAccelSaturated = 29,  // the accelerometer at its full scale (StreamSettings): taken as motion
  kSampleRateOff = 30,   // the measured sample rate is far from the nominal one (taken)
  // Stored calibration records (record.hpp) and the flash they live in (record_store.hpp).
  kRecordTruncated = 31,      // fewer bytes than the record's length field says
  kRecordBadMagic = 32,       // not a calibration record (or erased flash)
  kRecordBadVersion = 33,     // a format version this decoder does not know (0, or newer)
  kRecordBadLength = 34,      // the length field or a section length is impossible
  kRecordBadChecksum = 35,    // CRC-32 mismatch: the bytes were corrupted
  kRecordBadField = 36,       // checksum right, but a field is out of its range (see error offset)
  kNoRecord = 37,             // no valid record in the store (empty, erased or both slots corrupt)
  kStorageError = 38,         // the flash port failed (read, program, erase, or power lost)
  kStorageVerifyFailed = 39,  // the record read back differs from the one written
  kStorageBusy = 40,          // another call is using the record store: nothing was done
  kImplausible = 41,          // a calibration value outside its physical bounds (which: bound_name)
  // Magnetometer (mag_calibration.hpp) and temperature (temperature_fit.hpp) fits.
  kTooFewSamples = 42,         // fewer samples (or rests) than the fit needs
  kPoorCoverage = 43,          // the directions held do not cover enough of the sphere
  kFieldImplausible = 44,      // fitted field strength outside the configured Earth-field bounds
  kFitPoor = 45,               // the fit's residual error is above the configured limit
  kTemperatureSpanSmall = 46,  // the rests' temperatures span too little for a slope
  // Stream (calibrator.hpp), continued.
  kGlitch = 47,                  // a reading far outside its sensor's running range: refused
  kTemperatureImplausible = 48,  // a temperature non-finite or out of range: ignored, sample taken
  kGyroSaturated = 49,  // the gyro at its full scale (StreamSettings): the sample is refused
};

// How far to trust a calibration, from its sigmas, residuals and coverage.
enum class Quality : std::uint8_t { kNone, kPoor, kFair, kGood };

// True for the statuses that mean "this estimate is usable".
constexpr bool succeeded(Status s) {
  return s == Status::kOk || s == Status::kConvergedStep || s == Status::kConvergedGradient ||
         s == Status::kConvergedCost;
}

// Short English description, e.g. "poses coplanar". Static storage, never null.
// A firmware short of flash compiles lib/status.cpp with IMUCAL_STATUS_STRINGS=0: to_string()
// then gives the status's number ("13"; 2 KB less code), the description being the one above.
const char* to_string(Status s);

// The quality's name: "none", "poor", "fair" or "good" (the JSON's and the summary's word).
// Static storage, never null.
const char* to_string(Quality q);

}  // namespace imucal
