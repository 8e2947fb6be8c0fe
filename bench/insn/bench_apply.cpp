// bench/insn/bench_apply.cpp: instruction counts of keeping and applying a calibration on the Arm
// targets (bench/run_insn_bench.sh, QEMU with the counting plugin): the corrector per sample
// (both sensors), building it, encoding and decoding the record, and the two-slot store's save
// and load on the simulated NOR flash (the flash port's own copying included). Not a test.
#include <cstdint>
#include <cstdio>

#include "imucal/corrector.hpp"
#include "imucal/port/sim_nor_flash.hpp"
#include "imucal/record.hpp"
#include "imucal/record_store.hpp"
#include "markers.hpp"

using namespace imucal;

namespace {
// Raw samples arrive through volatile memory, as from a sensor driver: nothing folds away.
volatile float g_raw[6] = {33012.0f, 31020.0f, 36810.0f, 32790.0f, 32750.0f, 32801.0f};
Corrector<float> corrector;
Vector3<float> acc_raw, gyro_raw, acc_out, gyro_out;
SimNorFlash<8192> flash;
std::uint8_t bytes[kRecordMaxBytes];
CalibrationRecord record, decoded;
void load_raw() {
  for (int i = 0; i < 3; ++i) {
    acc_raw(i) = g_raw[i];
    gyro_raw(i) = g_raw[3 + i];
  }
}
}  // namespace

int main() {
  Calibration<float> c;
  c.accel.params << 0.0021f, -0.0013f, 0.0007f, 0.00241f, 0.00239f, 0.00243f, -32990.0f, -32770.5f,
      -33120.25f;
  c.accel.sigma.setConstant(1e-5f);
  c.accel.poses = 41;
  c.accel.status = Status::kOk;
  c.gyro.params << 0.003f, -0.002f, 0.001f, -0.004f, 0.0025f, -0.0015f, 2.1e-4f, 2.09e-4f, 2.11e-4f,
      -32750.0f, -32800.5f, -32690.0f;
  c.gyro.sigma.setConstant(2e-5f);
  c.gyro.moves = 40;
  c.gyro.status = Status::kOk;
  c.quality = Quality::kGood;
  c.sample_rate_hz = 100.0f;

  bench_announce("Corrector::set(): from a calibration, both sensors");
  imucal_bench_begin();
  corrector.set(c);
  imucal_bench_end();

  float check = 0.0f;
  for (int k = 0; k < 100; ++k) {
    load_raw();
    bench_announce("Corrector::apply(): accelerometer and gyro, per sample");
    imucal_bench_begin();
    corrector.apply(acc_raw, gyro_raw, acc_out, gyro_out);
    imucal_bench_end();
    check += acc_out(0) + gyro_out(2);
  }
  for (int k = 0; k < 100; ++k) {
    load_raw();
    bench_announce("Corrector::apply_checked(): both, per sample");
    imucal_bench_begin();
    corrector.apply_checked(acc_raw, gyro_raw, acc_out, gyro_out);
    imucal_bench_end();
    check += acc_out(1);
  }

  make_record(c, 1u, 2u, record);
  std::size_t size = 0;
  bench_announce("encode_record(): both sensors (232 bytes)");
  imucal_bench_begin();
  Status s = encode_record(record, bytes, sizeof bytes, &size);
  imucal_bench_end();
  bench_announce("decode_record(): both sensors, every field checked");
  imucal_bench_begin();
  const Status d = decode_record(bytes, size, decoded);
  imucal_bench_end();

  static RecordStore store(flash);
  for (int k = 0; k < 3; ++k) {
    bench_announce("RecordStore::save(): erase 4 KB + program + verify");
    imucal_bench_begin();
    s = store.save(record);
    imucal_bench_end();
  }
  bench_announce("RecordStore::load(): both slots read and decoded");
  imucal_bench_begin();
  const Status l = store.load(decoded);
  imucal_bench_end();
  std::printf("RESULT apply %d, record %s/%s, store %s/%s, %u bytes\n", static_cast<int>(check),
              to_string(s), to_string(d), to_string(s), to_string(l), static_cast<unsigned>(size));
  return s == Status::kOk && d == Status::kOk && l == Status::kOk ? 0 : 1;
}
