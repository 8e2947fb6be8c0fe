// SPDX-License-Identifier: MIT
// tools/imucal/noise.cpp: `imucal noise`: the noise of a still recording, per sensor and axis,
// from its overlapping Allan deviation (imucal/noise/allan.hpp): the fitted quantisation, white
// noise (noise density), bias instability and random walk with their sigmas, the classic read-outs,
// and the numbers Kalibr's imu.yaml wants. The whole file is taken as one still recording.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "allan_stream.hpp"
#include "cli.hpp"
#include "imucal/noise/allan.hpp"
#include "outputs.hpp"

namespace imucal::cli {

namespace {

using Json = nlohmann::ordered_json;

// The intervals between samples in bins 0.1 % wide (1 ns .. 1e9 s), and the largest exactly:
// how many exceed a bound known only at the end (to 0.1 %), in fixed memory.
class IntervalHistogram {
 public:
  IntervalHistogram() : bins_(kBins, 0) {}
  void add(double d) {
    largest_ = std::max(largest_, d);
    ++bins_[bin(d)];
  }
  long over(double bound) const {
    long n = 0;
    for (std::size_t k = bin(bound) + 1; k < kBins; ++k) n += bins_[k];
    return n;
  }
  double largest() const { return largest_; }

 private:
  static constexpr std::size_t kBins = 41500;  // log(1e18) / log(1.001)
  static std::size_t bin(double d) {
    const double k = std::floor(std::log(d / 1e-9) / std::log(1.001));
    return !(k >= 0)                             ? 0
           : k >= static_cast<double>(kBins - 1) ? kBins - 1
                                                 : static_cast<std::size_t>(k);
  }
  std::vector<long> bins_;
  double largest_ = 0;
};

constexpr int kMaxTaus = 64;
// The largest reading the variances take (in the unit reported): far beyond any sensor's range,
// far below where the sums of squares over a recording overflow.
constexpr double kLargestReading = 1e100;
constexpr int kPerDecade = 8;

struct SensorNoise {
  const char* name = "";
  const char* key = "";  // JSON key
  std::string unit;      // the rate unit (rad/s, m/s^2, or the input's unit)
  bool si = false;       // unit is rad/s or m/s^2 (Kalibr needs that)
  AllanPoint<double> pts[kMaxTaus];
  int n_pts = 0;
  NoiseTerms<double> terms[3];
  // Kalibr: one number per sensor, the largest of the axes.
  double density = 0, density_sigma = 0;
  double random_walk = 0, random_walk_sigma = 0;
  bool random_walk_bound = false;  // no axis shows a random walk: the upper bound the data allow
};

// The random-walk coefficient the last point's upper 68 % limit allows: K^2 tau / 3 <= adev_hi^2.
double random_walk_bound(const SensorNoise& s, int axis) {
  const AllanPoint<double>& p = s.pts[s.n_pts - 1];
  return p.adev_hi(axis) * std::sqrt(3.0 / p.tau);
}

void kalibr_numbers(SensorNoise& s) {
  s.random_walk_bound = true;
  for (int a = 0; a < 3; ++a) {
    const NoiseTerms<double>& t = s.terms[a];
    const double n = t.n.significant ? t.n.value : t.classic_n;
    if (n > s.density) {
      s.density = n;
      s.density_sigma = t.n.significant ? t.n.sigma : 0;
    }
  }
  double k_max = 0, k_sigma = 0;
  bool any = false;
  for (int a = 0; a < 3; ++a) {
    const NoiseTerm<double>& k = s.terms[a].k;
    if (k.significant && k.value > k_max) {
      k_max = k.value;
      k_sigma = k.sigma;
      any = true;
    }
  }
  if (any) {
    s.random_walk = k_max;
    s.random_walk_sigma = k_sigma;
    s.random_walk_bound = false;
  } else {
    for (int a = 0; a < 3; ++a) s.random_walk = std::max(s.random_walk, random_walk_bound(s, a));
  }
}

std::string term_text(const NoiseTerm<double>& t) {
  char b[96];
  if (!t.significant && t.value == 0) {
    std::snprintf(b, sizeof b, "%-22s", "-");
  } else {
    std::snprintf(b, sizeof b, "%.3e +- %.1e%s", t.value, t.sigma, t.significant ? "  " : "ns");
  }
  return b;
}

void print_sensor(const SensorNoise& s, std::FILE* out) {
  std::fprintf(out, "\n%s (%s)\n", s.name, s.unit.c_str());
  std::fprintf(out, "  axis  %-24s%-24s%-24s%-24s\n", "N white noise", "K random walk",
               "B bias instability", "Q quantisation");
  std::fprintf(out, "        %-24s%-24s%-24s%-24s\n", ("[" + s.unit + "/sqrt(Hz)]").c_str(),
               ("[" + s.unit + " sqrt(Hz)]").c_str(), ("[" + s.unit + "]").c_str(),
               ("[" + s.unit + " s]").c_str());
  const char* axes = "xyz";
  for (int a = 0; a < 3; ++a) {
    const NoiseTerms<double>& t = s.terms[a];
    std::fprintf(out, "  %c     %-24s%-24s%-24s%-24s\n", axes[a], term_text(t.n).c_str(),
                 term_text(t.k).c_str(), term_text(t.b).c_str(), term_text(t.q).c_str());
  }
  for (int a = 0; a < 3; ++a) {
    const NoiseTerms<double>& t = s.terms[a];
    std::fprintf(out,
                 "  %c     classic: N %.3e (ADEV at 1 s on the -1/2 line), B %.3e (min ADEV / "
                 "0.664 at %.3g s%s); fit chi2 %.1f / %d\n",
                 axes[a], t.classic_n, t.classic_b, t.classic_b_tau,
                 t.classic_b_at_end ? ", still falling: no floor seen" : "", t.chi2, t.dof);
  }
  std::fprintf(out, "  Allan deviation [%s], 68 %% interval:\n  %10s", s.unit.c_str(), "tau [s]");
  for (int a = 0; a < 3; ++a) std::fprintf(out, "   %c %-26s", axes[a], "");
  std::fprintf(out, "\n");
  for (int i = 0; i < s.n_pts; ++i) {
    const AllanPoint<double>& p = s.pts[i];
    std::fprintf(out, "  %10.4g", p.tau);
    for (int a = 0; a < 3; ++a)
      std::fprintf(out, "   %.3e [%.2e, %.2e]", std::sqrt(p.avar(a)), p.adev_lo(a), p.adev_hi(a));
    std::fprintf(out, "\n");
  }
}

Json term_json(const NoiseTerm<double>& t) {
  return Json{{"value", t.value}, {"sigma", t.sigma}, {"significant", t.significant}};
}

Json sensor_json(const SensorNoise& s) {
  Json j;
  j["unit"] = s.unit;
  Json axes = Json::array();
  for (int a = 0; a < 3; ++a) {
    const NoiseTerms<double>& t = s.terms[a];
    axes.push_back(Json{{"white_noise_N", term_json(t.n)},
                        {"random_walk_K", term_json(t.k)},
                        {"bias_instability_B", term_json(t.b)},
                        {"quantisation_Q", term_json(t.q)},
                        {"classic_N", t.classic_n},
                        {"classic_B", t.classic_b},
                        {"classic_B_tau", t.classic_b_tau},
                        {"classic_B_floor_seen", !t.classic_b_at_end},
                        {"fit_chi2", t.chi2},
                        {"fit_dof", t.dof}});
  }
  j["axes"] = axes;
  Json pts = Json::array();
  for (int i = 0; i < s.n_pts; ++i) {
    const AllanPoint<double>& p = s.pts[i];
    Json q{{"tau", p.tau}, {"m", p.m}};
    for (const char* name : {"adev", "adev_lo", "adev_hi", "edf"}) {
      Json v = Json::array();
      for (int a = 0; a < 3; ++a) {
        const std::string n = name;
        v.push_back(n == "adev"      ? std::sqrt(p.avar(a))
                    : n == "adev_lo" ? p.adev_lo(a)
                    : n == "adev_hi" ? p.adev_hi(a)
                                     : p.edf(a));
      }
      q[name] = v;
    }
    pts.push_back(q);
  }
  j["allan_deviation"] = pts;
  if (s.si) {
    j["kalibr"] = Json{{"noise_density", s.density},
                       {"noise_density_sigma", s.density_sigma},
                       {"random_walk", s.random_walk},
                       {"random_walk_sigma", s.random_walk_sigma},
                       {"random_walk_is_upper_bound", s.random_walk_bound}};
  }
  return j;
}

std::string kalibr_yaml(const SensorNoise* gyro, const SensorNoise* acc, double rate,
                        const std::string& file, long n, double duration) {
  char b[2048];
  std::string y;
  std::snprintf(b, sizeof b,
                "# imucal noise %s: %ld samples, %.1f s taken as still. Per sensor, the largest\n"
                "# axis of the Allan deviation fit (imucal/noise/allan.hpp).\n",
                file.c_str(), n, duration);
  y += b;
  auto entry = [&](const char* key, double v, double sigma, const char* unit, const char* note) {
    std::snprintf(b, sizeof b, "%s: %.6e  # [ %s ] %s", key, v, unit, note);
    y += b;
    if (sigma > 0) {
      std::snprintf(b, sizeof b, " (sigma %.2e)", sigma);
      y += b;
    }
    y += "\n";
  };
  if (acc != nullptr) {
    entry("accelerometer_noise_density", acc->density, acc->density_sigma, "m / s^2 / sqrt(Hz)",
          "white noise");
    entry("accelerometer_random_walk", acc->random_walk, acc->random_walk_sigma,
          "m / s^3 / sqrt(Hz)",
          acc->random_walk_bound ? "not seen: the upper bound the data allow" : "bias diffusion");
  }
  if (gyro != nullptr) {
    entry("gyroscope_noise_density", gyro->density, gyro->density_sigma, "rad / s / sqrt(Hz)",
          "white noise");
    entry("gyroscope_random_walk", gyro->random_walk, gyro->random_walk_sigma,
          "rad / s^2 / sqrt(Hz)",
          gyro->random_walk_bound ? "not seen: the upper bound the data allow" : "bias diffusion");
  }
  y += "rostopic: /imu0\n";
  std::snprintf(b, sizeof b, "update_rate: %.3f  # [ Hz ]\n", rate);
  y += b;
  return y;
}

// --- The SVG page: one log-log panel per sensor -------------------------------------------------

constexpr const char* kAxisColour[3] = {"#d62728", "#2ca02c", "#1f77b4"};

// Log-log panel at (x0, y0) of size w x h: the Allan deviation of each axis (points, 68 %
// bars), the fitted terms' asymptotes (dashed) and the fitted model (thin line).
std::string svg_panel(const SensorNoise& s, double x0, double y0, double w, double h) {
  double t_lo = s.pts[0].tau, t_hi = s.pts[s.n_pts - 1].tau, a_lo = 1e300, a_hi = 0;
  for (int i = 0; i < s.n_pts; ++i) {
    for (int a = 0; a < 3; ++a) {
      if (s.pts[i].adev_lo(a) > 0) a_lo = std::min(a_lo, s.pts[i].adev_lo(a));
      a_hi = std::max(a_hi, std::min(s.pts[i].adev_hi(a), 10 * std::sqrt(s.pts[i].avar(a))));
    }
  }
  const double lx0 = std::floor(std::log10(t_lo)), lx1 = std::ceil(std::log10(t_hi));
  const double ly0 = std::floor(std::log10(a_lo)), ly1 = std::ceil(std::log10(a_hi));
  auto X = [&](double t) { return x0 + (std::log10(t) - lx0) / (lx1 - lx0) * w; };
  auto Y = [&](double v) { return y0 + h - (std::log10(v) - ly0) / (ly1 - ly0) * h; };
  auto inside = [&](double t, double v) {
    return std::isfinite(t) && std::isfinite(v) && v > 0 && std::log10(v) >= ly0 &&
           std::log10(v) <= ly1;
  };
  std::string o;
  o += format_text(
      "<rect x='%.1f' y='%.1f' width='%.1f' height='%.1f' fill='none' stroke='#444'/>\n", x0, y0, w,
      h);
  for (double e = lx0; e <= lx1; e += 1) {
    const double x = X(std::pow(10.0, e));
    o += format_text("<line x1='%.1f' y1='%.1f' x2='%.1f' y2='%.1f' stroke='#ddd'/>\n", x, y0, x,
                     y0 + h);
    o += format_text("<text x='%.1f' y='%.1f' font-size='11' text-anchor='middle'>1e%g</text>\n", x,
                     y0 + h + 14, e);
  }
  for (double e = ly0; e <= ly1; e += 1) {
    const double y = Y(std::pow(10.0, e));
    o += format_text("<line x1='%.1f' y1='%.1f' x2='%.1f' y2='%.1f' stroke='#ddd'/>\n", x0, y,
                     x0 + w, y);
    o += format_text("<text x='%.1f' y='%.1f' font-size='11' text-anchor='end'>1e%g</text>\n",
                     x0 - 4, y + 4, e);
  }
  o += "<text x='" + format_text("%.1f", x0 + w / 2) + "' y='" + format_text("%.1f", y0 + h + 30) +
       "' font-size='12' text-anchor='middle'>tau [s]</text>\n";
  o += "<text x='" + format_text("%.1f", x0) + "' y='" + format_text("%.1f", y0 - 8) +
       "' font-size='14'>" + s.name + ": Allan deviation [" + s.unit +
       "], 68 % intervals; dashed: the fitted terms' asymptotes (Q, N, B, K)</text>\n";
  const int steps = 60;
  for (int a = 0; a < 3; ++a) {
    const NoiseTerms<double>& t = s.terms[a];
    // Asymptotes: sqrt(3) Q / tau, N / sqrt(tau), 0.664 B, K sqrt(tau / 3).
    const double q = t.q.value, n = t.n.value, b = t.b.value, k = t.k.value;
    for (int term = 0; term < 4; ++term) {
      const NoiseTerm<double>& tt = term == 0 ? t.q : term == 1 ? t.n : term == 2 ? t.b : t.k;
      const double c = tt.value;
      if (!(c > 0) || !tt.significant) continue;  // the asymptotes of the terms the data show
      std::string path;
      for (int i = 0; i <= steps; ++i) {
        const double tau = std::pow(10.0, lx0 + (lx1 - lx0) * i / steps);
        const double v = term == 0   ? std::sqrt(3.0) * c / tau
                         : term == 1 ? c / std::sqrt(tau)
                         : term == 2 ? 0.6642824702679265 * c
                                     : c * std::sqrt(tau / 3);
        if (!inside(tau, v)) continue;
        path += (path.empty() ? "M" : "L") + format_text("%.1f,%.1f ", X(tau), Y(v));
      }
      if (!path.empty())
        o += "<path d='" + path + "' fill='none' stroke='" + kAxisColour[a] +
             "' stroke-width='1' stroke-dasharray='5,4' opacity='0.7'/>\n";
    }
    std::string model;
    for (int i = 0; i <= steps; ++i) {
      const double tau = std::pow(10.0, lx0 + (lx1 - lx0) * i / steps);
      const double v = std::sqrt(3 * q * q / (tau * tau) + n * n / tau +
                                 0.4412712003053032 * b * b + k * k * tau / 3);
      if (!inside(tau, v)) continue;
      model += (model.empty() ? "M" : "L") + format_text("%.1f,%.1f ", X(tau), Y(v));
    }
    if (!model.empty())
      o += "<path d='" + model + "' fill='none' stroke='" + kAxisColour[a] +
           "' stroke-width='1' opacity='0.5'/>\n";
    for (int i = 0; i < s.n_pts; ++i) {
      const AllanPoint<double>& p = s.pts[i];
      const double v = std::sqrt(p.avar(a));
      if (!inside(p.tau, v)) continue;
      const double lo = std::max(p.adev_lo(a), std::pow(10.0, ly0));
      const double hi = std::min(p.adev_hi(a), std::pow(10.0, ly1));
      o += format_text("<line x1='%.1f' y1='%.1f' x2='%.1f' y2='%.1f' ", X(p.tau), Y(lo), X(p.tau),
                       Y(hi)) +
           "stroke='" + kAxisColour[a] + "'/>\n";
      o += format_text("<circle cx='%.1f' cy='%.1f' r='2.2' ", X(p.tau), Y(v)) + "fill='" +
           kAxisColour[a] + "'/>\n";
    }
    const char* names = "xyz";
    auto shown = [](const NoiseTerm<double>& x) {
      return x.significant ? format_text("%.3e", x.value) : std::string("ns");
    };
    o += format_text("<text x='%.1f' y='%.1f' font-size='12' ", x0 + w - 400, y0 + 18 + 16 * a) +
         "fill='" + kAxisColour[a] + "'>" + names[a] + ": N " + shown(t.n) + ", K " + shown(t.k) +
         ", B " + shown(t.b) + ", Q " + shown(t.q) + " (ns: not significant)</text>\n";
  }
  return o;
}

std::string noise_svg(const SensorNoise* sensors, const bool* present, const std::string& file) {
  const double w = 1000, panel_h = 420;
  int panels = 0;
  for (int s = 0; s < 2; ++s) panels += present[s] ? 1 : 0;
  const double height = 60 + panels * (panel_h + 80);
  std::string o = format_text(
      "<svg xmlns='http://www.w3.org/2000/svg' width='%.0f' height='%.0f' "
      "font-family='sans-serif'>\n<rect width='100%%' height='100%%' fill='white'/>\n",
      w + 120, height);
  std::string title = "imucal noise: " + file;
  std::string escaped;
  for (char c : title) escaped += c == '<' ? "&lt;" : c == '&' ? "&amp;" : std::string(1, c);
  o += "<text x='20' y='28' font-size='16'>" + escaped + "</text>\n";
  double y = 70;
  for (int s = 0; s < 2; ++s) {
    if (!present[s]) continue;
    o += svg_panel(sensors[s], 90, y, w, panel_h);
    y += panel_h + 80;
  }
  return o + "</svg>\n";
}

void print_diagnostics(const Diagnostics& diag) {
  for (const Diagnostic& d : diag.kept()) std::fprintf(stderr, "imucal: %s\n", d.text().c_str());
  if (diag.count() > diag.kept().size())
    std::fprintf(stderr, "imucal: ... and %zu more\n", diag.count() - diag.kept().size());
}

// The noise of the samples `reader` gives, with the options settled: the summary and every
// output's text. Exit code 0, or 2 with the reason.
int noise_from(Options& o, SampleReader& reader, Diagnostics& diag, NoiseRun& result) {
  reader.set_time_unit(o.time_unit);
  reader.set_rate(o.nominal_rate_hz);
  if (reader.format() == Format::kCsv && !reader.has_time() && !(o.nominal_rate_hz > 0)) {
    result.error = format_text(
        "%s has no time column (t): give --rate HZ (the Allan deviation "
        "needs the sample interval)",
        o.files[0].c_str());
    return 2;
  }
  const bool has_acc = reader.has_accelerometer(), has_gyro = reader.has_gyroscope();
  if (!has_acc && !has_gyro) {
    result.error = format_text("no accelerometer or gyroscope columns in %s", o.files[0].c_str());
    return 2;
  }
  // Units: SI when the options say how (counts need the nominal scale), else the input's own.
  const double gyro_scale = o.gyro_unit == GyroUnit::kRads      ? 1.0
                            : o.gyro_unit == GyroUnit::kDps     ? kPi / 180.0
                            : std::isfinite(o.gyro_lsb_per_dps) ? kPi / 180.0 / o.gyro_lsb_per_dps
                                                                : 1.0;
  const bool gyro_si = o.gyro_unit != GyroUnit::kCounts || std::isfinite(o.gyro_lsb_per_dps);
  const double acc_scale = o.accel_unit == AccelUnit::kMps2   ? 1.0
                           : o.accel_unit == AccelUnit::kG    ? kStandardGravity
                           : std::isfinite(o.accel_lsb_per_g) ? kStandardGravity / o.accel_lsb_per_g
                                                              : 1.0;
  const bool acc_si = o.accel_unit != AccelUnit::kCounts || std::isfinite(o.accel_lsb_per_g);
  const bool si = !(has_gyro && !gyro_si) && !(has_acc && !acc_si);  // every sensor present
  if (!o.kalibr_path.empty() && !si) {
    result.error = format_text(
        "--kalibr needs SI units: with counts give --gyro-lsb-per-dps "
        "and --accel-lsb-per-g (from the data sheet)");
    return 2;
  }

  // One pass, in bounded memory whatever the length: the Allan variances as the samples come
  // (AllanStream), the intervals in a histogram of 0.1 % bins (the mean is known only at the
  // end), each axis's first reading and whether another differs.
  AllanStream streams[2] = {AllanStream(kPerDecade), AllanStream(kPerDecade)};  // gyro, acc
  const char* const kSensor[2] = {"gyroscope", "accelerometer"};
  const bool present[2] = {has_gyro, has_acc};
  double first[2][3] = {};
  bool varies[2][3] = {};
  IntervalHistogram intervals;
  double t_first = 0, t_last = 0;
  long n = 0;
  Record r;
  while (reader.next(r, diag)) {
    if (n > 0) intervals.add(r.t - t_last);
    if (n == 0) t_first = r.t;
    t_last = r.t;
    ++n;
    const double* raw[2] = {r.gyro, r.acc};
    const double scale[2] = {gyro_scale, acc_scale};
    for (int s = 0; s < 2; ++s) {
      if (!present[s]) continue;
      const Vector3<double> v(raw[s][0] * scale[s], raw[s][1] * scale[s], raw[s][2] * scale[s]);
      // Beyond kLargestReading a reading's square, summed over the recording, overflows: a
      // glitch, not noise.
      int axis = 0;
      for (int a = 1; a < 3; ++a)
        if (std::abs(v(a)) > std::abs(v(axis))) axis = a;
      if (!(std::abs(v(axis)) <= kLargestReading)) {
        result.error = format_text(
            "%s reading %.9g (axis %c) at t = %.9g s, sample %ld: beyond %g %s, too large for "
            "a variance (a glitch in the logger? remove that line)",
            kSensor[s], raw[s][axis], "xyz"[axis], r.t, n, kLargestReading,
            s == 0 ? (gyro_si ? "rad/s" : "counts") : (acc_si ? "m/s^2" : "counts"));
        return 2;
      }
      for (int a = 0; a < 3; ++a) {
        if (n == 1) first[s][a] = raw[s][a];
        varies[s][a] = varies[s][a] || raw[s][a] != first[s][a];
      }
      streams[s].add(v);
    }
  }
  if (reader.failed()) {
    result.error = format_text("the input could not be read to its end");
    return 2;
  }
  if (n < 20) {
    result.error = format_text(
        "%ld samples: too few for an Allan deviation (20 at least; a "
        "useful one needs minutes of rest)",
        n);
    return 2;
  }
  const double duration = t_last - t_first;
  const double dt = duration / static_cast<double>(n - 1);
  if (!(dt > 0) || !std::isfinite(dt)) {
    result.error = format_text("the time stamps do not advance");
    return 2;
  }
  for (int s = 0; s < 2; ++s)
    for (int a = 0; a < 3; ++a)
      if (present[s] && !varies[s][a]) {
        result.error = format_text(
            "%s %c axis: every reading is %.9g (%ld samples): no noise to measure (a frozen "
            "sensor, or a noise below the readings' resolution)",
            kSensor[s], "xyz"[a], first[s][a], n);
        return 2;
      }
  // The Allan deviation assumes a constant interval: count the intervals far from it.
  const long gaps = intervals.over(1.5 * dt);
  const double worst = intervals.largest();

  SensorNoise sensors[2];
  sensors[0].name = "gyroscope";
  sensors[0].key = "gyroscope";
  sensors[0].si = gyro_si;
  sensors[0].unit = gyro_si ? "rad/s" : "counts";
  sensors[1].name = "accelerometer";
  sensors[1].key = "accelerometer";
  sensors[1].si = acc_si;
  sensors[1].unit = acc_si ? "m/s^2" : "counts";
  for (int s = 0; s < 2; ++s) {
    if (!present[s]) continue;
    SensorNoise& sn = sensors[s];
    const Status st = streams[s].finish(dt, sn.pts, kMaxTaus, sn.n_pts);
    if (st != Status::kOk && st != Status::kCapacityExceeded) {
      result.error = format_text("%s: %s", sn.name, to_string(st));
      return 2;
    }
    for (int a = 0; a < 3; ++a) {
      const Status f = fit_noise_terms(sn.pts, sn.n_pts, a, sn.terms[a]);
      if (f != Status::kOk) {
        result.error = format_text("%s axis %d: %s", sn.name, a, to_string(f));
        return 2;
      }
    }
    kalibr_numbers(sn);
  }

  result.summary = printed([&](std::FILE* out) {
    std::fprintf(out,
                 "imucal noise: %s\n  %ld samples over %.1f s at %.3f Hz, taken as one still "
                 "recording\n",
                 o.files[0].c_str(), n, duration, 1.0 / dt);
    if (gaps > 0 || reader.lines_skipped() > 0) {
      std::fprintf(out,
                   "  warning: %ld interval(s) over 1.5 x the mean (longest %.3g s), %ld line(s) "
                   "skipped: the Allan deviation assumes a constant rate\n",
                   gaps, worst, reader.lines_skipped());
    }
    std::fprintf(out,
                 "  AVAR(tau) = 3 Q^2/tau^2 + N^2/tau + (2 ln2/pi) B^2 + K^2 tau/3, fitted "
                 "(weighted, non-negative); +- one sigma, ns: not significant\n");
    for (int s = 0; s < 2; ++s)
      if (present[s]) print_sensor(sensors[s], out);
  });

  {
    Json j;
    j["file"] = o.files[0];
    j["samples"] = n;
    j["duration_s"] = duration;
    j["rate_hz"] = 1.0 / dt;
    j["intervals_over_1_5_dt"] = gaps;
    j["lines_skipped"] = reader.lines_skipped();
    j["model"] = "AVAR(tau) = 3 Q^2/tau^2 + N^2/tau + (2 ln2/pi) B^2 + K^2 tau/3";
    for (int s = 0; s < 2; ++s)
      if (present[s]) j[sensors[s].key] = sensor_json(sensors[s]);
    result.json = j.dump(2) + "\n";
  }
  if (si)
    result.kalibr = kalibr_yaml(has_gyro ? &sensors[0] : nullptr, has_acc ? &sensors[1] : nullptr,
                                1.0 / dt, o.files[0], n, duration);
  if (!o.svg_path.empty()) result.svg = noise_svg(sensors, present, o.files[0]);
  return 0;
}

}  // namespace

int noise_command(const std::vector<std::string>& args) {
  Options o;
  std::string error;
  if (!parse_calibrate_options(args, o, error)) {
    std::fprintf(stderr, "imucal noise: %s\n", error.c_str());
    return 2;
  }
  if (o.files.empty()) {
    std::fprintf(stderr, "imucal noise: no input (a CSV file, - for stdin, or two imu_tk files)\n");
    return 2;
  }
  if (!outputs_apart_from_inputs(
          o.files, {{"--json", o.json_path}, {"--kalibr", o.kalibr_path}, {"--svg", o.svg_path}}))
    return 2;
  Diagnostics diag;
  SampleReader reader;
  reader.set_columns(o.columns);
  if (!reader.open(o.files, o.format, diag)) {
    print_diagnostics(diag);
    return 2;
  }
  if (!apply_file_settings(reader.file_settings(), o, error)) {
    std::fprintf(stderr, "imucal noise: %s\n", error.c_str());
    return 2;
  }
  NoiseRun run;
  const int code = noise_from(o, reader, diag, run);
  print_diagnostics(diag);
  if (code != 0) {
    std::fprintf(stderr, "imucal noise: %s\n", run.error.c_str());
    return code;
  }
  const bool stdout_taken = o.json_path == "-" || o.kalibr_path == "-" || o.svg_path == "-";
  std::fputs(run.summary.c_str(), stdout_taken ? stderr : stdout);
  bool written = true;
  if (!o.json_path.empty()) written = write_text_file(o.json_path, run.json) && written;
  if (!o.kalibr_path.empty()) written = write_text_file(o.kalibr_path, run.kalibr) && written;
  if (!o.svg_path.empty()) written = write_text_file(o.svg_path, run.svg) && written;
  return written ? 0 : 2;
}

int noise_memory(const std::vector<std::string>& args, const SampleArrays& arrays, NoiseRun& out) {
  Options o;
  Diagnostics diag;
  SampleReader reader;
  if (!open_arrays(args, arrays, o, reader, diag, out.error)) return 2;
  const int code = noise_from(o, reader, diag, out);
  for (const Diagnostic& d : diag.kept()) out.diagnostics.push_back(d.text());
  return code;
}

}  // namespace imucal::cli
