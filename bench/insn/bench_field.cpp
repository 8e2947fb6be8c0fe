// SPDX-License-Identifier: MIT
// bench/insn/bench_field.cpp: instruction counts of the field calibrator (FieldCalibrator<float>,
// include/imucal/field/) on the cross targets (bench/run_insn_bench.sh, QEMU with the counting
// plugin), float as on the device. A simulated device's life (sim/life_sim.hpp, as
// host_tests/test_field.cpp runs it; here a fixed plan of about 8 minutes at 100 Hz: rests on a
// desk in several attitudes, picked up and used in the hand, a brisk gesture, a steady slow turn
// about the vertical, tremor in the hand, a knock that steps the gyro bias, a passing magnet, the
// magnetometer at 50 Hz, a temperature with every frame) is fed one 16-bit frame at a time, each
// add_raw() its own region, named by what the call did:
//   - still: the body truly still (the life's rests), nothing handed out or judged in the call,
//     and no model's solve under way (the per-frame cost a device pays for ever);
//   - moving: everything else (moves, hand use, the turn, tremor, the knock), the same;
//   - a solve slice: a call made while a model's solve was under way (it runs one slice, or adds
//     the magnetometer's share of a rest taken earlier), nothing handed out or judged;
//   - a rest judged: the calls in which the rest monitor handed out a piece of a rest or the
//     calibrator judged one (its counts changed), named by what it decided (taken, refused as
//     turning, held, published): the largest calls.
// The same frames go to a second calibrator with the temperature once a second only (regions
// "field, temperature at 1 Hz: ..."; without the magnetometer): the per-frame temperature's share.
// The same frames go to a third calibrator started from a stored record (a protocol's calibration,
// sim::protocol_record(): the accelerometer's model known well, the gyro's matrix 1 % off), which
// keeps and walks the moves between rests for the gyro's misalignment and scale ("field, from a
// stored calibration: ..."; without the magnetometer, the temperature with every frame; a call
// walks a segment in the call that closed it, so the walks are in its frames in motion).
// The same frames go to a calibrator built without the gyro's matrix and the magnetometer
// (FieldCalibrator<float, 8, 0, false>: what a part with little RAM builds; in a translation unit
// of its own, bench_field_lean.cpp), started from the same record without the magnetometer's
// settings, the temperature with every frame ("field, without the gyro's matrix: ..."): it keeps
// no moves and walks none.
// The same frames go to a fifth calibrator in FIFO batches of 25 (add_fifo(); without the
// magnetometer, the temperature once a batch), each call its own region ("field, FIFO batches of
// 25: ..."), named still or moving (every frame of the batch truly still, or not; nothing judged
// and no solve under way) or a rest judged or a solve slice: a frame's share is the call's / 25.
// The magnetometer's reading that arrives with every second frame (50 Hz) goes to add_mag(), each
// call its own region, named by whether a rest was open (the field is summed) or not. The life is
// simulated in double (slow on the cores without an FPU) between the regions, its frame written to
// a global before the begin marker: none of it is counted. The script sums regions of the same
// name. Not a test: it reports, it does not judge. It also reports the deepest stack use of
// add_raw() and add_mag() (one "STACK" line: bytes below main's stack pointer, stack_paint.hpp;
// add_raw()'s, add_mag() is a leaf), painted before and measured after each call, outside the
// counted regions, and sizeof(FieldCalibrator<float>), with and without the magnetometer's model
// (MagCells 0), and without the gyro's matrix as well.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>

#include "bench_field_lean.hpp"
#include "imucal/field/field_calibrator.hpp"
#include "imucal/sim/field_settings.hpp"
#include "imucal/sim/life_sim.hpp"
#include "markers.hpp"
#include "stack_paint.hpp"
#include "support/fifo_bytes.hpp"

using namespace imucal;

namespace {
FieldCalibrator<float> calibrator;  // global: no guard, no stack
// The same frames with the temperature once a second only (the life reads it with every frame):
// what the per-frame temperature costs (float smoothing, soft-float on the cores without an FPU).
FieldCalibrator<float> calibrator_1hz;
// Started from a protocol's record: the moves between rests teach the gyro's matrix.
FieldCalibrator<float> calibrator_stored;
// The same frames in FIFO batches of kBatch (add_fifo(): accelerometer then gyro, 12-byte frames,
// little-endian, the sensor's period), the temperature read once a batch (its first frame's), no
// magnetometer: what a firmware that drains the sensor's FIFO pays.
FieldCalibrator<float> calibrator_fifo;
constexpr std::uint32_t kBatch = 25;
std::uint8_t g_fifo[kBatch * 12];
std::uint32_t g_fifo_stamps[kBatch];
// The frame, its temperature and the field are written here before the begin marker (its memory
// clobber orders the stores), so that converting the simulator's doubles is not counted.
RawFrame g_frame;
float g_temperature = 0.0f;
Vector3<float> g_mag = Vector3<float>::Zero();

constexpr std::uintptr_t kStackWindow = 4096;  // repainted per call (stack_paint.hpp)

// The life: a desk's rests in four attitudes with hand use, a gesture, a slow steady turn and
// tremor between them; add_events() adds a passing magnet, a knock (a gyro bias step of 0.2 to
// 0.5 deg/s inside a rest) and a magnetisation change.
sim::LifePlan bench_plan() {
  using namespace sim::life_detail;
  sim::LifeOptions o;
  sim::Random rng(0xF1E1Dull);
  sim::LifePlan plan = begin_plan("bench_field", 7, o, rng);
  Matrix3<double> stations[4];
  stations[0] = lying(1.0 * kDeg, rng);
  stations[1] = lying(2.0 * kDeg, rng);
  stations[2] = tilted(rng.uniform(60.0, 75.0) * kDeg, rng);
  stations[3] = tilted(kPi - 1.0 * kDeg, rng);
  plan.start = Eigen::Quaterniond(stations[0]);
  PlanBuilder b(plan, 480.0, rng);
  b.rest(40.0);
  b.move_by({0.7, 1.6}, {1.5, 2.5});
  b.simple(sim::PhaseKind::kHand, 20.0);
  b.move_to(stations[1], {1.5, 3.0});
  b.rest(60.0);
  b.move_by({0.4, 1.0}, {1.0, 2.0});  // a touch: picked up and put back
  b.move_to(stations[1], {1.0, 2.0});
  b.rest(30.0);
  b.move_by({0.7, 1.6}, {1.5, 2.5});
  b.simple(sim::PhaseKind::kHand, 30.0);
  b.move_to(stations[2], {1.5, 3.0});
  b.rest(90.0);
  b.move_by({0.7, 1.6}, {1.5, 2.5});
  b.gesture(10.0);
  b.move_to(stations[3], {1.5, 3.0});
  b.rest(40.0);
  b.turn({3.0, 10.0}, 30.0);  // a turntable's: the detector may take it for a rest
  b.rest(30.0);
  b.move_by({0.7, 1.6}, {1.5, 2.5});
  b.simple(sim::PhaseKind::kHandRest, 20.0);
  b.move_to(stations[0], {1.5, 3.0});
  b.rest(480.0);  // to the end of the plan
  add_events(plan, o, 0.05, rng);
  return plan;
}

// The noise at rest and the gyro's scale from the datasheet, as the tests set it up.
FieldSettings<float> settings_for(const sim::DeviceSheet& sheet) {
  return sim::field_settings(sheet);
}

// Everything a rest's judging changes (on_rest() and judge() count each piece somewhere).
std::uint32_t decisions(const FieldCounts& c) {
  return c.rests + c.taken + c.turning + c.held + c.unconfirmed + c.changes + c.updates;
}

// Names the judged call by its decisions (the counts that changed).
const char* judged_name(const FieldCounts& a, const FieldCounts& b) {
  if (b.updates != a.updates) return "field: add_raw(), a rest judged: published, per call";
  if (b.changes != a.changes) return "field: add_raw(), a rest judged: a change, per call";
  if (b.turning != a.turning) return "field: add_raw(), a rest judged: turning, per call";
  if (b.held != a.held || b.unconfirmed != a.unconfirmed)
    return "field: add_raw(), a rest judged: held or unconfirmed, per call";
  if (b.taken != a.taken) return "field: add_raw(), a rest judged: taken, per call";
  return "field: add_raw(), a rest piece handed out (judged later), per call";
}
}  // namespace

// Built with IMUCAL_BENCH_PROFILE_FIELD defined, only the first calibrator's add_raw() calls are
// counted regions (one per frame, for bench/insn_profile.py); add_mag() and the 1 Hz variant run
// outside them; with IMUCAL_BENCH_PROFILE_STILL as well, only those of still frames while no
// model solves.
#ifdef IMUCAL_BENCH_PROFILE_FIELD
#define IMUCAL_OTHER_BEGIN() ((void)0)
#define IMUCAL_OTHER_END() ((void)0)
#define IMUCAL_OTHER_ANNOUNCE(name) ((void)(name))
constexpr bool kOtherCounted = false;
#else
constexpr bool kOtherCounted = true;
#define IMUCAL_OTHER_BEGIN() imucal_bench_begin()
#define IMUCAL_OTHER_END() imucal_bench_end()
#define IMUCAL_OTHER_ANNOUNCE(name) bench_announce(name)
#endif

int main() {
  const sim::LifePlan plan = bench_plan();
  sim::LifeSimulator life(plan);
  const Status started = calibrator.start(settings_for(life.sheet()));
  calibrator_1hz.start(settings_for(life.sheet()));
  const sim::StoredCalibration stored = sim::protocol_record(life, 0.01, 0.02);
  calibrator_stored.start(settings_for(life.sheet()), &stored.cal, &stored.model);
  FieldSettings<float> lean_settings = settings_for(life.sheet());
  lean_settings.mag = MagFieldSettings<float>{};  // no magnetometer in that build
  const Status lean_started = bench_lean::start(lean_settings, &stored.cal, &stored.model);
  calibrator_fifo.start(settings_for(life.sheet()));
  std::uint32_t fifo_n = 0;
  bool fifo_still = true;
  float fifo_temperature = std::numeric_limits<float>::quiet_NaN();
  double next_temperature_s = 0.0;
  sim::LifeSample s;
  sim::LifeTruth t;
  std::uint32_t frames = 0, mags = 0, refused = 0, events = 0, fifo_refused = 0;
  bench::stack_series_start(kStackWindow);
  while (life.next(s, t)) {
    g_frame.t_us = s.t_us;
    for (std::size_t i = 0; i < 3; ++i) {
      g_frame.acc[i] = s.acc_counts[i];
      g_frame.gyro[i] = s.gyro_counts[i];
    }
    g_temperature = s.temperature_new ? s.imu.temperature : std::numeric_limits<float>::quiet_NaN();
    const FieldCounts before = calibrator.counts();
    const bool solving = calibrator.accel_field().busy() || calibrator.mag_field().busy();
    bench::stack_paint();
#ifdef IMUCAL_BENCH_PROFILE_STILL
    const bool counted = t.still && !solving;
#else
    const bool counted = true;
#endif
    if (counted) imucal_bench_begin();
    const Status st = calibrator.add_raw(g_frame, g_temperature);
    if (counted) imucal_bench_end();
    bench::stack_measure();
    ++frames;
    if (!(st == Status::kOk || sample_taken(st))) ++refused;
    // Named after the fact (the region is already counted; the plugin pairs them in order).
    const FieldCounts& after = calibrator.counts();
    if (decisions(after) != decisions(before)) {
      bench_announce(judged_name(before, after));
    } else if (solving) {
      bench_announce("field: add_raw(), a solve slice, per call");
    } else {
      bench_announce(t.still ? "field: add_raw(), still, per frame"
                             : "field: add_raw(), moving, per frame");
    }
    // The magnetometer's reading that arrived with the frame (50 Hz), as a device feeds it.
    if (s.mag_new) {
      g_mag = s.mag;
      const bool resting = calibrator.monitor().resting();
      bench::stack_paint();
      IMUCAL_OTHER_BEGIN();
      calibrator.add_mag(g_mag);
      IMUCAL_OTHER_END();
      bench::stack_measure();
      ++mags;
      IMUCAL_OTHER_ANNOUNCE(resting ? "field: add_mag(), in a rest, per call (50 Hz)"
                                    : "field: add_mag(), no rest open, per call (50 Hz)");
    }
    FieldEvent<float> e;
    while (calibrator.take_event(e)) ++events;
    // The 1 Hz temperature variant, same frame, field not given (add_raw() only).
    if (s.temperature_new && s.t_s >= next_temperature_s) {
      next_temperature_s += 1.0;
    } else {
      g_temperature = std::numeric_limits<float>::quiet_NaN();
    }
    const std::uint32_t before_1hz = decisions(calibrator_1hz.counts());
    const bool solving_1hz =
        calibrator_1hz.accel_field().busy() || calibrator_1hz.mag_field().busy();
    bench::stack_paint();
    IMUCAL_OTHER_BEGIN();
    calibrator_1hz.add_raw(g_frame, g_temperature);
    IMUCAL_OTHER_END();
    bench::stack_measure();
    IMUCAL_OTHER_ANNOUNCE(decisions(calibrator_1hz.counts()) != before_1hz
                              ? "field, temperature at 1 Hz: add_raw(), a rest handed out or judged"
                          : solving_1hz
                              ? "field, temperature at 1 Hz: add_raw(), a solve slice, per call"
                          : t.still ? "field, temperature at 1 Hz: add_raw(), still, per frame"
                                    : "field, temperature at 1 Hz: add_raw(), moving, per frame");
    while (calibrator_1hz.take_event(e)) {
    }
    // From the stored record, the temperature with every frame.
    g_temperature = s.temperature_new ? s.imu.temperature : std::numeric_limits<float>::quiet_NaN();
    const std::uint32_t before_stored = decisions(calibrator_stored.counts());
    const bool solving_stored =
        calibrator_stored.accel_field().busy() || calibrator_stored.mag_field().busy();
    bench::stack_paint();
    IMUCAL_OTHER_BEGIN();
    calibrator_stored.add_raw(g_frame, g_temperature);
    IMUCAL_OTHER_END();
    bench::stack_measure();
    IMUCAL_OTHER_ANNOUNCE(
        decisions(calibrator_stored.counts()) != before_stored
            ? "field, from a stored calibration: add_raw(), a rest handed out or judged"
        : solving_stored ? "field, from a stored calibration: add_raw(), a solve slice, per call"
        : t.still        ? "field, from a stored calibration: add_raw(), still, per frame"
                         : "field, from a stored calibration: add_raw(), moving, per frame");
    while (calibrator_stored.take_event(e)) {
    }
    // Built without the gyro's matrix and the magnetometer, from the same record.
    const std::uint32_t before_lean = decisions(bench_lean::counts());
    const bool solving_lean = bench_lean::solving();
    bench::stack_paint();
    bench_lean::add_raw(g_frame, g_temperature, kOtherCounted);
    bench::stack_measure();
    IMUCAL_OTHER_ANNOUNCE(
        decisions(bench_lean::counts()) != before_lean
            ? "field, without the gyro's matrix: add_raw(), a rest handed out or judged"
        : solving_lean ? "field, without the gyro's matrix: add_raw(), a solve slice, per call"
        : t.still      ? "field, without the gyro's matrix: add_raw(), still, per frame"
                       : "field, without the gyro's matrix: add_raw(), moving, per frame");
    bench_lean::drop_events();
    // The FIFO: the frame joins the batch; a full batch goes in at once (the sensor's timestamps).
    if (fifo_n == 0) {
      fifo_still = true;
      fifo_temperature =
          s.temperature_new ? s.imu.temperature : std::numeric_limits<float>::quiet_NaN();
    }
    test::put_fifo_frame(g_fifo, fifo_n, FifoLayout{}, g_frame);
    g_fifo_stamps[fifo_n++] = g_frame.t_us;
    fifo_still = fifo_still && t.still;
    if (fifo_n == kBatch) {
      FifoTiming timing;
      timing.t_us = g_fifo_stamps;
      const std::uint32_t before_fifo = decisions(calibrator_fifo.counts());
      const bool solving_fifo =
          calibrator_fifo.accel_field().busy() || calibrator_fifo.mag_field().busy();
      IMUCAL_OTHER_BEGIN();
      const FifoResult r =
          calibrator_fifo.add_fifo(g_fifo, kBatch, FifoLayout{}, timing, fifo_temperature);
      IMUCAL_OTHER_END();
      IMUCAL_OTHER_ANNOUNCE(
          decisions(calibrator_fifo.counts()) != before_fifo || solving_fifo ||
                  calibrator_fifo.accel_field().busy() || calibrator_fifo.mag_field().busy()
              ? "field, FIFO batches of 25: add_fifo(), a rest judged or a solve slice, per call"
          : fifo_still ? "field, FIFO batches of 25: add_fifo(), still, per call"
                       : "field, FIFO batches of 25: add_fifo(), moving, per call");
      fifo_refused += r.refused;
      fifo_n = 0;
      while (calibrator_fifo.take_event(e)) {
      }
    }
  }
  bench::report_stack("field add_raw(), add_mag()");

  const FieldCounts& c = calibrator.counts();
  Vector3<float> bias;
  const bool published = calibrator.gyro_bias(bias);
  std::printf(
      "RESULT field: start %s, %u frames (%u refused), %u add_mag() calls, %u events: %u rests, "
      "%u taken, %u turning, %u held, %u unconfirmed, %u changes, %u updates; published %d; "
      "sizeof %u, without a magnetometer %u, and without the gyro's matrix %u\n",
      to_string(started), static_cast<unsigned>(frames), static_cast<unsigned>(refused),
      static_cast<unsigned>(mags), static_cast<unsigned>(events), static_cast<unsigned>(c.rests),
      static_cast<unsigned>(c.taken), static_cast<unsigned>(c.turning),
      static_cast<unsigned>(c.held), static_cast<unsigned>(c.unconfirmed),
      static_cast<unsigned>(c.changes), static_cast<unsigned>(c.updates), published ? 1 : 0,
      static_cast<unsigned>(sizeof(calibrator)),
      static_cast<unsigned>(sizeof(FieldCalibrator<float, 8, 0>)),
      static_cast<unsigned>(bench_lean::size()));
  std::printf(
      "RESULT field, temperature at 1 Hz (no magnetometer): %u rests, %u taken, %u "
      "updates\n",
      static_cast<unsigned>(calibrator_1hz.counts().rests),
      static_cast<unsigned>(calibrator_1hz.counts().taken),
      static_cast<unsigned>(calibrator_1hz.counts().updates));
  std::printf(
      "RESULT field, without the gyro's matrix (no magnetometer), from a stored calibration: %u "
      "rests, %u taken, %u updates, %u gyro moves\n",
      static_cast<unsigned>(bench_lean::counts().rests),
      static_cast<unsigned>(bench_lean::counts().taken),
      static_cast<unsigned>(bench_lean::counts().updates),
      static_cast<unsigned>(bench_lean::counts().gyro_moves));
  const FieldCounts& cs = calibrator_stored.counts();
  std::printf(
      "RESULT field, from a stored calibration (no magnetometer): %u rests, %u taken, %u gyro "
      "moves taken, %u refused, %u gyro matrix updates\n",
      static_cast<unsigned>(cs.rests), static_cast<unsigned>(cs.taken),
      static_cast<unsigned>(cs.gyro_moves), static_cast<unsigned>(cs.gyro_moves_refused),
      static_cast<unsigned>(cs.gyro_matrix_updates));
  std::printf(
      "RESULT field, FIFO batches of %u (no magnetometer): %u frames refused, %u rests, %u "
      "taken, %u updates\n",
      static_cast<unsigned>(kBatch), static_cast<unsigned>(fifo_refused),
      static_cast<unsigned>(calibrator_fifo.counts().rests),
      static_cast<unsigned>(calibrator_fifo.counts().taken),
      static_cast<unsigned>(calibrator_fifo.counts().updates));
  return started == Status::kOk && lean_started == Status::kOk && refused == 0 &&
                 fifo_refused == 0 && published
             ? 0
             : 1;
}
