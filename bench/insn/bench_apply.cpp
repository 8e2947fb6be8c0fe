// SPDX-License-Identifier: MIT
// bench/insn/bench_apply.cpp: instruction counts of keeping and applying a calibration on the cross
// targets (bench/run_insn_bench.sh, QEMU with the counting plugin): the corrector per sample
// (both sensors), building it, encoding and decoding the record, and the two-slot store's save
// and load on the simulated NOR flash (the flash port's own copying included). Not a test.
#include <cstdint>
#include <cstdio>

#include "imucal/corrector.hpp"
#include "imucal/port/sim_nor_flash.hpp"
#include "imucal/store/record.hpp"
#include "imucal/store/record_store.hpp"
#include "markers.hpp"

using namespace imucal;

namespace {
// Raw samples arrive through volatile memory, as from a sensor driver: nothing folds away.
volatile float g_raw[6] = {33012.0f, 31020.0f, 36810.0f, 32790.0f, 32750.0f, 32801.0f};
Corrector<float> corrector;
Vector3<float> acc_raw, gyro_raw, acc_out, gyro_out, mag_raw, mag_out;
volatile float g_mag[3] = {-210.0f, 455.0f, 130.0f};
volatile float g_temperature = 31.25f;
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

  // The magnetometer and the temperature model (linear, both sensors).
  MagCalibration<float> mag;
  mag.status = Status::kOk;
  mag.soft_iron << 0.151f, 0.004f, -0.002f, 0.003f, 0.148f, 0.005f, -0.001f, 0.006f, 0.152f;
  mag.hard_iron << -120.5f, 310.25f, -45.0f;
  mag.field_ut = 48.7f;
  mag.coverage = 0.86f;
  mag.samples = 96;
  TemperatureModel<float> temp;
  temp.reference_c = 24.5f;
  temp.min_c = 5.0f;
  temp.max_c = 45.0f;
  temp.rests = 37;
  temp.accel.b0 = c.accel.params.tail<3>();
  temp.accel.b1 << 0.41f, -0.27f, 0.63f;
  temp.gyro.b0 = c.gyro.params.tail<3>();
  temp.gyro.b1 << 1.5f, -0.8f, 2.2f;
  temp.accel.status = temp.gyro.status = Status::kOk;
  corrector.set_mag(mag);
  corrector.set_temperature_model(temp);
  for (int k = 0; k < 100; ++k) {
    for (int i = 0; i < 3; ++i) mag_raw(i) = g_mag[i];
    bench_announce("Corrector::mag(): magnetometer, per sample");
    imucal_bench_begin();
    mag_out = corrector.mag(mag_raw);
    imucal_bench_end();
    check += mag_out(0);
  }
  for (int k = 0; k < 10; ++k) {
    const float t = g_temperature;
    bench_announce("Corrector::set_temperature(): both biases at T (linear model)");
    imucal_bench_begin();
    corrector.set_temperature(t);
    imucal_bench_end();
    check += corrector.accel_offset()(0);
  }

  // Every part (460 bytes): encode and decode.
  make_record(c, 1u, 2u, record, &mag, &temp);
  std::size_t full_size = 0;
  bench_announce("encode_record(): every part, linear temperature model (460 bytes)");
  imucal_bench_begin();
  encode_record(record, bytes, sizeof bytes, &full_size);
  imucal_bench_end();
  bench_announce("decode_record(): every part, every field checked");
  imucal_bench_begin();
  const Status full = decode_record(bytes, full_size, decoded);
  imucal_bench_end();

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
  return s == Status::kOk && d == Status::kOk && l == Status::kOk && full == Status::kOk &&
                 full_size == 460
             ? 0
             : 1;
}
