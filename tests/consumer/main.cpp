// SPDX-License-Identifier: MIT
// A consumer of imucal: solves an accelerometer calibration from twelve poses, keeps it in a
// (simulated) flash through the record store, loads it back and applies it. Also runs a
// dynamically sized Eigen product of its own, which must work: imucal's EIGEN_NO_MALLOC is not
// forced on its consumers. Exit code 0 on success.
#include <Eigen/Core>
#include <cmath>
#include <cstdio>

#include "imucal/corrector.hpp"
#include "imucal/port/sim_nor_flash.hpp"
#include "imucal/solve/accel_calibration.hpp"
#include "imucal/store/record_store.hpp"

namespace {
imucal::SimNorFlash<8192, 4096, 256> flash;
}

int main() {
  // Twelve poses of a sensor with scale errors and an offset, gravity 9.81 m/s^2.
  const float k = 0.70710678f;
  const float directions[12][3] = {{1, 0, 0},  {-1, 0, 0}, {0, 1, 0},   {0, -1, 0},
                                   {0, 0, 1},  {0, 0, -1}, {k, k, 0},   {-k, 0, k},
                                   {0, -k, k}, {k, 0, -k}, {-k, -k, 0}, {0, k, -k}};
  imucal::PoseStore<float, 12> poses;
  for (int i = 0; i < 12; ++i) {
    const imucal::Vector3<float> g(9.81f * directions[i][0], 9.81f * directions[i][1],
                                   9.81f * directions[i][2]);
    const imucal::Vector3<float> raw(1.02f * g.x() + 0.1f, 0.97f * g.y() - 0.2f, g.z() + 0.05f);
    poses.add(raw, 100u);
  }
  imucal::AccelSettings<float> settings;
  settings.gravity = 9.81f;
  imucal::Calibration<float> calibration;
  imucal::Status s = imucal::calibrate_accelerometer(poses.span(), settings, calibration.accel);
  std::printf("accelerometer: %s\n", imucal::to_string(s));
  if (!imucal::succeeded(s)) return 1;

  imucal::CalibrationRecord record;
  s = imucal::make_record(calibration, 7u, 1u, record);
  imucal::RecordStore store(flash);
  if (s == imucal::Status::kOk) s = store.save(record);
  imucal::CalibrationRecord loaded;
  if (s == imucal::Status::kOk) s = store.load(loaded);
  imucal::Corrector<float> corrector;
  if (s == imucal::Status::kOk) s = corrector.set(loaded);
  std::printf("store and corrector: %s\n", imucal::to_string(s));
  if (s != imucal::Status::kOk) return 1;
  imucal::Vector3<float> acc, gyro;
  corrector.apply(imucal::Vector3<float>(1.02f * 9.81f + 0.1f, -0.2f, 0.05f),
                  imucal::Vector3<float>::Zero(), acc, gyro);
  const float error = (acc - imucal::Vector3<float>(9.81f, 0.0f, 0.0f)).norm();

  // The consumer's own dynamic Eigen code (allocates; would abort under EIGEN_NO_MALLOC).
  Eigen::MatrixXf m = Eigen::MatrixXf::Identity(4, 4);
  const float trace = (m * m).trace();
  std::printf("calibrated error %d um/s^2, dynamic trace %d\n", static_cast<int>(error * 1e6f),
              static_cast<int>(trace));
  return error < 1e-3f && trace == 4.0f ? 0 : 1;
}
