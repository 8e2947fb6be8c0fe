// SPDX-License-Identifier: MIT
// imucal on an Arduino board: the accelerometer calibrated from twelve still poses, the
// calibration kept in flash by the record store, then every reading corrected. The parts fit a
// SAMD21 (Arduino Zero, MKR: 32 KB of RAM): the accelerometer solver, the store and the corrector.
// The streaming calibrator (accelerometer and gyroscope, found rests, about 32 KB of RAM of its
// own) needs a board with more. Compile with -std=gnu++17 (docs/ecosystems.md).
//
// readRawAccelerometer() stands for the sensor: it simulates one with scale errors and offsets,
// turned through twelve orientations. Replace it with your driver's reading (counts or m/s^2),
// and the SimNorFlash with your board's flash (an imucal::FlashRegion, docs/porting.md).
#include <imucal/corrector.hpp>
#include <imucal/port/sim_nor_flash.hpp>
#include <imucal/solve/accel_calibration.hpp>
#include <imucal/store/record_store.hpp>

namespace {

constexpr int kPoses = 12;
constexpr int kSamplesPerPose = 100;

imucal::SimNorFlash<2048, 1024, 64> flash;  // two slots of one 1 KB erase unit each
imucal::RecordStore store(flash);
imucal::Corrector<float> corrector;
int simulatedPose = 0;

// The simulated sensor: gravity along the pose's direction, scaled, offset and noisy.
imucal::Vector3<float> readRawAccelerometer() {
  const float k = 0.70710678f;
  const float directions[kPoses][3] = {{1, 0, 0},  {-1, 0, 0}, {0, 1, 0},   {0, -1, 0},
                                       {0, 0, 1},  {0, 0, -1}, {k, k, 0},   {-k, 0, k},
                                       {0, -k, k}, {k, 0, -k}, {-k, -k, 0}, {0, k, -k}};
  const float* d = directions[simulatedPose % kPoses];
  const float noise = 0.002f * static_cast<float>(random(-100, 101)) / 100.0f;
  return imucal::Vector3<float>(1.02f * 9.81f * d[0] + 0.10f + noise,
                                0.97f * 9.81f * d[1] - 0.20f - noise, 9.81f * d[2] + 0.05f);
}

// The mean of a still pose's readings.
imucal::Vector3<float> meanOfRest() {
  imucal::Vector3<float> sum = imucal::Vector3<float>::Zero();
  for (int i = 0; i < kSamplesPerPose; ++i) {
    sum += readRawAccelerometer();
    delay(10);
  }
  return sum / static_cast<float>(kSamplesPerPose);
}

void printStatus(const char* what, imucal::Status s) {
  Serial.print(what);
  Serial.print(": ");
  Serial.println(imucal::to_string(s));
}

// Twelve poses, the solve, and the record saved in flash.
imucal::Status calibrate() {
  imucal::PoseStore<float, kPoses> poses;
  for (int i = 0; i < kPoses; ++i) {
    Serial.print("pose ");
    Serial.print(i + 1);
    Serial.println(": turn the board to a new orientation and hold it still");
    delay(3000);
    simulatedPose = i;
    const imucal::Status s = poses.add(meanOfRest(), kSamplesPerPose);
    if (s != imucal::Status::kOk) return s;
  }
  imucal::AccelSettings<float> settings;
  settings.gravity = 9.81f;  // the local gravity, m/s^2
  imucal::Calibration<float> calibration;
  imucal::Status s = imucal::calibrate_accelerometer(poses.span(), settings, calibration.accel);
  printStatus("accelerometer", s);
  if (!imucal::succeeded(s)) return s;
  imucal::CalibrationRecord record;
  s = imucal::make_record(calibration, 1u, 1u, record);
  if (s == imucal::Status::kOk) s = store.save(record);
  return s;
}

}  // namespace

void setup() {
  Serial.begin(115200);
  imucal::CalibrationRecord record;
  imucal::Status s = store.load(record);  // after a reboot: the calibration in flash
  if (s != imucal::Status::kOk) {
    s = calibrate();
    printStatus("calibrate and save", s);
    if (s == imucal::Status::kOk) s = store.load(record);
  }
  if (s == imucal::Status::kOk) s = corrector.set(record);
  printStatus("corrector", s);
}

void loop() {
  imucal::Vector3<float> acc, gyro;
  corrector.apply(readRawAccelerometer(), imucal::Vector3<float>::Zero(), acc, gyro);
  Serial.print("calibrated m/s^2: ");
  Serial.print(acc.x(), 3);
  Serial.print(' ');
  Serial.print(acc.y(), 3);
  Serial.print(' ');
  Serial.print(acc.z(), 3);
  Serial.print("  |a| ");
  Serial.println(acc.norm(), 3);
  delay(500);
}
