// SPDX-License-Identifier: MIT
// imucal/field/field_calibrator.hpp: keeps the gyro's bias, the accelerometer's model and the
// magnetometer's hard and soft iron right through normal use, with nobody turning the device (the
// design's field.md; docs/field.md). It runs forever on the raw stream.
//
// The stream layer finds the rests: a RestMonitor (rest_monitor.hpp: the protocol's checks,
// detector, blocks and rests) hands out every rest of min_rest_seconds or more, split into pieces
// of at most max_rest_seconds. Each piece is judged before it may move anything (a piece is judged
// once the next piece of its rest or the rest's end is known):
//   - turned: two consecutive pieces of one rest whose mean gravity direction turned faster than
//     turn_rate_max, or (with a magnetometer, add_mag()) whose mean fields differ by more than
//     their noise allows, are a slow rotation taken for a rest (a car's bend, a turntable) or a
//     magnet passing: both are refused (kRejected, kTurning). A rate that changed between them
//     (a turn's tail) refuses the earlier one. Pieces that pass are steady; with a magnetometer,
//     verified. The first piece of a rest after motion whose rate differs from the next one's
//     along gravity (a turn about the vertical slowing to a stop) keeps a weight by that
//     difference (widen_tail()).
//   - consistency: the piece's mean gyro against the bias filter's prediction at its temperature
//     (bias_filter.hpp: bias, slope and curvature per axis, a random walk between rests), a
//     chi-square(3) gate. A piece within the gate is taken into the filter. One outside is held
//     as a candidate (kHeld; a turn about the vertical looks like a bias inside one rest) and the
//     stated sigma widens at once by the disagreement. A verified piece confirm_seconds later (or,
//     once a bias is published, a steady one whose step lies across gravity, which no turn about
//     the vertical gives), a steady one after motion in an orientation 30 degrees or more away, or
//     three steady rests across motion over change_seconds, that agree with it confirm a change (a
//     knock; kChangeDetected: the filter's bias variance grows by change_sigma^2; published at
//     once, or before the first publication only taken); a piece that agrees with the filter
//     instead drops it (kRejected, kUnconfirmed).
// What the device applies is the *published* bias model, not the filter: the filter's model
// replaces it (kUpdated) only when the two differ significantly (publish_chi2 on the difference
// with both variances) and the filter's variance is the smaller, or when the filter's variance is
// at most better_ratio of the published one; or at once after a change. The first publication
// waits for first_rests independent rests. Both models age with the random walk, so the
// published sigma stays honest. The temperature it is evaluated at is smoothed without lag on a
// ramp. Every decision is an event (take_event()). The detector removes the published bias, so a
// turn held back stays visible as motion-like energy. save_due() and mark_saved() keep the saves
// within a wear budget (field_store.hpp writes them through the record store).
// The rests the gyro's filter takes feed the accelerometer's model (accel_field.hpp) and, with
// their mean fields and single readings in motion, the magnetometer's (mag_field.hpp); each is
// judged, held and published by its own rules, its events carry its sensor. One call does at most
// one of: taking a rest, the magnetometer's share of a rest taken before, one slice of a solve.
// The moves between the rests the gyro's filter takes, each from the end of one rest to the start
// of the next with nothing cut between, teach the gyro's misalignment and scale (gyro_field.hpp),
// through the accelerometer's model: the rest monitor hands on their segments as they come, one
// is walked a call (in the place of a solve slice); their publication is an event of its own
// sensor (kGyroMatrix).
//
// Units: raw gyro units (the bias is ADDED to the raw reading, as in the calibration:
// w = T K (w_raw + b)); settings in physical units convert through gyro_per_rad_s.
// Fixed memory (sizeof docs/field.md states per target), no allocation, no exceptions.
// Capacities: Events, the decisions waiting to be taken; MagCells, the magnetometer model's cells
// of field directions (0: built without a magnetometer, its model compiled out, 2,800 B less;
// settings that enable it are then refused with kInvalidArgument); GyroMatrix, the gyro's
// misalignment and scale learned from the moves (false: compiled out with the moves the rest
// monitor would keep for it, 1,900 B less; the stored matrix is kept as it is, whatever
// gyro_matrix.enabled says). Header-only.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "imucal/field/accel_field.hpp"
#include "imucal/field/bias_filter.hpp"
#include "imucal/field/gyro_field.hpp"
#include "imucal/field/mag_field.hpp"
#include "imucal/models/calibration.hpp"
#include "imucal/models/plausibility.hpp"
#include "imucal/models/temperature_model.hpp"
#include "imucal/status.hpp"
#include "imucal/stream/fifo.hpp"
#include "imucal/stream/rest_monitor.hpp"
#include "imucal/stream/ring.hpp"
#include "imucal/types.hpp"

namespace imucal {

// What the field calibrator is set up with: the rest monitor's settings (noise at rest, the
// stream checks, the detector; here rests of 1 s or more, in pieces of at most 5 s) and its own.
// The physical ones are in rad/s; gyro_per_rad_s converts them.
template <typename Scalar>
struct FieldSettings : RestMonitorSettings<Scalar> {
  FieldSettings() {
    this->min_rest_seconds = Scalar(1);
    this->max_rest_seconds = Scalar(5);
    this->follow_rests = false;
    // The detector's step and the trimming's granularity: a quarter second (the float work of a
    // sub-block, paid once per 25 samples at 100 Hz; a rest's edges still trimmed to 0.25 s).
    this->sub_block_seconds = Scalar(0.25);
    this->block_seconds = Scalar(0.25);
  }
  Scalar gyro_per_rad_s = std::numeric_limits<Scalar>::quiet_NaN();  // raw units per rad/s
  // The prior without a stored calibration: bias 0 with this sigma, slope 0 with its sigma.
  Scalar bias_sigma = Scalar(0.0524);  // rad/s (3 deg/s)
  // 0: not learned (a stored calibration's slope or curvature is kept as it is; without one, 0).
  Scalar slope_sigma = Scalar(5.2e-4);      // rad/s per deg C (0.03 deg/s/degC)
  Scalar curvature_sigma = Scalar(1.7e-5);  // rad/s per deg C^2 (0.001 deg/s/degC^2)
  Scalar walk = Scalar(5.2e-6);             // rate random walk, rad/s/sqrt(s) (3e-4 deg/s/sqrt s)
  Scalar floor = Scalar(1.7e-5);            // a rest mean's sigma is at least this (rad/s)
  Scalar change_sigma = Scalar(0.0175);     // a knock's step: its prior sigma (rad/s, 1 deg/s)
  Scalar turn_rate_max = Scalar(3e-4);      // gravity turning faster (rad/s) is not a rest
  // With a magnetometer, two pieces of one rest whose mean fields differ by more than their
  // noise allows (chi-square(3) above gate_chi2, the noise measured over each piece) turned,
  // about any axis, or a magnet passed: both are refused. Pieces whose field held still are
  // verified: a turn about the vertical would have shown.
  // Verified pieces this far apart (s) within one rest count as independent rests, and a
  // verified piece this long after a held one confirms a change.
  Scalar confirm_seconds = Scalar(10);
  // Without verification, a change is confirmed once the rests have disagreed with the model
  // (and agreed with each other) this long, across motion (s): longer than a vehicle's bend.
  Scalar change_seconds = Scalar(600);
  Scalar gate_chi2 = Scalar(16.27);    // chi-square(3) at 0.1 %: a rest the filter takes
  Scalar publish_chi2 = Scalar(7.81);  // chi-square(3) at 5 %: the published one is replaced
  // ... or when the filter's variance at the temperature now is at most this share of the
  // published one's (a much better estimate, within the published one's error bars).
  Scalar better_ratio = Scalar(0.25);
  Scalar temperature_margin_c = Scalar(5);  // the model is not extrapolated further than this
  Scalar temperature_seconds = Scalar(2);   // the temperature's smoothing (its noise removed)
  int first_rests = 2;                      // rests after motion before the first publication
  // The wear budget (field.md section 6): a publication is saved at most saves_per_day times a
  // day and save_interval_s apart, the first save_interval_s after start() (a device that
  // reboots often never wears the flash). Two slots of 10,000 erase cycles over ten years allow
  // 5.5 saves a day.
  Scalar save_interval_s = Scalar(14400);
  int saves_per_day = 5;
  // The accelerometer's model from the same rests (accel_field.hpp); kept when
  // accel.accel_per_m_s2 is set (NaN: the gyro alone).
  AccelFieldSettings<Scalar> accel{};
  // The magnetometer's hard and soft iron from the same rests' mean fields (mag_field.hpp); kept
  // when mag.counts_per_ut is set and add_mag() is fed.
  MagFieldSettings<Scalar> mag{};
  // The gyro's misalignment and scale from the moves between rests (gyro_field.hpp).
  GyroFieldSettings<Scalar> gyro_matrix{};
};

enum class FieldEventKind : std::uint8_t {
  kUpdated = 0,         // the published bias changed
  kRejected = 1,        // a rest was refused (reason)
  kHeld = 2,            // a rest outside the gate: held until a later rest confirms or drops it
  kChangeDetected = 3,  // the data prove the published value changed: two rests after motion
                        // agree on a bias the filter did not predict, refused moves on a new
                        // gyro matrix
  kSaved = 4,           // the published bias was saved (mark_saved())
};

enum class FieldReason : std::uint8_t {
  kNone = 0,
  kTurning = 1,        // the gravity direction turned during the rest
  kInconsistent = 2,   // outside the gate of the filter's prediction
  kUnconfirmed = 3,    // a held rest that the next rest after motion did not confirm
  kSignificant = 4,    // (kUpdated) the filter differs significantly and is better
  kChange = 5,         // (kUpdated) after a change
  kFirst = 6,          // (kUpdated) the first publication
  kBetter = 7,         // (kUpdated) the filter's variance is a small share of the published one's
  kImplausible = 8,    // (kRejected, the accelerometer's or the magnetometer's) its reading is no
                       // gravity, or no field of the expected strength, as set up
  kNoTemperature = 9,  // (kRejected) a rest without a temperature in a run that gave them (the
                       // sensor failed): the models cannot place it
};

inline const char* field_event_name(FieldEventKind k) {
  switch (k) {
    case FieldEventKind::kUpdated:
      return "updated";
    case FieldEventKind::kRejected:
      return "rejected";
    case FieldEventKind::kHeld:
      return "held";
    case FieldEventKind::kChangeDetected:
      return "change_detected";
    default:
      return "saved";
  }
}

inline const char* field_reason_name(FieldReason r) {
  switch (r) {
    case FieldReason::kNone:
      return "none";
    case FieldReason::kTurning:
      return "turning";
    case FieldReason::kInconsistent:
      return "inconsistent";
    case FieldReason::kUnconfirmed:
      return "unconfirmed";
    case FieldReason::kSignificant:
      return "significant";
    case FieldReason::kChange:
      return "change";
    case FieldReason::kFirst:
      return "first";
    case FieldReason::kImplausible:
      return "implausible";
    case FieldReason::kNoTemperature:
      return "no_temperature";
    default:
      return "better";
  }
}

// kGyro: the gyro's bias; kGyroMatrix: its misalignment and scale.
enum class FieldSensor : std::uint8_t { kGyro = 0, kAccel = 1, kMag = 2, kGyroMatrix = 3 };

inline const char* field_sensor_name(FieldSensor s) {
  switch (s) {
    case FieldSensor::kGyro:
      return "gyro";
    case FieldSensor::kAccel:
      return "accel";
    case FieldSensor::kMag:
      return "mag";
    default:
      return "gyro_matrix";
  }
}

// One decision. value: the sensor's published bias at temperature_c after it (raw, added; for
// kGyroMatrix the published scales, rad/s per raw unit); chi2:
// the statistic it was decided by (the gate's, the publication's, or the turn rate over its
// bound). A kSaved event is the gyro's and stands for the whole record.
template <typename Scalar>
struct FieldEvent {
  FieldEventKind kind = FieldEventKind::kUpdated;
  FieldReason reason = FieldReason::kNone;
  FieldSensor sensor = FieldSensor::kGyro;
  std::uint32_t time_s = 0;  // seconds since the calibrator started (the stream's clock)
  Scalar temperature_c = std::numeric_limits<Scalar>::quiet_NaN();
  Scalar chi2 = Scalar(0);
  Vector3<Scalar> value = Vector3<Scalar>::Zero();
};

// How many rests went where.
struct FieldCounts {
  std::uint32_t rests = 0;           // handed out by the rest monitor
  std::uint32_t taken = 0;           // into the filter
  std::uint32_t turning = 0;         // refused: gravity turned
  std::uint32_t no_temperature = 0;  // refused: no temperature, in a run that gave them
  std::uint32_t held = 0;            // outside the gate
  std::uint32_t unconfirmed = 0;
  std::uint32_t changes = 0;
  std::uint32_t updates = 0;  // publications
  std::uint32_t saves = 0;    // publications saved (mark_saved())
  std::uint32_t events_dropped = 0;
  // The accelerometer's: rests held outside its gate, changes, publications, rests refused as
  // implausible.
  std::uint32_t accel_held = 0;
  std::uint32_t accel_changes = 0;
  std::uint32_t accel_updates = 0;
  std::uint32_t accel_implausible = 0;
  // The magnetometer's, alike.
  std::uint32_t mag_held = 0;
  std::uint32_t mag_changes = 0;
  std::uint32_t mag_updates = 0;
  std::uint32_t mag_implausible = 0;
  std::uint32_t mag_glitches = 0;  // readings refused by add_mag() as beyond any field (kGlitch)
  // The gyro's misalignment and scale: moves taken, refused (outside the gate), publications,
  // changes found (refused moves that one new matrix explains; each also a publication).
  std::uint32_t gyro_moves = 0;
  std::uint32_t gyro_moves_refused = 0;
  std::uint32_t gyro_matrix_updates = 0;
  std::uint32_t gyro_matrix_changes = 0;
};

template <typename Scalar, int Events = 8, int MagCells = 26, bool GyroMatrix = true>
class FieldCalibrator {
 public:
  using Settings = FieldSettings<Scalar>;
  // The rest monitor: two finished rests queued, three blocks of 0.25 s waiting to be confirmed
  // still (trim_seconds and one block), room for kMoveSegments gyro segments of a move not walked
  // yet (taken one a call as they come; if they pile up, they are coarsened,
  // solve/move_store.hpp, and the move is not used; none without GyroMatrix), sub-blocks of up
  // to 32 samples.
  static constexpr int kMoveSegments = GyroMatrix ? 4 : 0;
  // Identical magnetometer readings in a rest beyond which the sensor is taken as stuck.
  static constexpr std::uint32_t kMagFrozenReadings = 16;
  using Monitor = RestMonitor<Scalar, 2, 3, kMoveSegments, 32>;

  FieldCalibrator() = default;

  // Starts from a stored calibration (its gyro bias and sigma, and its temperature model's gyro
  // part if usable; its accelerometer part and the magnetometer's calibration, if given and
  // usable, for those sensors' models) or, with nullptr, from the nominal prior.
  // kInvalidArgument: settings out of range (then add() refuses every sample); kNonFiniteInput:
  // the prior holds a NaN or infinity (the nominal prior is used instead).
  // The temperature model's range is taken as the temperatures seen plus temperature_margin_c,
  // as calibration() stores it: the models start from that range less the margin (its middle if
  // it is narrower than two margins), so a save after a resume stores the same range again.
  Status start(const Settings& settings, const Calibration<Scalar>* prior = nullptr,
               const TemperatureModel<Scalar>* temperature = nullptr,
               const MagCalibration<Scalar>* mag = nullptr) {
    TemperatureModel<Scalar> seen{};
    if (temperature != nullptr) {
      seen = *temperature;
      const Scalar lo = seen.min_c + settings.temperature_margin_c;
      const Scalar hi = seen.max_c - settings.temperature_margin_c;
      if (lo <= hi) {
        seen.min_c = lo;
        seen.max_c = hi;
      } else if (seen.min_c <= seen.max_c) {
        seen.min_c = seen.max_c = Scalar(0.5) * seen.min_c + Scalar(0.5) * seen.max_c;
      }
      temperature = &seen;
    }
    settings_ = settings;
    valid_ = check(settings) && monitor_.reset(settings) == Status::kOk;
    gyro_cue_ = false;
    events_.clear();
    counts_ = FieldCounts{};
    clock_started_ = false;
    elapsed_us_ = 0;
    last_t_us_ = 0;
    filter_time_us_ = 0;
    pending_ = candidate_ = false;
    if constexpr (GyroMatrix) {
      matrix_.from_ok = matrix_.end_pending = false;
      matrix_.move = 0;
    }
    group_ = 0;
    independent_ = 0;
    last_taken_group_ = 0;
    mag_sum_.setZero();
    mag_sq_ = Scalar(0);
    mag_n_ = 0;
    mag_reading_var_ = Scalar(0);
    mag_offered_us_ = mag_looked_us_ = mag_doubt_us_ = 0;
    mag_first_ = mag_due_ = 0;
    reset_dip();
    took_ = false;
    temperature_ = std::numeric_limits<Scalar>::quiet_NaN();
    temperature_us_ = 0 - kTemperatureBatchUs;  // the first reading is smoothed at once
    monitor_restarted();
    doubt_ = Scalar(0);
    if (!valid_) return Status::kInvalidArgument;
    const Scalar k = settings.gyro_per_rad_s;
    q_ = settings.walk * k * settings.walk * k;
    temperature_weight_ = Scalar(1e-6) / settings.temperature_seconds;  // per microsecond
    floor2_ = settings.floor * k * settings.floor * k;
    noise_axis_ = settings.gyro_noise / Scalar(3);
    filter_.start(Vector3<Scalar>::Zero(), settings.bias_sigma * k, Vector3<Scalar>::Zero(),
                  settings.slope_sigma * k, Vector3<Scalar>::Zero(), settings.curvature_sigma * k,
                  Scalar(25));
    published_ = filter_;
    has_published_ = false;
    unsaved_ = false;
    last_save_s_ = 0;
    day_start_s_ = 0;
    saves_today_ = 0;
    // Without a prior: the nominal gyro model (no misalignment, the nominal scale).
    base_ = Calibration<Scalar>{};
    base_.gyro.params.template segment<3>(kGyroScaleX).setConstant(Scalar(1) / k);
    base_.gyro.status = Status::kOk;
    Status result = Status::kOk;
    if (prior != nullptr) {
      if (succeeded(prior->gyro.status) && all_finite(prior->gyro.params) &&
          all_finite(prior->gyro.sigma)) {
        const Vector3<Scalar> b(prior->gyro.params(kGyroBiasX), prior->gyro.params(kGyroBiasY),
                                prior->gyro.params(kGyroBiasZ));
        const Vector3<Scalar> sb(prior->gyro.sigma(kGyroBiasX), prior->gyro.sigma(kGyroBiasY),
                                 prior->gyro.sigma(kGyroBiasZ));
        // Each stated sigma up to the nominal one (bias_filter.hpp, stated_sigma()).
        const Scalar sigma = stated_sigma(sb.maxCoeff(), settings.bias_sigma * k);
        Scalar t0 = prior->has_temperature && std::isfinite(prior->temperature_c)
                        ? prior->temperature_c
                        : Scalar(25);
        Vector3<Scalar> slope = Vector3<Scalar>::Zero(), curvature = Vector3<Scalar>::Zero();
        Scalar slope_sigma = settings.slope_sigma * k;
        Scalar curvature_sigma = settings.curvature_sigma * k;
        Vector3<Scalar> c = b;
        if (temperature != nullptr && succeeded(temperature->gyro.status) &&
            all_finite(temperature->gyro.b0) && all_finite(temperature->gyro.b1) &&
            std::isfinite(temperature->reference_c)) {
          t0 = temperature->reference_c;
          c = temperature->gyro.b0;
          slope = temperature->gyro.b1;
          slope_sigma = stated_sigma(temperature->gyro.b1_sigma.maxCoeff(), slope_sigma);
          if (temperature->order == 2 && all_finite(temperature->gyro.b2)) {
            curvature = temperature->gyro.b2;
            curvature_sigma = stated_sigma(temperature->gyro.b2_sigma.maxCoeff(), curvature_sigma);
          }
        }
        filter_.start(c, sigma, slope, slope_sigma, curvature, curvature_sigma, t0);
        if (temperature != nullptr && succeeded(temperature->gyro.status) &&
            temperature->min_c <= temperature->max_c) {  // the temperatures it saw
          filter_.min_c = temperature->min_c;
          filter_.max_c = temperature->max_c;
        }
        published_ = filter_;
        has_published_ = true;
        base_ = *prior;
      } else {
        result = Status::kNonFiniteInput;
      }
    }
    {  // the accelerometer's model, when its scale is set
      AccelFieldSettings<Scalar> a = settings.accel;
      a.enabled = a.enabled && !std::isnan(a.accel_per_m_s2);
      const bool noted = prior != nullptr && prior->has_temperature;
      const Scalar t0 =
          noted && std::isfinite(prior->temperature_c) ? prior->temperature_c : filter_.reference_c;
      const Status s = accel_.start(a, prior != nullptr ? &prior->accel : nullptr, temperature, t0);
      if (s == Status::kInvalidArgument) {
        valid_ = false;
        return s;
      }
      if (s != Status::kOk && result == Status::kOk) result = s;
    }
    {  // the magnetometer's model, when its scale is set: from the stored calibration if usable
      AccelFieldSettings<Scalar> m = mag_norm_settings(settings.mag);
      AccelCalibration<Scalar> stored;
      bool usable = false;
      if constexpr (MagCells > 0) {
        mag_kept_.frame.setIdentity();
        mag_kept_.like = MagCalibration<Scalar>{};
        usable = mag != nullptr && m.enabled && mag_prior(*mag, stored, mag_kept_.frame);
        if (usable)
          mag_kept_.like = *mag;
        else
          mag_kept_.frame.setIdentity();
      }
      if (usable) m.gravity = mag->field_ut;  // the strength the stored soft iron gives
      const Status s = mag_.start(m, usable ? &stored : nullptr, nullptr, Scalar(25));
      if (s == Status::kInvalidArgument) {
        valid_ = false;
        return s;
      }
      if (mag != nullptr && m.enabled && !usable && result == Status::kOk && succeeded(mag->status))
        result = Status::kNonFiniteInput;
      mag_field_ut_ = m.gravity;
      mag_g_counts_ = m.accel_per_m_s2 * m.gravity;
      set_mag_reach();
    }
    {  // the gyro's misalignment and scale: from the prior's where it states them
      using GyroVector9 = typename GyroField<Scalar>::Vector;
      GyroVector9 prior9 = base_.gyro.params.template head<kGyroMatrixParams>();
      // A prior that states only the bias (no scales): the nominal matrix, with its sigmas.
      const bool matrix = prior9.template segment<3>(kGyroScaleX).minCoeff() > Scalar(0);
      if (!matrix) {
        prior9.setZero();
        prior9.template segment<3>(kGyroScaleX).setConstant(Scalar(1) / k);
      }
      GyroVector9 sigma9;
      for (int i = 0; i < kGyroMatrixParams; ++i) {
        const Scalar nominal = i >= kGyroScaleX
                                   ? settings.gyro_matrix.scale_sigma * std::abs(prior9(i))
                                   : settings.gyro_matrix.misalignment_sigma;
        const Scalar stated = matrix && prior != nullptr && succeeded(prior->gyro.status)
                                  ? base_.gyro.sigma(i)
                                  : std::numeric_limits<Scalar>::quiet_NaN();
        sigma9(i) = stated_sigma(stated, nominal);
        if (stated > nominal) base_.gyro.sigma(i) = nominal;  // the output says what it uses
      }
      if constexpr (GyroMatrix) {
        if (matrix_.field.start(settings.gyro_matrix, prior9, sigma9) != Status::kOk &&
            result == Status::kOk)
          result = Status::kNonFiniteInput;
      }
    }
    accel_rests_ = 0;
    accel_noise_axis_ = settings.accel_noise / Scalar(3);
    gyro_cue_ = has_published_;
    monitor_.reset(monitor_settings(gyro_cue_));
    update_move_keeping();
    monitor_restarted();
    detector_temperature_ = temperature_;
    return result;
  }

  // One raw sample (the calibrator's ImuSample, raw units, temperature NaN without a sensor):
  // the rest monitor's statuses (refused, nothing changed: kInvalidArgument, kNonFiniteInput,
  // kTimeRepeated, kTimeBackwards, kSensorFrozen, kGyroSaturated, kGlitch; taken: kOk or a note).
  Status add(const ImuSample<Scalar>& s) {
    if (!valid_) return Status::kInvalidArgument;
    const Status st = monitor_.add(s);
    if (st == Status::kOk || sample_taken(st))
      after_sample(s.t_us);
    else
      after_refusal(st, s.t_us);
    return st;
  }

  // One frame of 16-bit counts and the temperature read with it (NaN: none); as add().
  Status add_raw(const RawFrame& f, Scalar temperature = std::numeric_limits<Scalar>::quiet_NaN()) {
    if (!valid_) return Status::kInvalidArgument;
    const Status st = monitor_.add_raw(f, temperature);
    if (st == Status::kOk || sample_taken(st))
      after_sample(f.t_us);
    else
      after_refusal(st, f.t_us);
    return st;
  }

  // A batch of frames as the sensor's FIFO delivers them (stream/fifo.hpp: where the readings are
  // in each frame, when each was taken), and the temperature read with the batch (NaN: none),
  // which goes with the first frame whose checks read it. Each frame gets the status add_raw()
  // would give it: counted in the result, and written to statuses[k] if given (count entries). An
  // invalid layout or a null buffer refuses every frame with kInvalidArgument (counted in the rest
  // monitor's samples_refused()). A magnetometer reading belongs between the batches: add_mag()
  // after the batch it arrived with.
  FifoResult add_fifo(const std::uint8_t* data, std::uint32_t count, const FifoLayout& layout,
                      const FifoTiming& timing,
                      Scalar temperature = std::numeric_limits<Scalar>::quiet_NaN(),
                      Status* statuses = nullptr) {
    return feed_fifo(
        data, count, layout, timing, temperature, statuses,
        [this](const RawFrame& f, Scalar t) { return add_raw(f, t); },
        [](Status s) { return sample_taken(s); },
        [this] { return valid_ ? monitor_.refuse_unreadable() : Status::kInvalidArgument; },
        [this] { return monitor_.temperatures_read(); });
  }

  // The stream ended (or the caller wants what is there now): the rest in progress ends and is
  // judged, as if motion followed. The next sample starts the stream again, as after a gap.
  void finish() {
    if (!valid_) return;
    monitor_.finish();
    rests_seen_ = monitor_.rests_found();
    RestSummary<Scalar> r;
    while (monitor_.take(r)) on_rest(r);
    if (pending_) {
      judge(pending_piece_);
      pending_ = false;
    }
    while (mag_due_ > 0) add_mag_piece();
  }

  // A magnetometer reading (raw units) that arrived with the latest sample: it shows a turn
  // about the vertical that the gyro and the accelerometer cannot tell from a bias. Nothing taken:
  // kNonFiniteInput for a NaN or infinity, kGlitch for a reading beyond any field the settings
  // allow (a saturated sensor, a magnet at it; with the magnetometer's scale set), kSensorFrozen
  // in a rest whose first kMagFrozenReadings readings were all the same and for each such reading
  // after them (a stuck sensor; give each new reading once), and kInvalidArgument without a
  // valid start().
  Status add_mag(const Vector3<Scalar>& m) {
    if (!valid_) return Status::kInvalidArgument;
    if (!all_finite(m)) return Status::kNonFiniteInput;
    if (beyond_mag_reach(m)) {
      ++counts_.mag_glitches;
      return Status::kGlitch;
    }
    look_at_mag(m);
    if (!monitor_.resting()) {
      mag_sum_.setZero();
      mag_sq_ = Scalar(0);
      mag_n_ = 0;
      offer_moving(m);
      return Status::kOk;
    }
    if (mag_n_ == 0) mag_ref_ = m;  // sums about the first reading: noise-sized terms
    const Vector3<Scalar> d = m - mag_ref_;
    // A sensor stuck on one reading (a hung bus): kMagFrozenReadings identical readings in a rest,
    // and each like them after, are refused.
    if (mag_sq_ == Scalar(0) && mag_n_ >= kMagFrozenReadings && d.squaredNorm() == Scalar(0))
      return Status::kSensorFrozen;
    mag_sum_ += d;
    mag_sq_ += d.squaredNorm();
    ++mag_n_;
    return Status::kOk;
  }

  // The bias the device applies now: at the smoothed temperature(); as below.
  bool gyro_bias(Vector3<Scalar>& out, Scalar* sigma = nullptr) const {
    return gyro_bias(temperature_, out, sigma);
  }

  // The bias the device applies at temperature t (NaN: at the model's reference; raw, added),
  // clamped to the temperatures the model saw plus the margin. False before the first
  // publication (then out is the prior's, or zero).
  bool gyro_bias(Scalar t, Vector3<Scalar>& out, Scalar* sigma = nullptr) const {
    out = published_.at(t, settings_.temperature_margin_c);
    if (sigma != nullptr) *sigma = std::sqrt(published_.variance_at(t) + doubt_);
    return has_published_;
  }

  // The published model as the library's temperature model's gyro part (order 2), for the
  // corrector: b0, b1 and their sigmas, the reference and the range (the temperatures seen plus
  // the margin; the reference alone before any). The accelerometer's part is left as it was.
  void published_model(TemperatureModel<Scalar>& out) const {
    out.order = 2;
    const std::uint32_t n = published_.measurements;  // the rests the model took
    out.rests = static_cast<int>(n < 1u ? 1u : (n > 65535u ? 65535u : n));
    out.reference_c = published_.reference_c;
    const Scalar m = settings_.temperature_margin_c;
    out.min_c = published_.seen_temperature() ? published_.min_c - m : published_.reference_c;
    out.max_c = published_.seen_temperature() ? published_.max_c + m : published_.reference_c;
    out.gyro.b0 = published_.c;
    out.gyro.b1 = published_.s;
    out.gyro.b2 = published_.q;
    out.gyro.b0_sigma.setConstant(root(published_.p(0, 0)));
    out.gyro.b1_sigma.setConstant(root(published_.p(1, 1)));
    out.gyro.b2_sigma.setConstant(root(published_.p(2, 2)));
    out.gyro.status = has_published_ ? Status::kOk : Status::kNotStarted;
    if (accel_.published()) {
      AccelCalibration<Scalar> unused;
      accel_.model(unused, out.accel);
    }
  }

  // The calibration the device applies now, for the corrector or a record: the prior's (or the
  // nominal gyro model) with the published gyro bias at the model's reference and its sigma,
  // and the published model as the temperature model's gyro part. False before the first
  // publication (then out is the prior's).
  bool calibration(Calibration<Scalar>& out, TemperatureModel<Scalar>& model) const {
    out = base_;
    published_model(model);
    if (accel_.published()) {
      const int poses = out.accel.poses;
      accel_.model(out.accel, model.accel);
      out.accel.status = Status::kOk;
      // A record's accelerometer part counts at least kAccelMinPoses poses: the prior's, or the
      // rests the field model took.
      const std::uint32_t n = accel_rests_ + static_cast<std::uint32_t>(poses > 0 ? poses : 0);
      out.accel.poses = static_cast<int>(n < static_cast<std::uint32_t>(kAccelMinPoses)
                                             ? static_cast<std::uint32_t>(kAccelMinPoses)
                                             : (n > 65535u ? 65535u : n));
      if (!has_published_) {
        out.has_temperature = true;
        out.temperature_c = accel_.reference_c();
        model.reference_c = accel_.reference_c();
        if (accel_.seen_temperature()) {
          model.min_c = accel_.min_c() - settings_.temperature_margin_c;
          model.max_c = accel_.max_c() + settings_.temperature_margin_c;
        }
      }
    }
    if (!has_published_) return accel_.published();
    out.gyro.params.template tail<3>() = published_.c;
    out.gyro.sigma.template tail<3>().setConstant(root(published_.p(0, 0)));
    out.has_temperature = true;
    out.temperature_c = published_.reference_c;
    if (out.gyro.moves < 1) {  // the nominal model: the rests its bias came from (a record's
                               // gyro part counts at least one move)
      const std::uint32_t n = published_.measurements;
      out.gyro.moves = static_cast<int>(n < 1u ? 1u : (n > 65535u ? 65535u : n));
    }
    return true;
  }

  // A publication not saved yet, and the wear budget allows a save now.
  bool save_due() const {
    if (!unsaved_) return false;
    const std::uint64_t now = elapsed_us_ / 1000000u;
    if (static_cast<Scalar>(now - last_save_s_) < settings_.save_interval_s) return false;
    return now - day_start_s_ >= 86400u ||
           saves_today_ < static_cast<std::uint32_t>(settings_.saves_per_day);
  }

  // A publication not saved yet, due now or waiting for the wear budget.
  bool unsaved() const { return unsaved_; }

  // The publication was saved (the caller's RecordStore::save() returned kOk): counted against
  // the budget, a kSaved event.
  void mark_saved() {
    spend_save();
    unsaved_ = false;
    ++counts_.saves;
    event(FieldEventKind::kSaved, FieldReason::kNone, temperature_, Scalar(0));
  }
  // A save failed after it reached the flash (kStorageError, kStorageVerifyFailed): it wore the
  // flash as a save does and counts against the budget, so a failing sector is not erased again
  // on every call; the publication stays unsaved and is saved at its next turn.
  void mark_save_failed() { spend_save(); }

  // The oldest decision not taken yet; false if none. Events wait in a ring of Events; beyond
  // that the oldest is overwritten (counts().events_dropped).
  bool take_event(FieldEvent<Scalar>& out) {
    if (events_.empty()) return false;
    out = events_.oldest();
    events_.pop();
    return true;
  }

  bool published() const { return has_published_; }
  const BiasFilter<Scalar>& published_filter() const { return published_; }
  const BiasFilter<Scalar>& filter() const { return filter_; }
  const AccelField<Scalar>& accel_field() const { return accel_; }

  // The accelerometer's bias the device applies at the smoothed temperature() (raw, added), its
  // sigma per axis; false before its first publication (then the prior's) or without the
  // accelerometer's model (FieldSettings::accel).
  bool accel_bias(Vector3<Scalar>& out, Vector3<Scalar>* sigma = nullptr) const {
    return accel_bias(temperature_, out, sigma);
  }
  bool accel_bias(Scalar t, Vector3<Scalar>& out, Vector3<Scalar>* sigma = nullptr) const {
    if (!accel_.enabled()) {
      out.setZero();
      if (sigma != nullptr) sigma->setZero();
      return false;
    }
    const bool published = accel_.bias(t, settings_.temperature_margin_c, out, sigma);
    // While the gyro holds a rest it cannot explain (a knock, until confirmed), the rests do not
    // reach the accelerometer's model: its sigma covers a knock's step meanwhile.
    if (sigma != nullptr && candidate_) {
      const Scalar step = settings_.accel.change_sigma * settings_.accel.accel_per_m_s2;
      for (int i = 0; i < 3; ++i) (*sigma)(i) = std::sqrt((*sigma)(i) * (*sigma)(i) + step * step);
    }
    return published;
  }

  // The magnetometer's hard iron the device applies (raw, added) and its sigma per axis; false
  // before its first publication (then the prior's) or without the magnetometer's model
  // (FieldSettings::mag).
  bool mag_hard_iron(Vector3<Scalar>& out, Vector3<Scalar>* sigma = nullptr) const {
    if (!mag_.enabled()) {
      out.setZero();
      if (sigma != nullptr) sigma->setZero();
      return false;
    }
    // Doubted: a reading at rest disagreed and its rest is not judged yet (look_at_mag()).
    return mag_.bias(std::numeric_limits<Scalar>::quiet_NaN(), Scalar(0), out, sigma,
                     mag_doubt_us_ != 0);
  }
  // The published magnetometer model as a calibration (the corrector's and the record's): soft
  // iron in the prior's frame, hard iron, their sigmas, the field strength; false before its
  // first publication (out unchanged).
  bool mag_calibration(MagCalibration<Scalar>& out) const {
    if constexpr (MagCells > 0) {
      if (!mag_.enabled() || !mag_.published()) return false;
      AccelCalibration<Scalar> model;
      TemperatureBias<Scalar> unused;
      mag_.model(model, unused);
      mag_from_model(model, mag_kept_.frame, mag_field_ut_, mag_kept_.like, out);
      out.samples = static_cast<int>(mag_.cells());
      return true;
    } else {
      (void)out;
      return false;
    }
  }
  const AccelField<Scalar, MagCells>& mag_field() const { return mag_; }
  const FieldCounts& counts() const { return counts_; }
  const Monitor& monitor() const { return monitor_; }
  template <bool G = GyroMatrix, std::enable_if_t<G, int> = 0>
  const GyroField<Scalar>& gyro_field() const {
    return matrix_.field;
  }
  const Settings& settings() const { return settings_; }
  // The temperature smoothed over temperature_seconds (NaN before any reading).
  Scalar temperature() const { return temperature_; }
  // Seconds since start() on the stream's clock.
  Scalar seconds() const { return static_cast<Scalar>(elapsed_us_ / 1000u) * Scalar(1e-3); }

 private:
  // The square root of a variance that rounding may have taken just below zero.
  static Scalar root(Scalar v) { return std::sqrt(v > Scalar(0) ? v : Scalar(0)); }

  static bool check(const Settings& s) {
    const auto positive = [](Scalar x) { return std::isfinite(x) && x > Scalar(0); };
    return positive(s.gyro_per_rad_s) && positive(s.bias_sigma) && std::isfinite(s.slope_sigma) &&
           s.slope_sigma >= Scalar(0) && std::isfinite(s.curvature_sigma) &&
           s.curvature_sigma >= Scalar(0) && std::isfinite(s.walk) && s.walk >= Scalar(0) &&
           std::isfinite(s.floor) && s.floor >= Scalar(0) && positive(s.change_sigma) &&
           positive(s.turn_rate_max) && positive(s.gate_chi2) && positive(s.publish_chi2) &&
           std::isfinite(s.confirm_seconds) && std::isfinite(s.change_seconds) &&
           s.change_seconds >= Scalar(0) && s.confirm_seconds >= Scalar(0) &&
           positive(s.better_ratio) && s.better_ratio < Scalar(1) &&
           std::isfinite(s.temperature_margin_c) && s.temperature_margin_c >= Scalar(0) &&
           positive(s.temperature_seconds) && s.first_rests >= 1 && positive(s.gyro_noise) &&
           positive(s.save_interval_s) && s.saves_per_day >= 1 && s.gyro_matrix.valid() &&
           in_float_range(s);
  }
  // The prior's variances and the walk in raw units squared, and one raw unit in rad/s, finite
  // (a scale near the type's largest or smallest would make them infinite).
  static bool in_float_range(const Settings& s) {
    const Scalar k = s.gyro_per_rad_s;
    const auto square = [k](Scalar sigma) { return std::isfinite((sigma * k) * (sigma * k)); };
    return std::isfinite(Scalar(1) / k) && square(s.bias_sigma) && square(s.slope_sigma) &&
           square(s.curvature_sigma) && square(s.walk) && square(s.floor) &&
           square(s.change_sigma) && square(s.turn_rate_max);
  }

  struct Piece {
    Vector3<Scalar> z = Vector3<Scalar>::Zero();    // the bias it measures (added, raw)
    Vector3<Scalar> acc = Vector3<Scalar>::Zero();  // mean accelerometer (raw)
    Vector3<Scalar> mag = Vector3<Scalar>::Zero();  // mean magnetometer (raw; with has_mag)
    Scalar mag_var = Scalar(0);                     // the variance of that mean, summed over axes
    Scalar acc_var = Scalar(0);                     // the variance of acc per axis
    bool has_mag = false;
    bool steady = false;        // the piece before in its rest agreed: same rate, same gravity
    bool verified = false;      // ... and the same field (no turn about the vertical either)
    bool lead = false;          // the first piece of a rest after motion
    bool unplaced = false;      // no temperature, in a run that gives them: not used
    Scalar turned = Scalar(0);  // above 1: it turned (the rate over its bound) from a neighbour
    Scalar r = Scalar(0);       // each axis's variance of z
    Scalar t = Scalar(0);       // temperature (NaN: none)
    std::uint64_t mid_us = 0, end_us = 0;      // on the elapsed clock
    std::uint32_t group = 0;                   // rests between motions share a group
    std::uint32_t begin_raw = 0, end_raw = 0;  // its first and last sample's timestamps
  };

  // What a move needs of a rest piece at either end: its mean reading, that mean's variance per
  // axis, its temperature, the timestamps that name it, its group.
  struct MoveEnd {
    Vector3<Scalar> z = Vector3<Scalar>::Zero();  // the bias it measures
    Vector3<Scalar> acc = Vector3<Scalar>::Zero();
    Scalar acc_var = Scalar(0), t = Scalar(0);
    std::uint32_t begin_raw = 0, end_raw = 0, group = 0;
  };
  static MoveEnd move_end(const Piece& p) {
    MoveEnd e;
    e.z = p.z;
    e.acc = p.acc;
    e.acc_var = p.acc_var;
    e.t = p.t;
    e.begin_raw = p.begin_raw;
    e.end_raw = p.end_raw;
    e.group = p.group;
    return e;
  }

  // The readings of the batch since the last call smoothed over temperature_seconds (a reading's
  // noise times the model's slope would otherwise be an error of the bias applied), without the
  // lag of a plain moving mean on a warming board: twice the moving mean less its own moving mean
  // follows a ramp exactly. The batch's mean stands for its readings (a batch is short beside
  // temperature_seconds).
  void smooth_temperature(const TemperatureMean<Scalar>& readings) {
    // The batch's mean from the front end's running sum (relative to its first reading) and
    // count, less what earlier batches took: no per-frame work here.
    const std::int64_t sum = readings.sum_q();
    const std::uint32_t n = readings.count() - temps_seen_;
    const Scalar reading = readings.ref() + detail::to_scalar<Scalar>(sum - temp_sum_seen_) *
                                                Scalar(1.0 / detail::kTemperatureQ) /
                                                static_cast<Scalar>(n);
    temps_seen_ = readings.count();
    temp_sum_seen_ = sum;
    const std::uint64_t since = elapsed_us_ - temperature_us_;
    temperature_us_ = elapsed_us_;
    if (detail::is_nan(temperature_) || since > 600000000u) {
      temp_mean_ = temp_mean2_ = temperature_ = reading;
    } else {
      Scalar w = static_cast<Scalar>(static_cast<std::uint32_t>(since)) * temperature_weight_;
      if (w > Scalar(1)) w = Scalar(1);
      temp_mean_ += w * (reading - temp_mean_);
      temp_mean2_ += w * (temp_mean_ - temp_mean2_);
      temperature_ = Scalar(2) * temp_mean_ - temp_mean2_;
    }
    // The detector removes the published bias at the temperature now.
    if (has_published_ && !(std::fabs(temperature_ - detector_temperature_) <= Scalar(0.25)))
      set_detector_bias();
  }

  void spend_save() {
    const std::uint64_t now = elapsed_us_ / 1000000u;
    if (now - day_start_s_ >= 86400u) {
      day_start_s_ = now;
      saves_today_ = 0;
    }
    ++saves_today_;
    last_save_s_ = now;
  }

  // The rest monitor was reset: its counts of rests and temperatures start again from zero, its
  // count of clock resets does so unless the stream went on (reset_in_stream()).
  void monitor_restarted() {
    rests_seen_ = temps_seen_ = 0;
    resets_seen_ = monitor_.stream_counts().clock_resets;
    temp_sum_seen_ = 0;
  }

  // The rests the monitor found since the last look.
  void take_rests() {
    if (monitor_.rests_found() == rests_seen_) return;
    rests_seen_ = monitor_.rests_found();
    RestSummary<Scalar> r;
    while (monitor_.take(r)) on_rest(r);
  }

  // A sample refused as a frozen or saturated sensor's is in order, and the front end orders the
  // next against it: its time passes here too (a spell of hours is the bias's random walk of
  // hours, and longer than the clock's 71.6 minutes it would otherwise be lost), unless a clock
  // reset came with it (after_sample() places the rests then).
  void after_refusal(Status st, std::uint32_t t_us) {
    if (st != Status::kSensorFrozen && st != Status::kGyroSaturated) return;
    if (!clock_started_ || monitor_.stream_counts().clock_resets != resets_seen_) return;
    elapsed_us_ += static_cast<std::uint32_t>(t_us - last_t_us_);
    last_t_us_ = t_us;
  }

  void after_sample(std::uint32_t t_us) {
    took_ = false;
    // A clock reset since the last sample taken (this sample's, or one a refused sample saw):
    // the time between is unknown and not counted, and the rests it ended, timed on the old
    // clock, are placed before the clock moves on.
    const std::uint32_t resets = monitor_.stream_counts().clock_resets;
    if (resets != resets_seen_) {
      resets_seen_ = resets;
      take_rests();
    } else if (clock_started_) {
      elapsed_us_ += static_cast<std::uint32_t>(t_us - last_t_us_);
    }
    clock_started_ = true;
    last_t_us_ = t_us;
    // The temperatures the front end took (it sums them in fixed point), smoothed once a batch
    // (the batch's time first: nearly every frame stops there).
    if (elapsed_us_ - temperature_us_ >= kTemperatureBatchUs) {
      const TemperatureMean<Scalar>& readings = monitor_.temperatures();
      if (readings.count() != temps_seen_) smooth_temperature(readings);
    }
    take_rests();
    if (pending_ && !monitor_.resting()) {  // the rest is over: its last piece is judged
      judge(pending_piece_);
      pending_ = false;
    }
    // A call that took a rest does nothing more. Otherwise the magnetometer's share of a rest
    // taken in an earlier call, or one slice of one model's solve, the accelerometer's first: no
    // call does two of these.
    if (took_) {
    } else if (mag_due_ > 0) {
      add_mag_piece();
    } else if (walk_due()) {
      walk_moves();
    } else if (accel_.busy()) {
      if (accel_.step() == AccelFieldEvent::kUpdated)
        model_published(accel_, FieldSensor::kAccel, counts_.accel_updates);
    } else if (mag_.busy() && mag_.step() == AccelFieldEvent::kUpdated) {
      model_published(mag_, FieldSensor::kMag, counts_.mag_updates);
      set_mag_reach();
      reset_dip();  // the dip through the new model, from its rests
    }
  }

  template <typename Model>
  void model_published(const Model& m, FieldSensor sensor, std::uint32_t& updates) {
    static constexpr FieldReason kWhy[4] = {FieldReason::kFirst, FieldReason::kSignificant,
                                            FieldReason::kBetter, FieldReason::kChange};
    const int r = m.update_reason();
    ++updates;
    unsaved_ = true;
    event(FieldEventKind::kUpdated, kWhy[r < 0 || r > 3 ? 0 : r], temperature_, m.last_chi2(),
          sensor);
  }

  // No field the settings allow reads beyond twice its strength plus five sigmas of hard iron
  // and of a magnetisation change from the hard iron known (the stored or published one; raw
  // counts): past that, a saturated sensor or a magnet at it. No bound without the
  // magnetometer's scale.
  void set_mag_reach() {
    const MagFieldSettings<Scalar>& ms = settings_.mag;
    Vector3<Scalar> hard_iron = Vector3<Scalar>::Zero();
    mag_.bias(std::numeric_limits<Scalar>::quiet_NaN(), Scalar(0), hard_iron);
    const Scalar reach =
        (Scalar(2) * ms.field_ut + Scalar(5) * (ms.hard_iron_sigma_ut + ms.change_sigma_ut)) *
            ms.counts_per_ut +
        hard_iron.norm();
    mag_reach_ = reach > Scalar(0) && std::isfinite(reach * reach)
                     ? reach
                     : std::numeric_limits<Scalar>::infinity();
    mag_inner_ = mag_reach_ * Scalar(0.577);  // below 1/sqrt(3): its cube is in the sphere
  }

  // A reading beyond the reach. Without an FPU its axes are compared first, on the float's bits
  // (integer compares, plausibility.hpp): one beyond the reach is, and one whose every axis is
  // within the inner cube is not; only a reading between the two needs |m|^2.
  bool beyond_mag_reach(const Vector3<Scalar>& m) const {
    if constexpr (!bounds::soft_float<Scalar>()) {
      return m.squaredNorm() > mag_reach_ * mag_reach_;
    } else {
      bool inner = true;
      for (int i = 0; i < 3; ++i) {
        if (!bounds::abs_at_most(m[i], mag_reach_)) return true;
        inner = inner && bounds::abs_at_most(m[i], mag_inner_);
      }
      return !inner && m.squaredNorm() > mag_reach_ * mag_reach_;
    }
  }

  // The oldest rest piece waiting for the magnetometer's model.
  void add_mag_piece() {
    if constexpr (MagCells > 0) {  // else no piece ever waits
      const MagPiece& p = mag_kept_.pieces[mag_first_];
      mag_first_ ^= 1u;
      --mag_due_;
      Scalar s = Scalar(0);
      Vector3<Scalar> up;
      bool same_pose = false;
      const Scalar other =
          dip_disagreement(p.mag, p.acc, p.t, Scalar(0), Scalar(-1), s, up, same_pose);
      const AccelFieldEvent e = mag_.add(
          p.mag, p.variance, std::numeric_limits<Scalar>::quiet_NaN(), p.end_us, p.group, other);
      if (p.end_us >= mag_doubt_us_) mag_doubt_us_ = 0;       // judged what the look doubted
      if (e == AccelFieldEvent::kNone && std::isfinite(s)) {  // taken: the dip's mean and spread
        if (dip_n_ < Scalar(50)) dip_n_ += Scalar(1);         // ... over the last fifty or so
        const Scalar d = s - dip_mean_;
        dip_mean_ += d / dip_n_;
        dip_m2_ += d * (s - dip_mean_) - (dip_n_ >= Scalar(50) ? dip_m2_ / dip_n_ : Scalar(0));
        if (!same_pose) pose_n_ = 0u;
        pose_up_ = up;
        ++pose_n_;
        pose_dip_ += (s - pose_dip_) / static_cast<Scalar>(pose_n_ < 50u ? pose_n_ : 50u);
      } else if (e == AccelFieldEvent::kChangeDetected) {
        reset_dip();
      }
      model_took(e, mag_, FieldSensor::kMag, p.t, counts_.mag_held, counts_.mag_implausible,
                 counts_.mag_changes);
    }
  }

  // The field's angle to gravity through the published model, against the rests' taken before:
  // a magnetisation change that leaves the field's strength at this pose as it was turns its
  // direction. acc: the accelerometer's mean (raw), its published bias added, that bias's sigma
  // taken as a direction's; extra: the sine's variance beyond the rests' (a single reading's
  // noise). Chi-square(1); s (the dip's sine), up (gravity's direction) and same_pose (within 2
  // degrees of the last rest taken, where the accelerometer's error is the same: the dip is
  // compared with that pose's alone, without it) for the caller. With decide_at >= 0 the caller
  // asks only whether it exceeds decide_at: the answer may be a bound that tells.
  Scalar dip_disagreement(const Vector3<Scalar>& mag, const Vector3<Scalar>& acc, Scalar t,
                          Scalar extra, Scalar decide_at, Scalar& s, Vector3<Scalar>& up,
                          bool& same_pose) const {
    // The bias's sigma only when the exact answer is asked for, or the bound does not tell.
    const bool exact = decide_at < Scalar(0);
    Vector3<Scalar> gravity = acc, ab, as;
    if (accel_.enabled()) {
      accel_.bias(t, settings_.temperature_margin_c, ab, exact ? &as : nullptr);
      gravity += ab;
    }
    s = dip_sine(mag, gravity);
    up = gravity.normalized();
    same_pose = pose_n_ > 0u && up.dot(pose_up_) > Scalar(0.99939);
    Scalar other = Scalar(0);
    if (same_pose && std::isfinite(s)) {
      const Scalar hard = mag_.published_sigmas().template segment<3>(kBiasX).squaredNorm();
      const Scalar d = s - pose_dip_;
      other = d * d / (hard + extra + Scalar(1e-4));
    }
    // Across poses, without gravity's variance first: the chi-square is at most that.
    if (!exact && (other > decide_at || !(dip_chi2(s, extra) > decide_at))) return other;
    Scalar gravity_var = Scalar(0.0025);  // 50 mg, without the accelerometer's model
    if (accel_.enabled()) {
      if (!exact) accel_.bias(t, settings_.temperature_margin_c, ab, &as);
      gravity_var = as.squaredNorm() / acc.squaredNorm();
    }
    const Scalar across = dip_chi2(s, gravity_var + extra);
    return across > other ? across : other;
  }

  // The dip's statistics start again (a change, a new model, start()).
  void reset_dip() {
    dip_n_ = dip_mean_ = dip_m2_ = pose_dip_ = Scalar(0);
    pose_n_ = 0u;
  }

  // The sine of the angle between the field through the published model and the plane normal to
  // gravity (the sine of the dip, up to its sign convention); NaN before a publication.
  Scalar dip_sine(const Vector3<Scalar>& mag, const Vector3<Scalar>& acc) const {
    if (!mag_.published()) return std::numeric_limits<Scalar>::quiet_NaN();
    const AccelVector<Scalar> p = mag_.published_parameters().template head<kAccelParams>();
    const Vector3<Scalar> m = accel_apply(p, Vector3<Scalar>(mag / mag_g_counts_));
    const Scalar nm = m.norm(), na = acc.norm();
    if (!(nm > Scalar(0)) || !(na > Scalar(0))) return std::numeric_limits<Scalar>::quiet_NaN();
    return m.dot(acc) / (nm * na);
  }

  // How far a rest's dip is from the rests' before it: chi-square(1) against their spread, the
  // published hard iron's sigma (a direction error of sigma / field), the gravity direction's
  // variance (the accelerometer's bias across gravity) and a floor of 0.01 (0.6 degrees); 0 until
  // three rests were taken since the last change or publication.
  Scalar dip_chi2(Scalar s, Scalar gravity_var) const {
    if (!std::isfinite(s) || dip_n_ < Scalar(3)) return Scalar(0);
    const Scalar spread = dip_m2_ / (dip_n_ - Scalar(1));
    const Scalar hard = mag_.published_sigmas().template segment<3>(kBiasX).squaredNorm();
    const Scalar v =
        (spread + hard + gravity_var + Scalar(1e-4)) * (Scalar(1) + Scalar(1) / dip_n_);
    const Scalar d = s - dip_mean_;
    return d * d / v;
  }

  // A magnetometer reading in motion: one reading, with the noise the rests measured. In a
  // direction no cell holds yet (a hand turns the device through many more than the rests show),
  // one a second; else one every confirm_seconds of the magnetometer's (the cells stay fresh, and
  // a magnetisation change shows without waiting for a rest).
  void offer_moving(const Vector3<Scalar>& m) {
    if (!mag_.enabled() || !(mag_reading_var_ > Scalar(0))) return;
    const std::uint64_t since = elapsed_us_ - mag_offered_us_;
    if (mag_offered_us_ != 0 && since < 1000000u) return;
    if ((mag_.full() || mag_.covers(m)) && mag_offered_us_ != 0 &&
        static_cast<Scalar>(since / 1000u) < Scalar(1000) * settings_.mag.confirm_seconds)
      return;
    offer_mag(m);
  }

  // One reading a second, at rest or in motion, against the published model: its strength, and
  // at rest its angle to gravity (from the detector's moving mean). In motion one that disagrees
  // is offered at once, as readings in motion are (held: the model's sigma widens by a change's
  // step until a later reading or rest confirms or drops it). At rest the rest's own mean is
  // judged when its piece ends; until a piece that ended after it is judged (held, taken, or
  // refused), a reading that disagrees widens the stated sigma by a change's step
  // (mag_doubt_us_). A magnetisation change is covered from the next second either way, and a
  // rest cannot confirm a reading of its own.
  void look_at_mag(const Vector3<Scalar>& m) {
    if (!mag_.enabled() || !(mag_reading_var_ > Scalar(0))) return;
    if (mag_looked_us_ != 0 && elapsed_us_ - mag_looked_us_ < 1000000u) return;
    mag_looked_us_ = elapsed_us_ > 0 ? elapsed_us_ : 1u;
    if (mag_.holding()) {  // its sigma is widened already
      mag_doubt_us_ = 0;
      return;
    }
    if (!monitor_.resting()) {
      if (mag_.disagrees(m, mag_reading_var_)) offer_mag(m);
      return;
    }
    if (mag_doubt_us_ != 0) return;  // until a rest piece that covers it is judged
    bool doubt = mag_.disagrees(m, mag_reading_var_);
    if (!doubt) {
      Scalar s = Scalar(0);
      Vector3<Scalar> up;
      bool same_pose = false;
      const Scalar gate = mag_.gate();
      doubt = dip_disagreement(m, monitor_.accel_now(), temperature_,
                               mag_reading_var_ / (mag_g_counts_ * mag_g_counts_), gate, s, up,
                               same_pose) > gate;
    }
    if (doubt) mag_doubt_us_ = mag_looked_us_;
  }

  // A single reading in motion to the magnetometer's model, with the noise the rests measured.
  void offer_mag(const Vector3<Scalar>& m) {
    mag_offered_us_ = elapsed_us_ > 0 ? elapsed_us_ : 1u;
    const AccelFieldEvent e = mag_.add(
        m, mag_reading_var_, std::numeric_limits<Scalar>::quiet_NaN(), elapsed_us_, group_);
    model_took(e, mag_, FieldSensor::kMag, temperature_, counts_.mag_held, counts_.mag_implausible,
               counts_.mag_changes);
  }

  // What a rest did to a sensor's model, as events and counts.
  template <typename Model>
  void model_took(AccelFieldEvent e, const Model& m, FieldSensor sensor, Scalar t,
                  std::uint32_t& held, std::uint32_t& implausible, std::uint32_t& changes) {
    if (e == AccelFieldEvent::kHeld) {
      ++held;
      event(FieldEventKind::kHeld, FieldReason::kInconsistent, t, m.last_chi2(), sensor);
    } else if (e == AccelFieldEvent::kUnconfirmed) {
      event(FieldEventKind::kRejected, FieldReason::kUnconfirmed, t, m.last_chi2(), sensor);
    } else if (e == AccelFieldEvent::kImplausible) {
      // The first only: a setup that is wrong says so once, not with every rest (the count has
      // every one of them).
      if (implausible++ == 0)
        event(FieldEventKind::kRejected, FieldReason::kImplausible, t, Scalar(0), sensor);
    } else if (e == AccelFieldEvent::kChangeDetected) {
      ++changes;
      event(FieldEventKind::kChangeDetected, FieldReason::kNone, t, m.last_chi2(), sensor);
    }
  }

  // Where a timestamp of the recent past lies on the elapsed clock.
  std::uint64_t elapsed_at(std::uint32_t t_us) const {
    const std::uint32_t back = last_t_us_ - t_us;
    return back <= elapsed_us_ ? elapsed_us_ - back : 0u;
  }

  void on_rest(const RestSummary<Scalar>& r) {
    ++counts_.rests;
    if (r.after_motion) ++group_;
    Piece p;
    p.z = -r.gyro_mean;
    p.acc = r.accel_mean;
    p.acc_var = accel_noise_axis_ / static_cast<Scalar>(r.samples);
    p.r = noise_axis_ / static_cast<Scalar>(r.samples) + q_ * r.duration_s / Scalar(3) + floor2_;
    p.t = r.has_temperature ? r.temperature_c : std::numeric_limits<Scalar>::quiet_NaN();
    // A run that gives temperatures but none with this rest (a sensor read more slowly than rests
    // come, or one that failed): the smoothed temperature while it is recent; else the models
    // cannot place the rest (at the reference temperature it would read as a change).
    if (std::isnan(p.t) && !std::isnan(temperature_)) {
      if (elapsed_us_ - temperature_us_ <= kTemperatureStaleUs)
        p.t = temperature_;
      else
        p.unplaced = true;
    }
    p.end_us = elapsed_at(r.end_us);
    p.mid_us = elapsed_at(r.begin_us / 2u + r.end_us / 2u + (r.begin_us & r.end_us & 1u));
    if (r.end_us < r.begin_us) p.mid_us = p.end_us;  // the timer wrapped inside the rest
    p.group = group_;
    p.lead = r.after_motion;
    p.begin_raw = r.begin_us;
    p.end_raw = r.end_us;
    // A rest that disagrees with the published bias widens its stated sigma at once, until the
    // rest is judged (a knock shows here a piece before it can be confirmed).
    if (has_published_ && !p.unplaced) {
      const Vector3<Scalar> nu = p.z - published_.value(published_.offset(p.t));
      const Scalar var = published_.variance(published_.offset(p.t)) + p.r;
      if (nu.squaredNorm() / var > settings_.gate_chi2) {
        const Scalar d = nu.squaredNorm() / Scalar(3);
        if (d > doubt_) doubt_ = d;
      }
    }
    if (mag_n_ > 1) {
      const Scalar n = static_cast<Scalar>(mag_n_);
      const Vector3<Scalar> mean = mag_sum_ / n;
      p.mag = mag_ref_ + mean;
      // The variance of one reading (summed over the axes) over n: that of the mean.
      const Scalar var = (mag_sq_ - n * mean.squaredNorm()) / (n - Scalar(1));
      p.mag_var = (var > Scalar(0) ? var : Scalar(0)) / n;
      // Readings without any spread say nothing of the field holding still (a sensor stuck on
      // one reading would verify every turn): such a piece has no field.
      p.has_mag = var > Scalar(0);
      // One reading's noise: a piece spread more than twice the noise known holds a change (a
      // magnetisation step, a magnet passing), which must not make the next readings' looks
      // blind to it; so the noise grows at most twofold a piece.
      if (var > Scalar(0)) {
        const Scalar v = var / Scalar(3);
        const bool jump = mag_reading_var_ > Scalar(0) && v > Scalar(2) * mag_reading_var_;
        mag_reading_var_ = jump ? Scalar(2) * mag_reading_var_ : v;
      }
    }
    mag_sum_.setZero();
    mag_sq_ = Scalar(0);
    mag_n_ = 0;
    if (pending_) {
      if (!r.after_motion && pending_piece_.group == p.group) {
        // Both pieces of a pair that turned are refused.
        Scalar ratio =
            turn_rate(pending_piece_.acc, p.acc, pending_piece_, p) / settings_.turn_rate_max;
        if (!(ratio > Scalar(1)) && pending_piece_.has_mag && p.has_mag) {
          ratio = field_change(pending_piece_, p) / settings_.gate_chi2;
          p.verified = !(ratio > Scalar(1));
        }
        // The rate itself changed between the pieces (the tail of a slow turn): the earlier
        // piece is refused. Otherwise the later one is steady: a rest of its own length at least
        // before it held the same rate and the same gravity direction.
        if (!(ratio > Scalar(1))) {
          if ((p.z - pending_piece_.z).squaredNorm() / (p.r + pending_piece_.r) >
              settings_.gate_chi2) {
            pending_piece_.turned = Scalar(2);
            p.verified = false;
          } else {
            p.steady = true;
            if (pending_piece_.lead && !p.unplaced) widen_tail(pending_piece_, p);
          }
        }
        if (ratio > Scalar(1)) {
          p.turned = ratio;
          if (!(pending_piece_.turned > Scalar(1))) pending_piece_.turned = ratio;
        }
      }
      judge(pending_piece_);
    }
    pending_piece_ = p;
    pending_ = true;
  }

  // The first piece of a rest may hold the slow end of the turn before it, below what the
  // detector sees: a rate about the axis the device turned about. Where the temperature model
  // does not explain its difference from the next piece, and the difference along gravity is
  // significant on its own (chi-square(1) above kTailChi2, 1 %), the piece keeps its place but
  // its variance grows by that difference squared: the filter weighs it as what it is, and it
  // cannot make a better estimate to publish on its own. A turn about the vertical shows there
  // and in no other test without a magnetometer.
  static constexpr Scalar kTailChi2 = Scalar(6.63);
  void widen_tail(Piece& lead, const Piece& next) const {
    const Scalar g2 = lead.acc.squaredNorm();
    if (!(g2 > Scalar(0))) return;
    const Scalar along = difference(lead, next, model_step(lead, next)).dot(lead.acc);
    const Scalar along2 = along * along / g2;
    if (along2 > kTailChi2 * (lead.r + next.r)) lead.r += along2;
  }

  // The turn rate of a direction between two pieces (rad/s): the angle from u to v over the time
  // between the pieces' middles.
  static Scalar turn_rate(const Vector3<Scalar>& u, const Vector3<Scalar>& v, const Piece& a,
                          const Piece& b) {
    const Scalar nu = u.norm(), nv = v.norm();
    if (!(nu > Scalar(0)) || !(nv > Scalar(0)) || b.mid_us <= a.mid_us) return Scalar(0);
    const Scalar angle = u.cross(v).norm() / (nu * nv);
    return angle / (static_cast<Scalar>(b.mid_us - a.mid_us) * Scalar(1e-6));
  }

  // The magnetic field's change between two pieces against the noise of their means (a
  // chi-square with three degrees of freedom): a turn by angle a about any axis moves the earth's
  // field by a times its part across that axis; a passing magnet moves it too (refused alike).
  static Scalar field_change(const Piece& a, const Piece& b) {
    const Scalar per_axis = (a.mag_var + b.mag_var) / Scalar(3);
    return (b.mag - a.mag).squaredNorm() / std::fmax(per_axis, Scalar(1e-30));
  }

  void predict_to(std::uint64_t t_us) {
    if (t_us > filter_time_us_) {
      const Scalar dt = static_cast<Scalar>(t_us - filter_time_us_) * Scalar(1e-6);
      filter_.predict(dt, q_);
      published_.predict(dt, q_);
      if (candidate_) candidate_piece_.r += q_ * dt;  // its bias walked since
      filter_time_us_ = t_us;
    }
  }

  void judge(const Piece& p) {
    // A move counts only between two pieces judged one after the other that did not turn: rests
    // whose gravity direction holds (their rate may disagree with the filter: the move's bias
    // variance then grows by it).
    [[maybe_unused]] bool from_rest = false;
    if constexpr (GyroMatrix) {
      from_rest = matrix_.from_ok;
      matrix_.from_ok = false;
    }
    if (p.turned > Scalar(1)) {
      event(FieldEventKind::kRejected, FieldReason::kTurning, p.t, p.turned);
      ++counts_.turning;
      return;
    }
    if (p.unplaced) {
      event(FieldEventKind::kRejected, FieldReason::kNoTemperature, p.t, Scalar(0));
      ++counts_.no_temperature;
      return;
    }
    if constexpr (GyroMatrix) {
      const bool walk_ends =
          from_rest && p.group == matrix_.from.group + 1u && matrix_.field.walking();
      matrix_.from = move_end(p);
      matrix_.from_ok = true;
      if (walk_ends) {
        matrix_.end = matrix_.from;  // the move into p: finished once walked
        matrix_.end_pending = true;
      }
    }
    predict_to(p.end_us);
    const Scalar chi2 = filter_.chi2(p.z, p.r, p.t);
    if (chi2 <= settings_.gate_chi2) {
      const bool first_of_group = p.group != last_taken_group_;
      take(p);
      if (candidate_) {
        candidate_ = false;
        ++counts_.unconfirmed;
        event(FieldEventKind::kRejected, FieldReason::kUnconfirmed, candidate_piece_.t, chi2);
      }
      // Published while at rest: the last piece of a rest is judged once motion came, which may
      // have stepped the bias (a knock). The first publication may also come from the first
      // rest after motion that agrees with the filter (a stream of short rests publishes too);
      // later ones wait for a rest long enough to be judged while it lasts (a short rest in a
      // car may be part of a bend).
      if (monitor_.resting() || (first_of_group && !has_published_)) consider_publishing(p.t);
      if (!candidate_ && published_.chi2(p.z, p.r, p.t) <= settings_.gate_chi2) doubt_ = Scalar(0);
      return;
    }
    if (candidate_) {
      const Scalar agree = agreement(candidate_piece_, p);
      if (agree <= settings_.gate_chi2) {
        if (confirms(p)) {  // a change, confirmed
          candidate_ = false;
          ++counts_.changes;
          event(FieldEventKind::kChangeDetected, FieldReason::kNone, p.t, chi2);
          filter_.inflate(change_var());
          take(candidate_piece_, false);  // counted as held already
          take(p);
          // Nothing published yet: the first publication still waits for its own rests.
          if (has_published_) publish(FieldReason::kChange, p.t, chi2);
          return;
        }
        // Held together with the candidate: their weighted mean, at the later temperature.
        Piece& c = candidate_piece_;
        const Scalar r = c.r * p.r / (c.r + p.r);
        c.z = (c.z * p.r + p.z * c.r) / (c.r + p.r);
        c.r = r;
        c.t = p.t;
        c.end_us = p.end_us;
        if (p.group != c.group && p.steady) {
          c.group = p.group;
          ++candidate_groups_;
        }
        ++counts_.held;
        event(FieldEventKind::kHeld, FieldReason::kInconsistent, p.t, chi2);
        return;
      }
      ++counts_.unconfirmed;
      event(FieldEventKind::kRejected, FieldReason::kUnconfirmed, candidate_piece_.t, agree);
    }
    candidate_piece_ = p;
    candidate_ = true;
    candidate_first_us_ = p.mid_us;
    candidate_groups_ = p.steady ? 1u : 0u;
    ++counts_.held;
    event(FieldEventKind::kHeld, FieldReason::kInconsistent, p.t, chi2);
  }

  // The chi-square(3) of two measurements' difference once the model's change between their
  // temperatures is removed.
  Scalar agreement(const Piece& a, const Piece& b) const {
    const Vector3<Scalar> dh = model_step(a, b);
    const Scalar v = a.r + b.r + dh.dot(filter_.p * dh);
    return difference(a, b, dh).squaredNorm() / v;
  }
  // The model's regressors' change from a's temperature to b's.
  Vector3<Scalar> model_step(const Piece& a, const Piece& b) const {
    return BiasFilter<Scalar>::h(filter_.offset(b.t)) - BiasFilter<Scalar>::h(filter_.offset(a.t));
  }
  // b's bias less a's, less the model's change dh (model_step()) between their temperatures.
  Vector3<Scalar> difference(const Piece& a, const Piece& b, const Vector3<Scalar>& dh) const {
    return b.z - a.z - (dh(1) * filter_.s + dh(2) * filter_.q);
  }

  // A piece that agrees with the held candidate confirms a change when it is verified (the field
  // held still: not a turn) confirm_seconds after the candidate began, or when it makes three
  // steady rests between motions that agree over change_seconds (a chance agreement of unrelated
  // turns is unlikely; the ramps of one turn are not steady).
  // A steady piece after motion in another orientation (gravity at least 30 degrees away) that
  // agrees confirms it too: a turn about the vertical reads as a rate along gravity, so two turns
  // seen in orientations apart cannot agree, while a bias is the same in every orientation.
  // So does a steady piece confirm_seconds later whose step lies across gravity (across()).
  // Both take 30 degrees as apart: far more than a bend's centripetal tilt of gravity.
  static constexpr Scalar kCos30 = Scalar(0.866);
  bool confirms(const Piece& p) const {
    if (!p.steady) return false;
    const Scalar held = static_cast<Scalar>(p.mid_us - candidate_first_us_) * Scalar(1e-6);
    const bool moved = p.group != candidate_piece_.group;
    const std::uint32_t groups = candidate_groups_ + (moved ? 1u : 0u);
    const Vector3<Scalar>& u = candidate_piece_.acc;
    const bool turned_over = moved && u.dot(p.acc) < kCos30 * u.norm() * p.acc.norm();
    const bool bias_step = p.verified || (has_published_ && across(p));
    return (bias_step && held >= settings_.confirm_seconds) || turned_over ||
           (groups >= 3u && held >= settings_.change_seconds);
  }

  // Whether a steady piece's disagreement with the filter is a bias and not a turn, by the
  // accelerometer alone: a rate across gravity turns gravity at that rate, and a steady piece's
  // gravity turned at most turn_rate_max since the piece before. The disagreement's part across
  // gravity must be significant (chi-square above gate_chi2), beyond three times turn_rate_max by
  // three sigmas, and the disagreement at least 30 degrees from gravity: a steady bend turns about
  // the vertical, and its centripetal acceleration tilts the measured gravity by far less.
  bool across(const Piece& p) const {
    const Scalar g2 = p.acc.squaredNorm();
    if (!(g2 > Scalar(0))) return false;
    const Scalar d = filter_.offset(p.t);
    const Vector3<Scalar> nu = p.z - filter_.value(d);
    const Scalar along = nu.dot(p.acc);
    const Scalar nu2 = nu.squaredNorm();
    const Scalar across2 = nu2 - along * along / g2;
    const Scalar var = filter_.variance(d) + p.r;  // per axis
    if (!(across2 > settings_.gate_chi2 * var) || !(along * along <= kCos30 * kCos30 * nu2 * g2))
      return false;
    const Scalar excess = std::sqrt(across2) - Scalar(3) * std::sqrt(var);
    return excess > Scalar(3) * settings_.turn_rate_max * settings_.gyro_per_rad_s;
  }

  Scalar change_var() const {
    const Scalar s = settings_.change_sigma * settings_.gyro_per_rad_s;
    return s * s;
  }

  // A later piece is independent of an earlier one when motion came between them, or when it
  // is verified (the field held still: no turn about the vertical) and confirm_seconds later.
  bool independent_of(const Piece& earlier, const Piece& later) const {
    if (later.group != earlier.group) return true;
    return later.verified && static_cast<Scalar>(later.mid_us - earlier.mid_us) * Scalar(1e-6) >=
                                 settings_.confirm_seconds;
  }

  void take(const Piece& p, bool count = true) {
    filter_.update(p.z, p.r, p.t);
    update_move_keeping();  // the accelerometer's model may have become known, or uncertain
    if (count) ++counts_.taken;
    if (accel_.enabled()) {  // the rests the gyro takes are rests for the accelerometer too
      ++accel_rests_;
      const AccelFieldEvent e = accel_.add(p.acc, p.acc_var, p.t, p.end_us, p.group);
      model_took(e, accel_, FieldSensor::kAccel, p.t, counts_.accel_held, counts_.accel_implausible,
                 counts_.accel_changes);
    }
    if constexpr (MagCells > 0) {
      if (mag_.enabled() && p.has_mag) {  // and the field held still over them: the
        // magnetometer's, in a later call (the cost of one call stays one model's)
        if (mag_due_ == 2) add_mag_piece();
        MagPiece& m = mag_kept_.pieces[(mag_first_ + mag_due_++) % 2];
        m.mag = p.mag;
        m.acc = p.acc;
        m.variance = p.mag_var / Scalar(3);
        m.end_us = p.end_us;
        m.group = p.group;
        m.t = p.t;
      }
    }
    took_ = true;
    last_taken_group_ = p.group;
    if (independent_ == 0 || independent_of(last_independent_, p)) {
      last_independent_ = p;
      ++independent_;
    }
  }

  // The filter's model replaces the published one where it is significantly different and better
  // at the temperature of the rest just taken.
  void consider_publishing(Scalar t) {
    if (!has_published_) {
      if (independent_ >= static_cast<std::uint32_t>(settings_.first_rests))
        publish(FieldReason::kFirst, t, Scalar(0));
      return;
    }
    const Scalar d = filter_.offset(t);
    const Scalar vf = filter_.variance(d);
    const Scalar vp = published_.variance(published_.offset(t));
    const Vector3<Scalar> diff = filter_.value(d) - published_.value(published_.offset(t));
    const Scalar chi2 = diff.squaredNorm() / (vf + vp);
    if (vf < vp && chi2 > settings_.publish_chi2)
      publish(FieldReason::kSignificant, t, chi2);
    else if (vf <= settings_.better_ratio * vp)
      publish(FieldReason::kBetter, t, chi2);
  }

  void publish(FieldReason why, Scalar t, Scalar chi2) {
    published_ = filter_;
    unsaved_ = true;
    doubt_ = Scalar(0);
    has_published_ = true;
    ++counts_.updates;
    event(FieldEventKind::kUpdated, why, t, chi2);
    if (!gyro_cue_) {  // the detector takes the gyro as a cue from the first publication on
      monitor_.reset_in_stream(monitor_settings(true));  // a frame behind is still refused
      update_move_keeping();
      monitor_restarted();
      gyro_cue_ = true;
      pending_ = false;
    }
    set_detector_bias();
  }

  // ---- The moves, for the gyro's misalignment and scale ----

  // One step of the moves' walk: a move whose end was judged is finished once every segment of
  // it was walked; otherwise the next segment the rest monitor holds is walked (a new move begins
  // where its rest was the last piece taken).
  void walk_moves() {
    if constexpr (GyroMatrix) {
      if (matrix_.end_pending &&
          monitor_.move_complete(matrix_.move, matrix_.end.begin_raw, matrix_.end.end_raw)) {
        matrix_.end_pending = false;
        end_walk(matrix_.from_walk, matrix_.end);
        return;
      }
      GyroSegment<Scalar> seg;
      std::uint32_t move = 0;
      if (!monitor_.take_move_segment(seg, move)) return;
      if (move != matrix_.move) {  // a new move: the one before cannot end any more
        matrix_.move = move;
        matrix_.end_pending = false;
        begin_walk(move);
      }
      matrix_.field.add_segment(seg);
    }
  }

  bool walk_due() const {
    if constexpr (GyroMatrix)
      return monitor_.keeps_moves() && (matrix_.end_pending || monitor_.move_segment_ready());
    else
      return false;
  }

  // The rest monitor keeps the moves only while they can be used: the gyro's matrix is learned
  // and the accelerometer's model is known well enough now (in the field, at the temperature
  // now); otherwise its blocks close as without moves, and nothing is walked.
  void update_move_keeping() {
    if constexpr (GyroMatrix) {
      Scalar shape = Scalar(0);
      const bool on = matrix_.field.enabled() && accel_shape(temperature_, shape) &&
                      shape <= settings_.gyro_matrix.accel_shape_max;
      if (on != monitor_.keeps_moves()) {
        monitor_.keep_moves(on);
        matrix_.field.abandon();
        matrix_.end_pending = false;
      }
    }
  }

  // A move begins at the rest of the last piece judged: the gravity direction there through the
  // accelerometer's model, the filter's bias at its temperature.
  void begin_walk(std::uint32_t move) {
    GyroField<Scalar>& field = matrix_.field;
    field.abandon();
    std::uint32_t begin = 0, end = 0;
    Vector3<Scalar> b0;
    if (!matrix_.from_ok || !monitor_.move_from(move, begin, end, b0) ||
        begin != matrix_.from.begin_raw || end != matrix_.from.end_raw)
      return;
    Vector3<Scalar> up;
    Scalar shape = Scalar(0);
    if (!gravity_direction(matrix_.from, up, shape)) return;
    const Scalar off = filter_.offset(matrix_.from.t);
    if (field.begin_move(up, filter_.value(off) - b0, shape)) matrix_.from_walk = matrix_.from;
  }

  // The move walked ended at piece b, judged right after the piece it began at.
  void end_walk(const MoveEnd& a, const MoveEnd& b) {
    GyroField<Scalar>& field = matrix_.field;
    Vector3<Scalar> up;
    Scalar shape = Scalar(0);
    if (!gravity_direction(b, up, shape)) {
      field.abandon();
      return;
    }
    // The bias's variance over the move: the filter's, and a rate at either end that disagrees
    // with it (a rest held as inconsistent: a knock, or a slow turn that the gravity direction
    // did not show).
    const Scalar off = filter_.offset(b.t);
    const Scalar da = (a.z - filter_.value(filter_.offset(a.t))).squaredNorm();
    const Scalar db = (b.z - filter_.value(off)).squaredNorm();
    const GyroFieldEvent e =
        field.end_move(up, a.acc_var / a.acc.squaredNorm() + b.acc_var / b.acc.squaredNorm(),
                       filter_.variance(off) + std::fmax(da, db) / Scalar(3));
    if (e == GyroFieldEvent::kRefused || e == GyroFieldEvent::kChanged) {
      ++counts_.gyro_moves_refused;
      event(FieldEventKind::kRejected, FieldReason::kInconsistent, temperature_, field.last_chi2(),
            FieldSensor::kGyroMatrix);
      if (e == GyroFieldEvent::kRefused) return;
    }
    if (e == GyroFieldEvent::kTaken || e == GyroFieldEvent::kUpdated) ++counts_.gyro_moves;
    if (e == GyroFieldEvent::kUpdated || e == GyroFieldEvent::kChanged) {
      base_.gyro.params.template head<kGyroMatrixParams>() = field.published();
      base_.gyro.sigma.template head<kGyroMatrixParams>() = field.published_sigmas();
      base_.gyro.status = Status::kOk;
      if (e == GyroFieldEvent::kChanged) {  // the new matrix's scales are the event's value
        ++counts_.gyro_matrix_changes;
        event(FieldEventKind::kChangeDetected, FieldReason::kNone, temperature_, field.last_chi2(),
              FieldSensor::kGyroMatrix);
      }
      model_published(field, FieldSensor::kGyroMatrix, counts_.gyro_matrix_updates);
    }
  }

  // A piece's gravity direction through the accelerometer's model at its temperature (the
  // field's model, or the prior's without it), and how well that model is known: the largest of
  // its misalignments' and relative scales' sigmas and of its bias's sigma against gravity (a
  // bias error turns both ends of a move alike, by its share of gravity). False without a model
  // or for a reading it cannot take.
  bool gravity_direction(const MoveEnd& p, Vector3<Scalar>& up, Scalar& shape) const {
    AccelVector<Scalar> pa;
    if (!(p.acc.squaredNorm() > Scalar(0)) || !accel_model(p.t, pa, shape)) return false;
    const Vector3<Scalar> g = accel_apply(pa, p.acc);
    const Scalar n = g.norm();
    if (!(n > Scalar(0))) return false;
    up = g / n;
    return all_finite(up);
  }

  // The accelerometer's model at temperature t (the field's, or the prior's without it; raw
  // units) and how well it is known (accel_shape()). False without a model.
  bool accel_model(Scalar t, AccelVector<Scalar>& pa, Scalar& shape) const {
    if (!accel_shape(t, shape)) return false;
    if (accel_.enabled()) {
      AccelCalibration<Scalar> cal;
      TemperatureBias<Scalar> unused;
      accel_.model(cal, unused);
      Vector3<Scalar> b;
      accel_.bias(t, settings_.temperature_margin_c, b);
      cal.params.template segment<3>(kBiasX) = b;
      pa = cal.params;
    } else {
      pa = base_.accel.params;
    }
    return all_finite(pa);
  }

  // How well the accelerometer's model at temperature t is known (accel_shape_sigma(): the
  // field's model, or the prior's without it), without converting it. False without a model.
  bool accel_shape(Scalar t, Scalar& shape) const {
    if (accel_.enabled()) {
      shape = accel_.shape_sigma(t);
    } else if (succeeded(base_.accel.status)) {
      const AccelCalibration<Scalar>& c = base_.accel;
      const Scalar g = Scalar(9.80665) / std::abs(c.params(kScaleX));  // raw units per g
      shape = accel_shape_sigma<Scalar>(c.params, c.sigma, c.sigma.template segment<3>(kBiasX) / g);
    } else {
      return false;
    }
    return std::isfinite(shape);
  }

  // The detector removes the published bias at the temperature now.
  void set_detector_bias() {
    detector_temperature_ = temperature_;
    monitor_.set_gyro_rest_reading(-published_.at(temperature_, settings_.temperature_margin_c));
  }

  // The rest monitor's settings: without a published bias the gyro is no cue (a bias of degrees
  // per second unremoved would read as motion), the accelerometer alone tells rests.
  RestMonitorSettings<Scalar> monitor_settings(bool gyro_cue) const {
    RestMonitorSettings<Scalar> m = settings_;
    if (!gyro_cue) m.gyro_noise = Scalar(0);
    m.gyro_rest_reading = -published_.at(temperature_, settings_.temperature_margin_c);
    m.follow_rests = false;
    // The moves between rests, for the gyro's misalignment and scale: the segment bounds in raw
    // units (path angle, and |alpha||beta| in rad^3).
    if (GyroMatrix && settings_.gyro_matrix.enabled) {
      const Scalar k = settings_.gyro_per_rad_s;
      m.move_max_angle = settings_.gyro_matrix.segment_max_angle * k;
      m.move_max_error = settings_.gyro_matrix.segment_max_error * k * k * k;
    }
    return m;
  }

  void event(FieldEventKind kind, FieldReason why, Scalar t, Scalar chi2,
             FieldSensor sensor = FieldSensor::kGyro) {
    FieldEvent<Scalar> e;
    e.kind = kind;
    e.reason = why;
    e.sensor = sensor;
    e.time_s = static_cast<std::uint32_t>(elapsed_us_ / 1000000u);
    e.temperature_c = t;
    e.chi2 = chi2;
    if (sensor == FieldSensor::kAccel)
      accel_.bias(t, settings_.temperature_margin_c, e.value);
    else if (sensor == FieldSensor::kMag)
      mag_.bias(std::numeric_limits<Scalar>::quiet_NaN(), Scalar(0), e.value);
    else if (sensor == FieldSensor::kGyroMatrix)
      e.value = base_.gyro.params.template segment<3>(kGyroScaleX);
    else
      e.value = published_.at(t, settings_.temperature_margin_c);
    if (events_.push(e)) ++counts_.events_dropped;
  }

  Settings settings_{};
  bool valid_ = false;
  Monitor monitor_{};
  BiasFilter<Scalar> filter_{}, published_{};
  bool has_published_ = false;
  bool unsaved_ = false;  // a publication since the last save
  std::uint64_t last_save_s_ = 0, day_start_s_ = 0;
  std::uint32_t saves_today_ = 0;
  Calibration<Scalar> base_{};  // the prior's calibration, or the nominal gyro model
  // Added to the published variance while rests disagree with it and the disagreement is not
  // resolved (a held candidate): the mean square of the largest disagreement per axis.
  Scalar doubt_ = Scalar(0);
  bool gyro_cue_ = false;  // the detector uses the gyro (from the first publication on)
  Scalar q_ = Scalar(0), floor2_ = Scalar(0), noise_axis_ = Scalar(0);
  Scalar temperature_ = std::numeric_limits<Scalar>::quiet_NaN();  // the readings' moving mean
  std::uint64_t temperature_us_ = 0;  // the latest smoothing (kTemperatureBatchUs before the first)
  Scalar temperature_weight_ = Scalar(0);  // the smoothing's weight per microsecond
  std::uint32_t rests_seen_ = 0;           // the rest monitor's rests_found() taken so far
  Scalar temp_mean_ = Scalar(0), temp_mean2_ = Scalar(0);  // the moving mean, and its own
  // The readings are smoothed once every kTemperatureBatchUs, short beside temperature_seconds:
  // the monitor's temperatures().count() and sum_q() at the last smoothing.
  static constexpr std::uint64_t kTemperatureBatchUs = 500000;
  // The smoothed temperature stands for a rest without a reading of its own this long after the
  // last reading.
  static constexpr std::uint64_t kTemperatureStaleUs = 60000000;
  std::int64_t temp_sum_seen_ = 0;
  std::uint32_t temps_seen_ = 0;
  std::uint32_t resets_seen_ = 0;  // the monitor's clock resets counted so far
  bool clock_started_ = false;
  std::uint32_t last_t_us_ = 0;
  std::uint64_t elapsed_us_ = 0, filter_time_us_ = 0;
  Piece pending_piece_{}, candidate_piece_{}, last_independent_{};
  std::uint64_t candidate_first_us_ = 0;  // when the held candidate began
  std::uint32_t candidate_groups_ = 0;    // steady rests between motions in the candidate
  Vector3<Scalar> mag_sum_ = Vector3<Scalar>::Zero();  // the field over the rest piece so far,
  Vector3<Scalar> mag_ref_ = Vector3<Scalar>::Zero();  // about its first reading
  Scalar mag_sq_ = Scalar(0);
  std::uint32_t mag_n_ = 0;
  bool pending_ = false, candidate_ = false;
  Scalar detector_temperature_ = Scalar(0);  // where the detector's bias was set
  std::uint32_t group_ = 0, independent_ = 0, last_taken_group_ = 0;
  FieldCounts counts_{};
  Ring<FieldEvent<Scalar>, Events> events_{};
  AccelField<Scalar> accel_{};
  std::uint32_t accel_rests_ = 0;  // rests the accelerometer's model took
  Scalar accel_noise_axis_ = Scalar(0);
  // The magnetometer's model (mag_field.hpp): a cell for each of the 26 directions.
  AccelField<Scalar, MagCells> mag_{};
  Scalar mag_reading_var_ = Scalar(0);  // one reading's variance per axis, at the last rest
  // Rest pieces taken, for the magnetometer's model in later calls (a call may judge two).
  struct MagPiece {
    Vector3<Scalar> mag = Vector3<Scalar>::Zero();  // mean field (raw)
    Vector3<Scalar> acc = Vector3<Scalar>::Zero();  // mean accelerometer (raw): gravity
    Scalar variance = Scalar(0);                    // of that mean, per axis
    Scalar t = Scalar(0);                           // temperature (NaN: none)
    std::uint64_t end_us = 0;
    std::uint32_t group = 0;
  };
  unsigned mag_first_ = 0, mag_due_ = 0;  // the oldest, and how many wait
  // The dip's sine over the rests taken since the last change: count (capped), mean, and the sum
  // of squared deviations.
  Scalar dip_n_ = Scalar(0), dip_mean_ = Scalar(0), dip_m2_ = Scalar(0);
  // ... and in the pose of the last rest taken: its gravity direction, the rests taken there, the
  // dip's mean there.
  Vector3<Scalar> pose_up_ = Vector3<Scalar>::Zero();
  std::uint32_t pose_n_ = 0;
  Scalar pose_dip_ = Scalar(0);
  Scalar mag_g_counts_ = Scalar(1);   // raw units per the field's strength
  bool took_ = false;                 // a piece was taken in this call
  std::uint64_t mag_offered_us_ = 0;  // when a single reading was last offered
  std::uint64_t mag_looked_us_ = 0;   // when one was last looked at (look_at_mag())
  std::uint64_t mag_doubt_us_ = 0;    // when one at rest disagreed, until judged (0: none)
  // What only the magnetometer's model keeps (nothing without one, MagCells 0): the rest pieces
  // taken for it, the soft iron's frame from the prior, and the prior (its alignment's notes) or
  // an empty calibration.
  struct MagKept {
    MagPiece pieces[2] = {};
    Matrix3<Scalar> frame = Matrix3<Scalar>::Identity();
    MagCalibration<Scalar> like{};
  };
  struct NoMagKept {};
  std::conditional_t<(MagCells > 0), MagKept, NoMagKept> mag_kept_{};
  Scalar mag_field_ut_ = Scalar(50);  // the field strength the model's norm is
  Scalar mag_reach_ = std::numeric_limits<Scalar>::infinity();  // |reading| beyond: a glitch
  Scalar mag_inner_ = std::numeric_limits<Scalar>::infinity();  // each axis within: no glitch
  // What only the gyro's misalignment and scale keep (nothing without GyroMatrix): its model, the
  // piece a move into the next taken one starts from, the move under way's rest (its timestamps)
  // and its two ends.
  struct MatrixKept {
    GyroField<Scalar> field{};
    MoveEnd from{};       // the last piece judged, if it did not turn (from_ok)
    MoveEnd from_walk{};  // the piece the move being walked began at
    MoveEnd end{};        // ... and the one it ended at, once judged (end_pending)
    bool from_ok = false, end_pending = false;
    std::uint32_t move = 0;  // the rest monitor's number of the move being walked
  };
  struct NoMatrixKept {};
  std::conditional_t<GyroMatrix, MatrixKept, NoMatrixKept> matrix_{};
};

}  // namespace imucal
