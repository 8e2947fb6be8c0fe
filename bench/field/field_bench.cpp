// SPDX-License-Identifier: MIT
// bench/field/field_bench.cpp: runs simulated lives (sim/life_sim.hpp) through field
// calibrators side by side and writes, per life, a markdown table of field.md section 7's
// metrics (metrics.hpp) with the estimators in columns, and the same as JSON.
//
//   field_bench --life vehicle --hours 24 --seed 3 --estimators chre,oracle
//   field_bench --life all --days 3 --markdown out.md --json out.json
//   field_bench --list
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "estimator.hpp"
#include "metrics.hpp"

namespace imucal::field_bench {
namespace {

constexpr double kRadToMdeg = 180.0e3 / 3.14159265358979323846;
constexpr double kNone = std::numeric_limits<double>::quiet_NaN();  // no value
constexpr std::array<Param, 3> kParams = {Param::kGyro, Param::kAccel, Param::kMag};

struct Options {
  std::vector<std::string> lives;
  double hours = 24.0;
  std::uint64_t seed = 1;
  std::vector<std::string> estimators;
  sim::LifeOptions life;
  std::string markdown, json;
  double away_margin_c = 3.0;
  bool trace = false;  // each update and each decision an estimator tells, to stdout
};

// What happened in the life, for the table's heading.
struct LifeFacts {
  double hours = 0.0, still_share = 0.0, turn_share = 0.0;
  double t_min = 1e9, t_max = -1e9;
  double gyro_offset_min = 1e9, gyro_offset_max = 0.0;  // |truth|, mdeg/s
  double wall_s = 0.0;
  std::string events;
};

struct Column {
  std::string name;
  std::unique_ptr<Estimator> estimator;
  std::vector<ParamTrack> tracks;  // gyro, accel, mag
  std::vector<ParamSummary> summaries;
};

struct LifeResult {
  sim::LifePlan plan;
  LifeFacts facts;
  std::vector<Column> columns;
};

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (start <= s.size()) {
    const std::size_t comma = s.find(',', start);
    const std::size_t end = comma == std::string::npos ? s.size() : comma;
    if (end > start) out.push_back(s.substr(start, end - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

const EstimatorEntry* find_estimator(const std::string& name) {
  for (const EstimatorEntry& e : estimators())
    if (name == e.name) return &e;
  return nullptr;
}

std::string event_list(const sim::LifePlan& plan) {
  std::string s;
  char buf[96];
  double t = 0.0;
  for (const sim::LifePhase& p : plan.phases) {
    if (p.kind == sim::PhaseKind::kKnock) {
      std::snprintf(buf, sizeof buf, "knock at %.2f h (gyro step %.0f mdeg/s, accel %.0f mg)",
                    t / 3600.0, p.gyro_step_dps.norm() * 1e3, p.accel_step_mg.norm());
      s += (s.empty() ? "" : "; ") + std::string(buf);
    }
    t += p.duration_s;
  }
  for (const sim::HardIronStep& h : plan.hard_iron_steps) {
    std::snprintf(buf, sizeof buf, "hard-iron step at %.2f h (%.0f uT)", h.t_s / 3600.0,
                  h.step_ut.norm());
    s += (s.empty() ? "" : "; ") + std::string(buf);
  }
  for (const sim::MagnetPass& m : plan.magnet_passes) {
    std::snprintf(buf, sizeof buf, "magnet at %.2f h for %.0f s (%.0f uT)", m.t_s / 3600.0,
                  m.duration_s, m.peak_ut.norm());
    s += (s.empty() ? "" : "; ") + std::string(buf);
  }
  return s.empty() ? "none" : s;
}

LifeResult run_life(const std::string& name, const Options& o) {
  LifeResult r;
  sim::make_life(name, o.seed, o.hours, o.life, r.plan);
  const auto start = std::chrono::steady_clock::now();
  sim::LifeSimulator sim(r.plan);
  const sim::DeviceSheet sheet = sim.sheet();
  for (const std::string& e : o.estimators) {
    Column c;
    c.name = e;
    c.estimator = find_estimator(e)->make(sheet);
    for (Param p : kParams) c.tracks.emplace_back(p, sheet.gravity, FalseUpdateRule{});
    if (o.trace) {
      c.estimator->trace(stdout, e.c_str());
      for (ParamTrack& t : c.tracks) t.trace(stdout, e);
    }
    r.columns.push_back(std::move(c));
  }
  RestTemperatures rests;
  sim::LifeSample s;
  sim::LifeTruth t;
  double next_poll = 1.0, still_run = 0.0;
  const double dt = 1.0 / sheet.rate_hz;
  std::uint64_t n = 0, still = 0, turning = 0;
  while (sim.next(s, t)) {
    ++n;
    still += t.still;
    turning += t.phase == sim::PhaseKind::kTurn;
    r.facts.t_min = std::min(r.facts.t_min, t.temperature_c);
    r.facts.t_max = std::max(r.facts.t_max, t.temperature_c);
    still_run = t.still ? still_run + dt : 0.0;
    if (still_run >= 5.0) rests.mark(t.temperature_c);
    for (Column& c : r.columns) c.estimator->feed(s, c.estimator->reads_truth() ? &t : nullptr);
    if (s.t_s + 1e-9 < next_poll) continue;
    next_poll += 1.0;
    const double offset = t.gyro_offset_si.norm() * kRadToMdeg;
    r.facts.gyro_offset_min = std::min(r.facts.gyro_offset_min, offset);
    r.facts.gyro_offset_max = std::max(r.facts.gyro_offset_max, offset);
    const bool motion = !t.still;
    const bool away = rests.away(t.temperature_c, o.away_margin_c);
    for (Column& c : r.columns) {
      const Estimate e = c.estimator->estimate();
      c.tracks[0].second(e.gyro_bias, t.gyro_offset_si, s.t_s, motion, away);
      c.tracks[1].second(e.accel_bias, t.accel_offset_si, s.t_s, motion, away);
      if (sheet.has_mag) c.tracks[2].second(e.hard_iron, t.hard_iron_ut, s.t_s, motion, away);
    }
  }
  for (Column& c : r.columns)
    for (const ParamTrack& p : c.tracks) c.summaries.push_back(p.summary());
  const double nd = static_cast<double>(n);
  r.facts.hours = nd * dt / 3600.0;
  r.facts.still_share = static_cast<double>(still) / nd;
  r.facts.turn_share = static_cast<double>(turning) / nd;
  r.facts.events = event_list(r.plan);
  r.facts.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

// ------------------------------------------------------------------------------------------
// Output.

std::string fmt(const char* f, double a) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, a);
  return buf;
}

// Three significant digits at most, no exponent.
std::string num(double v) {
  const double a = std::abs(v);
  return fmt(a >= 100.0 ? "%.0f" : a >= 10.0 ? "%.1f" : a >= 1.0 ? "%.2f" : "%.3f", v);
}

std::string pair(const ParamSummary& s, double a, double b, std::size_t n) {
  if (!s.any || n == 0) return "-";
  return num(a) + " / " + num(b);
}

std::string ratio(double a, double b) {
  if (!(b > 0.0) || !std::isfinite(a)) return "-";
  return fmt("%.2f", a / b);
}

struct Row {
  std::string label;
  std::string (*cell)(const ParamSummary&);
  // The metric's value(s) for the paired ratio (two numbers; NaN for none).
  void (*values)(const ParamSummary&, double&, double&);
};

std::vector<Row> rows_for(Param p) {
  std::vector<Row> rows;
  const std::string u = display_unit_name(p);
  const std::string n = param_name(p);
  rows.push_back({n + " error median / p95 (" + u + ")",
                  [](const ParamSummary& s) { return pair(s, s.median, s.p95, s.n); },
                  [](const ParamSummary& s, double& a, double& b) {
                    a = s.any ? s.median : kNone;
                    b = s.any ? s.p95 : kNone;
                  }});
  if (p == Param::kGyro) {
    rows.push_back(
        {"gyro error in motion median / p95 (" + u + ")",
         [](const ParamSummary& s) { return pair(s, s.median_motion, s.p95_motion, s.n_motion); },
         [](const ParamSummary& s, double& a, double& b) {
           a = s.n_motion ? s.median_motion : kNone;
           b = s.n_motion ? s.p95_motion : kNone;
         }});
    rows.push_back({"gyro error away from rest temperatures median / p95 (" + u + ")",
                    [](const ParamSummary& s) {
                      if (!s.any || s.n_away == 0) return std::string("-");
                      return pair(s, s.median_away, s.p95_away, s.n_away) +
                             fmt(" (%.0f %% of the time)", 100.0 * s.away_share);
                    },
                    [](const ParamSummary& s, double& a, double& b) {
                      a = s.n_away ? s.median_away : kNone;
                      b = s.n_away ? s.p95_away : kNone;
                    }});
  }
  rows.push_back({n + " first estimate (s) / share of the time",
                  [](const ParamSummary& s) {
                    if (!s.any) return std::string("never");
                    return fmt("%.0f", s.first_s) + fmt(" / %.0f %%", 100.0 * s.coverage);
                  },
                  [](const ParamSummary& s, double& a, double& b) {
                    a = s.any ? s.first_s : kNone;
                    b = kNone;
                  }});
  rows.push_back({n + " updates / false",
                  [](const ParamSummary& s) {
                    return fmt("%.0f", static_cast<double>(s.updates)) + " / " +
                           fmt("%.0f", static_cast<double>(s.false_updates));
                  },
                  [](const ParamSummary& s, double& a, double& b) {
                    a = static_cast<double>(s.updates);
                    b = static_cast<double>(s.false_updates);
                  }});
  rows.push_back({n + " sigma honesty (RMS error/sigma)",
                  [](const ParamSummary& s) {
                    return s.has_sigma ? fmt("%.2f", s.honesty) : std::string("no sigma");
                  },
                  [](const ParamSummary& s, double& a, double& b) {
                    a = s.has_sigma ? s.honesty : kNone;
                    b = kNone;
                  }});
  return rows;
}

std::string markdown(const LifeResult& r, const Options& o) {
  const sim::LifePlan& plan = r.plan;
  std::string out;
  char buf[512];
  std::snprintf(buf, sizeof buf, "## %s (seed %" PRIu64 ", %.1f h, %.0f Hz%s)\n\n",
                plan.name.c_str(), plan.seed, r.facts.hours, plan.sensors.rate_hz,
                plan.sensors.has_mag ? ", magnetometer" : ", no magnetometer");
  out += buf;
  std::snprintf(buf, sizeof buf,
                "Truly still %.0f %% of the time, steady turns %.0f %%; temperature %.1f to "
                "%.1f deg C; true gyro offset %.0f to %.0f mdeg/s. Events: %s. (%.0f s)\n\n",
                100.0 * r.facts.still_share, 100.0 * r.facts.turn_share, r.facts.t_min,
                r.facts.t_max, r.facts.gyro_offset_min, r.facts.gyro_offset_max,
                r.facts.events.c_str(), r.facts.wall_s);
  out += buf;
  // Paired ratios against chre for every other estimator but the oracle.
  int chre = -1;
  for (std::size_t i = 0; i < r.columns.size(); ++i)
    if (r.columns[i].name == "chre") chre = static_cast<int>(i);
  std::vector<std::size_t> ratios;
  if (chre >= 0)
    for (std::size_t i = 0; i < r.columns.size(); ++i)
      if (r.columns[i].name != "chre" && r.columns[i].name != "oracle") ratios.push_back(i);
  out += "| metric |";
  for (const Column& c : r.columns) out += " " + c.name + " |";
  for (std::size_t i : ratios) out += " " + r.columns[i].name + "/chre |";
  out += "\n|---|";
  for (std::size_t i = 0; i < r.columns.size() + ratios.size(); ++i) out += "---|";
  out += "\n";
  for (Param p : kParams) {
    if (p == Param::kMag && !plan.sensors.has_mag) continue;
    const auto k = static_cast<std::size_t>(p);
    for (const Row& row : rows_for(p)) {
      out += "| " + row.label + " |";
      for (const Column& c : r.columns) out += " " + row.cell(c.summaries[k]) + " |";
      for (std::size_t i : ratios) {
        double a0, a1, b0, b1;
        row.values(r.columns[i].summaries[k], a0, a1);
        row.values(r.columns[static_cast<std::size_t>(chre)].summaries[k], b0, b1);
        std::string cell = ratio(a0, b0);
        if (!std::isnan(a1) || !std::isnan(b1)) cell += " / " + ratio(a1, b1);
        out += " " + cell + " |";
      }
      out += "\n";
    }
  }
  const FalseUpdateRule rule;
  std::snprintf(buf, sizeof buf,
                "\nFalse update: a published update more than %.0f sigma from the truth on an "
                "axis, or without sigma more than %.0f mdeg/s, %.0f mg, %.0f uT. Away from rest "
                "temperatures: more than %.0f deg C from every true rest (5 s or more) so far.\n\n",
                rule.sigmas, rule.gyro_mdps, rule.accel_mg, rule.mag_ut, o.away_margin_c);
  out += buf;
  return out;
}

std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  return fmt("%.6g", v);
}

std::string json(const LifeResult& r) {
  std::string out = "  {\"life\": \"" + r.plan.name +
                    "\", \"seed\": " + std::to_string(r.plan.seed) +
                    ", \"hours\": " + json_number(r.facts.hours) +
                    ", \"rate_hz\": " + json_number(r.plan.sensors.rate_hz) +
                    ", \"magnetometer\": " + (r.plan.sensors.has_mag ? "true" : "false") +
                    ",\n   \"facts\": {\"still_share\": " + json_number(r.facts.still_share) +
                    ", \"turn_share\": " + json_number(r.facts.turn_share) +
                    ", \"temperature_min_c\": " + json_number(r.facts.t_min) +
                    ", \"temperature_max_c\": " + json_number(r.facts.t_max) + ", \"events\": \"" +
                    r.facts.events + "\"},\n   \"estimators\": {";
  for (std::size_t i = 0; i < r.columns.size(); ++i) {
    const Column& c = r.columns[i];
    out += (i ? ",\n    \"" : "\n    \"") + c.name + "\": {";
    for (std::size_t k = 0; k < c.summaries.size(); ++k) {
      const ParamSummary& s = c.summaries[k];
      const auto p = static_cast<Param>(k);
      if (p == Param::kMag && !r.plan.sensors.has_mag) continue;
      out += std::string(k ? ", " : "") + "\"" + param_name(p) + "\": {\"unit\": \"" +
             display_unit_name(p) + "\", \"any\": " + (s.any ? "true" : "false") +
             ", \"first_s\": " + (s.any ? json_number(s.first_s) : "null") +
             ", \"coverage\": " + json_number(s.coverage) +
             ", \"median\": " + (s.any ? json_number(s.median) : "null") +
             ", \"p95\": " + (s.any ? json_number(s.p95) : "null") +
             ", \"median_motion\": " + (s.n_motion ? json_number(s.median_motion) : "null") +
             ", \"p95_motion\": " + (s.n_motion ? json_number(s.p95_motion) : "null") +
             ", \"median_away\": " + (s.n_away ? json_number(s.median_away) : "null") +
             ", \"p95_away\": " + (s.n_away ? json_number(s.p95_away) : "null") +
             ", \"away_share\": " + json_number(s.away_share) +
             ", \"updates\": " + std::to_string(s.updates) +
             ", \"false_updates\": " + std::to_string(s.false_updates) +
             ", \"sigma_honesty\": " + (s.has_sigma ? json_number(s.honesty) : "null") + "}";
    }
    out += "}";
  }
  out += "}}";
  return out;
}

int usage(const char* why) {
  if (why) std::fprintf(stderr, "field_bench: %s\n", why);
  std::fprintf(stderr,
               "usage: field_bench [--life NAME[,NAME...]|all] [--hours H | --days D] [--seed N]\n"
               "                   [--estimators NAME[,NAME...]] [--rate HZ] [--no-mag]\n"
               "                   [--no-knock] [--no-hard-iron] [--no-magnet] [--trace]\n"
               "                   [--markdown FILE] [--json FILE] [--list]\n");
  return 2;
}

int list() {
  std::printf("lives:");
  for (const char* n : sim::life_names()) std::printf(" %s", n);
  std::printf("\nestimators:\n");
  for (const EstimatorEntry& e : estimators()) std::printf("  %-8s %s\n", e.name, e.description);
  return 0;
}

int main_(int argc, char** argv) {
  Options o;
  std::string lives = "all", names;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> const char* { return i + 1 < argc ? argv[++i] : nullptr; };
    if (a == "--list") return list();
    if (a == "--no-mag") {
      o.life.magnetometer = false;
    } else if (a == "--no-knock") {
      o.life.knock = false;
    } else if (a == "--no-hard-iron") {
      o.life.hard_iron_step = false;
    } else if (a == "--no-magnet") {
      o.life.magnet_pass = false;
    } else if (a == "--trace") {
      o.trace = true;
    } else if (a == "--life" || a == "--hours" || a == "--days" || a == "--seed" ||
               a == "--estimators" || a == "--rate" || a == "--markdown" || a == "--json") {
      const char* v = value();
      if (!v) return usage((a + " needs a value").c_str());
      if (a == "--life") lives = v;
      if (a == "--hours") o.hours = std::atof(v);
      if (a == "--days") o.hours = 24.0 * std::atof(v);
      if (a == "--seed") o.seed = std::strtoull(v, nullptr, 10);
      if (a == "--estimators") names = v;
      if (a == "--rate") o.life.sensors.rate_hz = std::atof(v);
      if (a == "--markdown") o.markdown = v;
      if (a == "--json") o.json = v;
    } else {
      return usage(("unknown option " + a).c_str());
    }
  }
  if (!(o.hours > 0.0)) return usage("the length must be positive");
  if (!(o.life.sensors.rate_hz >= 10.0)) return usage("the rate must be 10 Hz or more");
  if (lives == "all") {
    for (const char* n : sim::life_names()) o.lives.push_back(n);
  } else {
    o.lives = split(lives);
  }
  for (const std::string& l : o.lives) {
    sim::LifePlan p;
    if (!sim::make_life(l, 1, 0.01, o.life, p)) return usage(("no life named " + l).c_str());
  }
  if (names.empty())
    for (const EstimatorEntry& e : estimators()) o.estimators.push_back(e.name);
  else
    o.estimators = split(names);
  for (const std::string& e : o.estimators)
    if (!find_estimator(e)) return usage(("no estimator named " + e + " (--list)").c_str());

  std::string md, js = "[\n";
  for (std::size_t i = 0; i < o.lives.size(); ++i) {
    const LifeResult r = run_life(o.lives[i], o);
    const std::string table = markdown(r, o);
    md += table;
    js += (i ? ",\n" : "") + json(r);
    if (o.markdown.empty()) {
      std::fputs(table.c_str(), stdout);
      std::fflush(stdout);
    } else {
      std::fprintf(stderr, "%s: %.0f s\n", o.lives[i].c_str(), r.facts.wall_s);
    }
  }
  js += "\n]\n";
  auto write = [](const std::string& path, const std::string& text) {
    std::FILE* f = std::fopen(path.c_str(), "w");
    if (!f) return false;
    const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
    return std::fclose(f) == 0 && ok;
  };
  if (!o.markdown.empty() && !write(o.markdown, md)) {
    std::fprintf(stderr, "field_bench: cannot write %s\n", o.markdown.c_str());
    return 1;
  }
  if (!o.json.empty() && !write(o.json, js)) {
    std::fprintf(stderr, "field_bench: cannot write %s\n", o.json.c_str());
    return 1;
  }
  return 0;
}

}  // namespace
}  // namespace imucal::field_bench

int main(int argc, char** argv) { return imucal::field_bench::main_(argc, argv); }
