// SPDX-License-Identifier: MIT
// examples/firmware/main.cpp: imucal in a firmware, from raw samples to calibrated ones.
// Collect (every raw sample into add(), progress out), solve in slices, save the record to
// flash, reboot, load it, apply it. SimulatedImu stands in for the IMU driver and SimNorFlash
// for the flash driver; printf goes out over semihosting. No heap, no exceptions, no
// function-local statics (those need a thread-safe guard, and with it the unwinder).
#include <cmath>
#include <cstdio>

#include "imucal/calibrator/calibrator.hpp"
#include "imucal/corrector.hpp"
#include "imucal/port/sim_nor_flash.hpp"
#include "imucal/store/record_store.hpp"
#include "simulated_imu.hpp"

namespace {

imucal::Calibrator<float> calibrator;        // about 32 KiB: a global, not on the stack
imucal::SimNorFlash<8192, 4096, 256> flash;  // the flash driver: two 4 KiB erase units
SimulatedImu imu;                            // the IMU driver

// Collects until the calibrator is ready (or the sensor script ends), then solves in slices.
imucal::Status calibrate() {
  imucal::ImuSample<float> sample;
  int poses = -1;
  while (imu.read(sample)) {
    calibrator.add(sample);  // in a real firmware: from the sensor's data-ready handler
    const imucal::Progress p = calibrator.progress();
    if (p.poses != poses) {
      poses = p.poses;
      std::printf("poses %d, faces %d of 6, hint %d\n", p.poses, p.faces_covered,
                  static_cast<int>(p.hint));
    }
    if (p.phase == imucal::Phase::kReady) break;
  }
  imucal::Status s = calibrator.solve();
  int slices = 0;
  while (s == imucal::Status::kRunning) {  // one slice per main-loop pass, bounded time each
    s = calibrator.solve_step();
    ++slices;
  }
  std::printf("solve: %s after %d slices\n", imucal::to_string(s), slices);
  return s;
}

}  // namespace

int main() {
  imucal::Status s = calibrate();
  if (!imucal::succeeded(s)) return 1;
  imucal::CalibrationRecord record;
  s = imucal::make_record(calibrator.calibration(), 42u, 1u, record);
  if (s == imucal::Status::kOk) {
    imucal::RecordStore store(flash);
    s = store.save(record);
  }
  std::printf("save: %s\n", imucal::to_string(s));

  // Reboot: a new store and corrector over the same flash.
  imucal::RecordStore store(flash);
  imucal::CalibrationRecord loaded;
  s = store.load(loaded);
  imucal::Corrector<float> corrector;
  if (s == imucal::Status::kOk) s = corrector.set(loaded);
  std::printf("load: %s\n", imucal::to_string(s));
  if (s != imucal::Status::kOk) return 1;

  // Apply: raw in, calibrated out. The simulator knows the truth: the RMS error over 5 s of
  // turning and resting is the sensor noise (0.017 m/s^2, 0.0035 rad/s) plus what is left of
  // the distortion (uncalibrated: about 0.3 m/s^2 and 0.1 rad/s).
  float sum_acc = 0.0f, sum_gyro = 0.0f;
  imucal::ImuSample<float> sample;
  int n = 0;
  for (; n < 500 && imu.read(sample); ++n) {
    imucal::Vector3<float> acc, gyro;
    corrector.apply(sample.acc, sample.gyro, acc, gyro);
    sum_acc += (acc - imu.true_acc()).squaredNorm();
    sum_gyro += (gyro - imu.true_rate()).squaredNorm();
  }
  const float rms_acc = std::sqrt(sum_acc / 500.0f), rms_gyro = std::sqrt(sum_gyro / 500.0f);
  std::printf("apply: %d samples, RMS error %d mm/s^2, %d mrad/s\n", n,
              static_cast<int>(rms_acc * 1e3f), static_cast<int>(rms_gyro * 1e3f));
  return n == 500 && rms_acc < 0.025f && rms_gyro < 0.006f ? 0 : 1;
}
