// SPDX-License-Identifier: MIT
// tools/imucal/calibrate.cpp: `imucal calibrate` and `imucal report`: the recording through the
// same streaming calibrator as on the device (float, or double with --double), then the
// residuals before and after, the summary, and the requested outputs.
#include "calibrate.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <memory>
#include <utility>

#include "cli.hpp"
#include "imucal/calibrator/calibrator.hpp"
#include "imucal/magnetometer/mag_calibration.hpp"
#include "imucal/store/record.hpp"
#include "imucal/temperature/temperature_fit.hpp"
#include "outputs.hpp"
#include "sample_store.hpp"

namespace imucal::cli {

namespace {

// The angle between two directions, in degrees (stable for small and for near-opposite ones).
double angle_deg(const Vector3<double>& u, const Vector3<double>& v) {
  return std::atan2(u.cross(v).norm(), u.dot(v)) * kDeg;
}

// The angle (deg) between gravity carried over a move by the gyro model (M, bias relative to
// the statistics' own) and the gravity measured after it.
template <typename Scalar, class Cal>
double move_angle(const Cal& cal, const GyroMove& mv, const Matrix3<double>& m,
                  const Vector3<double>& b_rel, const std::vector<PoseResult>& poses) {
  const auto& from = poses[static_cast<std::size_t>(mv.from_pose)].up;
  const auto& to = poses[static_cast<std::size_t>(mv.to_pose)].up;
  Vector3<double> v(from[0], from[1], from[2]);
  for (int k = 0; k < mv.segments; ++k) {
    const GyroSegment<Scalar>& s = cal.segment(mv.first_segment + k);
    GyroSegment<double> d;
    d.alpha = s.alpha.template cast<double>();
    d.beta = s.beta.template cast<double>();
    d.gamma = s.gamma.template cast<double>();
    d.duration = static_cast<double>(s.duration);
    v = rotation_exp<double>(d.rotation_vector(m, b_rel)).transpose() * v;
  }
  return angle_deg(v, Vector3<double>(to[0], to[1], to[2]));
}

double rms(const std::vector<double>& v) {
  double sum = 0;
  long n = 0;
  for (double x : v) {
    if (!std::isfinite(x)) return kNaN;
    sum += x * x;
    ++n;
  }
  return n > 0 ? std::sqrt(sum / static_cast<double>(n)) : kNaN;
}

// The temperature model about `base` from the rests (raw means). False if the fit cannot start
// (`status` says why); otherwise `out` holds the model (each part's status inside).
template <typename Scalar>
bool fit_temperature(const Calibration<Scalar>& base, const std::vector<RestSummary<Scalar>>& rests,
                     const Options& o, TemperatureModel<Scalar>& out, Status& status) {
  TemperatureSettings<Scalar> ts;
  ts.order = o.temp_order;
  ts.min_span_c = static_cast<Scalar>(o.temp_min_span);
  ts.gravity = static_cast<Scalar>(o.gravity);
  auto fit = std::make_unique<TemperatureFit<Scalar>>();
  status = fit->reset(base, ts);
  if (status != Status::kOk) return false;
  for (const RestSummary<Scalar>& r : rests)
    if (r.has_temperature) fit->add_rest(r);
  status = fit->solve(out);
  return true;
}

// b(T) - b0 of a usable part (zero otherwise).
template <typename Scalar>
Vector3<double> bias_change(const TemperatureModel<Scalar>& m, const TemperatureBias<Scalar>& b,
                            double temp) {
  if (!succeeded(b.status) || !std::isfinite(temp)) return Vector3<double>::Zero();
  const double d = temp - static_cast<double>(m.reference_c);
  return d * (b.b1.template cast<double>() + d * b.b2.template cast<double>());
}

// Whether a reading is at or beyond the full scale (NaN limits: none given).
bool saturated(const double v[3], double lo, double hi) {
  for (int a = 0; a < 3; ++a)
    if (v[a] <= lo || v[a] >= hi) return true;
  return false;
}

// The readings with the model applied, raw + b(T) - b0 (the calibration then sees the biases at
// T0), one sample at a time in order; a sample without a temperature takes the nearest earlier
// one (before the first, the recording's first). A saturated reading stays as it is (the
// calibrator must still see it saturated).
template <typename Scalar>
class Compensation {
 public:
  Compensation(const TemperatureModel<Scalar>& m, const Options& o, double first_temp)
      : m_(m), o_(o), temp_(first_temp) {}
  void operator()(Sample& x) {
    note(x);
    apply(x);
  }
  // The temperature of every sample, in order; the model applied to the ones that need it.
  void note(const Sample& x) {
    if (std::isfinite(x.temp)) temp_ = x.temp;
  }
  void apply(Sample& x) const {
    const Vector3<double> da = bias_change(m_, m_.accel, temp_),
                          dg = bias_change(m_, m_.gyro, temp_);
    const bool acc_sat = saturated(x.acc, o_.accel_min, o_.accel_max);
    const bool gyro_sat = saturated(x.gyro, o_.gyro_min, o_.gyro_max);
    for (int a = 0; a < 3; ++a) {
      if (!acc_sat) x.acc[a] += da(a);
      if (!gyro_sat) x.gyro[a] += dg(a);
    }
  }

 private:
  TemperatureModel<Scalar> m_;
  const Options& o_;
  double temp_;
};

// The values one sensor's readings take, gathered as they are read: whether all are integers,
// and their least and largest.
struct IntegerRange {
  bool integers = true;
  double least = HUGE_VAL, most = -HUGE_VAL;

  void add(const double v[3]) {
    if (!integers) return;
    for (int a = 0; a < 3; ++a) {
      constexpr double kLimit = 2147483647.0;  // beyond it no reading is an int16 or uint16
      const double x = v[a];
      if (!(std::abs(x) <= kLimit)) {  // NaN and infinities are no readings, not a format
        if (std::isfinite(x)) integers = false;
        continue;
      }
      if (x != static_cast<double>(static_cast<std::int64_t>(x))) {
        integers = false;
        return;
      }
      least = std::min(least, x);
      most = std::max(most, x);
    }
  }

  // The limits of the integer format the readings fit: all integers within [-32768, 32767] are
  // int16 (a reading at -32768 or 32767 is clipped); within [0, 65535], uint16. False if they
  // fit neither (or there are none).
  bool format(double& lo, double& hi, std::string& name) const {
    if (!integers || least > most) return false;
    if (least >= -32768 && most <= 32767) {
      lo = -32768;
      hi = 32767;
      name = "int16";
    } else if (least >= 0 && most <= 65535) {
      lo = 0;
      hi = 65535;
      name = "uint16";
    } else {
      return false;
    }
    return true;
  }
};

// In counts without a range given, the readings at the limits of their integer format are
// saturated (the ADC clipped): the range is inferred from the data.
void infer_ranges(const IntegerRange& acc, const IntegerRange& gyro, bool has_gyro, Options& o) {
  if (o.accel_unit == AccelUnit::kCounts && !std::isfinite(o.accel_min))
    if (!acc.format(o.accel_min, o.accel_max, o.accel_range_inferred))
      o.accel_min = o.accel_max = kNaN;
  if (has_gyro && o.gyro_unit == GyroUnit::kCounts && !std::isfinite(o.gyro_min))
    if (!gyro.format(o.gyro_min, o.gyro_max, o.gyro_range_inferred)) o.gyro_min = o.gyro_max = kNaN;
}

// The saturation limits of one sensor inferred in counts (no range given) are known only at the
// end of the input. The first pass starts with the limits its first samples show (until one is
// negative or beyond 32767, at most kPrefix of them) and counts, for each integer format, the
// samples that format would have judged otherwise; the calibration is run again only if the
// format found at the end judges some sample otherwise.
struct RangeWatch {
  static constexpr std::size_t kPrefix = 4096;
  IntegerRange seen;
  bool active = false;  // inferred (counts, no range given)
  bool started = false;
  double used_lo = kNaN, used_hi = kNaN;
  long differs[3] = {0, 0, 0};  // int16, uint16, none

  // Whether the readings so far can only be one integer format (or none).
  bool settled() const { return !active || !seen.integers || seen.least < 0 || seen.most > 32767; }
  // The limits to start with, into lo and hi (NaN: none): those of the readings so far.
  void start(double& lo, double& hi) {
    if (!active) return;
    std::string name;
    if (!seen.format(lo, hi, name)) lo = hi = kNaN;
    used_lo = lo;
    used_hi = hi;
    started = true;
  }
  void add(const double v[3]) {
    seen.add(v);
    if (started) count(v);
  }
  void count(const double v[3]) {
    if (!active) return;
    // As saturated() at each pair of limits, from the least and the largest axis (a NaN axis
    // is at no limit).
    double least = HUGE_VAL, most = -HUGE_VAL;
    for (int a = 0; a < 3; ++a) {
      if (v[a] < least) least = v[a];
      if (v[a] > most) most = v[a];
    }
    auto at_limit = [&](double lo, double hi) { return least <= lo || most >= hi; };
    const bool used = at_limit(used_lo, used_hi);
    differs[0] += at_limit(-32768, 32767) != used;
    differs[1] += at_limit(0, 65535) != used;
    differs[2] += used;
  }
  // Whether the limits found at the end (lower limit lo; NaN: none) judge some sample otherwise
  // than those used.
  bool judged_otherwise(double lo) const {
    if (!active) return false;
    return differs[std::isnan(lo) ? 2 : lo < 0 ? 0 : 1] > 0;
  }
};

const char* const kFaceNames[6] = {"+x", "-x", "+y", "-y", "+z", "-z"};
const char* const kAxisNamesXyz[3] = {"x", "y", "z"};

// A misalignment the poses did not determine (held at 0) and a weak parameter, by name, with
// the orientations that would pin it down.
template <typename Scalar>
void advise_parameters(const AccelCalibration<Scalar>& a, Run& run) {
  for (int k = 0; k < kAccelParams; ++k) {
    if (a.held & (1u << k))
      run.advice.push_back(std::string("accelerometer ") + accel_parameter_name(k) +
                           " was not determined by the poses and is held at 0 (nominal): " +
                           accel_orientation_hint(k) + ".");
    else if (a.weak & (1u << k))
      run.advice.push_back(std::string("accelerometer ") + accel_parameter_name(k) +
                           " is weakly determined (see its sigma): " + accel_orientation_hint(k) +
                           ".");
  }
}

// What to do next, in words: from the calibrator's progress before the solve (its hint, the
// faces and axes still missing) and the counts after it.
void advise(const Progress& before, const Progress& after, const Options& o, Run& run) {
  std::vector<std::string>& a = run.advice;
  char buf[400];
  if (before.phase == Phase::kInitialRest) {
    std::snprintf(buf, sizeof buf,
                  "no still period of %g s was found (the run starts at the first one, "
                  "--initial-rest): the sensor never held still that long. Hold it still, on a "
                  "table, for a few seconds at the start or between turns.",
                  o.initial_rest);
    a.push_back(buf);
    if (before.hint == Hint::kCheckSensor)
      a.push_back(
          "the sensor repeated the same reading (frozen) during the initial rest: check the "
          "sensor and the logger.");
    return;
  }
  if (before.hint == Hint::kCheckSensor)
    a.push_back(
        "the sensor froze or the stream had gaps when it ended: check the sensor and the logger "
        "(the calibrator counts above say which).");
  if (after.rests_too_short > 0) {
    std::snprintf(buf, sizeof buf,
                  "%s shorter than --min-rest (%g s) did not count as poses: hold each "
                  "orientation still for at least %g s.",
                  plural(after.rests_too_short, "rest was", "rests were").c_str(), o.min_rest,
                  o.min_rest);
    a.push_back(buf);
  }
  if (after.poses < kAccelMinPoses) {
    std::snprintf(buf, sizeof buf,
                  "%s found, at least %d needed: hold more orientations, each still for a few "
                  "seconds, turning between them.",
                  plural(after.poses, "pose", "poses").c_str(), kAccelMinPoses);
    a.push_back(buf);
  }
  if (after.faces_covered < 6) {
    std::string missing;
    for (int i = 0; i < 6; ++i)
      if (((after.faces >> i) & 1) == 0)
        missing += (missing.empty() ? "" : ", ") + std::string(kFaceNames[i]);
    a.push_back("no pose had these faces up: " + missing +
                ". Put each of them up and hold it still (the first: " +
                kFaceNames[after.next_face] + ").");
  }
  if (run.has_gyro && after.poses >= kAccelMinPoses && after.axes_turned != 0x7) {
    std::string missing;
    for (int i = 0; i < 3; ++i)
      if (((after.axes_turned >> i) & 1) == 0)
        missing += (missing.empty() ? "" : " and ") + std::string(kAxisNamesXyz[i]);
    a.push_back("the turns between poses went little about the body axis " + missing +
                ": turn about it too, or the gyroscope's parameters for it stay weak.");
  }
  if (run.has_gyro && after.moves_dropped > 0)
    a.push_back(plural(after.moves_dropped, "turn", "turns") +
                " between poses could not be used for the gyroscope (across a gap in the "
                "timestamps, a frozen or saturated sensor, a full pose store, or the end of the "
                "recording while turning).");
}

template <typename Scalar>
using MagCal = MagCalibrator<Scalar, 4, Calibrator<Scalar>::kMaxPoses>;

template <typename Scalar>
MagSettings<Scalar> mag_settings(const Options& o) {
  MagSettings<Scalar> ms;
  ms.unit_ut = static_cast<Scalar>(mag_unit_ut(o));
  ms.field_min_ut = static_cast<Scalar>(o.mag_field_min);
  ms.field_max_ut = static_cast<Scalar>(o.mag_field_max);
  ms.min_coverage = static_cast<Scalar>(o.mag_min_coverage);
  return ms;
}

// The magnetometer's readings over one pose's window: their sum and count.
struct MagWindow {
  Vector3<double> sum = Vector3<double>::Zero();
  long n = 0;
};

// Magnetometer: the fit of the samples held, then (with an accelerometer calibration) the
// rotation into the accelerometer's frame from the poses (mean field over each pose's window
// with the pose's mean acceleration). `accel` null: no accelerometer calibration.
template <typename Scalar>
void finish_magnetometer(MagCal<Scalar>& mag, const Options& o,
                         const std::vector<MagWindow>& windows,
                         const AccelCalibration<Scalar>* accel, Run& run,
                         MagCalibration<Scalar>& mc) {
  MagResult& m = run.mag;
  m.present = run.has_mag;
  m.unit_ut = mag_unit_ut(o);
  if (!m.present) {
    m.status = "no magnetometer columns (mx, my, mz)";
  } else if (m.readings == 0) {
    m.status = "no magnetometer readings";
  } else {
    for (std::size_t k = 0; k < windows.size(); ++k) {
      if (windows[k].n == 0) continue;
      const Vector3<double> mean_mag = windows[k].sum / static_cast<double>(windows[k].n);
      const Vector3<double> mean_acc(run.pose_list[k].mean[0], run.pose_list[k].mean[1],
                                     run.pose_list[k].mean[2]);
      mag.add_rest(mean_mag.cast<Scalar>(), mean_acc.cast<Scalar>());
    }
    const Status ms_status = mag.solve(mc);
    m.status = to_string(ms_status);
    m.ok = succeeded(ms_status);
    if (!m.ok) {
      m.alignment_status = "no usable magnetometer fit";
    } else if (!o.mag_align) {
      m.alignment_status = "not asked (--no-mag-align)";
    } else if (!run.has_accel) {
      m.alignment_status = "no accelerometer in the input";
    } else if (accel == nullptr) {
      m.alignment_status = "no accelerometer calibration";
    } else {
      m.aligned = succeeded(mag.align(*accel, mc));
      m.alignment_status = to_string(mc.alignment_status);
    }
    for (int i = 0; i < 3; ++i) {
      for (int k = 0; k < 3; ++k) m.soft_iron[i][k] = static_cast<double>(mc.soft_iron(i, k));
      m.hard_iron[i] = static_cast<double>(mc.hard_iron(i));
      m.hard_iron_sigma[i] = static_cast<double>(mc.hard_iron_sigma(i));
      m.rotation[i] = static_cast<double>(mc.alignment_rotation(i));
      m.rotation_sigma[i] = static_cast<double>(mc.alignment_sigma(i));
    }
    for (int k = 0; k < kMagSymEntries; ++k)
      m.soft_iron_sigma[k] = static_cast<double>(mc.soft_iron_sigma(k));
    m.field_ut = static_cast<double>(mc.field_ut);
    m.fit_error_pct = static_cast<double>(mc.fit_error_pct);
    m.coverage = static_cast<double>(mc.coverage);
    m.samples = mc.samples;
    m.iterations = mc.iterations;
    m.quality = to_string(mc.quality);
    m.rests = mag.rests();
    if (m.aligned) {
      m.dip_deg = static_cast<double>(mc.dip_deg);
      m.dip_sigma_deg = static_cast<double>(mc.dip_sigma_deg);
      m.rests = mc.alignment_rests;
    }
  }
  for (int i = 0; i < mag.size(); ++i) {
    const Vector3<Scalar>& h = mag.sample(i);
    m.held.push_back(
        {static_cast<double>(h(0)), static_cast<double>(h(1)), static_cast<double>(h(2))});
  }
}

// The record of the parts that are usable, if asked for (else why not).
template <typename Scalar>
void make_run_record(const Calibration<Scalar>& c, const MagCalibration<Scalar>* mc,
                     const TemperatureModel<Scalar>* tm, const Options& o, Run& run) {
  if (o.record_path.empty() || !run.usable) return;
  CalibrationRecord record;
  std::uint8_t bytes[kRecordMaxBytes];
  std::size_t size = 0;
  Bound bound = Bound::kNone;
  Status st = make_record(c, o.device_id, o.sensor_id, record, mc, tm, &bound);
  if (st == Status::kOk) st = encode_record(record, bytes, sizeof bytes, &size);
  if (st == Status::kOk) {
    run.record.assign(bytes, bytes + size);
  } else {
    run.record_error = to_string(st);
    if (st == Status::kImplausible) run.record_error += std::string(": ") + to_string(bound);
  }
}

// A magnetometer alone (t, mx, my, mz, or no t): its fit (the collector holds the readings), no
// alignment.
template <typename Scalar>
int magnetometer_alone(const Options& o, MagCal<Scalar>& mag, Run& run) {
  MagCalibration<Scalar> mc;
  finish_magnetometer<Scalar>(mag, o, {}, nullptr, run, mc);
  run.accel_status = run.gyro_status = "not in the input";
  run.temperature.present = false;
  run.temperature.status = "needs the accelerometer and the gyroscope";
  run.temperature.accel.status = run.temperature.gyro.status = run.temperature.status;
  run.quality = run.mag.ok ? run.mag.quality : "none";
  run.quality_level = run.mag.ok ? static_cast<int>(mc.quality) : 0;
  run.usable = run.mag.ok;
  if (!run.mag.ok) {
    if (run.mag.status == to_string(Status::kPoorCoverage))
      run.advice.push_back(
          "the readings cover too few directions: turn the sensor slowly through every "
          "orientation (all of the sphere, not one plane), away from iron and motors.");
    else if (run.mag.status == to_string(Status::kFieldImplausible))
      run.advice.push_back(
          "the field strength is outside --mag-field-range: check --mag-unit (and "
          "--mag-lsb-per-ut), or keep the sensor away from magnets and iron.");
    else if (run.mag.status == to_string(Status::kTooFewSamples))
      run.advice.push_back(
          "too few readings: record longer while turning the sensor through every orientation.");
    else
      run.advice.push_back("the magnetometer was not calibrated: " + run.mag.status + ".");
  }
  Calibration<Scalar> none;
  make_run_record<Scalar>(none, run.mag.ok ? &mc : nullptr, nullptr, o, run);
  return run.usable ? 0 : 1;
}

// One line per pose: each sample is a pose's mean reading (an accelerometer alone, no time).
// The accelerometer solve directly, with equal weights.
template <typename Scalar>
int pose_file(const Options& o, const std::vector<Sample>& samples, Run& run) {
  run.has_gyro = false;
  run.mag.status = "no magnetometer columns (mx, my, mz)";
  std::vector<Pose<Scalar>> poses;
  for (const Sample& x : samples)
    poses.push_back({Vector3<Scalar>(static_cast<Scalar>(x.acc[0]), static_cast<Scalar>(x.acc[1]),
                                     static_cast<Scalar>(x.acc[2])),
                     1u});
  AccelSettings<Scalar> as;
  as.gravity = static_cast<Scalar>(o.gravity);
  Calibration<Scalar> c;
  const Status st = calibrate_accelerometer<Scalar>(
      PoseSpan<Scalar>{poses.data(), static_cast<int>(poses.size())}, as, c.accel);
  run.poses = static_cast<int>(poses.size());
  run.accel_status = to_string(st);
  run.accel_ok = succeeded(st);
  run.accel_iterations = c.accel.iterations;
  run.gyro_status = "not in the input";
  if (run.accel_ok) advise_parameters(c.accel, run);
  run.temperature.status = "needs the accelerometer and the gyroscope streams";
  run.temperature.accel.status = run.temperature.gyro.status = run.temperature.status;
  for (int k = 0; k < 9; ++k) {
    run.accel_params[static_cast<std::size_t>(k)] = static_cast<double>(c.accel.params(k));
    run.accel_sigma[static_cast<std::size_t>(k)] = static_cast<double>(c.accel.sigma(k));
  }
  const double sa = accel_nominal_scale(o), zero = accel_nominal_zero(o);
  run.have_nominal_accel = std::isfinite(sa) && std::isfinite(zero);
  for (int a = 0; a < 3; ++a) {
    run.accel_nominal[static_cast<std::size_t>(3 + a)] = sa;
    run.accel_nominal[static_cast<std::size_t>(6 + a)] = -zero;
  }
  const AccelVector<double> pa = Eigen::Map<const AccelVector<double>>(run.accel_params.data());
  const AccelVector<double> pn = Eigen::Map<const AccelVector<double>>(run.accel_nominal.data());
  std::vector<double> before, after;
  std::uint8_t faces = 0;
  for (const Sample& x : samples) {
    PoseResult pr;
    pr.t_begin = pr.t_end = x.t;
    pr.samples = 1;
    const Vector3<double> mean(x.acc[0], x.acc[1], x.acc[2]);
    for (int a = 0; a < 3; ++a) pr.mean[a] = mean(a);
    if (run.accel_ok) {
      const Vector3<double> cal_mean = accel_apply(pa, mean);
      pr.residual_after = o.gravity - cal_mean.norm();
      const Vector3<double> up = cal_mean.normalized();
      for (int a = 0; a < 3; ++a) {
        pr.up[a] = up(a);
        if (std::abs(up(a)) > 0.9)  // within about 25 deg of a face
          faces = static_cast<std::uint8_t>(faces | (1u << (2 * a + (up(a) < 0 ? 1 : 0))));
      }
    }
    if (run.have_nominal_accel) pr.residual_before = o.gravity - accel_apply(pn, mean).norm();
    before.push_back(pr.residual_before);
    after.push_back(pr.residual_after);
    run.pose_list.push_back(pr);
  }
  run.accel_pose_rms_before = rms(before);
  run.accel_pose_rms_after = rms(after);
  run.faces = faces;
  for (int i = 0; i < 6; ++i) run.faces_covered += (faces >> i) & 1;
  // Quality: good with every face up in some pose, fair otherwise (the stream's noise test
  // needs the samples of each rest, which a file of means does not hold).
  c.quality = !run.accel_ok ? Quality::kNone : faces == 0x3f ? Quality::kGood : Quality::kFair;
  run.quality = to_string(c.quality);
  run.quality_level = static_cast<int>(c.quality);
  run.usable = run.accel_ok;
  if (!run.accel_ok) {
    if (run.poses < kAccelMinPoses) {
      run.advice.push_back(plural(run.poses, "pose", "poses") + " in the file, at least " +
                           std::to_string(kAccelMinPoses) +
                           " needed: measure more orientations (all six faces up, and some "
                           "tilted between them).");
    } else {
      run.advice.push_back(
          "the poses do not determine the 9 parameters (" + run.accel_status +
          "): add orientations with each face up and some tilted between two faces.");
    }
  }
  make_run_record<Scalar>(c, nullptr, nullptr, o, run);
  return run.usable ? 0 : 1;
}

// The noise the calibrator measured, in SI units through the calibrated scales (the nominal ones
// where a sensor was not calibrated): the accelerometer's over the rests (each pose's, weighted
// by its samples), the gyro's over the initial rest; the accelerometer fit's floor and chi2/dof.
template <typename Scalar>
void measured_noise(const Calibrator<Scalar>& cal, const Calibration<Scalar>& c, const Options& o,
                    Run& run) {
  const PoseSpan<Scalar> poses = cal.poses();
  double sum = 0, n = 0;
  for (int i = 0; i < poses.size; ++i) {
    if (!(poses[i].noise > Scalar(0))) continue;
    sum += static_cast<double>(poses[i].noise) * poses[i].samples;
    n += poses[i].samples;
  }
  auto mean_scale = [](const auto& p, int first) {
    return (static_cast<double>(p(first)) + static_cast<double>(p(first + 1)) +
            static_cast<double>(p(first + 2))) /
           3;
  };
  const bool accel = succeeded(c.accel.status), gyro = succeeded(c.gyro.status);
  const double sa = accel ? mean_scale(c.accel.params, kScaleX) : accel_nominal_scale(o);
  if (n > 0) run.accel_noise = std::sqrt(sum / n) * sa;
  const double sg = gyro ? mean_scale(c.gyro.params, kGyroScaleX) : gyro_nominal_scale(o);
  if (run.has_gyro)
    run.gyro_noise = std::sqrt(static_cast<double>(cal.gyro_noise_variance().sum()) / 3) * sg;
  if (accel && c.accel.fit_to_noise > Scalar(0)) {
    run.accel_pose_floor = static_cast<double>(c.accel.pose_floor);
    run.accel_fit_to_noise = static_cast<double>(c.accel.fit_to_noise);
  }
}

// Opens the input again from its start with the same settings, for a pass after the first (empty:
// it cannot be read again, a stream).
using Reopen = std::function<bool(SampleReader&, Diagnostics&)>;

// The input's samples: read once as they come (next()), then as often again as the passes after
// the first need them (again()): from the store while they fit in --memory, else from the file
// read anew; a stream keeps every k-th sample instead (complete() false).
class Input {
 public:
  Input(SampleReader& reader, Diagnostics& diag, const Reopen& reopen, const Options& o,
        bool has_gyro)
      : reader_(reader),
        diag_(diag),
        reopen_(reopen),
        has_gyro_(has_gyro),
        store_(static_cast<std::size_t>(o.memory_mb * 1048576.0), static_cast<bool>(reopen),
               reader.has_temperature(), reader.has_magnetometer()) {}

  bool next(Sample& s) {
    Record r;
    if (!reader_.next(r, diag_)) return false;
    s = make_sample(r, clock_, has_gyro_);
    store_.add(s);
    if (++count_ == 1024) {  // a file's length says how many samples to expect
      const double read = reader_.fraction_read();
      if (read > 0 && read < 1) store_.expect(1024 / read);
    }
    return true;
  }
  // Every sample again, in order, to f(const Sample&); false (error()) if the file no longer
  // gives the samples it gave.
  template <class F>
  bool again(F&& f) {
    if (store_.kept()) {
      store_.for_each(f);
      return true;
    }
    SampleReader r;
    Diagnostics d;
    ++reads_;
    if (!reopen_(r, d)) {
      error_ = "the input could not be opened again: " +
               (d.kept().empty() ? std::string("?") : d.kept()[0].text());
      return false;
    }
    DeviceClock clock;
    Record rec;
    long n = 0;
    while (n < count_ && r.next(rec, d)) {
      f(static_cast<const Sample&>(make_sample(rec, clock, has_gyro_)));
      ++n;
    }
    if (n != count_ || r.failed()) {
      error_ =
          format_text("the input changed while it was read (%ld samples, then %ld)", count_, n);
      return false;
    }
    return true;
  }
  bool complete() const { return store_.stride() == 1; }  // again() gives every sample
  long stride() const { return store_.stride(); }
  int reads() const { return reads_; }
  const std::string& error() const { return error_; }

 private:
  SampleReader& reader_;
  Diagnostics& diag_;
  const Reopen& reopen_;
  bool has_gyro_;
  SampleStore store_;
  DeviceClock clock_;
  long count_ = 0;
  int reads_ = 1;
  std::string error_;
};

}  // namespace

template <typename Scalar>
CalibratorSettings<Scalar> calibrator_settings(const Options& o, const Run& run) {
  CalibratorSettings<Scalar> cs;
  cs.has_gyro = run.has_gyro;
  cs.initial_rest_seconds = static_cast<Scalar>(o.initial_rest);
  cs.min_rest_seconds = static_cast<Scalar>(o.min_rest);
  cs.accel.gravity = static_cast<Scalar>(o.gravity);
  cs.gyro.nominal_scale = static_cast<Scalar>(gyro_nominal_scale(o));
  cs.gyro.refine_bias = o.refine_gyro_bias;
  if (std::isfinite(o.accel_min)) {
    cs.accel_min = static_cast<Scalar>(o.accel_min);
    cs.accel_max = static_cast<Scalar>(o.accel_max);
  }
  if (std::isfinite(o.gyro_min)) {
    cs.gyro_min = static_cast<Scalar>(o.gyro_min);
    cs.gyro_max = static_cast<Scalar>(o.gyro_max);
  }
  // Without a time column the times come from the rate: nothing to check against it.
  if (run.time_source == "t column") cs.nominal_rate_hz = static_cast<Scalar>(o.nominal_rate_hz);
  const double zero = accel_nominal_zero(o);
  if (std::isfinite(zero))
    cs.accel_zero_hint = Vector3<Scalar>::Constant(static_cast<Scalar>(zero));
  return cs;
}

template CalibratorSettings<float> calibrator_settings(const Options&, const Run&);
template CalibratorSettings<double> calibrator_settings(const Options&, const Run&);

namespace {

// One pass of the streaming calibrator over the samples, as on the device: the rests it handed
// out (one per pose, for the temperature model), each pose's window on the device's clock
// (unwrapped), and what it said about the stream.
template <typename Scalar>
class CalibratorPass {
 public:
  CalibratorPass(const CalibratorSettings<Scalar>& cs, bool record_events)
      : cal(std::make_unique<Calibrator<Scalar>>(cs)), record_events_(record_events) {}

  void add(const Sample& x) {
    now_ = x.us;
    const Status st = cal->add(imu_sample<Scalar>(x));
    keep();
    if (record_events_ && st != Status::kOk) {
      StreamEvent& e = events[to_string(st)];
      if (e.count++ == 0) e.first_t = x.t;
      e.status = to_string(st);
    }
  }
  // The solve to its end; with `end_refused`, a solve refused for too few poses ends the stream
  // so that the rest open at the end is listed all the same.
  Status solve(bool end_refused) {
    before_solve = cal->progress();
    const Status solved = cal->solve_all();
    keep();                           // the rest open at the end became a pose
    stream = cal->progress().stream;  // of the readings as read
    if (end_refused && solved == Status::kTooFewPoses) {
      cal->end_stream();
      keep();
    }
    return solved;
  }

  std::unique_ptr<Calibrator<Scalar>> cal;  // 32 KB (float): on the heap of the host tool
  std::vector<RestSummary<Scalar>> rests;
  std::vector<std::array<std::int64_t, 2>> windows;  // first and last us of each pose
  std::map<std::string, StreamEvent> events;
  Progress before_solve{};
  StreamCounts stream{};

 private:
  // A new pose's window, unwrapped from the device's 32-bit clock by the sample just given (a
  // pose ends before the sample that closes it and lasts less than the clock's 71.6 minutes).
  void keep() {
    while (static_cast<int>(rests.size()) < cal->poses().size) {
      const int i = static_cast<int>(rests.size());
      rests.push_back(cal->last_rest());
      auto unwrap = [&](std::uint32_t us) {
        return now_ - static_cast<std::int64_t>(static_cast<std::uint32_t>(now_) - us);
      };
      windows.push_back({unwrap(cal->pose_begin_us(i)), unwrap(cal->pose_end_us(i))});
    }
  }
  bool record_events_;
  std::int64_t now_ = 0;
};

// What one pose's window holds: its first and last sample's time, the calibrated accelerometer's
// per-sample residuals, the magnetometer's readings.
struct WindowStats {
  double t_begin = kNaN, t_end = kNaN;
  long n = 0;
  double sum = 0, sum_noise = 0;
  double sum_first = 0;  // sum's part over the first Run::kImuTkSamples samples
  MagWindow mag;
};

// --- The steps of one run: read, stream, solve, temperature, assemble, advise, magnetometer ----

}  // namespace

// Read: what the input holds and how it is read (its format, parts, columns, where the time
// comes from, and so the mode: a stream, a file of poses, a magnetometer alone), from the opened
// reader and the settled options, into `run`. No sample is read.
template <typename Scalar>
void describe_input(const SampleReader& reader, const Options& o, Run& run) {
  run.scalar = sizeof(Scalar) == sizeof(float) ? "float" : "double";
  run.format = reader.from_arrays() ? "arrays" : reader.format() == Format::kCsv ? "csv" : "imu_tk";
  run.has_accel = reader.has_accelerometer();
  run.has_gyro = reader.has_gyroscope();
  run.has_mag = reader.has_magnetometer();
  run.mode = !run.has_accel ? "magnetometer" : o.pose_file ? "poses" : "stream";
  run.columns = reader.format() == Format::kImuTk ? "t x y z (two files)" : reader.column_names();
  run.columns_source = reader.format() == Format::kImuTk ? "imu_tk" : reader.columns_source();
  run.time_source = reader.format() == Format::kImuTk || reader.has_time() ? "t column"
                    : o.nominal_rate_hz > 0                                ? "--rate"
                                                                           : "none";
}

template void describe_input<float>(const SampleReader&, const Options&, Run&);
template void describe_input<double>(const SampleReader&, const Options&, Run&);

namespace {

// What the first pass leaves for the steps after it.
template <typename Scalar>
struct FirstPass {
  std::unique_ptr<CalibratorPass<Scalar>> pass;  // the stream's (none for poses or a magnetometer)
  std::unique_ptr<MagCal<Scalar>> mag;           // the magnetometer's collector
  std::vector<Sample> pose_lines;                // a file of poses: one line each
  RangeWatch acc_range, gyro_range;              // the integer formats the readings showed
  double first_temp = kNaN;  // the first temperature read: the samples before it take it
};

// Stream through the calibrator: every sample as it is read, one at a time as on the device,
// and every magnetometer reading to its collector; a file of poses keeps its lines instead. A
// stream in counts without a range given starts once its first samples show their integer
// format (at most RangeWatch::kPrefix held until then), with that format's saturation limits.
// Sets the run's sample count, first and last times and rate, and the saturation limits the
// whole input shows into `o` (inferred in counts without a range). run.samples 0: no sample.
template <typename Scalar>
FirstPass<Scalar> stream_first_pass(Input& in, const SampleReader& reader, Options& o, Run& run) {
  FirstPass<Scalar> f;
  const bool stream_mode = run.mode == "stream", pose_mode = run.mode == "poses";
  ProgressLine progress(!o.quiet);
  f.mag = std::make_unique<MagCal<Scalar>>(mag_settings<Scalar>(o));
  long n = 0;
  std::vector<Sample> prefix;  // the first samples, until their integer format shows
  auto start_pass = [&] {
    f.acc_range.start(o.accel_min, o.accel_max);
    f.gyro_range.start(o.gyro_min, o.gyro_max);
    f.pass = std::make_unique<CalibratorPass<Scalar>>(calibrator_settings<Scalar>(o, run), true);
    for (const Sample& s : prefix) {
      f.acc_range.count(s.acc);
      f.gyro_range.count(s.gyro);
      f.pass->add(s);
    }
    prefix = {};
  };
  Sample read;  // the sample just read
  while (in.next(read)) {
    if (n == 0) {
      run.t_first = read.t;
      f.acc_range.active =
          run.has_accel && o.accel_unit == AccelUnit::kCounts && !std::isfinite(o.accel_min);
      f.gyro_range.active = run.has_accel && run.has_gyro && o.gyro_unit == GyroUnit::kCounts &&
                            !std::isfinite(o.gyro_min);
    }
    ++n;
    run.t_last = read.t;
    f.acc_range.add(read.acc);
    f.gyro_range.add(read.gyro);
    if (std::isfinite(read.mag[0])) {  // the reader gives all three axes or none
      ++run.mag.readings;
      f.mag->add(Vector3<Scalar>(static_cast<Scalar>(read.mag[0]), static_cast<Scalar>(read.mag[1]),
                                 static_cast<Scalar>(read.mag[2])));
    }
    if (!std::isfinite(f.first_temp) && std::isfinite(read.temp)) f.first_temp = read.temp;
    if (pose_mode) f.pose_lines.push_back(read);
    if (f.pass) {
      f.pass->add(read);
    } else if (stream_mode) {
      prefix.push_back(read);
      if ((f.acc_range.settled() && f.gyro_range.settled()) || prefix.size() >= RangeWatch::kPrefix)
        start_pass();
    }
    if (progress.due(n)) progress.show(n, reader.fraction_read());
  }
  if (stream_mode && !f.pass && n > 0) start_pass();
  run.samples = n;
  run.lines_skipped = reader.lines_skipped();
  if (n == 0) return f;
  if (n > 1 && run.time_source != "none")
    run.rate_hz = static_cast<double>(n - 1) / (run.t_last - run.t_first);
  // The saturation limits as the whole input shows them (its first samples' until now).
  if (f.acc_range.active) o.accel_min = o.accel_max = kNaN;
  if (f.gyro_range.active) o.gyro_min = o.gyro_max = kNaN;
  if (run.has_accel) infer_ranges(f.acc_range.seen, f.gyro_range.seen, run.has_gyro, o);
  return f;
}

// The stream's solve: its status, and the calibrator's progress before it (the readings as read).
struct StreamSolve {
  Status status = Status::kNotStarted;
  Progress before{};  // progress before the solve (its hint, the faces and axes missing)
};

// Solve: the stream's calibration. When the whole input shows another integer format (so other
// saturation limits) than its first samples did, the stream runs again with the whole input's
// limits first (when the samples can be given again in full; else the advice says so). Then the
// solve to its end, the rest open at the end listed as a pose even when the solve is refused for
// too few poses. The calibrator's stream events and counts go to the run. False if the input
// could not be given again (in.error() says why).
template <typename Scalar>
bool solve_stream(Input& in, FirstPass<Scalar>& f, const CalibratorSettings<Scalar>& cs,
                  const Options& o, Run& run, StreamSolve& out) {
  if (f.acc_range.judged_otherwise(o.accel_min) || f.gyro_range.judged_otherwise(o.gyro_min)) {
    if (in.complete()) {
      f.pass = std::make_unique<CalibratorPass<Scalar>>(cs, true);
      if (!in.again([&](const Sample& s) { f.pass->add(s); })) return false;
    } else {
      run.advice.push_back(
          "the readings showed their integer format (and so where they saturate) only after "
          "more of the input than --memory holds: saturation was judged by the first samples'. "
          "Give --accel-range and --gyro-range, or the input as a file.");
    }
  }
  run.kept_every = in.stride();
  out.status = f.pass->solve(true);
  out.before = f.pass->before_solve;
  for (auto& kv : f.pass->events) run.events.push_back(kv.second);
  run.stream_counts.clear();
  for (const StreamCountName& name : kStreamCountNames)
    run.stream_counts.push_back({name.label, name.key, f.pass->stream.*name.count});
  return true;
}

// The temperature model as the passes left it: the one fitted about the last calibration, and
// the one the readings of that calibration had applied (passes > 0).
template <typename Scalar>
struct TemperaturePasses {
  TemperatureModel<Scalar> model, applied;
  bool have = false;  // the fit could start (its parts' statuses inside)
  Status status = Status::kNotStarted;
};

// Temperature: the biases against the rests' temperatures, about the stream's calibration. With
// a usable part, the calibration runs again over the readings with the model applied (raw +
// b(T) - b0: else the calibration absorbs part of the drift and the model, fitted about it, sees
// less than there is), and the model is fitted again about the new calibration, until its
// slopes settle (0.1 sigma) or after kMaxPasses. The last pass replaces f.pass and its solve's
// status `solved`; run.temperature gets whether the input has a temperature, the order and the
// passes run. False if the input could not be given again (in.error() says why).
template <typename Scalar>
bool temperature_passes(Input& in, bool has_temperature, FirstPass<Scalar>& f,
                        const CalibratorSettings<Scalar>& cs, const Options& o, Run& run,
                        Status& solved, TemperaturePasses<Scalar>& t) {
  TemperatureResult& tr = run.temperature;
  tr.present = has_temperature;
  tr.order = o.temp_order;
  auto usable = [](const Calibration<Scalar>& c) {
    return succeeded(c.accel.status) && succeeded(c.gyro.status);
  };
  const Calibration<Scalar>& base = f.pass->cal->calibration();
  if (!(tr.present && base.has_temperature && usable(base))) return true;
  t.have = fit_temperature(base, f.pass->rests, o, t.model, t.status);
  constexpr int kMaxPasses = 20;
  if (t.have && !in.complete())
    run.advice.push_back(
        "the calibration was not run again with the temperature model applied: the input "
        "was longer than --memory holds and cannot be read again (stdin). Give it as a file.");
  for (int k = 0; t.have && in.complete() && k < kMaxPasses; ++k) {
    if (!succeeded(t.model.accel.status) && !succeeded(t.model.gyro.status)) break;
    auto next = std::make_unique<CalibratorPass<Scalar>>(cs, false);
    Compensation<Scalar> compensate(t.model, o, f.first_temp);
    if (!in.again([&](const Sample& raw) {
          Sample y = raw;
          compensate(y);
          next->add(y);
        }))
      return false;
    const Status solved2 = next->solve(false);
    if (!usable(next->cal->calibration())) break;
    for (RestSummary<Scalar>& r2 : next->rests) {  // back to raw means for the model
      if (!r2.has_temperature) continue;
      const double temp = static_cast<double>(r2.temperature_c);
      r2.accel_mean -= bias_change(t.model, t.model.accel, temp).template cast<Scalar>();
      r2.gyro_mean -= bias_change(t.model, t.model.gyro, temp).template cast<Scalar>();
    }
    TemperatureModel<Scalar> tm2;
    Status st2 = Status::kNotStarted;
    if (!fit_temperature(next->cal->calibration(), next->rests, o, tm2, st2)) break;
    double change = 0;
    for (const auto& [b_old, b_new] :
         {std::make_pair(&t.model.accel, &tm2.accel), std::make_pair(&t.model.gyro, &tm2.gyro)}) {
      if (!succeeded(b_new->status)) continue;
      if (!succeeded(b_old->status)) change = HUGE_VAL;
      for (int a = 0; a < 3; ++a) {
        const double sd = std::max(static_cast<double>(b_new->b1_sigma(a)), 1e-30);
        change = std::max(change, std::abs(static_cast<double>(b_new->b1(a) - b_old->b1(a))) / sd);
      }
    }
    f.pass = std::move(next);
    t.applied = t.model;
    t.model = tm2;
    t.status = st2;
    solved = solved2;
    tr.passes = k + 1;
    if (change < 0.1) break;
  }
  return true;
}

// Assemble the result, from the calibrator of the last pass: the collection's counts, each
// sensor's status, parameters and sigmas, the quality and whether it is usable, the noise the
// calibrator measured, the nominal models ("before": T = I, the scale the units say, the zero
// given), and each pose's mean with its residual before and after (its times and per-sample
// statistics come from window_statistics).
template <typename Scalar>
void assemble_result(const Calibrator<Scalar>& cal, Status solved, const Options& o, Run& run) {
  const Calibration<Scalar>& c = cal.calibration();
  const Progress p = cal.progress();
  run.poses = p.poses;
  run.moves = p.moves;
  run.segments = p.segments;
  run.coarsenings = p.coarsenings;
  run.rests_too_short = p.rests_too_short;
  run.moves_dropped = p.moves_dropped;
  run.faces = p.faces;
  run.faces_covered = p.faces_covered;
  // A solve refused before the accelerometer started (too few poses) says so there.
  run.accel_status = to_string(c.accel.status == Status::kNotStarted ? solved : c.accel.status);
  run.accel_ok = succeeded(c.accel.status);
  run.accel_iterations = c.accel.iterations;
  run.gyro_status = to_string(
      c.gyro.status == Status::kNotStarted && !run.accel_ok ? Status::kNotStarted : c.gyro.status);
  run.gyro_ok = succeeded(c.gyro.status);
  run.gyro_iterations = c.gyro.iterations;
  run.gyro_bias_refined = c.gyro.bias_refined;
  run.quality = to_string(c.quality);
  run.quality_level = static_cast<int>(c.quality);
  run.quality_reason = cal.quality_reason();
  if (!run.has_gyro) run.gyro_status = "not in the input";
  run.usable = run.accel_ok && (run.gyro_ok || !run.has_gyro);
  for (int k = 0; k < kAccelParams; ++k) {
    run.accel_params[static_cast<std::size_t>(k)] = static_cast<double>(c.accel.params(k));
    run.accel_sigma[static_cast<std::size_t>(k)] = static_cast<double>(c.accel.sigma(k));
  }
  for (int k = 0; k < kGyroParams; ++k) {
    run.gyro_params[static_cast<std::size_t>(k)] = static_cast<double>(c.gyro.params(k));
    run.gyro_sigma[static_cast<std::size_t>(k)] = static_cast<double>(c.gyro.sigma(k));
  }
  measured_noise<Scalar>(cal, c, o, run);
  const double zero = accel_nominal_zero(o);
  const double sa = accel_nominal_scale(o);
  run.have_nominal_accel = std::isfinite(sa) && std::isfinite(zero);
  run.accel_nominal.fill(0.0);
  for (int a = 0; a < 3; ++a) {
    run.accel_nominal[static_cast<std::size_t>(kScaleX + a)] = sa;
    run.accel_nominal[static_cast<std::size_t>(kBiasX + a)] = -zero;
  }
  const double sg = gyro_nominal_scale(o);
  run.have_nominal_gyro = sg > 0;
  run.gyro_nominal.fill(0.0);
  for (int a = 0; a < 3; ++a) {
    run.gyro_nominal[static_cast<std::size_t>(kGyroScaleX + a)] = sg;
    run.gyro_nominal[static_cast<std::size_t>(kGyroBiasX + a)] =
        static_cast<double>(cal.gyro_bias0()(a));
  }
  const AccelVector<double> pa = Eigen::Map<const AccelVector<double>>(run.accel_params.data());
  const AccelVector<double> pn = Eigen::Map<const AccelVector<double>>(run.accel_nominal.data());
  const PoseSpan<Scalar> poses = cal.poses();
  std::vector<double> before, after;
  for (int i = 0; i < poses.size; ++i) {
    PoseResult pr;
    pr.samples = static_cast<int>(poses[i].samples);
    const Vector3<double> mean = poses[i].mean.template cast<double>();
    for (int a = 0; a < 3; ++a) pr.mean[a] = mean(a);
    if (run.accel_ok) {
      const Vector3<double> cal_mean = accel_apply(pa, mean);
      pr.residual_after = o.gravity - cal_mean.norm();
      const Vector3<double> up = cal_mean.normalized();
      for (int a = 0; a < 3; ++a) pr.up[a] = up(a);
    }
    if (run.have_nominal_accel) pr.residual_before = o.gravity - accel_apply(pn, mean).norm();
    before.push_back(pr.residual_before);
    after.push_back(pr.residual_after);
    run.pose_list.push_back(pr);
  }
  run.accel_pose_rms_before = rms(before);
  run.accel_pose_rms_after = rms(after);
}

// Window statistics: one more pass over the samples, on the readings the calibration saw (the
// temperature model applied if it was): each pose's window by the device's clock (its first and
// last sample's times, its magnetometer readings' mean into `mag_windows`), per sample in the
// windows |g| - |a_cal| and the scatter of |a_cal| about its pose's mean (the sensor's own
// noise, a floor no calibration goes below), imu_tk's cost over each pose's first samples, the
// rests split in two by a bump; and the page's samples when it is asked for. False if the input
// could not be given again (in.error() says why).
template <typename Scalar>
bool window_statistics(Input& in, const CalibratorPass<Scalar>& pass,
                       const TemperaturePasses<Scalar>& t, double first_temp, const Options& o,
                       Run& run, std::vector<Sample>& page, std::vector<MagWindow>& mag_windows) {
  const AccelVector<double> pa = Eigen::Map<const AccelVector<double>>(run.accel_params.data());
  const std::vector<std::array<std::int64_t, 2>>& windows = pass.windows;
  std::vector<WindowStats> stats(windows.size());
  std::unique_ptr<Compensation<Scalar>> compensate;
  if (run.temperature.passes > 0)
    compensate = std::make_unique<Compensation<Scalar>>(t.applied, o, first_temp);
  std::unique_ptr<PageSamples> pages;
  if (!o.svg_path.empty())
    pages = std::make_unique<PageSamples>(run.t_first, run.t_last, run.samples);
  std::size_t at = 0;  // the window a sample is in, or the next
  const bool again = in.again([&](const Sample& raw) {
    if (pages) pages->add(raw);
    if (compensate) compensate->note(raw);
    for (; at < windows.size() && raw.us > windows[at][1]; ++at)
      if (stats[at].n == 0) stats[at].t_begin = stats[at].t_end = raw.t;  // none kept in it
    if (at == windows.size() || raw.us < windows[at][0]) return;
    WindowStats& w = stats[at];
    if (w.n++ == 0) w.t_begin = raw.t;
    w.t_end = raw.t;
    if (std::isfinite(raw.mag[0])) {
      w.mag.sum += Vector3<double>(raw.mag[0], raw.mag[1], raw.mag[2]);
      ++w.mag.n;
    }
    if (run.accel_ok) {
      Sample y = raw;
      if (compensate) compensate->apply(y);
      const double mean_norm = o.gravity - run.pose_list[at].residual_after;
      const double norm = accel_apply(pa, Vector3<double>(y.acc[0], y.acc[1], y.acc[2])).norm();
      const double r2 = (o.gravity - norm) * (o.gravity - norm);
      w.sum += r2;
      if (w.n <= Run::kImuTkSamples) w.sum_first += r2;
      w.sum_noise += (norm - mean_norm) * (norm - mean_norm);
    }
  });
  if (!again) return false;
  if (pages) page = pages->take();
  double sum = 0, sum_noise = 0, sum_first = 0;
  long in_windows = 0, first = 0;
  for (std::size_t i = 0; i < stats.size(); ++i) {
    run.pose_list[i].t_begin = stats[i].t_begin;
    run.pose_list[i].t_end = stats[i].t_end;
    sum += stats[i].sum;
    sum_noise += stats[i].sum_noise;
    in_windows += stats[i].n;
    if (stats[i].n >= Run::kImuTkSamples) {
      sum_first += stats[i].sum_first;
      first += Run::kImuTkSamples;
    }
    mag_windows.push_back(stats[i].mag);
  }
  if (run.accel_ok && in_windows > 0) {
    run.accel_sample_rms_after = std::sqrt(sum / static_cast<double>(in_windows));
    run.accel_noise_floor = std::sqrt(sum_noise / static_cast<double>(in_windows));
  }
  // Rests split in two by a short motion that left the orientation as it was (a bump): each
  // half is a pose here, where a detector that smooths over the bump sees one rest.
  for (std::size_t i = 1; run.accel_ok && i < run.pose_list.size(); ++i) {
    PoseResult& pose = run.pose_list[i];
    const PoseResult& prev = run.pose_list[i - 1];
    pose.angle_to_previous = angle_deg(Vector3<double>(pose.up[0], pose.up[1], pose.up[2]),
                                       Vector3<double>(prev.up[0], prev.up[1], prev.up[2]));
    pose.gap_before = pose.t_begin - prev.t_end;
    if (pose.angle_to_previous <= PoseResult::kSplitDeg &&
        pose.gap_before <= PoseResult::kSplitGapS)
      pose.continues = static_cast<int>(i);
  }
  if (run.accel_ok && first > 0) {
    run.accel_imu_tk_cost = 0.5 * sum_first;
    run.accel_imu_tk_samples = first;
  }
  run.input_reads = in.reads();
  return true;
}

// The moves: for each, the angle between gravity carried over it by the gyro model and the
// gravity measured after it, with the nominal and with the calibrated model (the gravity
// directions from the calibrated accelerometer in both), their RMS, and imu_tk's cost.
template <typename Scalar>
void move_results(const Calibrator<Scalar>& cal, Run& run) {
  if (!run.accel_ok || !run.has_gyro) return;
  const Vector3<double> b0 = cal.gyro_bias0().template cast<double>();
  const GyroVector<double> pg = Eigen::Map<const GyroVector<double>>(run.gyro_params.data());
  const GyroVector<double> pgn = Eigen::Map<const GyroVector<double>>(run.gyro_nominal.data());
  std::vector<double> before, after;
  for (int i = 0; i < cal.move_count(); ++i) {
    const GyroMove& mv = cal.move(i);
    MoveResult m;
    m.from = mv.from_pose;
    m.to = mv.to_pose;
    m.segments = mv.segments;
    for (int k = 0; k < mv.segments; ++k)
      m.duration += static_cast<double>(cal.segment(mv.first_segment + k).duration);
    if (run.have_nominal_gyro)
      m.angle_before = move_angle<Scalar>(cal, mv, gyro_matrix<double>(pgn),
                                          Vector3<double>::Zero(), run.pose_list);
    if (run.gyro_ok)
      m.angle_after = move_angle<Scalar>(cal, mv, gyro_matrix<double>(pg),
                                         Vector3<double>(pg.tail<3>() - b0), run.pose_list);
    before.push_back(m.angle_before);
    after.push_back(m.angle_after);
    run.move_list.push_back(m);
  }
  run.gyro_rms_before = rms(before);
  run.gyro_rms_after = rms(after);
  if (run.gyro_ok && !after.empty()) {
    double cost = 0;
    for (double deg : after) {
      if (!std::isfinite(deg)) continue;
      const double chord = 2 * std::sin(0.5 * deg / kDeg);
      cost += 0.5 * chord * chord;
    }
    run.gyro_imu_tk_cost = cost;
  }
}

// Advise: what to do next, in words, from the calibrator's progress before the solve and after
// it (advise()), a sensor that was not calibrated, and the accelerometer's held or weak
// parameters.
template <typename Scalar>
void advise_run(const Progress& before_solve, const Calibrator<Scalar>& cal, const Options& o,
                Run& run) {
  advise(before_solve, cal.progress(), o, run);
  if (!run.accel_ok && run.poses >= kAccelMinPoses)
    run.advice.push_back("the accelerometer was not calibrated (" + run.accel_status +
                         "): the poses do not determine its 9 parameters; add orientations "
                         "with each face up and some tilted between two faces.");
  else if (run.accel_ok && run.has_gyro && !run.gyro_ok)
    run.advice.push_back("the gyroscope was not calibrated (" + run.gyro_status +
                         "): turn between the poses about all three body axes, and do not stop "
                         "the recording while turning.");
  if (run.accel_ok) advise_parameters(cal.calibration().accel, run);
}

// The temperature model into the run: as fitted (its parts' statuses, coefficients and sigmas),
// or why there is none; the rests with a temperature as raw means (the plots' points).
template <typename Scalar>
void temperature_result(const std::vector<RestSummary<Scalar>>& rests, const Calibration<Scalar>& c,
                        const TemperaturePasses<Scalar>& t, Run& run) {
  TemperatureResult& tr = run.temperature;
  for (const RestSummary<Scalar>& rs : rests) {
    if (!rs.has_temperature) continue;
    TemperatureRest x;
    x.temperature_c = static_cast<double>(rs.temperature_c);
    for (int a = 0; a < 3; ++a) {
      x.accel_mean[a] = static_cast<double>(rs.accel_mean(a));
      x.gyro_mean[a] = static_cast<double>(rs.gyro_mean(a));
    }
    x.samples = static_cast<long>(rs.samples);
    tr.rest_list.push_back(x);
  }
  if (!tr.present) {
    tr.status = "no temperature column";
  } else if (!c.has_temperature) {
    tr.status = "no temperature readings";
  } else if (!run.has_gyro) {
    tr.status = "needs the gyroscope too (not in the input)";
  } else if (!run.usable) {
    tr.status = "needs a usable accelerometer and gyroscope calibration";
  } else if (!t.have) {
    tr.status = to_string(t.status);
  } else {
    const TemperatureModel<Scalar>& tm = t.model;
    tr.reference_c = static_cast<double>(tm.reference_c);
    tr.min_c = static_cast<double>(tm.min_c);
    tr.max_c = static_cast<double>(tm.max_c);
    tr.rests = tm.rests;
    auto fill = [](const TemperatureBias<Scalar>& b, TemperatureBiasResult& out) {
      out.status = to_string(b.status);
      out.ok = succeeded(b.status);
      for (int a = 0; a < 3; ++a) {
        out.b0[a] = static_cast<double>(b.b0(a));
        out.b1[a] = static_cast<double>(b.b1(a));
        out.b2[a] = static_cast<double>(b.b2(a));
        out.b0_sigma[a] = static_cast<double>(b.b0_sigma(a));
        out.b1_sigma[a] = static_cast<double>(b.b1_sigma(a));
        out.b2_sigma[a] = static_cast<double>(b.b2_sigma(a));
      }
    };
    fill(tm.accel, tr.accel);
    fill(tm.gyro, tr.gyro);
    tr.status = tr.accel.ok || tr.gyro.ok ? "ok" : to_string(t.status);
  }
  if (tr.status != "ok") tr.accel.status = tr.gyro.status = tr.status;
}

// One calibration run over the reader's samples, in Scalar (float as on the device, or the
// double reference): the steps above in order, or a magnetometer alone, or a file of poses.
// Returns the exit code: 0 usable, 1 not, 2 no sample or an input that could not be read again
// (the reason in `diag`). `page`: the samples the report page draws, when it is asked for.
template <typename Scalar>
int run_calibration(Options& o, SampleReader& reader, const Reopen& reopen, Diagnostics& diag,
                    Run& run, std::vector<Sample>& page) {
  describe_input<Scalar>(reader, o, run);
  Input in(reader, diag, reopen, o, run.has_gyro);
  FirstPass<Scalar> f = stream_first_pass<Scalar>(in, reader, o, run);
  const std::string input_name = o.files.empty() ? "" : o.files[0];
  if (run.samples == 0) {
    diag.add({input_name, 0, 0, "no samples"});
    return 2;
  }
  auto failed_again = [&] {
    diag.add({input_name, 0, 0, in.error()});
    return 2;
  };
  if (run.mode == "magnetometer") {
    const int code = magnetometer_alone<Scalar>(o, *f.mag, run);
    if (!o.svg_path.empty()) {
      PageSamples pages(run.t_first, run.t_last, run.samples);
      if (!in.again([&](const Sample& s) { pages.add(s); })) return failed_again();
      page = pages.take();
    }
    return code;
  }
  if (run.mode == "poses") {
    if (!o.svg_path.empty()) page = f.pose_lines;
    return pose_file<Scalar>(o, f.pose_lines, run);
  }

  const CalibratorSettings<Scalar> cs = calibrator_settings<Scalar>(o, run);
  StreamSolve solve;
  if (!solve_stream(in, f, cs, o, run, solve)) return failed_again();
  TemperaturePasses<Scalar> t;
  if (!temperature_passes(in, reader.has_temperature(), f, cs, o, run, solve.status, t))
    return failed_again();
  const Calibrator<Scalar>& cal = *f.pass->cal;
  const Calibration<Scalar>& c = cal.calibration();
  assemble_result(cal, solve.status, o, run);
  advise_run(solve.before, cal, o, run);
  std::vector<MagWindow> mag_windows;
  if (!window_statistics(in, *f.pass, t, f.first_temp, o, run, page, mag_windows))
    return failed_again();
  move_results(cal, run);
  MagCalibration<Scalar> mc;
  finish_magnetometer<Scalar>(*f.mag, o, mag_windows, run.accel_ok ? &c.accel : nullptr, run, mc);
  temperature_result(f.pass->rests, c, t, run);
  // The record the device would store: from the calibration itself (float, as on the device),
  // with the magnetometer and the temperature model where usable (make_record leaves the rest).
  make_run_record<Scalar>(c, run.mag.ok ? &mc : nullptr, t.have ? &t.model : nullptr, o, run);
  return run.usable ? 0 : 1;
}

}  // namespace

void print_diagnostics(const Diagnostics& diag) {
  for (const Diagnostic& d : diag.kept()) std::fprintf(stderr, "imucal: %s\n", d.text().c_str());
  if (diag.count() > diag.kept().size())
    std::fprintf(stderr, "imucal: ... and %zu more\n", diag.count() - diag.kept().size());
}

// The settings the input itself gives (its `# imucal:` comments, its columns) joined to the
// command's, and checked before any sample is read. False with the reason otherwise.
bool settle_options(SampleReader& reader, Options& o, std::string& error) {
  if (!apply_file_settings(reader.file_settings(), o, error)) return false;
  if (o.mag_unit == MagUnit::kCounts && !std::isfinite(o.mag_lsb_per_ut)) {
    error = format_text(
        "--mag-unit counts needs the nominal --mag-lsb-per-ut (counts per uT, "
        "from the data sheet): the field bounds are in uT");
    return false;
  }
  if (o.accel_unit == AccelUnit::kCounts && std::isfinite(o.accel_lsb_per_g) &&
      !std::isfinite(o.accel_zero))
    o.accel_zero = 0;  // signed counts unless a zero was given
  reader.set_time_unit(o.time_unit);
  reader.set_rate(o.nominal_rate_hz);
  // An accelerometer alone without time is a file of pose means (one line each).
  const bool csv = reader.format() == Format::kCsv;
  const bool accel_alone =
      csv && reader.has_accelerometer() && !reader.has_gyroscope() && !reader.has_magnetometer();
  if (accel_alone && !reader.has_time() && !(o.nominal_rate_hz > 0)) o.pose_file = true;
  if (o.pose_file && !accel_alone) {
    error = format_text(
        "--poses reads one pose mean per line of an accelerometer alone (columns "
        "ax, ay, az; found %s)",
        reader.column_names().c_str());
    return false;
  }
  if (csv && reader.has_gyroscope() && !reader.has_time() && !(o.nominal_rate_hz > 0)) {
    error = format_text(
        "%s has no time column (t): give --rate HZ (sample i is then at i/HZ s), "
        "or name a t column with --columns",
        o.files[0].c_str());
    return false;
  }
  return true;
}

namespace {

// The calibration in float (the device's) or double, the diagnostics kept in the run.
int calibrate_from(Options& o, SampleReader& reader, const Reopen& reopen, Diagnostics& diag,
                   Run& run, std::vector<Sample>& page) {
  const int code = o.use_double ? run_calibration<double>(o, reader, reopen, diag, run, page)
                                : run_calibration<float>(o, reader, reopen, diag, run, page);
  run.diagnostic_count = static_cast<long>(diag.count());
  for (const Diagnostic& d : diag.kept()) run.diagnostics.push_back(d.text());
  return code;
}

}  // namespace

// Files that can be read again from their start (not stdin, a pipe or a terminal).
bool rereadable(const std::vector<std::string>& files) {
  for (const std::string& f : files) {
    struct stat st {};
    if (f == "-" || stat(f.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return false;
  }
  return !files.empty();
}

int calibrate_command(const std::vector<std::string>& args, bool report) {
  Options o;
  std::string error;
  if (!parse_calibrate_options(args, o, error)) {
    std::fprintf(stderr, "imucal: %s\n", error.c_str());
    return 2;
  }
  if (report && o.svg_path.empty()) {
    std::fprintf(stderr, "imucal report: give the page to write with -o PAGE.svg\n");
    return 2;
  }
  for (const std::string& k : o.command_line_keys) {
    if (k == "prior" || k == "gyro-noise" || k == "accel-noise" || k == "gyro-zero" ||
        k == "at-temperature" || k == "rest-piece") {
      std::fprintf(stderr, "imucal: --%s is an option of `imucal field`\n", k.c_str());
      return 2;
    }
    if ((k == "device-id" || k == "sensor-id") && o.record_path.empty()) {
      std::fprintf(stderr, "imucal: --%s goes into the record: give --record FILE\n", k.c_str());
      return 2;
    }
  }
  if (o.files.empty()) {
    std::fprintf(stderr, "imucal: no input (a CSV file, - for stdin, or two imu_tk files)\n");
    return 2;
  }
  std::vector<std::string> inputs = o.files;
  inputs.push_back(o.truth_path);
  if (!outputs_apart_from_inputs(inputs, {{"--json", o.json_path},
                                          {"--header", o.header_path},
                                          {"--record", o.record_path},
                                          {report ? "-o" : "--svg", o.svg_path}}))
    return 2;
  Diagnostics diag;
  SampleReader reader;
  const std::string columns = o.columns;
  const bool pose_file = o.pose_file;
  auto open = [&](SampleReader& r, Diagnostics& d) {
    r.set_columns(columns);
    if (pose_file) r.set_headerless_columns("ax,ay,az");
    return r.open(o.files, o.format, d);
  };
  if (!open(reader, diag)) {
    print_diagnostics(diag);
    return 2;
  }
  if (!settle_options(reader, o, error)) {
    std::fprintf(stderr, "imucal: %s\n", error.c_str());
    return 2;
  }
  Reopen reopen;
  if (rereadable(o.files))
    reopen = [&](SampleReader& r, Diagnostics& d) {
      if (!open(r, d)) return false;
      r.set_time_unit(o.time_unit);
      r.set_rate(o.nominal_rate_hz);
      return true;
    };

  Run run;
  std::vector<Sample> page;  // the samples the page draws
  const int code = calibrate_from(o, reader, reopen, diag, run, page);
  print_diagnostics(diag);
  if (run.samples == 0) return 2;
  if (reader.failed()) {
    std::fprintf(stderr, "imucal: the input could not be read to its end: nothing written\n");
    return 2;
  }

  // An output sent to stdout gets stdout to itself; the summary goes to stderr then.
  const bool stdout_taken =
      o.json_path == "-" || o.header_path == "-" || o.svg_path == "-" || o.record_path == "-";
  std::FILE* summary = stdout_taken ? stderr : stdout;
  print_summary(run, o, summary);
  bool written = true;
  if (!o.json_path.empty()) written = write_json(run, o, o.json_path) && written;
  if (!o.header_path.empty()) {
    if (run.usable) {
      written = write_header(run, o, o.header_path) && written;
    } else {
      std::fprintf(stderr, "imucal: no header written: the calibration is not usable\n");
    }
  }
  if (!o.record_path.empty()) {
    if (!run.usable) {
      std::fprintf(stderr, "imucal: no record written: the calibration is not usable\n");
    } else if (!run.record_error.empty()) {
      std::fprintf(stderr, "imucal: no record written: %s\n", run.record_error.c_str());
      written = false;
    } else {
      written = write_text_file(o.record_path, std::string(run.record.begin(), run.record.end())) &&
                written;
    }
  }
  if (!o.svg_path.empty())
    written = write_text_file(o.svg_path, report_svg(run, o, page)) && written;
  if (!o.truth_path.empty()) written = compare_with_truth(run, o.truth_path, summary) && written;

  if (!written) return 2;
  return code;
}

bool open_arrays(const std::vector<std::string>& args, const SampleArrays& arrays, Options& o,
                 SampleReader& reader, Diagnostics& diag, std::string& error) {
  std::vector<std::string> all = args;
  all.push_back("<arrays>");  // the input's name in messages
  if (!parse_calibrate_options(all, o, error)) return false;
  if (reader.open_arrays(arrays, diag)) return true;
  error = diag.kept().empty() ? "the columns cannot be read" : diag.kept()[0].message;
  return false;
}

int calibrate_memory(const std::vector<std::string>& args, const SampleArrays& arrays,
                     MemoryRun& out) {
  Options o;
  Diagnostics diag;
  SampleReader reader;
  if (!open_arrays(args, arrays, o, reader, diag, out.error) ||
      !settle_options(reader, o, out.error))
    return 2;
  o.quiet = true;
  if (o.record_path.empty()) o.record_path = "<memory>";  // the record is made, not written
  // The arrays are read again for the passes after the first, as a file is: beyond --memory
  // nothing is kept.
  const Reopen reopen = [&](SampleReader& r, Diagnostics& d) {
    if (!r.open_arrays(arrays, d)) return false;
    r.set_time_unit(o.time_unit);
    r.set_rate(o.nominal_rate_hz);
    return true;
  };
  Run run;
  std::vector<Sample> page;
  const int code = calibrate_from(o, reader, reopen, diag, run, page);
  if (run.samples == 0) {
    out.error = "no samples";
    return 2;
  }
  out.summary = printed([&](std::FILE* f) { print_summary(run, o, f); });
  out.json = run_json(run, o);
  if (run.usable && run.record_error.empty()) out.record = run.record;
  return code;
}

}  // namespace imucal::cli
