// SPDX-License-Identifier: MIT
// imucal/store/record.hpp: the calibration record, the bytes the firmware keeps in flash. Encoded
// field by field (little-endian, IEEE-754 binary32), so it does not depend on the compiler's
// struct layout or the CPU's byte order; decoding validates every byte and says what is wrong.
// Never allocates, never throws; float only (the device type).
//
// Format version 1 (all integers little-endian, all reals IEEE-754 binary32):
//
//   offset  size  field
//        0     4  magic "IMCR" (0x49 0x4D 0x43 0x52)
//        4     1  format version (1)
//        5     1  reserved, 0
//        6     2  total length N in bytes, CRC included
//        8     4  device id (the firmware's choice, e.g. a serial number)
//       12     4  sensor id (e.g. the IMU's WHO_AM_I and bus address)
//       16     2  parts present: bit 0 accelerometer, bit 1 gyroscope, bit 2 magnetometer,
//                   bit 3 temperature model (other bits: a newer format's, skipped)
//       18     2  reserved, 0
//       20   ...  sections, each: tag (1), reserved 0 (1), payload length L (2), payload (L)
//      N-4     4  CRC-32 (IEEE 802.3, as zlib's crc32) of bytes [0, N-4)
//
//   tag 1, info (12 bytes, always present): quality (1: 0 none .. 3 good), flags (1: bit 0
//          temperature known), reserved 0 (2), temperature at calibration in deg C (4), sample
//          rate in Hz (4; 0 if unknown)
//   tag 2, accelerometer (80 bytes, iff parts bit 0): poses (2), reserved 0 (2), the 9
//          parameters in accel_model.hpp's order (36), their sigmas (36), pose residual RMS (4)
//   tag 3, gyroscope (104 bytes, iff parts bit 1): moves (2), flags (1: bit 0 bias refined),
//          reserved 0 (1), the 12 parameters in gyro_model.hpp's order (48), sigmas (48),
//          move residual RMS (4)
//   tag 4, magnetometer (108 bytes, iff parts bit 2): samples (2), quality (1), flags (1: bit 0
//          aligned to the accelerometer frame), soft iron S row by row (36), hard iron h (12),
//          sigma of h (12), sigma of the symmetric S in mag_model.hpp's order (24), field in uT
//          (4), fit error in % (4), coverage 0..1 (4), dip in degrees (4), its sigma (4)
//   tag 5, temperature model (112 bytes linear, 160 quadratic, iff parts bit 3): order (1: 1 or
//          2), flags (1: bit 0 accelerometer model usable, bit 1 gyro model usable, each only
//          with its sensor's part: a model of neither sensor in the record is refused, the
//          coefficients of a sensor not in it are left out), rests (2), reference temperature
//          T0, lowest and highest temperature fitted (12, deg C), then for the accelerometer and
//          then the gyro: b0, b1 (and b2 if quadratic) (3 each), then their sigmas in the same
//          order; an unusable sensor's values are zeros
//
// Sizes: accelerometer and gyro 232 bytes; with the magnetometer 344; with a linear temperature
// model too 460, quadratic 508.
//
// How the format grows (and older records keep decoding): new content comes as new sections
// (new tags, new parts bits) or as fields appended to a section's payload; a decoder reads the
// fields it knows, skips sections it does not know (counted in unknown_sections) and ignores a
// payload's unknown tail. A record without a newer section simply lacks that part. The version
// changes only if the header itself changes; a decoder refuses versions newer than its own.
#pragma once

#include <cstddef>
#include <cstdint>

#include "imucal/models/calibration.hpp"
#include "imucal/models/mag_model.hpp"
#include "imucal/models/plausibility.hpp"
#include "imucal/models/temperature_model.hpp"
#include "imucal/status.hpp"

namespace imucal {

constexpr std::uint8_t kRecordVersion = 1;
constexpr std::size_t kRecordHeaderBytes = 20;
// The largest record a decoder accepts (version 1 with every part: 508 bytes at most; the
// remaining room is for appended fields). Buffers and flash slots are sized with it.
constexpr std::size_t kRecordMaxBytes = 512;

enum RecordPart : std::uint16_t {
  kRecordAccel = 1u << 0,
  kRecordGyro = 1u << 1,
  kRecordMag = 1u << 2,
  kRecordTemperature = 1u << 3,
};

// What a record holds: the calibration (quality, sample rate and temperature included) and
// who it belongs to. The parts absent from `parts` keep status kNotStarted and zeros.
struct CalibrationRecord {
  // Out of line (record.cpp): one copy of the member-wise code, whoever copies a record.
  CalibrationRecord();
  CalibrationRecord(const CalibrationRecord& other);
  CalibrationRecord& operator=(const CalibrationRecord& other);

  std::uint8_t version = kRecordVersion;  // of the decoded bytes (encode writes kRecordVersion)
  std::uint32_t device_id = 0;
  std::uint32_t sensor_id = 0;
  std::uint16_t parts = 0;
  Calibration<float> calibration{};
  MagCalibration<float> mag{};            // iff parts & kRecordMag
  TemperatureModel<float> temperature{};  // iff parts & kRecordTemperature
  int unknown_sections = 0;               // decode only: sections of a newer format, skipped

 private:
  // The members' Eigen matrices left unset (their own constructor does not set them): the public
  // constructors write every byte after it.
  struct Blank {};
  explicit CalibrationRecord(Blank);
};

// The record of a calibration: its usable parts (succeeded status, finite values) and quality,
// and, if given and usable, the magnetometer's calibration. kInvalidArgument if no part is usable
// or a value does not fit the format (counts above 65535, a non-positive scale, a negative sigma,
// non-finite values); kImplausible if a value is outside its physical bounds (plausibility.hpp),
// *bound (if given) saying which (kNone otherwise).
// The temperature model, if given, is a part only beside a sensor it models (its coefficients
// are bounded through that sensor's matrix and the corrector applies them to no other): the
// coefficients of the sensors in the record are kept, the others left out, and a model of none
// of them is not recorded (so no record holds a temperature model alone); its rest count is
// recorded up to 65535. A model that cannot go in costs only itself: out of its bounds (a range
// beyond -100..200 degC, a slope too steep, NaN) or not fitting the format (an order other than
// 1 or 2, a negative sigma), it is left out, the rest recorded with kOk, and *bound names the
// bound it broke (kNone for a format misfit); out.parts says whether it went in.
// The temperature at calibration is a note, not a parameter: one that is not finite or outside
// -100..200 degC is recorded as unknown (has_temperature false) rather than losing the
// calibration.
template <typename Scalar>
Status make_record(const Calibration<Scalar>& calibration, std::uint32_t device_id,
                   std::uint32_t sensor_id, CalibrationRecord& out,
                   const MagCalibration<Scalar>* mag = nullptr,
                   const TemperatureModel<Scalar>* temperature = nullptr, Bound* bound = nullptr);

// The first physical bound (plausibility.hpp) a record's parts break, kNone if none: the
// accelerometer, the gyro, the magnetometer, then the temperature model (its biases through
// the matrices of the sensors in the record).
Bound record_bound(const CalibrationRecord& record);

// Writes the record into out[0, capacity); *size receives its length. kInvalidArgument for an
// inconsistent record (the checks of decode_record; a temperature model's usable coefficients
// for a sensor not in the record among them), kImplausible for a value outside its
// physical bounds (record_bound() says which), kCapacityExceeded if it does not fit.
Status encode_record(const CalibrationRecord& record, std::uint8_t* out, std::size_t capacity,
                     std::size_t* size);

// Reads a record from data[0, size) (bytes after the record's own length are ignored, as in a
// flash slot). On success `out` holds it; otherwise `out` is unchanged and, if error_offset is
// given, it receives the offset of the first byte found wrong (for a CRC mismatch: N - 4). A
// value outside its physical bounds is kRecordBadField at its section's payload, *bound (if
// given) saying which bound.
Status decode_record(const std::uint8_t* data, std::size_t size, CalibrationRecord& out,
                     std::size_t* error_offset = nullptr, Bound* bound = nullptr);

// CRC-32 (IEEE 802.3, reflected 0xEDB88320, as zlib's crc32()); `crc` continues a previous
// value (start with 0). Table-free nibble loop: 64 bytes of constants.
std::uint32_t crc32(const std::uint8_t* data, std::size_t size, std::uint32_t crc = 0);

}  // namespace imucal
