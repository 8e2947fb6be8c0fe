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
  double initial_rest = 10;           // s
  double min_rest = 1;                // s
  // Full scale in raw units: a reading at or beyond a limit is saturated (NaN: not given).
  double accel_min = kNaN, accel_max = kNaN, gyro_min = kNaN, gyro_max = kNaN;
  double nominal_rate_hz = 0;  // the configured sample rate (0: not checked)
  bool refine_gyro_bias = false;
  bool use_double = false;  // the double reference instead of float (device)
  bool quiet = false;       // no progress display
  std::string json_path, header_path, svg_path, truth_path, record_path;
  std::uint32_t device_id = 0, sensor_id = 0;  // for the record
  std::vector<std::string> command_line_keys;  // the settings given on the command line
  std::vector<std::string> from_files;         // "key=value (file:line)" read from the input
};

// One sample as read (input units, time in s from the file).
struct Sample {
  double t;
  double acc[3];
  double gyro[3];
};

struct PoseResult {
  double t_begin = 0, t_end = 0;  // s, input time
  int samples = 0;
  double mean[3] = {0, 0, 0};     // raw mean (input units)
  double up[3] = {0, 0, 0};       // calibrated unit gravity direction (body frame)
  double residual_before = kNaN;  // |g| - |a_nominal(mean)|, m/s^2 (NaN: no nominal model)
  double residual_after = kNaN;   // |g| - |a_cal(mean)|, m/s^2
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

struct Run {
  std::string scalar;  // "float" or "double"
  // Input.
  std::string format;  // "csv" or "imu_tk"
  long samples = 0, lines_skipped = 0;
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
  // Gyroscope: [g_yz, g_zy, g_zx, g_xz, g_xy, g_yx, s_x, s_y, s_z, b_x, b_y, b_z], b added.
  std::string gyro_status;
  bool gyro_ok = false;
  bool gyro_bias_refined = false;
  int gyro_iterations = 0;
  std::array<double, 12> gyro_params{}, gyro_sigma{};
  bool have_nominal_gyro = false;
  std::array<double, 12> gyro_nominal{};  // T = I, s from the units, b from the initial rest
  double gyro_rms_before = kNaN, gyro_rms_after = kNaN;  // deg per move
  std::string quality;                                   // none, poor, fair, good
  int quality_level = 0;  // the same as a number: 0 none, 1 poor, 2 fair, 3 good
  bool usable = false;    // both sensors calibrated (quality fair or good)
  std::vector<PoseResult> pose_list;
  std::vector<MoveResult> move_list;
  // The device's calibration record (record.hpp), if asked for and usable; else why not.
  std::vector<std::uint8_t> record;
  std::string record_error;
};

extern const char* const kAccelNames[9];
// Unit names, said once for the summary, the JSON, the header and the page.
const char* accel_unit_name(AccelUnit u);
const char* gyro_unit_name(GyroUnit u);
const char* time_unit_name(TimeUnit u);
extern const char* const kGyroNames[12];

// The SVG report page: the signal over time with the rests shaded, |a| before and after, the
// per-pose and per-move residuals, the pose directions on a sphere. `samples` may be decimated.
std::string report_svg(const Run& run, const Options& options, const std::vector<Sample>& samples);

}  // namespace imucal::cli
