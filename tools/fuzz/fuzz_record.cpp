// libFuzzer target: the calibration record decoder and the two-slot store over arbitrary flash
// contents. Whatever the bytes: no crash, no read outside them (ASan), and a record that decodes
// holds only finite values, re-encodes, and decodes again to the same values; a store over any
// flash contents loads without crashing, and a save then load returns the saved record. Built
// and run by tools/fuzz.sh.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "imucal/port/sim_nor_flash.hpp"
#include "imucal/record.hpp"
#include "imucal/record_store.hpp"

namespace {

using namespace imucal;

void check(bool ok) {
  if (!ok) std::abort();
}

template <class V>
bool finite(const V& v) {
  for (int i = 0; i < v.size(); ++i)
    if (!std::isfinite(v(i))) return false;
  return true;
}

bool same(const CalibrationRecord& a, const CalibrationRecord& b) {
  const Calibration<float>&x = a.calibration, &y = b.calibration;
  return a.device_id == b.device_id && a.sensor_id == b.sensor_id && a.parts == b.parts &&
         x.quality == y.quality && x.has_temperature == y.has_temperature &&
         x.temperature_c == y.temperature_c && x.sample_rate_hz == y.sample_rate_hz &&
         x.accel.params == y.accel.params && x.accel.sigma == y.accel.sigma &&
         x.gyro.params == y.gyro.params && x.gyro.sigma == y.gyro.sigma &&
         x.accel.residual_rms == y.accel.residual_rms && x.gyro.residual_rms == y.gyro.residual_rms;
}

SimNorFlash<2048, 1024, 64> flash;

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
  return 0;
}
