// examples/firmware/main.cpp: imucal in a firmware, from raw samples to calibrated ones.
// Collect (every raw sample into add(), progress out), solve in slices, save the record to
// flash, reboot, load it, apply it. SimulatedImu stands in for the IMU driver and SimNorFlash
// for the flash driver; printf goes out over semihosting. No heap, no exceptions, no
// function-local statics (those need a thread-safe guard, and with it the unwinder).
#include <cstdio>

#include "imucal/calibrator.hpp"
#include "imucal/corrector.hpp"
#include "imucal/port/sim_nor_flash.hpp"
#include "imucal/record_store.hpp"
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
  if (!imucal::succeeded(calibrate())) return 1;
  imucal::CalibrationRecord record;
  imucal::Status s = imucal::make_record(calibrator.calibration(), 42u, 1u, record);
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

  // Apply: raw in, calibrated out. The simulator knows the truth, so the error is printed.
  float worst_acc = 0.0f, worst_gyro = 0.0f;
  imucal::ImuSample<float> sample;
  for (int i = 0; i < 500 && imu.read(sample); ++i) {
    imucal::Vector3<float> acc, gyro;
    corrector.apply(sample.acc, sample.gyro, acc, gyro);
    const float e_acc = (acc - imu.true_acc()).norm(), e_gyro = (gyro - imu.true_rate()).norm();
    if (e_acc > worst_acc) worst_acc = e_acc;
    if (e_gyro > worst_gyro) worst_gyro = e_gyro;
  }
  std::printf("apply: worst error %d mm/s^2, %d mrad/s\n", static_cast<int>(worst_acc * 1e3f),
              static_cast<int>(worst_gyro * 1e3f));
  return worst_acc < 0.05f && worst_gyro < 0.02f ? 0 : 1;
}
