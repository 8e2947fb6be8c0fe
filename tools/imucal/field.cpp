// SPDX-License-Identifier: MIT
// tools/imucal/field.cpp: `imucal field`: a recording of any length replayed through the field
// calibrator (imucal/field/field_calibrator.hpp), one sample at a time as on the device, in
// float: the rests it found, took and refused, the gyro bias it published with its sigma and
// temperature model, and the timeline of its decisions. The input is read once; the samples
// are kept only until the noise at rest is known (the recording's initial rest, measured by the
// streaming calibrator as `imucal calibrate` does, or --gyro-noise and --accel-noise).
#include <cmath>
#include <cstdio>
#include <deque>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "calibrate.hpp"
#include "cli.hpp"
#include "imucal/field/field_calibrator.hpp"
#include "imucal/models/gyro_model.hpp"
#include "imucal/store/record.hpp"
#include "outputs.hpp"
#include "report_svg_kit.hpp"
#include "sample_store.hpp"

namespace imucal::cli {

namespace {

using Json = nlohmann::ordered_json;

// The events the JSON lists (the rest counted), and the summary's first and last ones.
constexpr std::size_t kListed = 100000;
constexpr std::size_t kShownFirst = 30, kShownLast = 10;

// Options of `imucal calibrate` that say nothing to the field calibrator.
const char* const kNotField[] = {
    "poses",        "refine-gyro-bias", "double",           "header",       "record",
    "device-id",    "sensor-id",        "output",           "truth",        "kalibr",
    "min-rest",     "mag-field-range",  "mag-min-coverage", "no-mag-align", "temp-order",
    "temp-min-span"};

// One decision, as the timeline shows it.
struct EventRow {
  std::uint32_t time_s = 0;  // since the first sample, on the stream's clock
  const char* sensor = "";   // field_sensor_name()
  const char* kind = "";     // field_event_name()
  const char* reason = "";   // field_reason_name()
  double temperature_c = kNaN;
  double chi2 = kNaN;
  double bias[3] = {0, 0,
                    0};  // the sensor's published bias after it, at temperature_c (raw, added)
};

struct FieldRun {
  Run input;  // what the input holds and how it was read (samples, times, diagnostics)
  double gyro_per_rad_s = kNaN;
  double rest_piece = kNaN;  // s: the longest piece a rest is judged in
  // The nominal raw readings at zero (--accel-zero, --gyro-zero): taken off every sample before
  // the field calibrator sees it (its prior is bias 0, its gravity a direction), added back to
  // what it reports.
  double accel_zero = 0, gyro_zero = 0;
  double rest_bias[3] = {kNaN, kNaN, kNaN};  // the initial rest's (added, raw), when measured
  double gyro_noise_var = kNaN, accel_noise_var = kNaN;  // raw^2, one sample, summed over axes
  std::string noise_source;                              // "initial rest", "options", or both
  double noise_rest_end_s = kNaN;                        // input time where the initial rest ended
  std::string prior;                                     // "nominal" or the record's path
  std::string prior_status;                              // start()'s status
  FieldCounts counts{};
  bool published = false;
  double bias[3] = {0, 0, 0};
  double sigma = kNaN;
  double temperature_c = kNaN;  // the smoothed temperature the bias is at (NaN: none)
  double at_bias[3] = {kNaN, kNaN, kNaN}, at_sigma = kNaN;  // at --at-temperature
  // The filter's own estimate (what it would publish), at the temperature now and at
  // --at-temperature.
  double filter_bias[3] = {kNaN, kNaN, kNaN}, filter_sigma = kNaN;
  double filter_at_bias[3] = {kNaN, kNaN, kNaN}, filter_at_sigma = kNaN;
  TemperatureModel<float> model{};  // the published one
  // The accelerometer's model (kept when its nominal scale is known): the bias it applies at the
  // temperature now (raw, added) with its sigma per axis, and the model in sensor units.
  bool accel_enabled = false, accel_published = false;
  double accel_bias[3] = {kNaN, kNaN, kNaN}, accel_sigma[3] = {kNaN, kNaN, kNaN};
  double accel_per_m_s2 = kNaN;
  AccelCalibration<float> accel{};
  // The magnetometer's model (kept when the input has a magnetometer in known units): its hard
  // iron (raw, added) with its sigma per axis, and the calibration it publishes.
  bool mag_enabled = false, mag_published = false;
  double mag_ut_per_raw = kNaN;
  double hard_iron[3] = {kNaN, kNaN, kNaN}, hard_iron_sigma[3] = {kNaN, kNaN, kNaN};
  MagCalibration<float> mag{};
  // The gyro's misalignment and scale the device applies (the prior's or published), with their
  // sigmas, and whether the moves replaced the prior's.
  bool gyro_matrix_published = false;
  GyroVector<float> gyro_matrix = GyroVector<float>::Zero(),
                    gyro_matrix_sigma = GyroVector<float>::Zero();
  std::map<std::string, StreamEvent> stream;  // refused and noted samples, by status
  std::vector<EventRow> timeline;             // the first kListed events
  std::deque<EventRow> last;                  // the last kShownLast events
  long events = 0;                            // all of them
};

double mean3(double a, double b, double c) { return (a + b + c) / 3.0; }

struct Array3 {
  double v[3];
};
// v times k, each axis.
Array3 scaled(const double* v, double k) { return {{v[0] * k, v[1] * k, v[2] * k}}; }
Array3 array3(const Vector3<float>& x) {
  return {{static_cast<double>(x(0)), static_cast<double>(x(1)), static_cast<double>(x(2))}};
}

// The gyro's rad/s per raw unit: the units', else the prior record's calibrated scales.
double gyro_scale(const Options& o, const CalibrationRecord* prior) {
  const double s = gyro_nominal_scale(o);
  if (s > 0 || prior == nullptr || !succeeded(prior->calibration.gyro.status)) return s;
  const auto& p = prior->calibration.gyro.params;
  return mean3(static_cast<double>(p(kGyroScaleX)), static_cast<double>(p(kGyroScaleY)),
               static_cast<double>(p(kGyroScaleZ)));
}

EventRow event_row(const FieldEvent<float>& e) {
  EventRow r;
  r.time_s = e.time_s;
  r.sensor = field_sensor_name(e.sensor);
  r.kind = field_event_name(e.kind);
  r.reason = field_reason_name(e.reason);
  r.temperature_c = static_cast<double>(e.temperature_c);
  r.chi2 = static_cast<double>(e.chi2);
  for (int a = 0; a < 3; ++a) r.bias[a] = static_cast<double>(e.value(a));
  return r;
}

void keep_event(const FieldEvent<float>& e, FieldRun& run) {
  const EventRow r = event_row(e);
  ++run.events;
  if (run.timeline.size() < kListed) run.timeline.push_back(r);
  run.last.push_back(r);
  if (run.last.size() > kShownLast) run.last.pop_front();
}

// The field calibrator over the reader's samples. The samples are held until the noise at rest
// is known (the streaming calibrator's initial rest, unless both noises are given), at most
// --memory MB of them. Returns 0 (the bias was published), 1 (not), 2 (the reason in `error`).
int run_field(Options& o, SampleReader& reader, Diagnostics& diag, const CalibrationRecord* prior,
              FieldRun& run, std::string& error) {
  describe_input<float>(reader, o, run.input);
  Run& in = run.input;
  if (!in.has_accel || !in.has_gyro || in.mode != "stream") {
    error = "the field calibrator needs an accelerometer and a gyroscope stream (found columns " +
            in.columns + ")";
    return 2;
  }
  const double sg = gyro_scale(o, prior);
  if (!(sg > 0)) {
    error =
        "--gyro-unit counts needs --gyro-lsb-per-dps (the field calibrator's settings are in "
        "rad/s), or a --prior record with the gyro's scale";
    return 2;
  }
  run.gyro_per_rad_s = 1.0 / sg;
  const double sa = accel_nominal_scale(o);
  if (std::isfinite(o.accel_noise) && !(sa > 0)) {
    error = "--accel-noise is in m/s^2: with --accel-unit counts give --accel-lsb-per-g";
    return 2;
  }
  if (std::isfinite(o.gyro_noise)) run.gyro_noise_var = 3 * std::pow(o.gyro_noise / sg, 2);
  if (std::isfinite(o.accel_noise)) run.accel_noise_var = 3 * std::pow(o.accel_noise / sa, 2);
  const bool measure = !std::isfinite(run.gyro_noise_var) || !std::isfinite(run.accel_noise_var);
  run.noise_source = !measure ? "options"
                     : std::isfinite(run.gyro_noise_var) || std::isfinite(run.accel_noise_var)
                         ? "initial rest and options"
                         : "initial rest";

  // The calibrator's settings carry the stream checks (ranges, rate) and the detector's.
  const CalibratorSettings<float> cs = calibrator_settings<float>(o, in);
  FieldSettings<float> fs;
  static_cast<StreamSettings<float>&>(fs) = static_cast<const StreamSettings<float>&>(cs);
  fs.stillness = cs.stillness;
  fs.glitch_sigma = cs.glitch_sigma;
  fs.gyro_per_rad_s = static_cast<float>(run.gyro_per_rad_s);
  if (sa > 0) {  // the accelerometer's model needs its nominal scale
    run.accel_per_m_s2 = 1.0 / sa;
    fs.accel.accel_per_m_s2 = static_cast<float>(run.accel_per_m_s2);
    fs.accel.gravity = static_cast<float>(o.gravity);
    run.accel_enabled = true;
  }
  if (in.has_mag && std::isfinite(mag_unit_ut(o))) {  // the magnetometer's model: its units known
    run.mag_ut_per_raw = mag_unit_ut(o);
    fs.mag.counts_per_ut = static_cast<float>(1.0 / run.mag_ut_per_raw);
    run.mag_enabled = true;
  }
  if (std::isfinite(o.rest_piece)) fs.max_rest_seconds = static_cast<float>(o.rest_piece);
  run.rest_piece = static_cast<double>(fs.max_rest_seconds);
  const double az = accel_nominal_zero(o);
  run.accel_zero = std::isfinite(az) ? az : 0;
  run.gyro_zero = std::isfinite(o.gyro_zero) ? o.gyro_zero : 0;
  if (std::isfinite(o.accel_min)) {
    fs.accel_min = static_cast<float>(o.accel_min - run.accel_zero);
    fs.accel_max = static_cast<float>(o.accel_max - run.accel_zero);
  }
  if (std::isfinite(o.gyro_min)) {
    fs.gyro_min = static_cast<float>(o.gyro_min - run.gyro_zero);
    fs.gyro_max = static_cast<float>(o.gyro_max - run.gyro_zero);
  }
  // The prior about the zero reading, as the samples are.
  Calibration<float> prior_cal;
  TemperatureModel<float> prior_model;
  const bool prior_model_present = prior != nullptr && (prior->parts & kRecordTemperature) != 0;
  if (prior != nullptr) {
    prior_cal = prior->calibration;
    prior_model = prior->temperature;
    const float gz = static_cast<float>(run.gyro_zero);
    for (int a = 0; a < 3; ++a) prior_cal.gyro.params(kGyroBiasX + a) += gz;
    prior_model.gyro.b0 += Vector3<float>::Constant(gz);
    const float a0 = static_cast<float>(run.accel_zero);
    for (int a = 0; a < 3; ++a) prior_cal.accel.params(kBiasX + a) += a0;
    prior_model.accel.b0 += Vector3<float>::Constant(a0);
  }

  std::unique_ptr<Calibrator<float>> noise_cal;
  if (measure) noise_cal = std::make_unique<Calibrator<float>>(cs);
  auto field = std::make_unique<FieldCalibrator<float>>();
  bool started = false;
  run.prior = prior != nullptr ? o.prior_path : "nominal";
  auto start = [&]() -> bool {
    fs.gyro_noise = static_cast<float>(run.gyro_noise_var);
    fs.accel_noise = static_cast<float>(run.accel_noise_var);
    const bool prior_mag = prior != nullptr && (prior->parts & kRecordMag) != 0;
    const Status st = field->start(fs, prior != nullptr ? &prior_cal : nullptr,
                                   prior_model_present ? &prior_model : nullptr,
                                   prior_mag ? &prior->mag : nullptr);
    run.prior_status = to_string(st);
    if (st == Status::kInvalidArgument) {
      error = format_text(
          "the field calibrator refused its settings (noise at rest: gyro %s, accelerometer %s "
          "raw units^2 summed over the axes; %g raw units per rad/s)",
          fmt("%.4g", run.gyro_noise_var).c_str(), fmt("%.4g", run.accel_noise_var).c_str(),
          run.gyro_per_rad_s);
      return false;
    }
    started = true;
    return true;
  };
  if (!measure && !start()) return 2;

  auto feed = [&](const Sample& s) {
    Sample x = s;
    for (int a = 0; a < 3; ++a) {
      x.acc[a] -= run.accel_zero;
      x.gyro[a] -= run.gyro_zero;
    }
    const Status st = field->add(imu_sample<float>(x));
    if (st != Status::kOk) {
      StreamEvent& e = run.stream[to_string(st)];
      if (e.count++ == 0) e.first_t = s.t;
      e.status = to_string(st);
    }
    if (std::isfinite(s.mag[0]))
      field->add_mag(Vector3<float>(static_cast<float>(s.mag[0]), static_cast<float>(s.mag[1]),
                                    static_cast<float>(s.mag[2])));
    FieldEvent<float> e;
    while (field->take_event(e)) {
      if (e.sensor == FieldSensor::kGyro || e.sensor == FieldSensor::kAccel)
        e.value -= Vector3<float>::Constant(
            static_cast<float>(e.sensor == FieldSensor::kAccel ? run.accel_zero : run.gyro_zero));
      keep_event(e, run);
    }
  };

  const std::size_t most = static_cast<std::size_t>(o.memory_mb * 1048576.0 / sizeof(Sample));
  std::vector<Sample> held;  // the samples before the noise is known
  DeviceClock clock;
  Record r;
  long n = 0;
  while (reader.next(r, diag)) {
    const Sample s = make_sample(r, clock, in.has_gyro);
    if (n == 0) in.t_first = s.t;
    ++n;
    in.t_last = s.t;
    if (started) {
      feed(s);
      continue;
    }
    held.push_back(s);
    noise_cal->add(imu_sample<float>(s));
    if (noise_cal->progress().phase != Phase::kInitialRest) {
      if (!std::isfinite(run.gyro_noise_var))
        run.gyro_noise_var = static_cast<double>(noise_cal->gyro_noise_variance().sum());
      if (!std::isfinite(run.accel_noise_var))
        run.accel_noise_var = static_cast<double>(noise_cal->accel_noise_variance().sum());
      run.noise_rest_end_s = s.t;
      for (int a = 0; a < 3; ++a)
        run.rest_bias[a] = static_cast<double>(noise_cal->gyro_bias0()(a));
      noise_cal.reset();
      if (!start()) return 2;
      for (const Sample& x : held) feed(x);
      held = {};
    } else if (held.size() > most) {
      error = format_text(
          "no still period of --initial-rest %g s in the first %zu samples (--memory %g MB) "
          "to measure the noise at rest from: give --gyro-noise and --accel-noise",
          o.initial_rest, held.size(), o.memory_mb);
      return 2;
    }
  }
  in.samples = n;
  in.lines_skipped = reader.lines_skipped();
  if (n == 0) {
    diag.add({o.files[0], 0, 0, "no samples"});
    return 2;
  }
  if (n > 1 && in.time_source != "none")
    in.rate_hz = static_cast<double>(n - 1) / (in.t_last - in.t_first);
  if (!started) {
    error = format_text(
        "no still period of --initial-rest %g s followed by motion in the recording to measure "
        "the noise at rest from: give a shorter --initial-rest, or --gyro-noise and "
        "--accel-noise",
        o.initial_rest);
    return 2;
  }
  for (const auto& kv : run.stream) in.events.push_back(kv.second);
  run.counts = field->counts();
  {
    TemperatureModel<float> unused;
    Calibration<float> cal;
    field->calibration(cal, unused);
    run.gyro_matrix = cal.gyro.params;
    run.gyro_matrix_sigma = cal.gyro.sigma;
    run.gyro_matrix_published = field->gyro_field().has_published();
  }
  Vector3<float> b;
  float sigma = 0;
  run.published = field->gyro_bias(b, &sigma);
  for (int a = 0; a < 3; ++a) run.bias[a] = static_cast<double>(b(a)) - run.gyro_zero;
  run.sigma = static_cast<double>(sigma);
  run.temperature_c = static_cast<double>(field->temperature());
  if (std::isfinite(o.at_temperature)) {
    field->gyro_bias(static_cast<float>(o.at_temperature), b, &sigma);
    for (int a = 0; a < 3; ++a) run.at_bias[a] = static_cast<double>(b(a)) - run.gyro_zero;
    run.at_sigma = static_cast<double>(sigma);
  }
  const BiasFilter<float>& filter = field->filter();
  const float margin = field->settings().temperature_margin_c;
  auto filter_at = [&](float t, double* out, double& sd) {
    const Vector3<float> v = filter.at(t, margin);
    for (int a = 0; a < 3; ++a) out[a] = static_cast<double>(v(a)) - run.gyro_zero;
    sd = std::sqrt(static_cast<double>(filter.variance(filter.clamped_offset(t, margin))));
  };
  filter_at(field->temperature(), run.filter_bias, run.filter_sigma);
  if (std::isfinite(o.at_temperature))
    filter_at(static_cast<float>(o.at_temperature), run.filter_at_bias, run.filter_at_sigma);
  field->published_model(run.model);
  run.model.gyro.b0 -= Vector3<float>::Constant(static_cast<float>(run.gyro_zero));
  if (succeeded(run.model.accel.status))
    run.model.accel.b0 -= Vector3<float>::Constant(static_cast<float>(run.accel_zero));
  if (run.accel_enabled) {
    Vector3<float> ab, as;
    run.accel_published = field->accel_bias(ab, &as);
    for (int a = 0; a < 3; ++a) {
      run.accel_bias[a] = static_cast<double>(ab(a)) - run.accel_zero;
      run.accel_sigma[a] = static_cast<double>(as(a));
    }
    TemperatureModel<float> unused;
    Calibration<float> cal;
    field->calibration(cal, unused);
    run.accel = cal.accel;
    for (int a = 0; a < 3; ++a) run.accel.params(kBiasX + a) -= static_cast<float>(run.accel_zero);
  }
  if (run.mag_enabled) {
    Vector3<float> h, sh;
    run.mag_published = field->mag_hard_iron(h, &sh);
    for (int a = 0; a < 3; ++a) {
      run.hard_iron[a] = static_cast<double>(h(a));
      run.hard_iron_sigma[a] = static_cast<double>(sh(a));
    }
    field->mag_calibration(run.mag);
  }
  return run.published ? 0 : 1;
}

// The accelerometer's mg per raw unit (NaN without its model).
double mg_per_raw(const FieldRun& run, const Options& o) {
  return run.accel_enabled ? 1000.0 / (run.accel_per_m_s2 * o.gravity) : kNaN;
}

std::string vec_text(const double* v, const char* format) {
  return "[" + fmt(format, v[0]) + ", " + fmt(format, v[1]) + ", " + fmt(format, v[2]) + "]";
}

// An event's bias in deg/s (the gyro's), mg (the accelerometer's) or uT (the magnetometer's hard
// iron); the gyro's scales (gyro_matrix) as multiples of the nominal one.
void print_event(std::FILE* out, const EventRow& e, double to_dps, double to_mg, double to_ut) {
  const std::string sensor = e.sensor;
  const bool accel = sensor == "accel", mag = sensor == "mag", matrix = sensor == "gyro_matrix";
  const double k = accel ? to_mg : (mag ? to_ut : (matrix ? kDeg / to_dps : to_dps));
  const double v[3] = {e.bias[0] * k, e.bias[1] * k, e.bias[2] * k};
  std::fprintf(out, "  %9lu  %-6s %-15s %-12s %8s %10s  %s %s\n",
               static_cast<unsigned long>(e.time_s), e.sensor, e.kind, e.reason,
               fmt("%.2f", e.temperature_c).c_str(), fmt("%.3g", e.chi2).c_str(),
               vec_text(v, accel || mag ? "% .2f" : (matrix ? "% .5f" : "% .5f")).c_str(),
               accel ? "mg" : (mag ? "uT" : (matrix ? "x nominal scale" : "deg/s")));
}

void print_field_summary(const FieldRun& run, const Options& o, std::FILE* out) {
  const Run& in = run.input;
  const char* gu = gyro_unit_name(o.gyro_unit);
  const double to_dps = kDeg / run.gyro_per_rad_s;  // deg/s per raw unit
  const double span = in.t_last - in.t_first;
  std::fprintf(out, "imucal field %s: %ld samples over %s s (%s h), %s Hz, %s\n",
               o.files.size() == 2 ? (o.files[0] + " " + o.files[1]).c_str() : o.files[0].c_str(),
               in.samples, fmt("%.1f", span).c_str(), fmt("%.3f", span / 3600).c_str(),
               fmt("%.2f", in.rate_hz).c_str(), in.format.c_str());
  if (in.lines_skipped > 0) std::fprintf(out, "  %ld lines skipped\n", in.lines_skipped);
  for (const StreamEvent& e : in.events)
    std::fprintf(out, "  stream: %s: %ld samples (first at %s s)\n", e.status.c_str(), e.count,
                 fmt("%.3f", e.first_t).c_str());
  std::fprintf(out, "gyro     %s, %s raw units per rad/s, zero reading %g\n", gu,
               fmt("%.6g", run.gyro_per_rad_s).c_str(), run.gyro_zero);
  std::fprintf(
      out, "noise    from the %s%s: gyro %s %s, accelerometer %s %s (one sample, one axis)\n",
      run.noise_source.c_str(),
      std::isfinite(run.noise_rest_end_s)
          ? (" (ended at " + fmt("%.2f", run.noise_rest_end_s) + " s)").c_str()
          : "",
      fmt("%.4g", std::sqrt(run.gyro_noise_var / 3)).c_str(), gu,
      fmt("%.4g", std::sqrt(run.accel_noise_var / 3)).c_str(), accel_unit_name(o.accel_unit));
  std::fprintf(out, "prior    %s (%s); rests judged in pieces of at most %g s\n", run.prior.c_str(),
               run.prior_status.c_str(), run.rest_piece);
  const FieldCounts& c = run.counts;
  std::fprintf(out,
               "rests    %u found: %u taken, %u refused as turning, %u held (outside the gate), "
               "%u unconfirmed",
               c.rests, c.taken, c.turning, c.held, c.unconfirmed);
  if (c.no_temperature > 0)  // a temperature sensor that stopped reading
    std::fprintf(out, ", %u refused without a temperature", c.no_temperature);
  std::fprintf(out, "\n");
  std::fprintf(out, "changes  %u detected; %u updates published\n", c.changes, c.updates);
  if (run.published) {
    const Array3 dps = scaled(run.bias, to_dps);
    std::fprintf(out, "\ngyro bias published (added to the raw reading), %s:\n",
                 std::isfinite(run.temperature_c)
                     ? ("at " + fmt("%.2f", run.temperature_c) + " deg C").c_str()
                     : "no temperature in the input");
    std::fprintf(out, "  b  %s +- %s %s\n", vec_text(run.bias, "% .6g").c_str(),
                 fmt("%.3g", run.sigma).c_str(), gu);
    std::fprintf(out, "     %s +- %s deg/s\n", vec_text(dps.v, "% .5f").c_str(),
                 fmt("%.3g", run.sigma * to_dps).c_str());
    if (std::isfinite(o.at_temperature))
      std::fprintf(out, "  at %s deg C: %s +- %s %s\n", fmt("%.2f", o.at_temperature).c_str(),
                   vec_text(run.at_bias, "% .6g").c_str(), fmt("%.3g", run.at_sigma).c_str(), gu);
  } else {
    std::fprintf(out,
                 "\ngyro bias NOT published: the filter publishes from a piece judged while its "
                 "rest goes on (a rest of three pieces or more, --rest-piece), once %d rests "
                 "after motion were taken\n",
                 FieldSettings<float>().first_rests);
    // A rest reading far from the zero given: the prior's 3 deg/s cannot take it.
    double off = 0;
    for (int a = 0; a < 3; ++a) off = std::fmax(off, std::fabs(run.rest_bias[a] + run.gyro_zero));
    if (std::isfinite(off) &&
        off * to_dps > 3 * kDeg * static_cast<double>(FieldSettings<float>().bias_sigma))
      std::fprintf(
          out,
          "  the gyro read up to %s deg/s at the initial rest, beyond 3 sigma of the "
          "prior's %s deg/s: give its zero reading (--gyro-zero 32768 for unsigned 16-bit "
          "counts) or a --prior record\n",
          fmt("%.1f", off * to_dps).c_str(),
          fmt("%.0f", kDeg * static_cast<double>(FieldSettings<float>().bias_sigma)).c_str());
  }
  std::fprintf(out, "the filter's estimate (%s): %s +- %s %s\n",
               run.published ? "published when it differs significantly" : "not published",
               vec_text(run.filter_bias, "% .6g").c_str(), fmt("%.3g", run.filter_sigma).c_str(),
               gu);
  if (std::isfinite(o.at_temperature))
    std::fprintf(out, "  at %s deg C: %s +- %s %s\n", fmt("%.2f", o.at_temperature).c_str(),
                 vec_text(run.filter_at_bias, "% .6g").c_str(),
                 fmt("%.3g", run.filter_at_sigma).c_str(), gu);
  const TemperatureModel<float>& m = run.model;
  const TemperatureBias<float>& g = m.gyro;
  std::fprintf(out, "temperature model of the published bias  %s\n", kTemperatureModel);
  std::fprintf(out, "  T0 %s deg C, valid %s .. %s deg C (%s)\n",
               fmt("%.2f", static_cast<double>(m.reference_c)).c_str(),
               fmt("%.2f", static_cast<double>(m.min_c)).c_str(),
               fmt("%.2f", static_cast<double>(m.max_c)).c_str(), to_string(g.status));
  auto row = [&](const char* name, const Vector3<float>& v, const Vector3<float>& sd,
                 const char* format, const char* unit) {
    const Array3 x = array3(v), y = array3(sd);
    std::fprintf(out, "  %s %s  %s%s\n", name, vec_pm(x.v, y.v, format).c_str(), gu, unit);
  };
  row("b0", g.b0, g.b0_sigma, "% .6g", "");
  row("b1", g.b1, g.b1_sigma, "% .4g", "/degC");
  row("b2", g.b2, g.b2_sigma, "% .4g", "/degC^2");

  const double to_mg = mg_per_raw(run, o);
  if (run.accel_enabled) {
    const Array3 mg = scaled(run.accel_bias, to_mg), smg = scaled(run.accel_sigma, to_mg);
    std::fprintf(out, "\naccelerometer bias %s (added to the raw reading), %s:\n",
                 run.accel_published ? "published" : "NOT published (the prior's)",
                 std::isfinite(run.temperature_c)
                     ? ("at " + fmt("%.2f", run.temperature_c) + " deg C").c_str()
                     : "no temperature in the input");
    std::fprintf(out, "  b  %s %s\n", vec_pm(run.accel_bias, run.accel_sigma, "% .6g").c_str(),
                 accel_unit_name(o.accel_unit));
    std::fprintf(out, "     %s mg; %u rests held, %u changes, %u updates\n",
                 vec_pm(mg.v, smg.v, "% .3f").c_str(), c.accel_held, c.accel_changes,
                 c.accel_updates);
    if (c.accel_implausible > 0)
      std::fprintf(out,
                   "  %u rests refused: their reading is not gravity through the nominal scale "
                   "(give the accelerometer's zero reading, --accel-zero 32768 for unsigned "
                   "16-bit counts, or its --accel-lsb-per-g)\n",
                   c.accel_implausible);
  }

  {  // the gyro's scales as multiples of the nominal one, misalignments in mrad
    const double k = run.gyro_per_rad_s;
    double sc[3], ss[3], mis[6], ms[6];
    for (int a = 0; a < 3; ++a) {
      sc[a] = static_cast<double>(run.gyro_matrix(kGyroScaleX + a)) * k;
      ss[a] = static_cast<double>(run.gyro_matrix_sigma(kGyroScaleX + a)) * k;
    }
    for (int a = 0; a < 6; ++a) {
      mis[a] = 1e3 * static_cast<double>(run.gyro_matrix(a));
      ms[a] = 1e3 * static_cast<double>(run.gyro_matrix_sigma(a));
    }
    std::fprintf(out,
                 "\ngyro misalignment and scale %s: %u moves taken, %u refused, %u updates, "
                 "%u changes found\n",
                 run.gyro_matrix_published ? "published" : "NOT published (the prior's)",
                 run.counts.gyro_moves, run.counts.gyro_moves_refused,
                 run.counts.gyro_matrix_updates, run.counts.gyro_matrix_changes);
    std::fprintf(out, "  scale  %s x nominal\n", vec_pm(sc, ss, "% .5f").c_str());
    std::fprintf(out, "  misalignment  %s  %s mrad\n", vec_pm(mis, ms, "% .2f").c_str(),
                 vec_pm(mis + 3, ms + 3, "% .2f").c_str());
  }

  const double to_ut = run.mag_ut_per_raw;
  if (run.mag_enabled) {
    const Array3 ut = scaled(run.hard_iron, to_ut), sut = scaled(run.hard_iron_sigma, to_ut);
    std::fprintf(out, "\nmagnetometer hard iron %s (added to the raw reading):\n",
                 run.mag_published ? "published" : "NOT published (the prior's)");
    std::fprintf(out, "  h  %s %s\n", vec_pm(run.hard_iron, run.hard_iron_sigma, "% .6g").c_str(),
                 mag_unit_name(o.mag_unit));
    std::fprintf(out, "     %s uT; field %s uT; %u rests held, %u changes, %u updates\n",
                 vec_pm(ut.v, sut.v, "% .3f").c_str(),
                 fmt("%.2f", static_cast<double>(run.mag.field_ut)).c_str(), c.mag_held,
                 c.mag_changes, c.mag_updates);
    if (c.mag_implausible > 0)
      std::fprintf(out,
                   "  %u rests refused: their field is not of the expected strength through "
                   "the model (a magnet on the device, or the wrong --mag-unit)\n",
                   c.mag_implausible);
  } else if (run.input.has_mag) {
    std::fprintf(out,
                 "\nmagnetometer: used to verify the rests only; its model needs its scale "
                 "(--mag-lsb-per-ut with --mag-unit counts)\n");
  }

  std::fprintf(out, "\ntimeline (%s; t in s since the first sample; the sensor's bias after it)\n",
               plural(run.events, "event", "events").c_str());
  if (run.events == 0) return;
  std::fprintf(out, "  %9s  %-6s %-15s %-12s %8s %10s  %s\n", "t", "sensor", "event", "reason",
               "temp", "chi2", "published bias");
  const std::size_t all = static_cast<std::size_t>(run.events);
  if (all <= kShownFirst + kShownLast) {
    for (const EventRow& e : run.timeline) print_event(out, e, to_dps, to_mg, to_ut);
    return;
  }
  for (std::size_t i = 0; i < kShownFirst; ++i)
    print_event(out, run.timeline[i], to_dps, to_mg, to_ut);
  std::fprintf(out, "  ... %zu events not shown (--json lists %s) ...\n",
               all - kShownFirst - kShownLast,
               all <= kListed ? "every one" : format_text("the first %zu", kListed).c_str());
  for (const EventRow& e : run.last) print_event(out, e, to_dps, to_mg, to_ut);
}

// The picture page (--svg): per sensor, the published bias over the recording (each axis, in
// deg/s, mg or uT) with its decisions marked (updated: a dot; held: an orange tick; refused: a
// grey one; a change: a red line), and the temperature at the decisions.
std::string field_svg(const FieldRun& run, const Options& o) {
  using namespace report;
  const Run& in = run.input;
  const double span_s = std::isfinite(in.t_last - in.t_first) ? in.t_last - in.t_first : 0;
  const bool hours = span_s > 7200;
  const double unit_s = hours ? 3600 : 1;
  TimeAxis axis;
  axis.lo = 0;
  axis.hi = std::max(span_s / unit_s, 1e-3);
  axis.valid = true;
  axis.name = hours ? "hours since the first sample" : "seconds since the first sample";
  Page page;
  page.text(30, 38, "imucal field calibrator", "class=\"t\"");
  page.text(30, 62,
            elide(o.files.empty() ? std::string() : o.files[0], 80) + " \u00b7 " +
                grouped(in.samples) + " samples over " + printf_string("%.2f", span_s / 3600) +
                " h \u00b7 prior " + elide(run.prior, 40),
            "class=\"v\"");
  double y = 100;
  struct Sensor {
    const char* name;
    const char* title;
    double scale;
  };
  const double to_dps = kDeg / run.gyro_per_rad_s;
  std::vector<Sensor> sensors = {{"gyro", "gyro bias published (deg/s, added)", to_dps}};
  if (run.accel_enabled)
    sensors.push_back({"accel", "accelerometer bias published (mg, added)", mg_per_raw(run, o)});
  if (run.mag_enabled)
    sensors.push_back({"mag", "magnetometer hard iron published (uT, added)", run.mag_ut_per_raw});
  for (const Sensor& s : sensors) {
    std::vector<const EventRow*> rows;
    for (const EventRow& e : run.timeline)
      if (std::string(e.sensor) == s.name) rows.push_back(&e);
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    for (const EventRow* e : rows)
      for (int a = 0; a < 3; ++a) {
        lo = std::min(lo, e->bias[a] * s.scale);
        hi = std::max(hi, e->bias[a] * s.scale);
      }
    pad_range(lo, hi, 0.08);
    section_title(page, y, s.title);
    legend(page, y, {{"x", kAxisColour[0]}, {"y", kAxisColour[1]}, {"z", kAxisColour[2]}});
    const Panel p = make_panel(y + 12, 150, axis.lo, axis.hi, lo, hi);
    value_grid(page, p, s.name);
    time_grid(page, p, axis, false);
    if (rows.empty()) caption_in(page, p, "no decision");
    for (int a = 0; a < 3; ++a) {
      PathBuilder path;
      double last = kNaN;
      for (const EventRow* e : rows) {
        const double x = p.sx(e->time_s / unit_s), v = p.sy(e->bias[a] * s.scale);
        if (std::isfinite(last)) path.point(x, last);
        path.point(x, v);
        last = v;
      }
      if (std::isfinite(last)) path.point(p.sx(axis.hi), last);
      page.path(path.str(), std::string("class=\"s\" stroke=\"") + kAxisColour[a] + "\"");
    }
    for (const EventRow* e : rows) {
      const double x = p.sx(e->time_s / unit_s);
      const std::string kind = e->kind;
      const std::string tip = kind + " (" + e->reason + ") at " + std::to_string(e->time_s) + " s";
      if (kind == "change_detected")
        page.line(x, p.y, x, p.y + p.h, "stroke=\"#c62828\" stroke-width=\"1.5\"");
      else if (kind == "updated")
        page.circle(x, p.y + p.h - 5, 2.5, "fill=\"#1565c0\"", tip);
      else if (kind == "held")
        page.rect(x - 0.5, p.y + p.h - 12, 1.5, 8, "fill=\"#ef6c00\"", tip);
      else if (kind == "rejected")
        page.rect(x - 0.5, p.y + p.h - 10, 1, 6, "fill=\"#9e9e9e\"", tip);
    }
    frame(page, p);
    y = p.y + p.h + 40;
  }
  // The temperature at the decisions, where the input has one.
  double tlo = HUGE_VAL, thi = -HUGE_VAL;
  for (const EventRow& e : run.timeline)
    if (std::isfinite(e.temperature_c)) {
      tlo = std::min(tlo, e.temperature_c);
      thi = std::max(thi, e.temperature_c);
    }
  if (tlo <= thi) {
    pad_range(tlo, thi, 0.08);
    section_title(page, y, "temperature at the decisions (deg C)");
    const Panel p = make_panel(y + 12, 110, axis.lo, axis.hi, tlo, thi);
    value_grid(page, p, "deg C");
    time_grid(page, p, axis, true);
    PathBuilder temp;
    for (const EventRow& e : run.timeline)
      if (std::isfinite(e.temperature_c))
        temp.point(p.sx(e.time_s / unit_s), p.sy(e.temperature_c));
    page.path(temp.str(), "class=\"s\" stroke=\"#6d4c41\"");
    frame(page, p);
    y = p.y + p.h + 50;
  } else {
    page.text(kPlotLeft + kPlotWidth / 2, y - 8, axis.label(),
              "class=\"ax\" text-anchor=\"middle\"");
    y += 10;
  }
  page.text(kPlotLeft, y,
            "decisions: a dot updated \u00b7 orange held \u00b7 grey refused \u00b7 a red line "
            "a change confirmed",
            "class=\"cap\"");
  y += 20;
  return svg_document(page, y, "imucal field calibrator");
}

Json number(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }
Json vec3(const double* v) { return Json::array({number(v[0]), number(v[1]), number(v[2])}); }
Json vec3(const Vector3<float>& v) { return vec3(array3(v).v); }

// A sensor's published bias in the JSON: published or not, its unit and convention, the value and
// sigma (one for the three axes, or one each), and the temperature it is at.
Json bias_json(bool published, const char* unit, const double* value, Json sigma,
               double temperature_c) {
  Json b;
  b["published"] = published;
  b["unit"] = unit;
  b["convention"] = "added to the raw reading";
  b["value"] = vec3(value);
  b["sigma"] = std::move(sigma);
  b["temperature_c"] = number(temperature_c);
  return b;
}

std::string field_json(const FieldRun& run, const Options& o) {
  const Run& in = run.input;
  const double to_dps = kDeg / run.gyro_per_rad_s;
  Json j;
  j["imucal"] = "0.1.0";
  j["command"] = "field";
  Json input;
  input["files"] = o.files;
  input["format"] = in.format;
  input["columns"] = in.columns;
  input["time"] = in.time_source;
  input["samples"] = in.samples;
  input["t_first_s"] = in.t_first;
  input["t_last_s"] = in.t_last;
  input["hours"] = (in.t_last - in.t_first) / 3600;
  input["rate_hz"] = number(in.rate_hz);
  input["lines_skipped"] = in.lines_skipped;
  input["diagnostics"] = in.diagnostics;
  input["diagnostic_count"] = in.diagnostic_count;
  Json events = Json::array();
  for (const StreamEvent& e : in.events)
    events.push_back({{"status", e.status}, {"samples", e.count}, {"first_t_s", e.first_t}});
  input["stream_events"] = events;
  j["input"] = input;
  Json config;
  config["time_unit"] = time_unit_name(o.time_unit);
  config["accel_unit"] = accel_unit_name(o.accel_unit);
  config["gyro_unit"] = gyro_unit_name(o.gyro_unit);
  config["gyro_per_rad_s"] = number(run.gyro_per_rad_s);
  config["accel_zero"] = run.accel_zero;
  config["gyro_zero"] = run.gyro_zero;
  config["initial_rest_s"] = o.initial_rest;
  config["rest_piece_s"] = run.rest_piece;
  config["nominal_rate_hz"] = o.nominal_rate_hz > 0 ? Json(o.nominal_rate_hz) : Json(nullptr);
  config["prior"] = run.prior;
  config["prior_status"] = run.prior_status;
  config["from_files"] = o.from_files;
  j["configuration"] = config;
  j["noise"] = {{"source", run.noise_source},
                {"initial_rest_end_s", number(run.noise_rest_end_s)},
                {"gyro_variance_raw", number(run.gyro_noise_var)},
                {"accel_variance_raw", number(run.accel_noise_var)}};
  const FieldCounts& c = run.counts;
  j["counts"] = {{"rests", c.rests},
                 {"taken", c.taken},
                 {"turning", c.turning},
                 {"no_temperature", c.no_temperature},
                 {"held", c.held},
                 {"unconfirmed", c.unconfirmed},
                 {"changes", c.changes},
                 {"updates", c.updates},
                 {"events_dropped", c.events_dropped},
                 {"accel_held", c.accel_held},
                 {"accel_changes", c.accel_changes},
                 {"accel_updates", c.accel_updates},
                 {"accel_implausible", c.accel_implausible},
                 {"mag_held", c.mag_held},
                 {"mag_changes", c.mag_changes},
                 {"mag_updates", c.mag_updates},
                 {"mag_implausible", c.mag_implausible},
                 {"mag_glitches", c.mag_glitches},
                 {"gyro_moves", c.gyro_moves},
                 {"gyro_moves_refused", c.gyro_moves_refused},
                 {"gyro_matrix_updates", c.gyro_matrix_updates},
                 {"gyro_matrix_changes", c.gyro_matrix_changes}};
  Json bias = bias_json(run.published, gyro_unit_name(o.gyro_unit), run.bias, number(run.sigma),
                        run.temperature_c);
  bias["value_dps"] = vec3(scaled(run.bias, to_dps).v);
  bias["sigma_dps"] = number(run.sigma * to_dps);
  j["gyro_bias"] = bias;
  j["filter_bias"] = {{"value", vec3(run.filter_bias)}, {"sigma", number(run.filter_sigma)}};
  if (std::isfinite(o.at_temperature)) {
    j["gyro_bias_at"] = {{"temperature_c", o.at_temperature},
                         {"value", vec3(run.at_bias)},
                         {"sigma", number(run.at_sigma)}};
    j["filter_bias_at"] = {{"temperature_c", o.at_temperature},
                           {"value", vec3(run.filter_at_bias)},
                           {"sigma", number(run.filter_at_sigma)}};
  }
  {  // the gyro's misalignment and scale (rad/s per raw unit), the prior's until published
    Json params;
    for (int k = 0; k < kGyroMatrixParams; ++k)
      params[kGyroParamNames[k]] = {
          {"value", number(static_cast<double>(run.gyro_matrix(k)))},
          {"sigma", number(static_cast<double>(run.gyro_matrix_sigma(k)))}};
    j["gyro_matrix"] = {{"published", run.gyro_matrix_published}, {"parameters", params}};
  }
  if (run.accel_enabled) {
    Json a = bias_json(run.accel_published, accel_unit_name(o.accel_unit), run.accel_bias,
                       vec3(run.accel_sigma), run.temperature_c);
    Json params, sig;
    for (int k = 0; k < kAccelParams; ++k) {
      params[kAccelParamNames[k]] = number(static_cast<double>(run.accel.params(k)));
      sig[kAccelParamNames[k]] = number(static_cast<double>(run.accel.sigma(k)));
    }
    a["model"] = {{"parameters", params}, {"sigma", sig}};
    j["accel_bias"] = a;
  } else {
    j["accel_bias"] = nullptr;
  }
  if (run.mag_enabled) {
    Json h = bias_json(run.mag_published, mag_unit_name(o.mag_unit), run.hard_iron,
                       vec3(run.hard_iron_sigma), kNaN);
    h["value_ut"] = vec3(scaled(run.hard_iron, run.mag_ut_per_raw).v);
    h["sigma_ut"] = vec3(scaled(run.hard_iron_sigma, run.mag_ut_per_raw).v);
    Json s = Json::array();
    for (int r = 0; r < 3; ++r) s.push_back(vec3(Vector3<float>(run.mag.soft_iron.row(r))));
    h["soft_iron"] = s;
    h["field_ut"] = number(static_cast<double>(run.mag.field_ut));
    j["mag_hard_iron"] = h;
  } else {
    j["mag_hard_iron"] = nullptr;
  }
  const TemperatureModel<float>& m = run.model;
  j["temperature_model"] = {{"model", kTemperatureModel},
                            {"status", to_string(m.gyro.status)},
                            {"order", m.order},
                            {"reference_c", number(static_cast<double>(m.reference_c))},
                            {"min_c", number(static_cast<double>(m.min_c))},
                            {"max_c", number(static_cast<double>(m.max_c))},
                            {"b0", vec3(m.gyro.b0)},
                            {"b1", vec3(m.gyro.b1)},
                            {"b2", vec3(m.gyro.b2)},
                            {"b0_sigma", vec3(m.gyro.b0_sigma)},
                            {"b1_sigma", vec3(m.gyro.b1_sigma)},
                            {"b2_sigma", vec3(m.gyro.b2_sigma)},
                            {"accel_status", to_string(m.accel.status)},
                            {"accel_b0", vec3(m.accel.b0)},
                            {"accel_b1", vec3(m.accel.b1)},
                            {"accel_b2", vec3(m.accel.b2)},
                            {"accel_b0_sigma", vec3(m.accel.b0_sigma)},
                            {"accel_b1_sigma", vec3(m.accel.b1_sigma)},
                            {"accel_b2_sigma", vec3(m.accel.b2_sigma)}};
  Json timeline = Json::array();
  for (const EventRow& e : run.timeline)
    timeline.push_back({{"time_s", e.time_s},
                        {"sensor", e.sensor},
                        {"kind", e.kind},
                        {"reason", e.reason},
                        {"temperature_c", number(e.temperature_c)},
                        {"chi2", number(e.chi2)},
                        {"bias", vec3(e.bias)}});
  j["timeline"] = timeline;
  j["events"] = run.events;
  j["events_not_listed"] = run.events - static_cast<long>(run.timeline.size());
  return j.dump(2) + "\n";
}

// An option given that says nothing to the field calibrator: false with the reason.
bool field_options_apply(const Options& o, std::string& error) {
  for (const std::string& k : o.command_line_keys) {
    for (const char* no : kNotField) {
      if (k == no) {
        error = "--" + k + " does not apply to the field calibrator";
        return false;
      }
    }
  }
  return true;
}

}  // namespace

int field_command(const std::vector<std::string>& args) {
  Options o;
  std::string error;
  if (!parse_calibrate_options(args, o, error) || !field_options_apply(o, error)) {
    std::fprintf(stderr, "imucal field: %s\n", error.c_str());
    return 2;
  }
  if (o.files.empty()) {
    std::fprintf(stderr, "imucal field: no input (a CSV file, - for stdin, or two imu_tk files)\n");
    return 2;
  }
  std::vector<std::string> inputs = o.files;
  inputs.push_back(o.prior_path);
  if (!outputs_apart_from_inputs(inputs, {{"--json", o.json_path}, {"--svg", o.svg_path}}))
    return 2;
  std::unique_ptr<CalibrationRecord> prior;
  if (!o.prior_path.empty()) {
    prior = std::make_unique<CalibrationRecord>();
    const int code = read_record_file(o.prior_path, *prior, error);
    if (code != 0) {
      std::fprintf(stderr, "imucal field: --prior: %s\n", error.c_str());
      return 2;
    }
  }
  Diagnostics diag;
  SampleReader reader;
  reader.set_columns(o.columns);
  if (!reader.open(o.files, o.format, diag)) {
    print_diagnostics(diag);
    return 2;
  }
  if (!settle_options(reader, o, error)) {
    std::fprintf(stderr, "imucal: %s\n", error.c_str());
    return 2;
  }
  FieldRun run;
  const int code = run_field(o, reader, diag, prior.get(), run, error);
  run.input.diagnostic_count = static_cast<long>(diag.count());
  for (const Diagnostic& d : diag.kept()) run.input.diagnostics.push_back(d.text());
  print_diagnostics(diag);
  if (code == 2) {
    if (error.empty()) return 2;  // the diagnostics said why
    std::fprintf(stderr, "imucal field: %s\n", error.c_str());
    return 2;
  }
  if (reader.failed()) {
    std::fprintf(stderr, "imucal: the input could not be read to its end: nothing written\n");
    return 2;
  }
  std::FILE* summary = o.json_path == "-" ? stderr : stdout;
  print_field_summary(run, o, summary);
  if (!o.json_path.empty() && !write_text_file(o.json_path, field_json(run, o))) return 2;
  if (!o.svg_path.empty() && !write_text_file(o.svg_path, field_svg(run, o))) return 2;
  return code;
}

int field_memory(const std::vector<std::string>& args, const SampleArrays& arrays,
                 const std::vector<std::uint8_t>* prior, MemoryRun& out) {
  Options o;
  Diagnostics diag;
  SampleReader reader;
  if (!open_arrays(args, arrays, o, reader, diag, out.error) ||
      !field_options_apply(o, out.error) || !settle_options(reader, o, out.error))
    return 2;
  std::unique_ptr<CalibrationRecord> record;
  if (prior != nullptr) {
    record = std::make_unique<CalibrationRecord>();
    static const std::uint8_t kNothing = 0;
    const std::uint8_t* p = prior->empty() ? &kNothing : prior->data();
    const Status st = decode_record(p, prior->size(), *record);
    if (st != Status::kOk) {
      out.error = std::string("prior: not a valid record: ") + to_string(st);
      return 2;
    }
    o.prior_path = "<bytes>";
  }
  FieldRun run;
  const int code = run_field(o, reader, diag, record.get(), run, out.error);
  run.input.diagnostic_count = static_cast<long>(diag.count());
  for (const Diagnostic& d : diag.kept()) run.input.diagnostics.push_back(d.text());
  if (code == 2) {
    if (out.error.empty())
      out.error = diag.kept().empty() ? "the input could not be read" : diag.kept()[0].message;
    return 2;
  }
  out.summary = printed([&](std::FILE* f) { print_field_summary(run, o, f); });
  out.json = field_json(run, o);
  return code;
}

}  // namespace imucal::cli
