// imucal/status.hpp: the one status type every fallible imucal call returns, and what it means.
// Never allocates, never throws; to_string() returns a static string.
#pragma once

#include <cstdint>

#include "imucal/config.hpp"

namespace imucal {

enum class Status : std::uint8_t {
  kOk = 0,
  // Levenberg-Marquardt progress and why it stopped.
  kRunning,            // one iteration done, not converged yet: call step() again
  kConvergedStep,      // the step fell below the step tolerance
  kConvergedGradient,  // the residual is orthogonal to every Jacobian column (to tolerance)
  kConvergedCost,      // the cost no longer decreases by more than the cost tolerance
  kMaxIterations,      // iteration cap reached before convergence (estimate not trusted)
  kNoProgress,         // damping at its maximum and still no decrease of the cost
  kNotStarted,         // step() called before start()
  // Input.
  kNonFiniteInput,       // NaN or infinity in a reading, weight or parameter
  kInvalidArgument,      // a count, weight or setting out of its range
  kCapacityExceeded,     // a fixed-capacity store is full; nothing was overwritten
  kTooFewPoses,          // fewer poses than parameters
  kTooFewDistinctPoses,  // enough poses, but too many of them point the same way
  kPosesCoplanar,        // all poses in one plane (e.g. turned about a single axis)
  kTooFewResiduals,      // covariance asked with no more residuals than parameters
  // Numerics.
  kRankDeficient,   // the normal matrix is singular (a parameter is not observable)
  kIllConditioned,  // the normal matrix is too close to singular for this scalar type
  kNotAnEllipsoid,  // the closed-form fit found a quadric that is not an ellipsoid
  kUnobservable,    // solved, but a parameter's sigma is too large to call it calibrated
  // The sample stream (streaming calibrator).
  kTimeRepeated,          // the same timestamp as the previous sample: the sample is refused
  kTimeBackwards,         // a timestamp before the previous one: the sample is refused
  kClockReset,            // the clock went back and stayed back: taken, handled as a gap
  kTimestampGap,          // samples missing: the move across the gap is dropped, poses are kept
  kSensorFrozen,          // a sensor repeats the same reading: samples refused until it recovers
  kInitialRestDisturbed,  // the unit moved during the initial rest: it starts again
  kRestTooShort,          // a rest ended before it was long enough to become a pose
  kEndedInMotion,         // the stream stopped during a move: that move is not used
  kTooFewMoves,           // fewer usable moves between poses than the gyro model needs
  kBusy,                  // the calibrator is solving: samples are not taken meanwhile
  kAccelSaturated,        // the accelerometer at its full scale (StreamSettings): taken as motion
  kSampleRateOff,         // the measured sample rate is far from the nominal one (taken)
  // Stored calibration records (record.hpp) and the flash they live in (record_store.hpp).
  kRecordTruncated,      // fewer bytes than the record's length field says
  kRecordBadMagic,       // not a calibration record (or erased flash)
  kRecordBadVersion,     // a format version this decoder does not know (0, or newer)
  kRecordBadLength,      // the length field or a section length is impossible
  kRecordBadChecksum,    // CRC-32 mismatch: the bytes were corrupted
  kRecordBadField,       // checksum right, but a field is out of its range (see error offset)
  kNoRecord,             // no valid record in the store (empty, erased or both slots corrupt)
  kStorageError,         // the flash port failed (read, program, erase, or power lost)
  kStorageVerifyFailed,  // the record read back differs from the one written
  kStorageBusy,          // another call is using the record store: nothing was done
  kImplausible,          // a calibration value outside its physical bounds (which: bound_name)
  // Magnetometer (mag_calibration.hpp) and temperature (temperature_fit.hpp) fits.
  kTooFewSamples,         // fewer samples (or rests) than the fit needs
  kPoorCoverage,          // the directions held do not cover enough of the sphere
  kFieldImplausible,      // fitted field strength outside the configured Earth-field bounds
  kFitPoor,               // the fit's residual error is above the configured limit
  kTemperatureSpanSmall,  // the rests' temperatures span too little for a slope
  // Stream (calibrator.hpp), continued.
  kGlitch,                  // a reading far outside its sensor's running range: refused
  kTemperatureImplausible,  // a temperature non-finite or out of range: ignored, sample taken
  kGyroSaturated,           // the gyro at its full scale (StreamSettings): the sample is refused
};

// How far to trust a calibration, from its sigmas, residuals and coverage.
enum class Quality : std::uint8_t { kNone, kPoor, kFair, kGood };

// True for the statuses that mean "this estimate is usable".
constexpr bool succeeded(Status s) {
  return s == Status::kOk || s == Status::kConvergedStep || s == Status::kConvergedGradient ||
         s == Status::kConvergedCost;
}

// Short English description, e.g. "poses coplanar". Static storage, never null.
const char* to_string(Status s);

// The quality's name: "none", "poor", "fair" or "good" (the JSON's and the summary's word).
// Static storage, never null.
const char* to_string(Quality q);

}  // namespace imucal
