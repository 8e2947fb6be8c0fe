// SPDX-License-Identifier: MIT
#include "imucal/status.hpp"

// 1: to_string(Status) gives the description; 0: the number (status.hpp).
#ifndef IMUCAL_STATUS_STRINGS
#define IMUCAL_STATUS_STRINGS 1
#endif

namespace imucal {

#if !IMUCAL_STATUS_STRINGS
namespace {

// "10" to "99", each in 3 characters with its terminator. The last two characters of "1d" are
// the string "d".
struct Numbers {
  char text[90][3];
};
constexpr Numbers numbers() {
  Numbers n{};
  for (int i = 10; i < 100; ++i) {
    n.text[i - 10][0] = static_cast<char>('0' + i / 10);
    n.text[i - 10][1] = static_cast<char>('0' + i % 10);
  }
  return n;
}
constexpr Numbers kNumbers = numbers();

}  // namespace

const char* to_string(Status s) {
  const unsigned i = static_cast<unsigned>(s);
  if (i < 10) return kNumbers.text[i] + 1;
  return i < 100 ? kNumbers.text[i - 10] : "unknown status";
}
#else
const char* to_string(Status s) {
  switch (s) {
    case Status::kOk:
      return "ok";
    case Status::kRunning:
      return "running";
    case Status::kConvergedStep:
      return "converged (step below tolerance)";
    case Status::kConvergedGradient:
      return "converged (gradient below tolerance)";
    case Status::kConvergedCost:
      return "converged (cost no longer decreasing)";
    case Status::kMaxIterations:
      return "stopped at the iteration limit";
    case Status::kNoProgress:
      return "no progress (damping at maximum)";
    case Status::kNotStarted:
      return "solver not started";
    case Status::kNonFiniteInput:
      return "non-finite input (NaN or infinity)";
    case Status::kInvalidArgument:
      return "invalid argument";
    case Status::kCapacityExceeded:
      return "capacity exceeded";
    case Status::kTooFewPoses:
      return "too few poses";
    case Status::kTooFewDistinctPoses:
      return "too few distinct poses";
    case Status::kPosesCoplanar:
      return "poses coplanar (turned about one axis only)";
    case Status::kTooFewResiduals:
      return "too few residuals for a covariance";
    case Status::kRankDeficient:
      return "rank-deficient normal equations";
    case Status::kIllConditioned:
      return "ill-conditioned normal equations";
    case Status::kNotAnEllipsoid:
      return "fitted quadric is not an ellipsoid";
    case Status::kUnobservable:
      return "a parameter is not observable from these poses";
    case Status::kTimeRepeated:
      return "timestamp repeated (sample refused)";
    case Status::kTimeBackwards:
      return "timestamp went backwards (sample refused)";
    case Status::kClockReset:
      return "clock reset (the stream restarts as after a gap)";
    case Status::kTimestampGap:
      return "gap in the timestamps (the move across it is dropped)";
    case Status::kSensorFrozen:
      return "sensor frozen (identical readings)";
    case Status::kInitialRestDisturbed:
      return "moved during the initial rest (restarted)";
    case Status::kRestTooShort:
      return "rest too short to become a pose";
    case Status::kEndedInMotion:
      return "stream ended during a move (move not used)";
    case Status::kTooFewMoves:
      return "too few usable moves between poses";
    case Status::kBusy:
      return "busy solving (sample not taken)";
    case Status::kAccelSaturated:
      return "accelerometer at full scale (taken as motion)";
    case Status::kSampleRateOff:
      return "sample rate far from nominal";
    case Status::kRecordTruncated:
      return "record truncated";
    case Status::kRecordBadMagic:
      return "not a calibration record (bad magic)";
    case Status::kRecordBadVersion:
      return "unknown record format version";
    case Status::kRecordBadLength:
      return "record length or section length invalid";
    case Status::kRecordBadChecksum:
      return "record corrupted (CRC-32 mismatch)";
    case Status::kRecordBadField:
      return "record field out of range";
    case Status::kNoRecord:
      return "no valid record stored";
    case Status::kStorageError:
      return "flash storage error";
    case Status::kStorageVerifyFailed:
      return "flash verify failed (read back differs)";
    case Status::kStorageBusy:
      return "record store busy (another call is running)";
    case Status::kImplausible:
      return "a calibration value outside its physical bounds";
    case Status::kTooFewSamples:
      return "too few samples";
    case Status::kPoorCoverage:
      return "poor coverage of directions (turn the unit through more orientations)";
    case Status::kFieldImplausible:
      return "field strength implausible for the Earth's field (magnetic disturbance or wrong "
             "unit)";
    case Status::kFitPoor:
      return "fit error too large (magnetic disturbance nearby, or motion too fast)";
    case Status::kTemperatureSpanSmall:
      return "temperatures span too little for a slope";
    case Status::kGlitch:
      return "a reading far outside the sensor's running range (refused)";
    case Status::kTemperatureImplausible:
      return "temperature reading not finite or out of range (ignored)";
    case Status::kGyroSaturated:
      return "gyroscope at full scale (refused, the move in progress dropped)";
  }
  return "unknown status";
}
#endif

const char* to_string(Quality q) {
  switch (q) {
    case Quality::kNone:
      return "none";
    case Quality::kPoor:
      return "poor";
    case Quality::kFair:
      return "fair";
    case Quality::kGood:
      return "good";
  }
  return "unknown quality";
}

}  // namespace imucal
