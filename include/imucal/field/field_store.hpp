// SPDX-License-Identifier: MIT
// imucal/field/field_store.hpp: the field calibrator's publications to flash and back, through
// the record store (store/record_store.hpp: power-cut safe, two slots). What is saved is a
// calibration record: the calibration the device applies (the prior's, or the nominal gyro model,
// with the published gyro bias and accelerometer model), the published bias-versus-temperature
// model with its range, and the magnetometer's published calibration.
// After a reboot the calibrator resumes from it: the bias, its sigma, the slope and curvature
// with theirs, and the temperatures the model saw.
// Saves follow the calibrator's wear budget (FieldSettings::save_interval_s, saves_per_day):
// call save_field() whenever convenient (from a task, never an interrupt: it erases flash); it
// writes only when FieldCalibrator::save_due(). Header-only; links the store.
#pragma once

#include <cstdint>
#include <type_traits>

#include "imucal/field/field_calibrator.hpp"
#include "imucal/store/record.hpp"
#include "imucal/store/record_store.hpp"

namespace imucal {

// Saves the published calibration if a save is due, with the magnetometer's: the field
// calibrator's published one, else `mag` if given. *saved (if given) says whether it wrote.
// kOk: saved, or nothing due; otherwise the first failure (make_record()'s kInvalidArgument or
// kImplausible, the store's kStorageError, kStorageVerifyFailed, kStorageBusy), and the
// publication stays unsaved: the record load() returns is the previous one or the new one. A
// failure of the flash itself (kStorageError, kStorageVerifyFailed) counts against the wear
// budget as a save does: the next try waits its turn.
template <int Events, int MagCells, bool GyroMatrix>
Status save_field(FieldCalibrator<float, Events, MagCells, GyroMatrix>& field, RecordStore& store,
                  std::uint32_t device_id, std::uint32_t sensor_id, bool* saved = nullptr,
                  const MagCalibration<float>* mag = nullptr) {
  if (saved != nullptr) *saved = false;
  if (!field.save_due()) return Status::kOk;
  Calibration<float> calibration;
  TemperatureModel<float> model;
  field.calibration(calibration, model);
  MagCalibration<float> published;
  if (field.mag_calibration(published)) mag = &published;
  CalibrationRecord record;
  Status s = make_record(calibration, device_id, sensor_id, record, mag, &model);
  if (!succeeded(s)) return s;
  s = store.save(record);
  if (s == Status::kStorageError || s == Status::kStorageVerifyFailed) field.mark_save_failed();
  if (s != Status::kOk) return s;
  field.mark_saved();
  if (saved != nullptr) *saved = true;
  return Status::kOk;
}

// Starts the calibrator from the store's record (its gyro and accelerometer parts, temperature
// model and magnetometer's calibration), or from
// the nominal prior when there is none usable: then the store's reason (kNoRecord,
// kStorageError, a record status) or kNotStarted for a record without a usable gyro part. The
// calibrator's own refusals (kInvalidArgument for settings out of range) come first.
template <int Events, int MagCells, bool GyroMatrix>
Status resume_field(FieldCalibrator<float, Events, MagCells, GyroMatrix>& field,
                    const FieldSettings<float>& settings, RecordStore& store,
                    CalibrationRecord* loaded = nullptr) {
  CalibrationRecord record;
  const Status s = store.load(record);
  const bool gyro = s == Status::kOk && (record.parts & kRecordGyro) != 0 &&
                    succeeded(record.calibration.gyro.status);
  if (!gyro) {
    const Status started = field.start(settings);
    if (started != Status::kOk) return started;
    return s == Status::kOk ? Status::kNotStarted : s;
  }
  if (loaded != nullptr) *loaded = record;
  const bool model = (record.parts & kRecordTemperature) != 0;
  const bool mag = (record.parts & kRecordMag) != 0;
  return field.start(settings, &record.calibration, model ? &record.temperature : nullptr,
                     mag ? &record.mag : nullptr);
}

}  // namespace imucal
