// SPDX-License-Identifier: MIT
// libFuzzer target: the calibration record decoder and the two-slot store over arbitrary flash
// contents. Whatever the bytes: no crash, no read outside them (ASan), and a record that decodes
// holds only finite values within their physical bounds, re-encodes, and decodes again to the
// same values; a store over any flash contents loads without crashing, and a save then load
// returns the saved record. Then the same contents on a flash with ECC program units that fails
// and changes between reads (sim_ecc_flash.hpp), the fault chosen from the input: a power cut at
// some step of a save (the unit torn as an ECC error, arbitrary bits or a weak bit), a failure
// reported for a step that completed, misreads. Afterwards the record read before the save or
// the saved one is read (the saved one if the save said kOk), and the next save succeeds. Built
// and run by tools/fuzz.sh.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "imucal/port/sim_ecc_flash.hpp"
#include "imucal/port/sim_nor_flash.hpp"
#include "imucal/store/record.hpp"
#include "imucal/store/record_store.hpp"

namespace {

using namespace imucal;

void check_at(bool ok, int line) {
  if (ok) return;
  std::fprintf(stderr, "fuzz_record.cpp:%d: check failed\n", line);
  std::abort();
}
#define check(ok) check_at((ok), __LINE__)

template <class V>
bool finite(const V& v) {
  for (int i = 0; i < v.size(); ++i)
    if (!std::isfinite(v(i))) return false;
  return true;
}

bool same_mag(const MagCalibration<float>& a, const MagCalibration<float>& b) {
  return a.soft_iron == b.soft_iron && a.hard_iron == b.hard_iron &&
         a.hard_iron_sigma == b.hard_iron_sigma && a.soft_iron_sigma == b.soft_iron_sigma &&
         a.field_ut == b.field_ut && a.fit_error_pct == b.fit_error_pct &&
         a.coverage == b.coverage && a.samples == b.samples && a.quality == b.quality &&
         a.dip_deg == b.dip_deg && a.dip_sigma_deg == b.dip_sigma_deg;
}
bool same_bias(const TemperatureBias<float>& a, const TemperatureBias<float>& b) {
  return a.status == b.status && a.b0 == b.b0 && a.b1 == b.b1 && a.b2 == b.b2 &&
         a.b0_sigma == b.b0_sigma && a.b1_sigma == b.b1_sigma && a.b2_sigma == b.b2_sigma;
}
bool same_temperature(const TemperatureModel<float>& a, const TemperatureModel<float>& b) {
  return a.order == b.order && a.reference_c == b.reference_c && a.min_c == b.min_c &&
         a.max_c == b.max_c && a.rests == b.rests && same_bias(a.accel, b.accel) &&
         same_bias(a.gyro, b.gyro);
}

bool same(const CalibrationRecord& a, const CalibrationRecord& b) {
  const Calibration<float>&x = a.calibration, &y = b.calibration;
  return a.device_id == b.device_id && a.sensor_id == b.sensor_id && a.parts == b.parts &&
         x.quality == y.quality && x.has_temperature == y.has_temperature &&
         x.temperature_c == y.temperature_c && x.sample_rate_hz == y.sample_rate_hz &&
         x.accel.params == y.accel.params && x.accel.sigma == y.accel.sigma &&
         x.gyro.params == y.gyro.params && x.gyro.sigma == y.gyro.sigma &&
         x.accel.residual_rms == y.accel.residual_rms &&
         x.gyro.residual_rms == y.gyro.residual_rms && same_mag(a.mag, b.mag) &&
         same_temperature(a.temperature, b.temperature);
}

SimNorFlash<2048, 1024, 64> flash;
SimEccFlash<2048, 1024, 256, 8> ecc;

// A record that is always valid, for saving over contents that decode to nothing.
CalibrationRecord fallback_record() {
  CalibrationRecord r;
  r.device_id = 0xF00D;
  r.parts = kRecordAccel;
  r.calibration.accel.params << 0.001f, 0.0f, 0.0f, 0.0024f, 0.0024f, 0.0024f, -3.0f, 2.0f, 1.0f;
  r.calibration.accel.poses = 12;
  r.calibration.accel.status = Status::kOk;
  return r;
}

// The store over these contents on the failing flash: see the file comment.
void faulty_flash(const std::uint8_t* data, std::size_t size, const CalibrationRecord* decoded) {
  const std::uint32_t h = crc32(data, size);
  ecc.reset();
  std::memcpy(ecc.raw(), data, size < 2048 ? size : 2048);
  ecc.seed(h | 1u);
  ecc.set_torn(static_cast<TornReads>(h % 3u));
  CalibrationRecord before;
  Status had = RecordStore(ecc).load(before);
  check(had == Status::kOk || had == Status::kNoRecord || had == Status::kStorageError);
  // A record saved cleanly over the contents first (one slot then holds it) when none loads.
  if (had != Status::kOk && (h & 0x20000u) != 0) {
    check(RecordStore(ecc).save(fallback_record()) == Status::kOk);
    had = RecordStore(ecc).load(before);
    check(had == Status::kOk && same(before, fallback_record()));
  }
  const CalibrationRecord r = decoded != nullptr ? *decoded : fallback_record();
  const std::uint32_t step = (h >> 4) % 48u;
  switch ((h >> 10) % 4u) {
    case 0:
      ecc.cut_power_at_step(step);
      break;
    case 1:
      ecc.report_failure_at_step(step);
      break;
    case 2:
      ecc.fail_next_reads(static_cast<int>((h >> 12) % 3u) + 1);
      break;
    default:
      ecc.flip_next_reads(static_cast<int>((h >> 12) % 3u) + 1);
      break;
  }
  const Status saved = RecordStore(ecc).save(r);
  ecc.power_on();
  ecc.fail_next_reads(0);
  ecc.flip_next_reads(0);
  check(ecc.double_programs() == 0);
  CalibrationRecord after;
  const Status loaded = RecordStore(ecc).load(after);
  if (saved == Status::kOk) check(loaded == Status::kOk && same(after, r));
  if (had == Status::kOk) check(loaded == Status::kOk && (same(after, before) || same(after, r)));
  // The next save succeeds unless neither slot could be trusted before (then nothing is erased).
  RecordStore next(ecc);
  const Status again = next.save(r);
  if (had == Status::kOk || saved == Status::kOk) check(again == Status::kOk);
  if (again == Status::kOk) check(next.load(after) == Status::kOk && same(after, r));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  CalibrationRecord r;
  std::size_t where = 0;
  const Status s = decode_record(data, size, r, &where);
  if (s == Status::kOk) {
    const Calibration<float>& c = r.calibration;
    check(finite(c.accel.params) && finite(c.accel.sigma) && finite(c.gyro.params) &&
          finite(c.gyro.sigma) && std::isfinite(c.temperature_c) &&
          std::isfinite(c.sample_rate_hz));
    check(record_bound(r) == Bound::kNone);
    if (r.parts & kRecordMag)
      check(finite(r.mag.soft_iron.reshaped()) && finite(r.mag.hard_iron) &&
            r.mag.soft_iron.determinant() > 0.0f && std::isfinite(r.mag.field_ut));
    if (r.parts & kRecordTemperature)
      check(finite(r.temperature.accel.b0) && finite(r.temperature.accel.b1) &&
            finite(r.temperature.gyro.b0) && finite(r.temperature.gyro.b1) &&
            r.temperature.min_c <= r.temperature.max_c);
    if (r.parts != 0) {  // a record of newer parts only has nothing this version can write
      std::uint8_t out[kRecordMaxBytes];
      std::size_t n = 0;
      check(encode_record(r, out, sizeof out, &n) == Status::kOk);
      CalibrationRecord again;
      check(decode_record(out, n, again) == Status::kOk && same(r, again));
    }
  } else {
    check(where <= size);
  }
  // The store over flash holding these bytes (both slots, from the start of each).
  std::memset(flash.raw(), 0xFF, 2048);
  std::memcpy(flash.raw(), data, size < 1024 ? size : 1024);
  if (size > 1024)
    std::memcpy(flash.raw() + 1024, data + 1024, size - 1024 < 1024 ? size - 1024 : 1024);
  RecordStore store(flash);
  CalibrationRecord loaded;
  const Status l = store.load(loaded);
  check(l == Status::kOk || l == Status::kNoRecord);
  if (s == Status::kOk && r.parts != 0) {
    check(store.save(r) == Status::kOk);
    CalibrationRecord back;
    check(store.load(back) == Status::kOk && same(r, back));
  }
  faulty_flash(data, size, s == Status::kOk && r.parts != 0 ? &r : nullptr);
  return 0;
}
