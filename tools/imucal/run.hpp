// SPDX-License-Identifier: MIT
// tools/imucal/run.hpp: one calibration run of the `imucal` tool, as the outputs (summary, JSON,
// C header, SVG report) read it. Host only. All values in double, whatever scalar the
// calibrator ran in.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "input.hpp"

namespace imucal::cli {

enum class AccelUnit { kCounts, kG, kMps2 };
enum class GyroUnit { kCounts, kDps, kRads };
enum class MagUnit { kCounts, kUt, kNt, kGauss };

constexpr double kStandardGravity = 9.80665;
constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = 180.0 / kPi;

// Everything `imucal calibrate` and `imucal report` can be told (command line, or a
// `# imucal: key=value` comment in the input; the command line wins).
struct Options {
  std::vector<std::string> files;
  Format format = Format::kAuto;
  TimeUnit time_unit = TimeUnit::kSeconds;
  AccelUnit accel_unit = AccelUnit::kMps2;
  GyroUnit gyro_unit = GyroUnit::kRads;
  double accel_lsb_per_g = kNaN;      // counts per standard g (counts only; nominal)
  double accel_zero = kNaN;           // raw reading at zero acceleration (counts only; nominal)
  double gyro_lsb_per_dps = kNaN;     // counts per deg/s (counts only; else the scale is searched)
  double gravity = kStandardGravity;  // local gravity, m/s^2
  double initial_rest = 2;            // s: the shortest still period that starts the run
  double min_rest = 0.6;              // s
  // Full scale in raw units: a reading at or beyond a limit is saturated (NaN: not given).
  double accel_min = kNaN, accel_max = kNaN, gyro_min = kNaN, gyro_max = kNaN;
  // Inferred when a sensor's unit is counts and no range was given: the integer format's
  // limits ("int16", "uint16"), else empty.
  std::string accel_range_inferred, gyro_range_inferred;
  // The configured sample rate: with a t column checked against it (0: not checked); without
  // one, sample i is at i / rate.
  double nominal_rate_hz = 0;
  std::string columns;     // --columns: the names in the file's order ("" : header or default)
  bool pose_file = false;  // --poses: one line per pose mean (accelerometer only)
  bool refine_gyro_bias = false;
  // Magnetometer (used when the input has mx, my, mz): unit, nominal counts per uT (counts
  // only), the Earth-field bounds in uT, the coverage needed, alignment to the accelerometer.
  MagUnit mag_unit = MagUnit::kUt;
  double mag_lsb_per_ut = kNaN;
  double mag_field_min = 20, mag_field_max = 70;
  double mag_min_coverage = 0.5;
  bool mag_align = true;
  // Temperature model of the biases (used when the input has temp): order 1 or 2, the span of
  // rest temperatures needed for a slope.
  int temp_order = 1;
  double temp_min_span = 5;
  bool use_double = false;  // the double reference instead of float (device)
  // MB the samples may be kept in for the passes after the first; beyond it a file is read
  // again and a stream keeps every k-th sample (SampleStore).
  double memory_mb = 256;
  bool quiet = false;  // no progress display
  std::string json_path, header_path, svg_path, truth_path, record_path;
  std::string kalibr_path;  // `imucal noise --kalibr`: Kalibr's imu.yaml
  // `imucal field`: the calibration record to start from (empty: the nominal prior), and the
  // noise at rest of one sample on one axis, rad/s and m/s^2 (NaN: measured over the
  // recording's initial rest).
  std::string prior_path;
  double gyro_noise = kNaN, accel_noise = kNaN;
  // `imucal field`: the nominal raw gyro reading at zero rate (counts; NaN: 0), and a temperature
  // to give the published bias at as well (NaN: none).
  double gyro_zero = kNaN, at_temperature = kNaN;
  // `imucal field`: the longest piece a rest is judged in, s (NaN: the library's default).
  double rest_piece = kNaN;
  std::uint32_t device_id = 0, sensor_id = 0;  // for the record
  std::vector<std::string> command_line_keys;  // the settings given on the command line
  std::vector<std::string> from_files;         // "key=value (file:line)" read from the input
};

// One sample as read (input units, time in s from the file).
struct Sample {
  double t = 0;
  // The device's clock at this sample in us, unwrapped (DeviceClock in sample_store.hpp); the
  // device sees its low 32 bits.
  std::int64_t us = 0;
  double acc[3] = {0, 0, 0};
  double gyro[3] = {0, 0, 0};
  double temp = kNaN;                  // deg C (NaN: none)
  double mag[3] = {kNaN, kNaN, kNaN};  // input units (NaN: none at this sample)
};

struct PoseResult {
  double t_begin = 0, t_end = 0;  // s, input time
  int samples = 0;
  double mean[3] = {0, 0, 0};     // raw mean (input units)
  double up[3] = {0, 0, 0};       // calibrated unit gravity direction (body frame)
  double residual_before = kNaN;  // |g| - |a_nominal(mean)|, m/s^2 (NaN: no nominal model)
  double residual_after = kNaN;   // |g| - |a_cal(mean)|, m/s^2
  // A rest split in two: this pose holds the previous one's orientation (within
  // kSplitDeg) after a short motion (at most kSplitGapS): the 1-based number of that pose, else 0;
  // the angle between them and the time between them.
  static constexpr double kSplitDeg = 1.0, kSplitGapS = 2.0;
  int continues = 0;
  double angle_to_previous = kNaN;  // deg
  double gap_before = kNaN;         // s
};

struct MoveResult {
  int from = 0, to = 0, segments = 0;
  double duration = 0;         // s, integrated time
  double angle_before = kNaN;  // deg: predicted vs measured gravity, nominal gyro model
  double angle_after = kNaN;   // deg: the same with the calibration
};

struct StreamEvent {
  std::string status;  // to_string() of the library's status
  long count = 0;
  double first_t = 0;  // s, input time of the first
};

// One kind of the calibrator's stream counts (Progress::stream).
struct StreamCount {
  const char* name;  // short, for the summary: "accel saturated"
  const char* key;   // for the JSON: "accel_saturated"
  long count = 0;
};

// The magnetometer's calibration, m_cal = S (m_raw + h) (mag_model.hpp), and what it saw.
struct MagResult {
  bool present = false;  // the input has magnetometer columns
  std::string status;    // the fit's status (to_string), or why there was none
  bool ok = false;       // usable
  double soft_iron[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};  // S, uT per input unit
  double hard_iron[3] = {0, 0, 0};                             // h, input units, added
  double hard_iron_sigma[3] = {0, 0, 0};
  double soft_iron_sigma[6] = {0, 0, 0, 0, 0, 0};  // S00 S11 S22 S01 S02 S12 (before alignment)
  double field_ut = kNaN, fit_error_pct = kNaN, coverage = kNaN;
  int samples = 0, iterations = 0;  // samples held by the collector and fitted
  std::string quality = "none";
  std::string alignment_status;  // to_string, or why not ("not asked")
  bool aligned = false;
  double dip_deg = kNaN, dip_sigma_deg = kNaN;
  double rotation[3] = {0, 0, 0}, rotation_sigma[3] = {0, 0, 0};  // rad, mag to accel frame
  int rests = 0;                                                  // static poses for the dip
  std::vector<std::array<double, 3>> held;  // the collector's samples (input units)
  long readings = 0;                        // finite magnetometer readings in the input
  double unit_ut = kNaN;                    // the nominal uT per input unit the fit used
};

// One rest as the temperature fit saw it (Calibrator::last_rest()).
struct TemperatureRest {
  double temperature_c = kNaN;
  double accel_mean[3] = {0, 0, 0}, gyro_mean[3] = {0, 0, 0};  // input units
  long samples = 0;
};

// b(T) = b0 + b1 (T - T0) + b2 (T - T0)^2 for the added biases (temperature_model.hpp).
struct TemperatureBiasResult {
  std::string status;
  bool ok = false;
  double b0[3] = {0, 0, 0}, b1[3] = {0, 0, 0}, b2[3] = {0, 0, 0};  // input units, per degC^k
  double b0_sigma[3] = {0, 0, 0}, b1_sigma[3] = {0, 0, 0}, b2_sigma[3] = {0, 0, 0};
};
struct TemperatureResult {
  bool present = false;  // the input has a temperature column
  std::string status;    // overall: why there is no model, or "ok"
  int order = 1;
  double reference_c = kNaN, min_c = kNaN, max_c = kNaN;
  int rests = 0;
  TemperatureBiasResult accel, gyro;
  std::vector<TemperatureRest> rest_list;  // raw means (not compensated)
  // Calibration passes over the readings with the model applied (0: none): the accelerometer
  // and gyro calibration, the poses' means and the residuals are then those of the compensated
  // readings (raw + b(T) - b0), so the base no longer absorbs the drift.
  int passes = 0;
};

struct Run {
  std::string scalar;  // "float" or "double"
  // Input.
  std::string format;  // "csv" or "imu_tk"
  // What the input holds, and so what is calibrated: the sensors, and how it was read.
  bool has_accel = true, has_gyro = true, has_mag = false;
  std::string mode = "stream";  // "stream", "poses" (one line per pose), "magnetometer"
  std::string columns;          // the column names as read, in file order
  std::string columns_source;   // "header", "--columns", "columns= comment", "assumed"
  std::string time_source;      // "t column", "--rate", "none"
  long samples = 0, lines_skipped = 0;
  // How many times the input was read (more than once when its samples did not fit in
  // --memory), and which samples the passes after the first saw: every one (1), or, of a
  // stream longer than --memory holds, every k-th.
  int input_reads = 1;
  long kept_every = 1;
  double t_first = 0, t_last = 0, rate_hz = 0;
  std::vector<std::string> diagnostics;  // the first ones, "file:line:column: message"
  long diagnostic_count = 0;
  std::vector<StreamEvent> events;         // what the calibrator said about the stream
  std::vector<StreamCount> stream_counts;  // what it counted, every kind (zeros too)
  // Collection.
  int poses = 0, moves = 0, segments = 0, coarsenings = 0, rests_too_short = 0, moves_dropped = 0,
      faces_covered = 0;
  std::uint8_t faces = 0;
  // Accelerometer: [alpha_yz, alpha_zy, alpha_zx, s_x, s_y, s_z, b_x, b_y, b_z].
  std::string accel_status;
  bool accel_ok = false;
  int accel_iterations = 0;
  std::array<double, 9> accel_params{}, accel_sigma{};
  bool have_nominal_accel = false;
  std::array<double, 9> accel_nominal{};  // T = I, s and b from the units (if known)
  double accel_pose_rms_before = kNaN, accel_pose_rms_after = kNaN;  // m/s^2
  double accel_sample_rms_after = kNaN, accel_noise_floor = kNaN;    // m/s^2, pose windows
  // The figure imu_tk prints as the accelerometer's "residual": Ceres's final cost, half the sum
  // of (|g| - |a_cal|)^2 over the first kImuTkSamples samples of every pose that has as many
  // ((m/s^2)^2), and how many samples that is.
  static constexpr long kImuTkSamples = 100;
  double accel_imu_tk_cost = kNaN;
  long accel_imu_tk_samples = 0;
  // The noise the calibrator measured and weighs with (one sample, one axis, SI units): the
  // accelerometer's in its rests, the gyro's in the initial rest; the pose means' floor beyond
  // the accelerometer's noise (m/s^2) and the fit's chi-square per degree of freedom under it.
  double accel_noise = kNaN, gyro_noise = kNaN, accel_pose_floor = kNaN, accel_fit_to_noise = kNaN;
  // Gyroscope: [g_yz, g_zy, g_zx, g_xz, g_xy, g_yx, s_x, s_y, s_z, b_x, b_y, b_z], b added.
  std::string gyro_status;
  bool gyro_ok = false;
  bool gyro_bias_refined = false;
  int gyro_iterations = 0;
  std::array<double, 12> gyro_params{}, gyro_sigma{};
  bool have_nominal_gyro = false;
  std::array<double, 12> gyro_nominal{};  // T = I, s from the units, b from the initial rest
  double gyro_rms_before = kNaN, gyro_rms_after = kNaN;  // deg per move
  // The figure imu_tk prints as the gyro's "residual": half the sum over the moves of
  // |carried - measured gravity direction|^2 (unit vectors: (2 sin(angle / 2))^2).
  double gyro_imu_tk_cost = kNaN;
  std::string quality;         // none, poor, fair, good
  std::string quality_reason;  // the check that set it (streaming runs; empty otherwise)
  int quality_level = 0;       // the same as a number: 0 none, 1 poor, 2 fair, 3 good
  // What the input holds is calibrated: both sensors (quality fair or good), the accelerometer
  // of an accelerometer-only input, the magnetometer of a magnetometer-only one.
  bool usable = false;
  // Why not usable or weak, and what to do next: sentences for the user (the library's hint,
  // the counts explained). Empty when there is nothing to say.
  std::vector<std::string> advice;
  std::vector<PoseResult> pose_list;
  std::vector<MoveResult> move_list;
  MagResult mag;
  TemperatureResult temperature;
  // The device's calibration record (record.hpp), if asked for and usable; else why not.
  std::vector<std::uint8_t> record;
  std::string record_error;
};

// Unit names, said once for the summary, the JSON, the header and the page.
const char* accel_unit_name(AccelUnit u);
const char* gyro_unit_name(GyroUnit u);
const char* time_unit_name(TimeUnit u);
const char* mag_unit_name(MagUnit u);

// The SVG report page: the signal over time with the rests shaded, |a| before and after, the
// per-pose and per-move residuals, the pose directions on a sphere; with a magnetometer, its
// raw and calibrated point clouds; with a temperature model, the biases against temperature.
// `samples` may be decimated.
std::string report_svg(const Run& run, const Options& options, const std::vector<Sample>& samples);

}  // namespace imucal::cli
