// SPDX-License-Identifier: MIT
// bench/footprint/footprint.cpp: a firmware-shaped program that uses the whole public API in
// float (the accelerometer solver, the streaming calibrator, the field calibrator), built optimised
// for each cross target. The build fails if it links any allocation symbol
// (cmake/CheckNoHeap.cmake), and prints its sizes. Built a second time with
// IMUCAL_FOOTPRINT_BASELINE (same I/O, no imucal) so the difference is imucal's own size.
//
// IMUCAL_FOOTPRINT_PARTS selects what a firmware would link (bench/footprint_parts.sh builds each):
//   1  load and apply: a record read from the store, samples corrected;
//   2  the accelerometer alone: the solver from pose means, the record saved and loaded, applied;
//   3  2 + the streaming calibrator with the gyro (its solvers);
//   4  3 + the magnetometer (collector, solve, alignment);
//   5  4 + the temperature model (rest monitor, fit, corrector);
//   6  5 + the field calibrator (its saves and resume through the store): everything, the default;
//   7  the field calibrator alone, with the magnetometer's model: resumed from the store, fed
//      frames, FIFO batches and magnetometer readings, saved, its calibration applied (what a
//      product that is calibrated elsewhere runs forever);
//   8  7 built without the magnetometer's model (FieldCalibrator<float, 8, 0>);
//   9  8 built without the gyro's matrix as well (FieldCalibrator<float, 8, 0, false>).
#include <cstdint>
#include <cstdio>

#ifndef IMUCAL_FOOTPRINT_PARTS
#define IMUCAL_FOOTPRINT_PARTS 6
#endif

#ifndef IMUCAL_FOOTPRINT_BASELINE
#include "imucal/field/field_store.hpp"
#include "imucal/imucal.hpp"
#include "imucal/port/sim_nor_flash.hpp"
#endif

namespace {

// Pose means arrive through volatile memory, as from a sensor driver, so nothing folds away.
volatile float g_input[3 * 12] = {9.8f, 0.1f,  0.2f, -9.7f, 0.2f, 0.1f,  0.1f,  9.9f,  0.3f,
                                  0.2f, -9.8f, 0.1f, 0.1f,  0.2f, 9.9f,  0.3f,  0.1f,  -9.7f,
                                  6.9f, 6.9f,  0.2f, -6.9f, 0.1f, 6.9f,  0.2f,  -6.8f, -6.9f,
                                  5.7f, -5.6f, 5.7f, -5.6f, 5.7f, -5.7f, -5.7f, -5.6f, 5.6f};

#ifndef IMUCAL_FOOTPRINT_BASELINE
// A global, not a function-local static: that would need a thread-safe guard (__cxa_guard_*).
imucal::SimNorFlash<2048, 1024, 64> flash;  // the firmware's flash driver (2 KB of bss here)
#if IMUCAL_FOOTPRINT_PARTS >= 3 && IMUCAL_FOOTPRINT_PARTS <= 6
imucal::Calibrator<float> calibrator;
#endif
#if IMUCAL_FOOTPRINT_PARTS >= 4 && IMUCAL_FOOTPRINT_PARTS <= 6
imucal::MagCalibrator<float> mag;  // the magnetometer collector
#endif
#if IMUCAL_FOOTPRINT_PARTS == 5 || IMUCAL_FOOTPRINT_PARTS == 6
imucal::TemperatureFit<float, 1> temperature_fit;  // bias against temperature (linear)
imucal::RestMonitor<float> rest_monitor;           // rests in the field
#endif
#if IMUCAL_FOOTPRINT_PARTS == 9
imucal::FieldCalibrator<float, 8, 0, false> field;  // nor the gyro's matrix
#elif IMUCAL_FOOTPRINT_PARTS == 8
imucal::FieldCalibrator<float, 8, 0> field;  // without the magnetometer's model
#elif IMUCAL_FOOTPRINT_PARTS >= 6
imucal::FieldCalibrator<float> field;
#endif
#endif

#if !defined(IMUCAL_FOOTPRINT_BASELINE) && IMUCAL_FOOTPRINT_PARTS >= 6
// The field calibrator as a product runs it: resumed from the store, a minute of frames one by
// one and in FIFO batches (values from volatile memory), magnetometer readings, its events, a
// save, its calibration applied. Returns the corrector's parts (nothing folds away).
template <class Field>
unsigned run_field(Field& f, imucal::RecordStore& store, imucal::Corrector<float>& corrector) {
  imucal::FieldSettings<float> s;
  s.accel_noise = s.gyro_noise = 3.0f;
  s.gyro_per_rad_s = 939.0f;
  s.accel.accel_per_m_s2 = 417.7f;
  if (IMUCAL_FOOTPRINT_PARTS < 8) s.mag.counts_per_ut = 6.67f;
  imucal::resume_field(f, s, store);
  std::uint32_t t_us = 0;
  for (int k = 0; k < 3000; ++k) {
    imucal::RawFrame frame;
    t_us += 10000u;
    frame.t_us = t_us;
    for (int i = 0; i < 3; ++i) {
      frame.acc[i] = static_cast<std::int16_t>(400.0f * g_input[(k + i) % 36]);
      frame.gyro[i] = static_cast<std::int16_t>(g_input[(k + 2 * i) % 5]);
    }
    f.add_raw(frame, 20.0f + g_input[k % 36] * 0.01f);
    if (k % 10 == 0)
      f.add_mag(imucal::Vector3<float>(40.0f * g_input[k % 36], 40.0f * g_input[(k + 7) % 36],
                                       40.0f * g_input[(k + 13) % 36]));
  }
  std::uint8_t batch[25 * 12];
  for (unsigned i = 0; i < sizeof batch; ++i)
    batch[i] = static_cast<std::uint8_t>(g_input[i % 36] * 10.0f);
  imucal::FifoTiming timing;
  timing.first_us = t_us + 10000u;
  timing.period_q8 = 10000u * 256u;
  const imucal::FifoResult r = f.add_fifo(batch, 25, imucal::FifoLayout{}, timing, 20.0f);
  f.finish();
  imucal::FieldEvent<float> e;
  unsigned events = 0;
  while (f.take_event(e)) ++events;
  const imucal::Status saved = imucal::save_field(f, store, 1u, 2u);
  imucal::Calibration<float> cal;
  imucal::TemperatureModel<float> model;
  if (f.calibration(cal, model)) {
    imucal::CalibrationRecord record;
    if (imucal::make_record<float>(cal, 1u, 2u, record, nullptr, &model) == imucal::Status::kOk)
      corrector.set(record);
  }
  std::printf("field: %u bytes, %u taken, %u events, %s, parts %u\n",
              static_cast<unsigned>(sizeof(f)), static_cast<unsigned>(r.taken), events,
              imucal::to_string(saved), static_cast<unsigned>(corrector.parts()));
  return corrector.parts();
}
#endif

}  // namespace

int main() {
#ifdef IMUCAL_FOOTPRINT_BASELINE
  float sum = 0.0f;
  for (int i = 0; i < 36; ++i) sum += g_input[i];
  std::printf("baseline %d\n", static_cast<int>(sum));
  return 0;
#elif IMUCAL_FOOTPRINT_PARTS == 1
  // A firmware that only loads the stored calibration and applies it.
  imucal::RecordStore store(flash);
  imucal::CalibrationRecord loaded;
  const imucal::Status s = store.load(loaded);
  imucal::Corrector<float> corrector;
  const imucal::Status s2 = corrector.set(loaded);
  imucal::Vector3<float> a_cal, w_cal;
  const float r[6] = {g_input[0], g_input[1], g_input[2], g_input[3], g_input[4], g_input[5]};
  corrector.apply(imucal::Vector3<float>(r[0], r[1], r[2]),
                  imucal::Vector3<float>(r[3], r[4], r[5]), a_cal, w_cal);
  std::printf("apply: %s, %s, |a| %d\n", imucal::to_string(s), imucal::to_string(s2),
              static_cast<int>(a_cal.norm()));
  return 0;
#elif IMUCAL_FOOTPRINT_PARTS >= 7
  imucal::RecordStore store(flash);
  imucal::Corrector<float> corrector;
  run_field(field, store, corrector);
  imucal::Vector3<float> a_cal, w_cal;
  const float r[6] = {g_input[0], g_input[1], g_input[2], g_input[3], g_input[4], g_input[5]};
  corrector.apply(imucal::Vector3<float>(r[0], r[1], r[2]),
                  imucal::Vector3<float>(r[3], r[4], r[5]), a_cal, w_cal);
  return a_cal.norm() > 0.0f ? 0 : 1;
#else
  imucal::PoseStore<float, 48> poses;
  for (int i = 0; i < 12; ++i) {
    const float x = g_input[3 * i], y = g_input[3 * i + 1], z = g_input[3 * i + 2];
    const imucal::Vector3<float> m(x, y, z);
    if (poses.add(m, 200u + static_cast<std::uint32_t>(i)) != imucal::Status::kOk) return 2;
  }
  imucal::AccelSettings<float> settings;
  settings.gravity = 9.81f;
  imucal::AccelSolver<float> solver(settings);
  imucal::Status s = solver.start(poses.span());
  while (s == imucal::Status::kRunning) s = solver.step();  // time-sliced form
  imucal::AccelCalibration<float> cal;
  s = solver.finish(cal);
  imucal::AccelCalibration<float> once;
  const imucal::Status s2 = imucal::calibrate_accelerometer(poses.span(), settings, once);
  const imucal::Vector3<float> a = imucal::accel_apply(cal.params, poses[0].mean);
  std::printf("%s / %s, |a| = %d mm/s^2, rms %d um/s^2\n", imucal::to_string(s),
              imucal::to_string(s2), static_cast<int>(a.norm() * 1000.0f),
              static_cast<int>(cal.residual_rms * 1e6f));
#if IMUCAL_FOOTPRINT_PARTS == 2
  imucal::Calibration<float> calibration;
  calibration.accel = cal;
#else
  // The streaming calibrator: a few seconds of samples (values from volatile memory), progress,
  // the whole solve and the calibration applied, so all of its code is linked and checked.
  std::uint32_t t_us = 0;
  for (int k = 0; k < 3000; ++k) {
    imucal::ImuSample<float> sample;
    t_us += 10000u;
    sample.t_us = t_us;
    const float jitter = static_cast<float>(k % 7) * 1e-3f;
    const float ax = g_input[k % 36], ay = g_input[(k + 1) % 36], az = g_input[(k + 2) % 36];
    const float gz = g_input[k % 5];
    sample.acc = imucal::Vector3<float>(ax, ay + jitter, az);
    sample.gyro = imucal::Vector3<float>(jitter, -jitter, gz * 1e-3f);
    calibrator.add(sample);
  }
  const imucal::Progress progress = calibrator.progress();
  const imucal::Status s3 = calibrator.solve_all();
  const imucal::Vector3<float> w =
      imucal::gyro_apply(calibrator.calibration().gyro.params, imucal::Vector3<float>(1, 2, 3));
  std::printf("calibrator: %u bytes, phase %d, %d poses, %s, |w| %d\n",
              static_cast<unsigned>(sizeof(calibrator)), static_cast<int>(progress.phase),
              progress.poses, imucal::to_string(s3), static_cast<int>(w.norm()));
  const imucal::Calibration<float>& calibration = calibrator.calibration();
#endif
  // Kept and applied: the record through the two-slot store, then the corrector.
  imucal::CalibrationRecord record;
  imucal::Status s4 = imucal::make_record(calibration, 1u, 2u, record);
  imucal::RecordStore store(flash);
  if (s4 == imucal::Status::kOk) s4 = store.save(record);
  imucal::CalibrationRecord loaded;
  const imucal::Status s5 = store.load(loaded);
  imucal::Corrector<float> corrector;
  corrector.set(loaded);
  imucal::Vector3<float> a_cal, w_cal;
  const float r[6] = {g_input[0], g_input[1], g_input[2], g_input[3], g_input[4], g_input[5]};
  corrector.apply(imucal::Vector3<float>(r[0], r[1], r[2]),
                  imucal::Vector3<float>(r[3], r[4], r[5]), a_cal, w_cal);
  std::printf("record: %s, %s, parts %u, |a| %d\n", imucal::to_string(s4), imucal::to_string(s5),
              static_cast<unsigned>(corrector.parts()), static_cast<int>(a_cal.norm()));
#if IMUCAL_FOOTPRINT_PARTS >= 4
  // The magnetometer: collector, solve and alignment, so all of its code is linked and checked.
  for (int k = 0; k < 600; ++k) {
    const float x = g_input[k % 36], y = g_input[(k + 7) % 36], z = g_input[(k + 13) % 36];
    mag.add(imucal::Vector3<float>(40.0f * x, 40.0f * y, 40.0f * z));
    if (k % 60 == 0) mag.add_rest(imucal::Vector3<float>(x, y, z), imucal::Vector3<float>(z, y, x));
  }
  imucal::MagCalibration<float> mag_cal;
  const imucal::Status s6 = mag.solve(mag_cal);
  const imucal::Status s7 = mag.align(cal, mag_cal);
  std::printf("mag: %u bytes, %d samples, %s, %s\n", static_cast<unsigned>(sizeof(mag)), mag.size(),
              imucal::to_string(s6), imucal::to_string(s7));
  corrector.set_mag(mag_cal);
#endif
#if IMUCAL_FOOTPRINT_PARTS >= 5
  // The temperature model: rests from the field monitor into the fit, applied by the corrector.
  imucal::RestMonitorSettings<float> rm;
  rm.accel_noise = rm.gyro_noise = 1.0f;
  rest_monitor.reset(rm);
  const imucal::Status s8 = temperature_fit.reset(calibration);
  for (int k = 0; k < 2000; ++k) {
    imucal::ImuSample<float> sample;
    sample.t_us = static_cast<std::uint32_t>(k) * 10000u;
    const float ax = g_input[k % 36], ay = g_input[(k + 1) % 36];
    sample.acc = imucal::Vector3<float>(ax, ay, 9.8f);
    sample.temperature = 20.0f + 0.01f * static_cast<float>(k);
    rest_monitor.add(sample);
    imucal::RestSummary<float> rest;
    if (rest_monitor.take(rest)) temperature_fit.add_rest(rest);
  }
  imucal::TemperatureModel<float> model;
  const imucal::Status s9 = temperature_fit.solve(model);
  corrector.set_temperature_model(model);
  const float temperature = g_input[5];
  corrector.set_temperature(temperature);
  std::printf("temperature: fit %u B, monitor %u B, %s, %s, parts %u\n",
              static_cast<unsigned>(sizeof(temperature_fit)),
              static_cast<unsigned>(sizeof(rest_monitor)), imucal::to_string(s8),
              imucal::to_string(s9), static_cast<unsigned>(corrector.parts()));
#endif
#if IMUCAL_FOOTPRINT_PARTS >= 6
  run_field(field, store, corrector);
#endif
  return imucal::succeeded(s) && imucal::succeeded(s2) ? 0 : 1;
#endif
}
