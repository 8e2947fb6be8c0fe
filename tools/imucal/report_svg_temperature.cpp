// SPDX-License-Identifier: MIT
// tools/imucal/report_svg_temperature.cpp: the report page's temperature panels: the biases against
// temperature, the rests and the fitted b(T).
#include "report_svg_sections.hpp"

namespace imucal::cli::report {

namespace {

// One sensor's bias against temperature: b(T) - b0 per axis (the fitted curve, a +-1 sigma band
// from the slope's and the curvature's sigma) and, for the gyro, what each rest saw.
void temperature_panel(Page& page, const Panel& p, const TemperatureResult& t,
                       const TemperatureBiasResult& bias, bool gyro, const std::string& unit) {
  const bool model = bias.ok && std::isfinite(t.reference_c);
  const std::size_t n = t.rest_list.size();
  // The reference subtracted: b0, or without a model the mean of the rests' observations.
  double ref[3] = {0, 0, 0};
  for (int a = 0; a < 3; ++a) {
    if (model) {
      ref[a] = bias.b0[a];
      continue;
    }
    double sum = 0;
    long count = 0;
    for (const TemperatureRest& r : t.rest_list)
      if (std::isfinite(r.gyro_mean[a])) {
        sum += -r.gyro_mean[a];
        ++count;
      }
    ref[a] = count > 0 ? sum / static_cast<double>(count) : 0;
  }
  auto curve = [&](int a, double temp) {
    const double d = temp - t.reference_c;
    return d * (bias.b1[a] + d * bias.b2[a]);
  };
  auto sigma = [&](int a, double temp) {
    const double d = temp - t.reference_c;
    return std::hypot(d * bias.b1_sigma[a], d * d * bias.b2_sigma[a]);
  };
  const Scale& sx = p.sx;
  const double x_lo = sx.d0, x_hi = sx.d1;
  const double c_lo = std::isfinite(t.min_c) ? t.min_c : x_lo;
  const double c_hi = std::isfinite(t.max_c) ? t.max_c : x_hi;

  // Values for the range.
  std::vector<double> values;
  if (gyro)
    for (const TemperatureRest& r : t.rest_list)
      for (int a = 0; a < 3; ++a)
        if (std::isfinite(r.gyro_mean[a])) values.push_back(-r.gyro_mean[a] - ref[a]);
  if (model)
    for (int a = 0; a < 3; ++a)
      for (double temp : {c_lo, c_hi}) {
        values.push_back(curve(a, temp) + sigma(a, temp));
        values.push_back(curve(a, temp) - sigma(a, temp));
      }
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (double v : values)
    if (std::isfinite(v)) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  if (!(lo <= hi)) lo = hi = 0;
  pad_range(lo, hi, 0.06);
  Panel q = p;
  q.sy = {lo, hi, p.y + p.h, p.y, false};

  const double step = nice_step(x_hi - x_lo, 8);
  for (double v : ticks(x_lo, x_hi, step)) {
    const double x = q.sx(v);
    page.line(x, q.y, x, q.y + q.h, "class=\"g\"");
    page.line(x, q.y + q.h, x, q.y + q.h + 4, "class=\"tk\"");
    page.text(x, q.y + q.h + 16, tick_text(v, step), "class=\"n\" text-anchor=\"middle\"");
  }
  page.text(q.x + q.w / 2, q.y + q.h + 32, "temperature (\u00b0C)",
            "class=\"ax\" text-anchor=\"middle\"");
  value_grid(page, q, (model ? "bias \u2212 b0 (" : "bias \u2212 mean (") + unit + ")");
  if (lo < 0 && hi > 0) page.line(q.x, q.sy(0), q.x + q.w, q.sy(0), "stroke=\"#999\"");
  if (model) {
    const int steps = 60;
    for (int a = 0; a < 3; ++a) {
      PathBuilder line, band;
      std::vector<std::array<double, 2>> lower;
      for (int k = 0; k <= steps; ++k) {
        const double temp = c_lo + (c_hi - c_lo) * k / steps;
        const double v = curve(a, temp), s = sigma(a, temp);
        line.point(q.sx(temp), q.sy(v));
        band.point(q.sx(temp), q.sy(v + s));
        lower.push_back({q.sx(temp), q.sy(v - s)});
      }
      for (auto it = lower.rbegin(); it != lower.rend(); ++it) band.point((*it)[0], (*it)[1]);
      page.path(band.str() + "Z", std::string("fill=\"") + kAxisColour[a] +
                                      "\" fill-opacity=\"0.13\" stroke=\"none\"");
      page.path(line.str(),
                std::string("fill=\"none\" stroke=\"") + kAxisColour[a] + "\" stroke-width=\"2\"");
    }
    const double x0 = q.sx(t.reference_c);
    if (x0 >= q.x && x0 <= q.x + q.w) {
      page.line(x0, q.y, x0, q.y + q.h, "stroke=\"#555\" stroke-dasharray=\"3 3\"");
      page.text(x0 + 3, q.y + 12, "T0", "class=\"gl\"");
    }
  }
  // The rests: the gyro's observed bias as dots, the accelerometer's temperatures as ticks (a rest
  // does not observe the accelerometer's bias per axis, only |a|).
  for (std::size_t i = 0; i < n; ++i) {
    const TemperatureRest& r = t.rest_list[i];
    if (!std::isfinite(r.temperature_c)) continue;
    const double x = q.sx(r.temperature_c);
    if (!std::isfinite(x) || x < q.x - 1 || x > q.x + q.w + 1) continue;
    if (!gyro) {
      page.line(x, q.y + q.h - 8, x, q.y + q.h, "stroke=\"#333\" stroke-width=\"1.2\"");
      continue;
    }
    for (int a = 0; a < 3; ++a) {
      const double v = -r.gyro_mean[a] - ref[a];
      if (!std::isfinite(v) || v < lo || v > hi) continue;
      const std::string attrs = std::string("fill=\"") + kAxisColour[a] +
                                "\" fill-opacity=\"0.8\" stroke=\"#fff\" stroke-width=\"0.6\"";
      if (n <= 100)
        page.circle(x, q.sy(v), 3.2, attrs,
                    printf_string("rest %zu: %.2f \u00b0C, %ld samples, %s bias \u2212 %s = %s",
                                  i + 1, r.temperature_c, r.samples,
                                  a == 0   ? "x"
                                  : a == 1 ? "y"
                                           : "z",
                                  model ? "b0" : "mean", value_text(v).c_str()));
      else
        page.circle(x, q.sy(v), 2.2, attrs);
    }
  }
  page.rect(q.x, q.y, q.w, q.h, "class=\"fr\"");
}

// "0.166, −0.109, 0.340": three values.
std::string triple(const double v[3]) {
  return value_text(v[0]) + ", " + value_text(v[1]) + ", " + value_text(v[2]);
}

}  // namespace

double temperature_section(Page& page, double y, const Run& run, const Options& options) {
  const TemperatureResult& t = run.temperature;
  if (!t.present) return y;
  section_title(page, y,
                "Biases against temperature: b(T) \u2212 b0 = b1 (T \u2212 T0)" +
                    std::string(t.order >= 2 ? " + b2 (T \u2212 T0)\u00b2" : "") +
                    ", per axis, \u00b11\u03c3 band");
  legend(page, y, {{"x", kAxisColour[0]}, {"y", kAxisColour[1]}, {"z", kAxisColour[2]}});
  if (t.rest_list.empty() && !t.gyro.ok && !t.accel.ok) {
    Panel p = make_panel(y + 10, 60, 0, 1, 0, 1);
    caption_in(page, p,
               "no temperature model: " + (t.status.empty() ? std::string("?") : t.status));
    frame(page, p);
    return p.y + p.h + 30;
  }
  // The temperature range: the rests' and the model's.
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (const TemperatureRest& r : t.rest_list)
    if (std::isfinite(r.temperature_c)) {
      lo = std::min(lo, r.temperature_c);
      hi = std::max(hi, r.temperature_c);
    }
  for (double v : {t.min_c, t.max_c})
    if (std::isfinite(v)) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  if (!(lo <= hi)) lo = hi = 20;
  if (hi - lo < 1) {
    lo -= 0.5;
    hi += 0.5;
  }
  pad_range(lo, hi, 0.04);

  const double gap = 100, w = (kPlotWidth - gap) / 2, h = 220;
  const std::string gyro_unit = gyro_unit_name(options.gyro_unit);
  const std::string accel_unit = accel_unit_name(options.accel_unit);
  struct Side {
    const TemperatureBiasResult& bias;
    bool gyro;
    std::string name, unit;
    double x;
  };
  const Side sides[2] = {{t.gyro, true, "gyroscope", gyro_unit, kPlotLeft},
                         {t.accel, false, "accelerometer", accel_unit, kPlotLeft + w + gap}};
  double bottom = y;
  for (const Side& side : sides) {
    Panel p;
    p.x = side.x;
    p.y = y + 30;
    p.w = w;
    p.h = h;
    p.sx = {lo, hi, p.x, p.x + p.w, false};
    p.sy = {0, 1, p.y + p.h, p.y, false};
    page.text(p.x, p.y - 8,
              side.name + (side.gyro ? ": each rest's bias (\u2212 mean rate), the fit"
                                     : ": the fit; ticks: the rests' temperatures"),
              "class=\"k\"");
    double cy = p.y + p.h + 52;
    if (!side.gyro && !side.bias.ok) {
      page.rect(p.x, p.y, p.w, p.h, "class=\"fr\"");
      caption_in(
          page, p,
          "no accelerometer model: " + (side.bias.status.empty() ? t.status : side.bias.status));
    } else {
      temperature_panel(page, p, t, side.bias, side.gyro, side.unit);
    }
    std::vector<std::string> lines;
    if (side.bias.ok) {
      lines.push_back("b1 (x, y, z) = " + triple(side.bias.b1) + " " + side.unit + "/\u00b0C");
      lines.push_back("  \u03c3 = " + triple(side.bias.b1_sigma) + " " + side.unit + "/\u00b0C");
      // The slope in physical units, through the calibrated scale.
      const bool cal = side.gyro ? run.gyro_ok : run.accel_ok;
      if (cal) {
        double phys[3];
        bool finite = true;
        for (int a = 0; a < 3; ++a) {
          const double s = side.gyro ? run.gyro_params[static_cast<std::size_t>(6 + a)]
                                     : run.accel_params[static_cast<std::size_t>(3 + a)];
          phys[a] = side.bias.b1[a] * s * (side.gyro ? kDeg : 1000 / gravity(options));
          finite = finite && std::isfinite(phys[a]);
        }
        if (finite)
          lines.push_back("  = " + triple(phys) + (side.gyro ? " deg/s/\u00b0C" : " mg/\u00b0C"));
      }
      if (t.order >= 2)
        lines.push_back("b2 = " + triple(side.bias.b2) + " \u00b1 " + triple(side.bias.b2_sigma) +
                        " " + side.unit + "/\u00b0C\u00b2");
      lines.push_back("T0 = " + printf_string("%.2f", t.reference_c) + " \u00b0C, " +
                      std::to_string(t.rests) + " rests over " + printf_string("%.1f", t.min_c) +
                      " \u2026 " + printf_string("%.1f", t.max_c) + " \u00b0C");
    } else if (side.gyro) {
      lines.push_back("no gyroscope model: " +
                      (side.bias.status.empty() ? t.status : side.bias.status));
    }
    for (const std::string& line : lines) {
      page.text(p.x, cy, line, "class=\"cap\"");
      cy += 15;
    }
    bottom = std::max(bottom, cy);
  }
  return bottom + 22;
}

}  // namespace imucal::cli::report
