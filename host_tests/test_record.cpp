// SPDX-License-Identifier: MIT
// The calibration record: round trip, the pinned version-1 bytes, every single-byte corruption
// and every truncation detected, each field validated, and records of a grown format decoding.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <initializer_list>
#include <limits>
#include <new>

#include "imucal/corrector.hpp"
#include "imucal/store/record.hpp"
#include "support/example_calibration.hpp"
#include "support/gtest_status.hpp"

namespace imucal {
namespace {

using test::example_calibration;
using test::example_mag;
using test::example_temperature;

CalibrationRecord example_record() {
  CalibrationRecord r;
  EXPECT_EQ(make_record(example_calibration(), 0x12345678u, 0x00006A68u, r), Status::kOk);
  return r;
}

// Every part: accelerometer, gyro, magnetometer and a temperature model of the given order.
CalibrationRecord full_record(int order) {
  CalibrationRecord r;
  const MagCalibration<double> mag = example_mag();
  const TemperatureModel<double> t = example_temperature(order);
  EXPECT_EQ(make_record(example_calibration(), 0x12345678u, 0x00006A68u, r, &mag, &t), Status::kOk);
  return r;
}

struct Encoded {
  std::uint8_t bytes[kRecordMaxBytes] = {};
  std::size_t size = 0;
};

Encoded encode(const CalibrationRecord& r) {
  Encoded e;
  EXPECT_EQ(encode_record(r, e.bytes, sizeof e.bytes, &e.size), Status::kOk);
  return e;
}

void store_u32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
// Makes the CRC right again after a deliberate edit (to reach the field checks).
void reseal(Encoded& e) { store_u32(e.bytes + e.size - 4, crc32(e.bytes, e.size - 4)); }

void expect_same(const CalibrationRecord& a, const CalibrationRecord& b) {
  EXPECT_EQ(a.device_id, b.device_id);
  EXPECT_EQ(a.sensor_id, b.sensor_id);
  EXPECT_EQ(a.parts, b.parts);
  const Calibration<float>&x = a.calibration, &y = b.calibration;
  EXPECT_EQ(x.quality, y.quality);
  EXPECT_EQ(x.has_temperature, y.has_temperature);
  EXPECT_EQ(x.temperature_c, y.temperature_c);
  EXPECT_EQ(x.sample_rate_hz, y.sample_rate_hz);
  if (a.parts & kRecordAccel) {
    EXPECT_EQ(x.accel.params, y.accel.params);
    EXPECT_EQ(x.accel.sigma, y.accel.sigma);
    EXPECT_EQ(x.accel.residual_rms, y.accel.residual_rms);
    EXPECT_EQ(x.accel.poses, y.accel.poses);
  }
  if (a.parts & kRecordGyro) {
    EXPECT_EQ(x.gyro.params, y.gyro.params);
    EXPECT_EQ(x.gyro.sigma, y.gyro.sigma);
    EXPECT_EQ(x.gyro.residual_rms, y.gyro.residual_rms);
    EXPECT_EQ(x.gyro.moves, y.gyro.moves);
    EXPECT_EQ(x.gyro.bias_refined, y.gyro.bias_refined);
  }
  if (a.parts & kRecordMag) {
    const MagCalibration<float>&m = a.mag, &n = b.mag;
    EXPECT_EQ(m.soft_iron, n.soft_iron);
    EXPECT_EQ(m.hard_iron, n.hard_iron);
    EXPECT_EQ(m.hard_iron_sigma, n.hard_iron_sigma);
    EXPECT_EQ(m.soft_iron_sigma, n.soft_iron_sigma);
    EXPECT_EQ(m.field_ut, n.field_ut);
    EXPECT_EQ(m.fit_error_pct, n.fit_error_pct);
    EXPECT_EQ(m.coverage, n.coverage);
    EXPECT_EQ(m.samples, n.samples);
    EXPECT_EQ(m.quality, n.quality);
    EXPECT_EQ(succeeded(m.alignment_status), succeeded(n.alignment_status));
    EXPECT_EQ(m.dip_deg, n.dip_deg);
    EXPECT_EQ(m.dip_sigma_deg, n.dip_sigma_deg);
  }
  if (a.parts & kRecordTemperature) {
    const TemperatureModel<float>&s = a.temperature, &t = b.temperature;
    EXPECT_EQ(s.order, t.order);
    EXPECT_EQ(s.reference_c, t.reference_c);
    EXPECT_EQ(s.min_c, t.min_c);
    EXPECT_EQ(s.max_c, t.max_c);
    EXPECT_EQ(s.rests, t.rests);
    for (const auto* p : {&s.accel, &s.gyro}) {
      const auto* q = p == &s.accel ? &t.accel : &t.gyro;
      EXPECT_EQ(succeeded(p->status), succeeded(q->status));
      EXPECT_EQ(p->b0, q->b0);
      EXPECT_EQ(p->b1, q->b1);
      EXPECT_EQ(p->b2, q->b2);
      EXPECT_EQ(p->b0_sigma, q->b0_sigma);
      EXPECT_EQ(p->b1_sigma, q->b1_sigma);
      EXPECT_EQ(p->b2_sigma, q->b2_sigma);
    }
  }
}

// Whether value holds T's defaults: T default-constructed in zeroed storage (its initialisers
// written; what it leaves unset, such as an Eigen matrix without an initialiser, and the padding
// stay zero, as CalibrationRecord() leaves them), compared byte for byte.
template <class T>
bool holds_defaults(const T& value) {
  alignas(T) unsigned char storage[sizeof(T)];
  std::memset(storage, 0, sizeof storage);
  const T* fresh = new (storage) T;
  return std::memcmp(static_cast<const void*>(fresh), static_cast<const void*>(&value),
                     sizeof(T)) == 0;
}

// CalibrationRecord() zero-fills and sets the few defaults that are not zero (record.cpp): they
// must be the members' own, whatever member is added or default changed.
TEST(Record, DefaultsAreTheMembersOwn) {
  const CalibrationRecord r;
  EXPECT_EQ(r.version, kRecordVersion);
  EXPECT_EQ(r.device_id, 0u);
  EXPECT_EQ(r.sensor_id, 0u);
  EXPECT_EQ(r.parts, 0u);
  EXPECT_EQ(r.unknown_sections, 0);
  EXPECT_TRUE(holds_defaults(r.calibration));
  EXPECT_TRUE(holds_defaults(r.mag));
  EXPECT_TRUE(holds_defaults(r.temperature));
  const CalibrationRecord copy(r);
  EXPECT_EQ(std::memcmp(static_cast<const void*>(&copy), static_cast<const void*>(&r), sizeof r),
            0);
}

TEST(Crc32, MatchesTheStandardCheckValue) {
  const char* check = "123456789";
  const auto* p = reinterpret_cast<const std::uint8_t*>(check);
  EXPECT_EQ(crc32(p, 9), 0xCBF43926u);  // the catalogue's check value for CRC-32/ISO-HDLC
  EXPECT_EQ(crc32(p + 4, 5, crc32(p, 4)), 0xCBF43926u);  // continued
  EXPECT_EQ(crc32(p, 0), 0u);
}

TEST(Record, RoundTripKeepsEveryField) {
  const CalibrationRecord r = example_record();
  EXPECT_EQ(r.parts, kRecordAccel | kRecordGyro);
  const Encoded e = encode(r);
  EXPECT_EQ(e.size, 232u);
  CalibrationRecord back;
  ASSERT_EQ(decode_record(e.bytes, e.size, back), Status::kOk);
  expect_same(r, back);
  EXPECT_EQ(back.version, 1);
  EXPECT_EQ(back.unknown_sections, 0);
  EXPECT_EQ(back.calibration.accel.status, Status::kOk);
  // The values are the double calibration's, rounded once to float.
  const Calibration<double> c = example_calibration();
  for (int i = 0; i < kAccelParams; ++i)
    EXPECT_EQ(back.calibration.accel.params(i), static_cast<float>(c.accel.params(i)));
  // Bytes after the record (the rest of a flash slot) are ignored.
  Encoded longer = e;
  std::memset(longer.bytes + e.size, 0xFF, sizeof longer.bytes - e.size);
  EXPECT_EQ(decode_record(longer.bytes, sizeof longer.bytes, back), Status::kOk);
}

TEST(Record, OnePartOnly) {
  Calibration<double> c = example_calibration();
  c.gyro.status = Status::kTooFewMoves;  // the accelerometer alone is still worth keeping
  c.has_temperature = false;
  CalibrationRecord r;
  ASSERT_EQ(make_record(c, 1, 2, r), Status::kOk);
  EXPECT_EQ(r.parts, kRecordAccel);
  const Encoded e = encode(r);
  EXPECT_EQ(e.size, 232u - 108u);
  CalibrationRecord back;
  ASSERT_EQ(decode_record(e.bytes, e.size, back), Status::kOk);
  expect_same(r, back);
  EXPECT_EQ(back.calibration.gyro.status, Status::kNotStarted);
  EXPECT_FALSE(back.calibration.has_temperature);
  // Nothing usable: no record.
  c.accel.status = Status::kPosesCoplanar;
  EXPECT_EQ(make_record(c, 1, 2, r), Status::kInvalidArgument);
}

// Version 1 as first written (2026-11-22). These bytes must decode to these values for as long
// as the format exists: change the encoder and this test says which old records would break.
constexpr std::uint8_t kVersion1[] = {
#include "support/record_v1_bytes.inc"
};

TEST(Record, Version1BytesStayReadable) {
  CalibrationRecord back;
  ASSERT_EQ(decode_record(kVersion1, sizeof kVersion1, back), Status::kOk);
  expect_same(example_record(), back);
  // And today's encoder still writes exactly them.
  const Encoded e = encode(example_record());
  ASSERT_EQ(e.size, sizeof kVersion1);
  EXPECT_EQ(std::memcmp(e.bytes, kVersion1, e.size), 0);
}

// Every part, both model orders: the sizes record.hpp states, every value back bit for bit.
TEST(Record, MagnetometerAndTemperatureRoundTrip) {
  for (int order : {1, 2}) {
    const CalibrationRecord r = full_record(order);
    EXPECT_EQ(r.parts, kRecordAccel | kRecordGyro | kRecordMag | kRecordTemperature);
    const Encoded e = encode(r);
    EXPECT_EQ(e.size, order == 1 ? 460u : 508u);
    CalibrationRecord back;
    ASSERT_EQ(decode_record(e.bytes, e.size, back), Status::kOk);
    expect_same(r, back);
    EXPECT_EQ(back.unknown_sections, 0);
  }
  // The magnetometer alone with the two inertial parts: 344 bytes; a temperature model with
  // only the gyro usable keeps the accelerometer's coefficients out (zeros, not started).
  CalibrationRecord r;
  const MagCalibration<double> mag = example_mag();
  TemperatureModel<double> t = example_temperature(1);
  t.accel.status = Status::kRankDeficient;
  ASSERT_EQ(make_record(example_calibration(), 1, 2, r, &mag), Status::kOk);
  EXPECT_EQ(encode(r).size, 344u);
  ASSERT_EQ(make_record(example_calibration(), 1, 2, r, &mag, &t), Status::kOk);
  const Encoded e = encode(r);
  CalibrationRecord back;
  ASSERT_EQ(decode_record(e.bytes, e.size, back), Status::kOk);
  EXPECT_FALSE(succeeded(back.temperature.accel.status));
  EXPECT_TRUE(back.temperature.accel.b0.isZero(0.0f));
  EXPECT_TRUE(succeeded(back.temperature.gyro.status));
  EXPECT_EQ(back.temperature.gyro.b1, t.gyro.b1.cast<float>());
  // Unusable parts are left out, not refused.
  t.gyro.status = Status::kTooFewSamples;
  MagCalibration<double> bad_mag = mag;
  bad_mag.status = Status::kPoorCoverage;
  ASSERT_EQ(make_record(example_calibration(), 1, 2, r, &bad_mag, &t), Status::kOk);
  EXPECT_EQ(r.parts, kRecordAccel | kRecordGyro);
}

// Every part, as first written: the magnetometer and temperature sections are pinned like
// version 1's.
constexpr std::uint8_t kEveryPart[] = {
#include "support/record_full_bytes.inc"
};

TEST(Record, EveryPartBytesStayReadable) {
  CalibrationRecord back;
  ASSERT_EQ(decode_record(kEveryPart, sizeof kEveryPart, back), Status::kOk);
  expect_same(full_record(2), back);
  const Encoded e = encode(full_record(2));
  ASSERT_EQ(e.size, sizeof kEveryPart);
  EXPECT_EQ(std::memcmp(e.bytes, kEveryPart, e.size), 0);
}

TEST(Record, EverySingleByteCorruptionIsDetected) {
  for (const Encoded& e : {encode(example_record()), encode(full_record(2))}) {
    int cases = 0;
    for (std::size_t at = 0; at < e.size; ++at) {
      for (int v = 0; v < 256; ++v) {
        if (v == e.bytes[at]) continue;
        Encoded bad = e;
        bad.bytes[at] = static_cast<std::uint8_t>(v);
        CalibrationRecord out;
        out.device_id = 777;
        std::size_t where = 9999;
        const Status s = decode_record(bad.bytes, bad.size, out, &where);
        ++cases;
        if (s == Status::kOk) {
          ADD_FAILURE() << "byte " << at << " = " << v << " accepted";
          return;
        }
        EXPECT_EQ(out.device_id, 777u);  // the output is untouched on failure
        EXPECT_LE(where, e.size);
      }
    }
    EXPECT_EQ(cases, static_cast<int>(e.size) * 255);
  }
}

TEST(Record, EveryTruncationIsDetected) {
  for (const Encoded& e : {encode(example_record()), encode(full_record(1))})
    for (std::size_t n = 0; n < e.size; ++n) {
      CalibrationRecord out;
      std::size_t where = 9999;
      EXPECT_EQ(decode_record(e.bytes, n, out, &where), Status::kRecordTruncated) << n;
      EXPECT_EQ(where, n);
    }
  // A length field pointing beyond the bytes given is a truncation too, not a checksum error.
}

TEST(Record, HeaderErrorsSayWhatIsWrong) {
  const Encoded e = encode(example_record());
  CalibrationRecord out;
  std::size_t where = 0;
  Encoded bad = e;
  bad.bytes[2] = 'X';
  EXPECT_EQ(decode_record(bad.bytes, bad.size, out, &where), Status::kRecordBadMagic);
  EXPECT_EQ(where, 2u);
  std::uint8_t erased[kRecordMaxBytes];
  std::memset(erased, 0xFF, sizeof erased);
  EXPECT_EQ(decode_record(erased, sizeof erased, out), Status::kRecordBadMagic);
  bad = e;
  bad.bytes[4] = 2;  // a newer format
  EXPECT_EQ(decode_record(bad.bytes, bad.size, out, &where), Status::kRecordBadVersion);
  EXPECT_EQ(where, 4u);
  bad.bytes[4] = 0;
  EXPECT_EQ(decode_record(bad.bytes, bad.size, out), Status::kRecordBadVersion);
  bad = e;
  bad.bytes[6] = 10;  // shorter than any record
  bad.bytes[7] = 0;
  EXPECT_EQ(decode_record(bad.bytes, bad.size, out, &where), Status::kRecordBadLength);
  EXPECT_EQ(where, 6u);
  bad = e;
  bad.bytes[100] ^= 0x01;
  EXPECT_EQ(decode_record(bad.bytes, bad.size, out, &where), Status::kRecordBadChecksum);
  EXPECT_EQ(where, e.size - 4);
  EXPECT_EQ(decode_record(nullptr, 10, out), Status::kInvalidArgument);
}

// Offsets of version 1 (record.hpp): header 20, info section at 20 (payload 24), accelerometer
// section at 36 (payload 40), gyro section at 120 (payload 124).
struct FieldCase {
  const char* what;
  std::size_t at;
  std::uint32_t value;  // written little-endian over `bytes` bytes
  int bytes;
  Status expected;
};

TEST(Record, EveryFieldIsValidatedEvenWithARightChecksum) {
  const Encoded e = encode(example_record());
  const std::uint32_t nan = 0x7FC00000u, inf = 0x7F800000u, minus_one = 0xBF800000u;
  const FieldCase cases[] = {
      {"reserved header byte", 5, 1, 1, Status::kRecordBadField},
      {"reserved header word", 18, 1, 2, Status::kRecordBadField},
      {"section tag 0", 20, 0, 1, Status::kRecordBadField},
      {"section reserved byte", 21, 3, 1, Status::kRecordBadField},
      {"quality 4", 24, 4, 1, Status::kRecordBadField},
      {"unknown info flag", 25, 3, 1, Status::kRecordBadField},
      {"info reserved", 26, 1, 2, Status::kRecordBadField},
      {"temperature NaN", 28, nan, 4, Status::kRecordBadField},
      {"temperature 1000", 28, 0x447A0000u, 4, Status::kRecordBadField},
      {"sample rate negative", 32, minus_one, 4, Status::kRecordBadField},
      {"sample rate infinite", 32, inf, 4, Status::kRecordBadField},
      {"accel poses 3", 40, 3, 2, Status::kRecordBadField},
      {"accel reserved", 42, 1, 2, Status::kRecordBadField},
      {"accel misalignment NaN", 44, nan, 4, Status::kRecordBadField},
      {"accel scale negative", 44 + 4 * kScaleY, minus_one, 4, Status::kRecordBadField},
      {"accel scale zero", 44 + 4 * kScaleZ, 0, 4, Status::kRecordBadField},
      {"accel bias infinite", 44 + 4 * kBiasX, inf, 4, Status::kRecordBadField},
      {"accel sigma negative", 80 + 4 * 2, minus_one, 4, Status::kRecordBadField},
      {"accel residual NaN", 116, nan, 4, Status::kRecordBadField},
      {"gyro moves 0", 124, 0, 2, Status::kRecordBadField},
      {"gyro unknown flag", 126, 2, 1, Status::kRecordBadField},
      {"gyro reserved", 127, 1, 1, Status::kRecordBadField},
      {"gyro scale zero", 128 + 4 * kGyroScaleX, 0, 4, Status::kRecordBadField},
      {"gyro sigma NaN", 176 + 4 * 11, nan, 4, Status::kRecordBadField},
      {"gyro residual negative", 224, minus_one, 4, Status::kRecordBadField},
      {"section longer than the record", 22, 205, 2, Status::kRecordBadLength},
      {"accel section too short", 38, 40, 2, Status::kRecordBadLength},
      {"gyro part bit cleared", 16, kRecordAccel, 2, Status::kRecordBadField},
      {"accel part bit cleared", 16, kRecordGyro, 2, Status::kRecordBadField},
      {"duplicate accel section", 120, 2, 1, Status::kRecordBadField},
      {"gyro tag on the accel payload", 36, 3, 1, Status::kRecordBadLength},
  };
  for (const FieldCase& c : cases) {
    Encoded bad = e;
    for (int i = 0; i < c.bytes; ++i)
      bad.bytes[c.at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(c.value >> (8 * i));
    reseal(bad);
    CalibrationRecord out;
    std::size_t where = 9999;
    EXPECT_EQ(decode_record(bad.bytes, bad.size, out, &where), c.expected) << c.what;
    if (c.expected == Status::kRecordBadField && c.at >= 24 && c.at != 120) {
      EXPECT_EQ(where, c.at) << c.what;
    }
  }
}

// The magnetometer and temperature sections of the full quadratic record (508 bytes): mag
// section at 228 (payload 232), temperature section at 340 (payload 344; accelerometer
// coefficients from 360, the gyro's from 432).
TEST(Record, MagnetometerAndTemperatureFieldsAreValidated) {
  const Encoded e = encode(full_record(2));
  ASSERT_EQ(e.size, 508u);
  const std::uint32_t nan = 0x7FC00000u, minus_one = 0xBF800000u;
  const FieldCase cases[] = {
      {"mag samples 0", 232, 0, 2, Status::kRecordBadField},
      {"mag quality 4", 234, 4, 1, Status::kRecordBadField},
      {"mag unknown flag", 235, 2, 1, Status::kRecordBadField},
      {"soft iron NaN", 236 + 4 * 4, nan, 4, Status::kRecordBadField},
      {"hard iron sigma negative", 284 + 4, minus_one, 4, Status::kRecordBadField},
      {"soft iron sigma NaN", 296 + 4 * 5, nan, 4, Status::kRecordBadField},
      {"field 0 uT", 320, 0, 4, Status::kRecordBadField},
      {"fit error negative", 324, minus_one, 4, Status::kRecordBadField},
      {"coverage 1.5", 328, 0x3FC00000u, 4, Status::kRecordBadField},
      {"dip 100 degrees", 332, 0x42C80000u, 4, Status::kRecordBadField},
      {"temperature order 3", 344, 3, 1, Status::kRecordBadField},
      {"temperature flags 0", 345, 0, 1, Status::kRecordBadField},
      {"temperature unknown flag", 345, 7, 1, Status::kRecordBadField},
      {"temperature rests 0", 346, 0, 2, Status::kRecordBadField},
      {"reference temperature NaN", 348, nan, 4, Status::kRecordBadField},
      {"accel slope NaN", 372 + 4, nan, 4, Status::kRecordBadField},
      {"gyro sigma negative", 432 + 36 + 8, minus_one, 4, Status::kRecordBadField},
      {"temperature section too short for its order", 342, 112, 2, Status::kRecordBadLength},
      {"mag part bit cleared", 16, kRecordAccel | kRecordGyro | kRecordTemperature, 2,
       Status::kRecordBadField},
      {"temperature part bit cleared", 16, kRecordAccel | kRecordGyro | kRecordMag, 2,
       Status::kRecordBadField},
  };
  for (const FieldCase& c : cases) {
    Encoded bad = e;
    for (int i = 0; i < c.bytes; ++i)
      bad.bytes[c.at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(c.value >> (8 * i));
    reseal(bad);
    CalibrationRecord out;
    std::size_t where = 9999;
    EXPECT_EQ(decode_record(bad.bytes, bad.size, out, &where), c.expected) << c.what;
    if (c.at != 16) {
      EXPECT_EQ(where, c.at) << c.what;
    }
  }
  // A mirrored soft iron (det S < 0) is not a calibration: refused at S's first byte.
  Encoded bad = e;
  bad.bytes[236 + 3] ^= 0x80;  // S00's sign
  reseal(bad);
  CalibrationRecord out;
  std::size_t where = 0;
  EXPECT_EQ(decode_record(bad.bytes, bad.size, out, &where), Status::kRecordBadField);
  EXPECT_EQ(where, 236u);
  // The lowest temperature above the highest: refused at the highest.
  bad = e;
  const std::uint32_t fifty = 0x42480000u;
  for (int i = 0; i < 4; ++i) bad.bytes[352 + i] = static_cast<std::uint8_t>(fifty >> (8 * i));
  reseal(bad);
  EXPECT_EQ(decode_record(bad.bytes, bad.size, out, &where), Status::kRecordBadField);
  EXPECT_EQ(where, 356u);
}

TEST(Record, EncodeRefusesWhatDecodeWouldRefuse) {
  std::uint8_t buf[kRecordMaxBytes];
  std::size_t n = 0;
  CalibrationRecord r = example_record();
  r.calibration.accel.params(kScaleX) = -1.0f;
  EXPECT_EQ(encode_record(r, buf, sizeof buf, &n), Status::kInvalidArgument);
  r = example_record();
  r.calibration.gyro.sigma(3) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(encode_record(r, buf, sizeof buf, &n), Status::kInvalidArgument);
  r = example_record();
  r.parts = 0x0010;  // a part this version cannot write
  EXPECT_EQ(encode_record(r, buf, sizeof buf, &n), Status::kInvalidArgument);
  r = example_record();
  r.calibration.has_temperature = false;  // then the temperature must be 0, as decode expects
  EXPECT_EQ(encode_record(r, buf, sizeof buf, &n), Status::kInvalidArgument);
  r = example_record();
  EXPECT_EQ(encode_record(r, buf, 231, &n), Status::kCapacityExceeded);
  EXPECT_EQ(encode_record(r, buf, 232, &n), Status::kOk);
  // A double calibration whose values overflow float cannot be recorded.
  Calibration<double> c = example_calibration();
  c.gyro.params(kGyroBiasX) = 1e300;
  EXPECT_EQ(make_record(c, 0, 0, r), Status::kInvalidArgument);
}

// A record from a newer writer: an extra section (tag 9) and an accelerometer section with
// fields appended. Today's decoder reads what it knows and skips the rest.
TEST(Record, GrownFormatStillDecodes) {
  const Encoded e = encode(example_record());
  Encoded grown;
  std::size_t w = 0;
  auto put = [&](const std::uint8_t* p, std::size_t n) {
    std::memcpy(grown.bytes + w, p, n);
    w += n;
  };
  put(e.bytes, 36);                                                     // header and info section
  grown.bytes[16] = static_cast<std::uint8_t>(grown.bytes[16] | 0x10);  // a newer part's bit
  const std::uint8_t accel_header[4] = {2, 0, 80 + 8, 0};               // 8 more bytes
  put(accel_header, 4);
  put(e.bytes + 40, 80);
  const std::uint8_t appended[8] = {1, 2, 3, 4, 5, 6, 7, 8};
  put(appended, 8);
  const std::uint8_t future[4 + 6] = {9, 0, 6, 0, 0xAA, 0xBB, 0xCC, 0xDD, 0xEE, 0xFF};
  put(future, sizeof future);
  put(e.bytes + 120, 108);  // gyro section
  grown.size = w + 4;
  grown.bytes[6] = static_cast<std::uint8_t>(grown.size & 0xFF);
  grown.bytes[7] = static_cast<std::uint8_t>(grown.size >> 8);
  reseal(grown);
  CalibrationRecord back;
  ASSERT_EQ(decode_record(grown.bytes, grown.size, back), Status::kOk);
  expect_same(example_record(), back);
  EXPECT_EQ(back.unknown_sections, 1);
}

}  // namespace
}  // namespace imucal

namespace imucal {
namespace {

// Puts a float into an encoded record and makes the CRC right again.
void put_f32(Encoded& e, std::size_t at, float v) {
  std::uint32_t bits;
  std::memcpy(&bits, &v, sizeof bits);
  store_u32(e.bytes + at, bits);
  reseal(e);
}

// Finite but absurd values (a scale of 3e38, a temperature slope of 1e38, ...) are refused by
// make, encode and decode alike, each naming the bound it breaks; decode points at the section.
TEST(RecordPlausibility, AbsurdFiniteValuesAreRefusedEverywhere) {
  struct Case {
    const char* what;
    void (*edit)(Calibration<double>&, TemperatureModel<double>&, MagCalibration<double>&);
    Bound bound;
    std::size_t section;  // payload offset of the section the decoder blames
  };
  // Sections of full_record(1): info at 24, accelerometer 40, gyro 124, magnetometer 232, then
  // the temperature model at 344.
  const Case cases[] = {
      {"accel scale 3e38", [](auto& c, auto&, auto&) { c.accel.params(kScaleY) = 3e38; },
       Bound::kAccelScale, 40},
      {"accel scale 1e-12", [](auto& c, auto&, auto&) { c.accel.params(kScaleX) = 1e-12; },
       Bound::kAccelScale, 40},
      {"accel misalignment 0.9", [](auto& c, auto&, auto&) { c.accel.params(kAlphaZx) = 0.9; },
       Bound::kAccelMisalignment, 40},
      {"accel bias 1e30", [](auto& c, auto&, auto&) { c.accel.params(kBiasZ) = 1e30; },
       Bound::kAccelOffset, 40},
      {"gyro scale -3e38", [](auto& c, auto&, auto&) { c.gyro.params(kGyroScaleZ) = -3e38; },
       Bound::kGyroScale, 124},
      {"gyro misalignment -2", [](auto& c, auto&, auto&) { c.gyro.params(kGammaXy) = -2.0; },
       Bound::kGyroMisalignment, 124},
      {"gyro bias 1e8 counts", [](auto& c, auto&, auto&) { c.gyro.params(kGyroBiasY) = 1e8; },
       Bound::kGyroOffset, 124},
      {"field 5000 uT", [](auto&, auto&, auto& m) { m.field_ut = 5000.0; }, Bound::kMagField, 232},
      {"soft iron 3e38", [](auto&, auto&, auto& m) { m.soft_iron(1, 1) = 3e38; },
       Bound::kMagSoftIron, 232},
      {"hard iron 1e20", [](auto&, auto&, auto& m) { m.hard_iron(0) = 1e20; }, Bound::kMagOffset,
       232},
      {"accel slope 1e38", [](auto&, auto& t, auto&) { t.accel.b1(0) = 1e38; }, Bound::kAccelSlope,
       344},
      {"gyro slope 1e5 counts/degC", [](auto&, auto& t, auto&) { t.gyro.b1(2) = 1e5; },
       Bound::kGyroSlope, 344},
      {"model reference 1e30 degC", [](auto&, auto& t, auto&) { t.reference_c = 1e30; },
       Bound::kTemperature, 344},
  };
  for (const Case& k : cases) {
    Calibration<double> c = example_calibration();
    TemperatureModel<double> t = example_temperature(1);
    MagCalibration<double> m = example_mag();
    k.edit(c, t, m);
    CalibrationRecord r;
    Bound bound = Bound::kNone;
    // A temperature model out of bounds costs only itself (ABadTemperatureModelCostsOnlyItself).
    const bool model = k.section == 344;
    EXPECT_EQ(make_record(c, 1, 2, r, &m, &t, &bound), model ? Status::kOk : Status::kImplausible)
        << k.what;
    EXPECT_EQ(bound, k.bound) << k.what << ": " << to_string(bound);
    if (model) {
      EXPECT_EQ(r.parts, kRecordAccel | kRecordGyro | kRecordMag) << k.what;
    }
    // The same value in a record built by hand: encode refuses it.
    CalibrationRecord good = full_record(1);
    CalibrationRecord bad = good;
    Calibration<float>& f = bad.calibration;
    f.accel.params = c.accel.params.cast<float>();
    f.gyro.params = c.gyro.params.cast<float>();
    bad.mag.soft_iron = m.soft_iron.cast<float>();
    bad.mag.hard_iron = m.hard_iron.cast<float>();
    bad.mag.field_ut = static_cast<float>(m.field_ut);
    bad.temperature.accel.b1 = t.accel.b1.cast<float>();
    bad.temperature.gyro.b1 = t.gyro.b1.cast<float>();
    if (std::isfinite(static_cast<float>(t.reference_c)))
      bad.temperature.reference_c = static_cast<float>(t.reference_c);
    else
      bad.temperature.reference_c = 1e30f;
    std::uint8_t buf[kRecordMaxBytes];
    std::size_t n = 0;
    EXPECT_EQ(encode_record(bad, buf, sizeof buf, &n), Status::kImplausible) << k.what;
    EXPECT_EQ(record_bound(bad), k.bound) << k.what;
  }
  // Decode, field by field: the accelerometer's scale y at 3e38, the temperature slope at 1e38.
  const Encoded e = encode(full_record(1));
  CalibrationRecord out;
  std::size_t where = 0;
  Bound bound = Bound::kNone;
  Encoded scale = e;
  put_f32(scale, 44 + 4 * kScaleY, 3e38f);
  EXPECT_EQ(decode_record(scale.bytes, scale.size, out, &where, &bound), Status::kRecordBadField);
  EXPECT_EQ(bound, Bound::kAccelScale);
  EXPECT_EQ(where, 40u);
  Encoded slope = e;
  put_f32(slope, 344 + 16 + 12, 1e38f);  // the accelerometer's b1 x, after T0, min, max, b0
  EXPECT_EQ(decode_record(slope.bytes, slope.size, out, &where, &bound), Status::kRecordBadField);
  EXPECT_EQ(bound, Bound::kAccelSlope);
  EXPECT_EQ(where, 344u);
  Encoded good = e;
  EXPECT_EQ(decode_record(good.bytes, good.size, out, &where, &bound), Status::kOk);
  EXPECT_EQ(bound, Bound::kNone);
}

// One absurd temperature reading (infinite, or 1e30 finite) in the calibration's temperature
// note does not make an otherwise good calibration unstorable: the note is dropped.
TEST(RecordPlausibility, AnAbsurdTemperatureNoteIsDroppedNotTheCalibration) {
  for (double temperature : {std::numeric_limits<double>::infinity(), -1e30, 1e30, 250.0,
                             std::numeric_limits<double>::quiet_NaN()}) {
    Calibration<double> c = example_calibration();
    c.temperature_c = temperature;
    CalibrationRecord r;
    ASSERT_EQ(make_record(c, 1, 2, r), Status::kOk) << temperature;
    EXPECT_FALSE(r.calibration.has_temperature);
    EXPECT_EQ(r.calibration.temperature_c, 0.0f);
    std::uint8_t buf[kRecordMaxBytes];
    std::size_t n = 0;
    ASSERT_EQ(encode_record(r, buf, sizeof buf, &n), Status::kOk);
    CalibrationRecord back;
    ASSERT_EQ(decode_record(buf, n, back), Status::kOk);
    EXPECT_EQ(back.calibration.accel.params, r.calibration.accel.params);
  }
  Calibration<double> c = example_calibration();
  c.temperature_c = 199.0;  // inside the bounds: kept
  CalibrationRecord r;
  ASSERT_EQ(make_record(c, 1, 2, r), Status::kOk);
  EXPECT_TRUE(r.calibration.has_temperature);
  EXPECT_EQ(r.calibration.temperature_c, 199.0f);
}

// Likewise an absurd sample-rate note is dropped (0: unknown), and a record written by hand
// with one is refused as implausible, naming the bound.
TEST(RecordPlausibility, AnAbsurdSampleRateNoteIsDroppedNotTheCalibration) {
  for (double rate : {2e6, -100.0, 1e300, std::numeric_limits<double>::infinity(),
                      std::numeric_limits<double>::quiet_NaN()}) {
    Calibration<double> c = example_calibration();
    c.sample_rate_hz = rate;
    CalibrationRecord r;
    ASSERT_EQ(make_record(c, 1, 2, r), Status::kOk) << rate;
    EXPECT_EQ(r.calibration.sample_rate_hz, 0.0f) << rate;
    std::uint8_t buf[kRecordMaxBytes];
    std::size_t n = 0;
    EXPECT_EQ(encode_record(r, buf, sizeof buf, &n), Status::kOk) << rate;
  }
  Calibration<double> c = example_calibration();
  c.sample_rate_hz = 1e6;  // inside the bounds: kept
  CalibrationRecord r;
  ASSERT_EQ(make_record(c, 1, 2, r), Status::kOk);
  EXPECT_EQ(r.calibration.sample_rate_hz, 1e6f);
  r.calibration.sample_rate_hz = 2e6f;
  std::uint8_t buf[kRecordMaxBytes];
  std::size_t n = 0;
  EXPECT_EQ(encode_record(r, buf, sizeof buf, &n), Status::kImplausible);
  EXPECT_EQ(record_bound(r), Bound::kSampleRate);
  r.calibration.sample_rate_hz = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(encode_record(r, buf, sizeof buf, &n), Status::kInvalidArgument);
}

// The sections of an encoded record with the given tags, under the parts field `parts`: bytes a
// hand-made (or an older) encoder could have written.
Encoded with_sections(const Encoded& e, std::initializer_list<int> tags, std::uint16_t parts) {
  Encoded out;
  std::memcpy(out.bytes, e.bytes, kRecordHeaderBytes);
  out.size = kRecordHeaderBytes;
  for (std::size_t at = kRecordHeaderBytes; at + 4 < e.size;) {
    const std::size_t n = 4 + (e.bytes[at + 2] | std::size_t{e.bytes[at + 3]} << 8);
    for (int tag : tags) {
      if (e.bytes[at] != tag) continue;
      std::memcpy(out.bytes + out.size, e.bytes + at, n);
      out.size += n;
    }
    at += n;
  }
  out.size += 4;
  out.bytes[6] = static_cast<std::uint8_t>(out.size & 0xFF);
  out.bytes[7] = static_cast<std::uint8_t>(out.size >> 8);
  out.bytes[16] = static_cast<std::uint8_t>(parts & 0xFF);
  out.bytes[17] = static_cast<std::uint8_t>(parts >> 8);
  reseal(out);
  return out;
}

// A temperature model's coefficients are bounded through their sensor's matrix, and the
// corrector applies them only to a sensor it calibrates: a model is part of a record only beside
// a sensor it models. A temperature model alone (its slope of 1e38 would meet no bound) is
// refused by make, encode and decode alike; the coefficients of a sensor the record does not hold
// are left out. Whatever they accept, the corrector accepts.
TEST(RecordPlausibility, ATemperatureModelGoesOnlyWithItsSensor) {
  const MagCalibration<double>* const kNoMag = nullptr;
  TemperatureModel<double> t = example_temperature(1);
  t.accel.b1(0) = 1e38;
  Calibration<double> none = example_calibration();
  none.accel.status = Status::kTooFewPoses;
  none.gyro.status = Status::kTooFewMoves;
  CalibrationRecord r;
  EXPECT_EQ(make_record(none, 1, 2, r, kNoMag, &t), Status::kInvalidArgument);
  CalibrationRecord alone = full_record(1);
  alone.parts = kRecordTemperature;
  alone.calibration.accel = AccelCalibration<float>{};
  alone.calibration.gyro = GyroCalibration<float>{};
  alone.temperature.accel.b1(0) = 1e38f;
  std::uint8_t buf[kRecordMaxBytes];
  std::size_t n = 0;
  EXPECT_EQ(encode_record(alone, buf, sizeof buf, &n), Status::kInvalidArgument);
  // Its bytes: the info section (payload at 24) and the temperature section (payload at 40: the
  // flags at 41, the accelerometer's b1 x at 68) of a full record.
  const Encoded full = encode(full_record(1));
  Encoded bytes = with_sections(full, {1, 5}, kRecordTemperature);
  put_f32(bytes, 68, 1e38f);
  CalibrationRecord out;
  std::size_t where = 0;
  EXPECT_EQ(decode_record(bytes.bytes, bytes.size, out, &where), Status::kRecordBadField);
  EXPECT_EQ(where, 41u);

  // The gyro alone with a model of both sensors: the model keeps the gyro's coefficients only.
  Calibration<double> gyro = example_calibration();
  gyro.accel.status = Status::kTooFewPoses;
  ASSERT_EQ(make_record(gyro, 1, 2, r, kNoMag, &t), Status::kOk);
  EXPECT_EQ(r.parts, kRecordGyro | kRecordTemperature);
  EXPECT_FALSE(succeeded(r.temperature.accel.status));
  EXPECT_TRUE(r.temperature.accel.b1.isZero(0.0f));
  EXPECT_EQ(r.temperature.gyro.b1, t.gyro.b1.cast<float>());
  const Encoded e = encode(r);
  ASSERT_EQ(decode_record(e.bytes, e.size, out), Status::kOk);
  expect_same(r, out);
  Corrector<float> corrector;
  EXPECT_EQ(corrector.set(out), Status::kOk);
  EXPECT_EQ(corrector.parts(), kRecordGyro | kRecordTemperature);
  // By hand, with the accelerometer's coefficients: encode refuses it.
  CalibrationRecord stray = r;
  stray.temperature.accel = alone.temperature.accel;
  EXPECT_EQ(encode_record(stray, buf, sizeof buf, &n), Status::kInvalidArgument);
  // The bytes of such a record (flags 3, parts gyro and temperature: gyro section at 36,
  // temperature payload at 148, the accelerometer's b1 x at 176) decode without them.
  Encoded older = with_sections(full, {1, 3, 5}, kRecordGyro | kRecordTemperature);
  put_f32(older, 176, 1e38f);
  ASSERT_EQ(decode_record(older.bytes, older.size, out), Status::kOk);
  EXPECT_EQ(out.parts, kRecordGyro | kRecordTemperature);
  EXPECT_FALSE(succeeded(out.temperature.accel.status));
  EXPECT_TRUE(out.temperature.accel.b1.isZero(0.0f));
  EXPECT_TRUE(succeeded(out.temperature.gyro.status));
  EXPECT_EQ(corrector.set(out), Status::kOk);
  EXPECT_EQ(corrector.parts(), kRecordGyro | kRecordTemperature);
}

// A temperature model that cannot be recorded costs only itself: make_record() leaves it out,
// keeps the accelerometer, the gyro and the magnetometer, and *bound names the bound it broke
// (a range from -300 degC: the fit's rests are checked too, TemperatureFit.ImplausibleRest...).
TEST(RecordPlausibility, ABadTemperatureModelCostsOnlyItself) {
  struct Case {
    const char* what;
    void (*edit)(TemperatureModel<double>&);
    Bound bound;
  };
  const Case cases[] = {
      {"range from -300 degC", [](auto& t) { t.min_c = -300; }, Bound::kTemperature},
      {"range up to 1e30 degC", [](auto& t) { t.max_c = 1e30; }, Bound::kTemperature},
      {"reference 1e30 degC", [](auto& t) { t.reference_c = 1e30; }, Bound::kTemperature},
      {"accel slope 1e38", [](auto& t) { t.accel.b1(0) = 1e38; }, Bound::kAccelSlope},
      {"gyro slope 1e5 counts/degC", [](auto& t) { t.gyro.b1(2) = 1e5; }, Bound::kGyroSlope},
      {"accel b0 NaN", [](auto& t) { t.accel.b0(1) = std::nan(""); }, Bound::kNonFinite},
      {"gyro b1 1e300 (infinite in float)", [](auto& t) { t.gyro.b1(0) = 1e300; },
       Bound::kNonFinite},
  };
  const MagCalibration<double> m = example_mag();
  for (const Case& k : cases) {
    TemperatureModel<double> t = example_temperature(1);
    k.edit(t);
    CalibrationRecord r;
    Bound bound = Bound::kNone;
    ASSERT_EQ(make_record(example_calibration(), 1, 2, r, &m, &t, &bound), Status::kOk) << k.what;
    EXPECT_EQ(r.parts, kRecordAccel | kRecordGyro | kRecordMag) << k.what;
    EXPECT_EQ(bound, k.bound) << k.what << ": " << to_string(bound);
    const Encoded e = encode(r);
    CalibrationRecord back;
    ASSERT_EQ(decode_record(e.bytes, e.size, back), Status::kOk) << k.what;
    Corrector<float> corrector;
    EXPECT_EQ(corrector.set(back), Status::kOk) << k.what;
  }
  // A good model goes in, *bound kNone; one kept up to date in the field for years (more rests
  // than the record's 16 bits count) goes in with its count saturated.
  TemperatureModel<double> t = example_temperature(1);
  t.rests = 100000;
  CalibrationRecord r;
  Bound bound = Bound::kAccelSlope;
  ASSERT_EQ(make_record(example_calibration(), 1, 2, r, &m, &t, &bound), Status::kOk);
  EXPECT_EQ(r.parts, kRecordAccel | kRecordGyro | kRecordMag | kRecordTemperature);
  EXPECT_EQ(bound, Bound::kNone);
  EXPECT_EQ(r.temperature.rests, 65535);
}

}  // namespace
}  // namespace imucal
