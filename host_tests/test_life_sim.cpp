// SPDX-License-Identifier: MIT
// The life simulator (sim/life_sim.hpp) that the field bench runs calibrators on: its truth is
// consistent with its raw stream (still means, the models, the bias curves and walks, the
// counts' saturation, the steady turns, the events), and a seed gives one stream.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <tuple>
#include <vector>

#include "imucal/models/accel_model.hpp"
#include "imucal/models/gyro_model.hpp"
#include "imucal/sim/life_sim.hpp"

namespace imucal::sim {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// Runs the whole life, calling f(sim, sample, truth) at each sample; returns the sample count.
template <class F>
std::size_t run(const LifePlan& plan, F f) {
  LifeSimulator sim(plan);
  LifeSample s;
  LifeTruth t;
  std::size_t n = 0;
  while (sim.next(s, t)) {
    f(sim, s, t);
    ++n;
  }
  return n;
}

// Rounding to counts adds 1/12 count^2 to the white noise's variance (Sheppard).
double counts_sd(double noise) { return std::sqrt(noise * noise + 1.0 / 12.0); }

Vector3<double> counts(const std::array<std::int16_t, 3>& c) {
  return {static_cast<double>(c[0]), static_cast<double>(c[1]), static_cast<double>(c[2])};
}

LifeOptions quiet() {
  LifeOptions o;
  o.knock = o.hard_iron_step = o.magnet_pass = false;
  return o;
}

TEST(LifeSim, SameSeedSameStreamAnotherSeedAnother) {
  for (const char* name : life_names()) {
    LifePlan a, b, c;
    ASSERT_TRUE(make_life(name, 7, 1.0, {}, a));
    ASSERT_TRUE(make_life(name, 7, 1.0, {}, b));
    ASSERT_TRUE(make_life(name, 8, 1.0, {}, c));
    LifeSimulator sa(a), sb(b), sc(c);
    LifeSample xa, xb, xc;
    LifeTruth ta, tb, tc;
    std::size_t differ = 0;
    for (int k = 0; k < 20000; ++k) {
      ASSERT_TRUE(sa.next(xa, ta) && sb.next(xb, tb) && sc.next(xc, tc));
      ASSERT_EQ(xa.gyro_counts, xb.gyro_counts) << name << " sample " << k;
      ASSERT_EQ(xa.acc_counts, xb.acc_counts) << name << " sample " << k;
      ASSERT_EQ(xa.mag_counts, xb.mag_counts) << name << " sample " << k;
      ASSERT_EQ(xa.t_us, xb.t_us);
      ASSERT_EQ(xa.imu.temperature, xb.imu.temperature);
      ASSERT_EQ(ta.gyro_bias, tb.gyro_bias);
      ASSERT_EQ(ta.attitude.coeffs(), tb.attitude.coeffs());
      differ += xa.gyro_counts != xc.gyro_counts || xa.acc_counts != xc.acc_counts;
    }
    EXPECT_GT(differ, 19000u) << name << ": another seed gives another stream";
  }
}

// During a true rest the rate is zero, the accelerometer reads gravity alone, and the mean raw
// gyro reading equals minus the true (added) bias within the noise over sqrt(n).
TEST(LifeSim, StillMeansAreTheTruthBias) {
  for (const char* name : {"desk", "vehicle", "drone"}) {
    LifePlan plan;
    ASSERT_TRUE(make_life(name, 3, 6.0, {}, plan));
    Vector3<double> raw_sum = Vector3<double>::Zero(), bias_sum = Vector3<double>::Zero();
    std::size_t n = 0, rests = 0;
    double sd = 0.0;
    auto close_rest = [&]() {
      if (n >= 1000) {
        const Vector3<double> diff = (raw_sum + bias_sum) / static_cast<double>(n);
        const double tol = 5.0 * sd / std::sqrt(static_cast<double>(n));
        for (int i = 0; i < 3; ++i) EXPECT_LT(std::abs(diff(i)), tol) << name << " axis " << i;
        ++rests;
      }
      raw_sum.setZero();
      bias_sum.setZero();
      n = 0;
    };
    run(plan, [&](const LifeSimulator& sim, const LifeSample& s, const LifeTruth& t) {
      sd = counts_sd(sim.gyro_noise_counts());
      if (!t.still) {
        close_rest();
        return;
      }
      ASSERT_EQ(t.rate.squaredNorm(), 0.0);
      const Vector3<double> g = t.attitude.toRotationMatrix().transpose() *
                                Vector3<double>(0.0, 0.0, plan.sensors.gravity);
      ASSERT_LT((t.specific_force - g).norm(), 1e-9);
      raw_sum += counts(s.gyro_counts);
      bias_sum += t.gyro_bias;
      ++n;
    });
    close_rest();
    EXPECT_GE(rests, 3u) << name;
  }
}

// Without a walk the biases are the curves at the true temperature; the walk's increments over
// a second have the variance its density says; the curves are a consumer part's.
TEST(LifeSim, BiasesFollowTheTemperatureCurveAndTheWalk) {
  LifeOptions o = quiet();
  o.sensors.gyro_rrw_dps_rts = 0.0;
  o.sensors.accel_rrw_mg_rts = 0.0;
  LifePlan plan = drone_life(5, 2.0, o);
  double t_min = 1e9, t_max = -1e9;
  run(plan, [&](const LifeSimulator& sim, const LifeSample&, const LifeTruth& t) {
    const TemperatureTruth& imu = sim.imu_truth();
    ASSERT_LT((t.gyro_bias - imu.gyro_bias(t.temperature_c)).norm(), 1e-9);
    ASSERT_LT((t.accel_bias - imu.accel_bias(t.temperature_c)).norm(), 1e-9);
    t_min = std::min(t_min, t.temperature_c);
    t_max = std::max(t_max, t.temperature_c);
  });
  EXPECT_GT(t_max - t_min, 10.0) << "a drone's warm-up heats it";

  LifeSimulator sim(plan);
  const TemperatureModel<double>& m = sim.imu_truth().model;
  const double gyro_unit = 1.0 / (plan.sensors.gyro_lsb_per_dps);  // deg/s per count
  const double accel_unit = 1e3 / plan.sensors.accel_lsb_per_g;    // mg per count
  for (int i = 0; i < 3; ++i) {
    EXPECT_LE(std::abs(m.gyro.b0(i)) * gyro_unit, 3.0);
    EXPECT_GE(std::abs(m.gyro.b1(i)) * gyro_unit, 0.002 - 1e-12);
    EXPECT_LE(std::abs(m.gyro.b1(i)) * gyro_unit, 0.02 + 1e-12);
    EXPECT_LE(std::abs(m.accel.b0(i)) * accel_unit, 40.0);
    EXPECT_GE(std::abs(m.accel.b1(i)) * accel_unit * 9.80665 / plan.sensors.gravity, 0.1 - 1e-9);
    EXPECT_LE(std::abs(m.accel.b1(i)) * accel_unit * 9.80665 / plan.sensors.gravity, 1.0 + 1e-9);
    EXPECT_NE(m.gyro.b2(i), 0.0);
  }

  // The walk: increments over one second, 6 h, three axes.
  LifePlan walk = fixed_life(6, 6.0, quiet());
  double sum_g = 0.0, sum_a = 0.0;
  std::size_t n = 0;
  Vector3<double> last_g = Vector3<double>::Zero(), last_a = Vector3<double>::Zero();
  std::size_t k = 0;
  run(walk, [&](const LifeSimulator&, const LifeSample&, const LifeTruth& t) {
    if (k++ % 100 != 0) return;
    if (k > 1) {
      sum_g += (t.gyro_walk - last_g).squaredNorm();
      sum_a += (t.accel_walk - last_a).squaredNorm();
      n += 3;
    }
    last_g = t.gyro_walk;
    last_a = t.accel_walk;
  });
  const double var_g = sum_g / static_cast<double>(n);
  const double var_a = sum_a / static_cast<double>(n);
  const double want_g = std::pow(walk.sensors.gyro_rrw_dps_rts * walk.sensors.gyro_lsb_per_dps, 2);
  const double want_a =
      std::pow(walk.sensors.accel_rrw_mg_rts * 1e-3 * walk.sensors.accel_lsb_per_g, 2);
  const double tol = 5.0 * std::sqrt(2.0 / static_cast<double>(n));
  EXPECT_NEAR(var_g / want_g, 1.0, tol);
  EXPECT_NEAR(var_a / want_a, 1.0, tol);
}

// raw = model(truth) + white noise + rounding: the accelerometer and gyro residuals have zero
// mean and the noise's RMS; the magnetometer's field magnitude is the local field's, except
// while a magnet passes.
TEST(LifeSim, RawIsTheModelOfTheTruth) {
  LifePlan plan = handheld_life(11, 1.5, LifeOptions{});
  ASSERT_EQ(plan.magnet_passes.size(), 1u);
  Vector3<double> sum_g = Vector3<double>::Zero(), sum_a = Vector3<double>::Zero();
  Vector3<double> sq_g = Vector3<double>::Zero(), sq_a = Vector3<double>::Zero();
  double sum_m = 0.0, sq_m = 0.0, magnet_max = 0.0;
  std::size_t n = 0, n_m = 0, n_magnet = 0;
  double gyro_sd = 0.0, accel_sd = 0.0, mag_sd = 0.0;
  run(plan, [&](const LifeSimulator& sim, const LifeSample& s, const LifeTruth& t) {
    ASSERT_FALSE(t.saturated);
    gyro_sd = counts_sd(sim.gyro_noise_counts());
    accel_sd = counts_sd(sim.accel_noise_counts());
    const Vector3<double> g_clean =
        gyro_matrix<double>(t.gyro).inverse() * t.rate - t.gyro.tail<3>();
    const Vector3<double> a_clean =
        accel_matrix(t.accel).inverse() * t.specific_force - t.accel.tail<3>();
    const Vector3<double> rg = counts(s.gyro_counts) - g_clean;
    const Vector3<double> ra = counts(s.acc_counts) - a_clean;
    // The library's models map the clean raw readings back to the truth.
    ASSERT_LT((gyro_apply(t.gyro, g_clean) - t.rate).norm(), 1e-9);
    ASSERT_LT((accel_apply(t.accel, a_clean) - t.specific_force).norm(), 1e-9);
    ASSERT_EQ(s.imu.gyro.cast<double>(), counts(s.gyro_counts));
    sum_g += rg;
    sum_a += ra;
    sq_g += rg.cwiseAbs2();
    sq_a += ra.cwiseAbs2();
    ++n;
    if (s.mag_new) {
      const MagTruth& m = sim.mag_truth();
      const double field = (m.S_true * (counts(s.mag_counts) + t.hard_iron)).norm();
      mag_sd = m.unit_ut * counts_sd(sim.mag_noise_counts());
      if (t.magnet_near) {
        magnet_max = std::max(magnet_max, std::abs(field - m.field_ut));
        ++n_magnet;
      } else {
        sum_m += field - m.field_ut;
        sq_m += (field - m.field_ut) * (field - m.field_ut);
        ++n_m;
      }
    }
  });
  const double nd = static_cast<double>(n);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT(std::abs(sum_g(i) / nd), 5.0 * gyro_sd / std::sqrt(nd)) << i;
    EXPECT_LT(std::abs(sum_a(i) / nd), 5.0 * accel_sd / std::sqrt(nd)) << i;
    EXPECT_NEAR(std::sqrt(sq_g(i) / nd) / gyro_sd, 1.0, 0.02) << i;
    EXPECT_NEAR(std::sqrt(sq_a(i) / nd) / accel_sd, 1.0, 0.02) << i;
  }
  const double nm = static_cast<double>(n_m);
  EXPECT_LT(std::abs(sum_m / nm), 5.0 * mag_sd / std::sqrt(nm));
  EXPECT_NEAR(std::sqrt(sq_m / nm) / mag_sd, 1.0, 0.05);
  EXPECT_GT(n_magnet, 100u);
  EXPECT_GT(magnet_max, 50.0) << "a passing magnet's field shows";
}

// Counts clip at the int16 range with the true value's sign (no wrap), as a sensor saturates.
TEST(LifeSim, CountsSaturateLikeASensor) {
  LifePlan plan;
  plan.seed = 1;
  LifePhase rest;
  rest.duration_s = 1.0;
  LifePhase spin;
  spin.kind = PhaseKind::kTurn;
  spin.duration_s = 4.0;
  spin.turn_dps = -3000.0;  // beyond +-2000 deg/s
  LifePhase shake;
  shake.kind = PhaseKind::kVibration;
  shake.duration_s = 2.0;
  shake.vib_accel_m_s2 = 150.0;  // beyond +-8 g
  shake.vib_min_hz = 5.0;
  shake.vib_max_hz = 10.0;
  plan.phases = {rest, spin, rest, shake, rest};
  std::size_t clipped_gyro = 0, clipped_accel = 0, free = 0;
  run(plan, [&](const LifeSimulator& sim, const LifeSample& s, const LifeTruth& t) {
    const Vector3<double> g = gyro_matrix<double>(t.gyro).inverse() * t.rate - t.gyro.tail<3>();
    const Vector3<double> a =
        accel_matrix(t.accel).inverse() * t.specific_force - t.accel.tail<3>();
    bool any = false;
    for (int i = 0; i < 3; ++i) {
      const auto u = static_cast<std::size_t>(i);
      for (const auto& [value, count, clip_count] :
           {std::tuple<double, std::int16_t, std::size_t*>{g(i), s.gyro_counts[u], &clipped_gyro},
            {a(i), s.acc_counts[u], &clipped_accel}}) {
        if (std::abs(value) > 32800.0) {
          EXPECT_EQ(count, value > 0 ? 32767 : -32768);
          ++*clip_count;
          any = true;
        } else if (std::abs(value) < 32700.0) {
          EXPECT_LT(std::abs(count - value), 8.0 * counts_sd(sim.accel_noise_counts()));
          ++free;
        }
      }
    }
    if (any) {
      EXPECT_TRUE(t.saturated);
    }
    EXPECT_EQ(s.imu.gyro(0), static_cast<float>(s.gyro_counts[0]));
  });
  EXPECT_GT(clipped_gyro, 100u);
  EXPECT_GT(clipped_accel, 20u);
  EXPECT_GT(free, 1000u);
}

// A steady turn is about the vertical at the planned rate, the body is never still there, and
// the accelerometer is steady (its readings vary by the noise alone).
TEST(LifeSim, SteadyTurnsAreThePlannedRate) {
  for (const char* name : {"vehicle", "turntable"}) {
    LifePlan plan;
    ASSERT_TRUE(make_life(name, 4, 8.0, quiet(), plan));
    std::size_t held = 0, turns = 0;
    Vector3<double> f0 = Vector3<double>::Zero();
    Vector3<double> acc_sum = Vector3<double>::Zero(), acc_sq = Vector3<double>::Zero();
    std::size_t acc_n = 0, last_phase = ~std::size_t{0};
    double accel_sd = 0.0;
    run(plan, [&](const LifeSimulator& sim, const LifeSample& s, const LifeTruth& t) {
      if (t.phase != PhaseKind::kTurn) return;
      EXPECT_FALSE(t.still);
      const LifePhase& p = plan.phases[t.phase_index];
      const double ramp = std::min(2.0, 0.25 * p.duration_s);
      if (t.phase_time_s < ramp + 0.01 || t.phase_time_s > p.duration_s - ramp - 0.01) return;
      EXPECT_GE(std::abs(p.turn_dps), 0.2);
      EXPECT_LE(std::abs(p.turn_dps), 2.0);
      const Vector3<double> w_world = t.attitude.toRotationMatrix() * t.rate;
      ASSERT_NEAR(w_world.z(), p.turn_dps * kDeg, 1e-9 * std::abs(p.turn_dps));
      ASSERT_LT(w_world.head<2>().norm(), 1e-9);
      if (t.phase_index != last_phase) {
        last_phase = t.phase_index;
        f0 = t.specific_force;
        ++turns;
      }
      ASSERT_LT((t.specific_force - f0).norm(), 1e-6) << "the specific force is steady";
      accel_sd = counts_sd(sim.accel_noise_counts());
      // The raw accelerometer's spread about the truth (the bias and temperature move slowly).
      const Vector3<double> a_clean =
          accel_matrix(t.accel).inverse() * t.specific_force - t.accel.tail<3>();
      const Vector3<double> r = counts(s.acc_counts) - a_clean;
      acc_sum += r;
      acc_sq += r.cwiseAbs2();
      ++acc_n;
      ++held;
    });
    EXPECT_GE(turns, 2u) << name;
    EXPECT_GT(held, 10000u) << name;
    const double nd = static_cast<double>(acc_n);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(std::sqrt(acc_sq(i) / nd) / accel_sd, 1.0, 0.03);
  }
}

// The timer wraps modulo 2^32 and steps by the sample period; the temperature reads in steps of
// its resolution with its noise; the magnetometer and the temperature sensor at their own rates;
// the magnetometer-free variant has none and no magnetic events.
TEST(LifeSim, TimerTemperatureAndRates) {
  LifeOptions o;
  o.sensors.temperature_rate_hz = 2.0;
  o.sensors.mag_rate_hz = 25.0;
  LifePlan plan = desk_life(9, 1.0, o);
  std::uint32_t last = 0;
  std::size_t wraps = 0, n = 0, mags = 0, temps = 0;
  double sq = 0.0;
  const double lsb = plan.sensors.temperature_lsb_c;
  run(plan, [&](const LifeSimulator&, const LifeSample& s, const LifeTruth& t) {
    if (n > 0) {
      EXPECT_EQ(static_cast<std::uint32_t>(s.t_us - last), 10000u);
      wraps += s.t_us < last;
    }
    EXPECT_NEAR(s.t_s, static_cast<double>(n) * 0.01, 1e-9);
    last = s.t_us;
    mags += s.mag_new;
    if (s.temperature_new) {
      const double r = static_cast<double>(s.imu.temperature);
      EXPECT_NEAR(std::remainder(r, lsb), 0.0, 1e-4);
      sq += (r - t.temperature_c) * (r - t.temperature_c);
      ++temps;
    }
    ++n;
  });
  const double seconds = static_cast<double>(n) / 100.0;
  EXPECT_EQ(wraps, 1u);
  EXPECT_NEAR(static_cast<double>(mags), 25.0 * seconds, 1.0);
  EXPECT_NEAR(static_cast<double>(temps), 2.0 * seconds, 1.0);
  // float keeps the reading to 2e-6 deg C at 40: the noise and the rounding to the resolution.
  const double want = std::sqrt(std::pow(plan.sensors.temperature_noise_c, 2) + lsb * lsb / 12.0);
  EXPECT_NEAR(std::sqrt(sq / static_cast<double>(temps)) / want, 1.0,
              5.0 / std::sqrt(2.0 * static_cast<double>(temps)));

  LifeOptions free_of_mag;
  free_of_mag.magnetometer = false;
  LifePlan nomag = desk_life(9, 0.5, free_of_mag);
  EXPECT_TRUE(nomag.magnet_passes.empty());
  EXPECT_TRUE(nomag.hard_iron_steps.empty());
  std::size_t nomags = 0;
  run(nomag,
      [&](const LifeSimulator&, const LifeSample& s, const LifeTruth&) { nomags += s.mag_new; });
  EXPECT_EQ(nomags, 0u);
}

// A knock steps the biases by the planned amounts; a hard-iron step moves the hard iron by its
// step; the fixed node's knock leaves its one orientation as it was.
TEST(LifeSim, EventsStepTheTruth) {
  for (const char* name : {"desk", "fixed"}) {
    LifePlan plan;
    ASSERT_TRUE(make_life(name, 12, 4.0, {}, plan));
    std::size_t knock = plan.phases.size();
    for (std::size_t i = 0; i < plan.phases.size(); ++i)
      if (plan.phases[i].kind == PhaseKind::kKnock) knock = i;
    ASSERT_LT(knock, plan.phases.size()) << name;
    ASSERT_EQ(plan.hard_iron_steps.size(), 1u);
    const LifePhase& k = plan.phases[knock];
    LifeTruth before, after;
    Vector3<double> h_before = Vector3<double>::Zero(), h_after = Vector3<double>::Zero();
    bool seen_knock = false, seen_step = false;
    Vector3<double> up0 = Vector3<double>::Zero();
    double max_tilt = 0.0;
    run(plan, [&](const LifeSimulator&, const LifeSample& s, const LifeTruth& t) {
      if (t.phase_index == knock - 1) before = t;
      if (t.phase_index == knock + 1 && !seen_knock) {
        after = t;
        seen_knock = true;
      }
      if (s.t_s < plan.hard_iron_steps[0].t_s) h_before = t.hard_iron;
      if (s.t_s >= plan.hard_iron_steps[0].t_s && !seen_step) {
        h_after = t.hard_iron;
        seen_step = true;
      }
      if (t.still) {
        const Vector3<double> up = t.attitude.toRotationMatrix().row(2).transpose();
        if (up0.isZero()) up0 = up;
        max_tilt = std::max(max_tilt, std::acos(std::min(1.0, up.dot(up0))));
      }
    });
    ASSERT_TRUE(seen_knock && seen_step);
    const Vector3<double> want_g = k.gyro_step_dps * plan.sensors.gyro_lsb_per_dps;
    const Vector3<double> want_a = k.accel_step_mg * 1e-3 * plan.sensors.accel_lsb_per_g;
    EXPECT_LT((after.gyro_walk - before.gyro_walk - want_g).norm(), 0.01) << name;
    EXPECT_LT((after.accel_walk - before.accel_walk - want_a).norm(), 0.05) << name;
    EXPECT_LT((after.gyro_bias - before.gyro_bias - want_g).norm(), 0.02) << name;
    EXPECT_GT(want_g.norm(), 0.2 * plan.sensors.gyro_lsb_per_dps - 1e-9);
    EXPECT_LT(
        (h_after - h_before - plan.hard_iron_steps[0].step_ut / plan.sensors.mag_ut_per_lsb).norm(),
        1e-9);
    if (std::string(name) == "fixed") {
      EXPECT_LT(max_tilt, 1e-6) << "one orientation, the knock included";
      EXPECT_LT(after.attitude.angularDistance(before.attitude), 1e-6);
    }
  }
}

// The plans have their life's character and length.
TEST(LifeSim, PlansHaveTheirLifesCharacter) {
  for (const char* name : life_names()) {
    LifePlan plan;
    ASSERT_TRUE(make_life(name, 21, 24.0, {}, plan));
    EXPECT_NEAR(plan.duration_s(), 24.0 * 3600.0, 30.0) << name;
    std::array<std::size_t, 10> kinds{};
    for (const LifePhase& p : plan.phases) ++kinds[static_cast<std::size_t>(p.kind)];
    auto count = [&](PhaseKind k) { return kinds[static_cast<std::size_t>(k)]; };
    EXPECT_EQ(count(PhaseKind::kKnock), 1u) << name;
    EXPECT_GT(count(PhaseKind::kRest), 1u) << name;
    const std::string n = name;
    if (n == "vehicle" || n == "turntable") {
      EXPECT_GT(count(PhaseKind::kTurn), 2u) << name;
      for (const LifePhase& p : plan.phases)
        if (p.kind == PhaseKind::kTurn) {
          EXPECT_GE(std::abs(p.turn_dps), 0.2);
          EXPECT_LE(std::abs(p.turn_dps), 2.0);
        }
    }
    if (n == "vehicle") {
      EXPECT_GT(count(PhaseKind::kVibration), 2u);
      EXPECT_GT(count(PhaseKind::kDrive), 2u);
    }
    if (n == "handheld") {
      EXPECT_GT(count(PhaseKind::kPocket), 2u);
      EXPECT_GT(count(PhaseKind::kHandRest), 2u);
    }
    if (n == "drone") {
      EXPECT_GT(count(PhaseKind::kFlight), 1u);
      for (std::size_t i = 0; i < plan.phases.size(); ++i)
        if (plan.phases[i].kind == PhaseKind::kFlight) {
          ASSERT_GT(i, 0u);
          EXPECT_EQ(plan.phases[i - 1].kind, PhaseKind::kRest);
          EXPECT_GE(plan.phases[i - 1].heat_c, 10.0) << "warmed up at rest before the flight";
        }
    }
    if (n == "fixed") {
      EXPECT_EQ(count(PhaseKind::kMove), 0u);
    }
    if (n == "desk") {  // rests in several orientations: moves to at least two far apart
      std::vector<Eigen::Quaterniond> places;
      for (const LifePhase& p : plan.phases)
        if (p.kind == PhaseKind::kMove && !p.relative) places.push_back(p.target);
      double widest = 0.0;
      for (const Eigen::Quaterniond& a : places)
        for (const Eigen::Quaterniond& b : places) {
          const Vector3<double> ua = a.toRotationMatrix().row(2).transpose();
          const Vector3<double> ub = b.toRotationMatrix().row(2).transpose();
          widest = std::max(widest, std::acos(std::clamp(ua.dot(ub), -1.0, 1.0)));
        }
      EXPECT_GT(widest, 45.0 * kDeg);
    }
  }
}

}  // namespace
}  // namespace imucal::sim
