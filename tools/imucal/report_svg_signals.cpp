// SPDX-License-Identifier: MIT
// tools/imucal/report_svg_signals.cpp: the report page's signal panels: raw accelerometer and
// gyroscope over time, rests shaded and numbered; |a| before and after the calibration.
#include "report_svg_sections.hpp"

namespace imucal::cli::report {

namespace {

struct ValueRange {
  double lo = HUGE_VAL, hi = -HUGE_VAL;    // what is drawn
  double min = HUGE_VAL, max = -HUGE_VAL;  // the extremes
  bool clipped = false;
  bool empty() const { return !(min <= max); }
};

ValueRange raw_range(const std::vector<Sample>& samples, const TimeAxis& t, bool gyro) {
  ValueRange r;
  std::vector<double> some;  // at most ~300k values for the quantiles
  const std::size_t stride = std::max<std::size_t>(1, samples.size() / 100000);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const Sample& s = samples[i];
    if (!std::isfinite(s.t) || s.t < t.lo || s.t > t.hi) continue;
    for (double v : gyro ? s.gyro : s.acc) {
      if (!std::isfinite(v)) continue;
      r.min = std::min(r.min, v);
      r.max = std::max(r.max, v);
      if (i % stride == 0) some.push_back(v);
    }
  }
  r.lo = r.min;
  r.hi = r.max;
  if (r.empty() || some.size() < 100) return r;
  const double q_lo = quantile(some, 0.0005), q_hi = quantile(some, 0.9995);
  const double span = q_hi - q_lo;
  if (span > 0 && r.max - r.min > 3 * span) {
    r.lo = std::max(r.min, q_lo - 0.25 * span);
    r.hi = std::min(r.max, q_hi + 0.25 * span);
    r.clipped = true;
  }
  return r;
}

}  // namespace

// Raw accelerometer or gyroscope, three axes over time.
double signal_section(Page& page, double y, double h, const Run& run,
                      const std::vector<Sample>& samples, const TimeAxis& t, bool gyro,
                      const std::string& title, const std::string& unit, bool numbers,
                      bool time_title) {
  const ValueRange range = raw_range(samples, t, gyro);
  section_title(
      page, y,
      title + (range.clipped ? " \u00b7 outliers drawn at the edge (extremes " +
                                   value_text(range.min) + " \u2026 " + value_text(range.max) + ")"
                             : ""));
  if (!range.empty())
    legend(page, y, {{"x", kAxisColour[0]}, {"y", kAxisColour[1]}, {"z", kAxisColour[2]}});
  double lo = range.lo, hi = range.hi;
  const bool have_values = !range.empty();
  pad_range(lo, hi, 0.04);
  const Panel p = make_panel(y + 10, h, t.lo, t.hi, lo, hi);
  if (t.valid) {
    rest_bands(page, p, run, numbers);
    time_grid(page, p, t, time_title);
  }
  if (have_values) {
    value_grid(page, p, unit);
    const double gap = gap_threshold(run, t);
    for (int a = 0; a < 3; ++a) {
      auto value_of = [&](std::size_t i) { return gyro ? samples[i].gyro[a] : samples[i].acc[a]; };
      const std::string d = series_path(p, samples, value_of, gap);
      page.path(d, std::string("class=\"s\" stroke=\"") + kAxisColour[a] + "\"");
    }
  } else {
    caption_in(page, p, samples.empty() ? "no samples: nothing to show" : "no finite values");
  }
  frame(page, p);
  return p.y + p.h + (time_title ? 58 : 44);
}

// |a| before and after over time, the pose levels, gravity.
double norm_section(Page& page, double y, const Run& run, const Options& options,
                    const std::vector<Sample>& samples, const TimeAxis& t) {
  const double g = gravity(options);
  const bool after = run.accel_ok && usable_params(run.accel_params);
  const bool before = run.have_nominal_accel && usable_params(run.accel_nominal);
  const AccelModel cal(run.accel_params), nominal(run.accel_nominal);

  section_title(page, y, "Gravity norm |a| (m/s\u00b2): before and after calibration");
  std::vector<LegendItem> items;
  if (before) items.push_back({"before (nominal model)", kBeforeColour});
  if (after) items.push_back({"after (calibrated)", kAfterColour});
  items.push_back({"gravity " + printf_string("%.6g", g), "#000000", LegendItem::kDashed});
  if (!samples.empty() || !run.pose_list.empty()) legend(page, y, items);

  // The range: from the rest samples and the pose levels (at most ~200k samples looked at).
  std::vector<double> rest_after, rest_before;
  const std::size_t stride = std::max<std::size_t>(1, samples.size() / 200000);
  std::size_t k = 0;
  for (std::size_t i = 0; i < samples.size() && k < run.pose_list.size(); i += stride) {
    const Sample& s = samples[i];
    if (!std::isfinite(s.t) || !finite3(s.acc)) continue;
    while (k < run.pose_list.size() && s.t > run.pose_list[k].t_end) ++k;
    if (k >= run.pose_list.size() || s.t < run.pose_list[k].t_begin) continue;
    if (after) rest_after.push_back(cal.norm(s.acc));
    if (before) rest_before.push_back(nominal.norm(s.acc));
  }
  auto half_range = [&](std::vector<double>& values, bool use_pose_before) {
    double half = 0;
    if (!values.empty())
      half =
          std::max(std::fabs(quantile(values, 0.005) - g), std::fabs(quantile(values, 0.995) - g));
    for (const PoseResult& pose : run.pose_list) {
      const double r = use_pose_before ? pose.residual_before : pose.residual_after;
      if (std::isfinite(r)) half = std::max(half, std::fabs(r));
    }
    return std::isfinite(half) ? half : 0.0;
  };
  const double half_after = after ? half_range(rest_after, false) : 0;
  const double half_before = before ? half_range(rest_before, true) : 0;
  const double min_half = 0.05;  // m/s^2: the smallest range drawn
  double half = std::max({1.25 * half_after, 1.1 * half_before, min_half});
  if (rest_after.empty() && rest_before.empty() && run.pose_list.empty()) half = 1;  // no rests
  const bool zoom = after && before && half > 4 * std::max(1.25 * half_after, min_half);

  // Which samples lie in a rest: drawn strongly there, faintly during motion.
  std::vector<bool> in_rest(samples.size(), false);
  k = 0;
  for (std::size_t i = 0; i < samples.size() && k < run.pose_list.size(); ++i) {
    const double ts = samples[i].t;
    while (k < run.pose_list.size() && ts > run.pose_list[k].t_end) ++k;
    in_rest[i] = k < run.pose_list.size() && ts >= run.pose_list[k].t_begin;
  }
  const double gap = gap_threshold(run, t);
  auto series = [&](const Panel& p, const AccelModel& model, const char* colour) {
    for (bool rest : {false, true}) {
      auto value_of = [&](std::size_t i) {
        return in_rest[i] == rest ? model.norm(samples[i].acc) : kNaN;
      };
      page.path(series_path(p, samples, value_of, gap),
                std::string("class=\"s\" stroke=\"") + colour + "\"" +
                    (rest ? "" : " stroke-opacity=\"0.25\""));
    }
  };
  auto draw = [&](const Panel& p, bool with_before, bool time_title) {
    if (t.valid) {
      rest_bands(page, p, run, !zoom || with_before);
      time_grid(page, p, t, time_title);
    }
    value_grid(page, p, "m/s\u00b2");
    const double gy = p.sy(g);
    if (with_before) series(p, nominal, kBeforeColour);
    if (after) series(p, cal, kAfterColour);
    page.line(p.x, gy, p.x + p.w, gy, "stroke=\"#000\" stroke-dasharray=\"6 4\"");
    // The pose means' levels, g - residual, as short thick bars over each rest.
    for (const PoseResult& pose : run.pose_list) {
      if (pose.t_end < p.sx.d0 || pose.t_begin > p.sx.d1) continue;
      const double x0 = std::max(p.sx(pose.t_begin), p.x);
      const double x1 = std::min(p.sx(pose.t_end), p.x + p.w);
      if (!std::isfinite(x0) || !std::isfinite(x1) || x1 < x0) continue;
      const double lo = std::min(p.sy.d0, p.sy.d1), hi = std::max(p.sy.d0, p.sy.d1);
      auto level = [&](double r, const char* colour) {
        if (!std::isfinite(r)) return;
        const double yl = p.sy(std::clamp(g - r, lo, hi));
        page.line(x0, yl, std::max(x1, x0 + 2), yl,
                  std::string("stroke=\"") + colour + "\" stroke-width=\"3\"");
      };
      if (with_before) level(pose.residual_before, "#424242");
      if (after) level(pose.residual_after, "#0d47a1");
    }
    frame(page, p);
  };

  Panel p = make_panel(y + 10, 200, t.lo, t.hi, g - half, g + half);
  const bool drawn = (before || after) && !(samples.empty() && run.pose_list.empty());
  if (!before && !after) {
    if (t.valid) time_grid(page, p, t, true);
    caption_in(page, p, "accelerometer not calibrated and no nominal model: nothing to show");
    frame(page, p);
  } else if (samples.empty() && run.pose_list.empty()) {
    if (t.valid) time_grid(page, p, t, true);
    caption_in(page, p, "no samples and no rests: nothing to show");
    frame(page, p);
  } else {
    draw(p, before, !zoom);
  }
  y = p.y + p.h + (zoom ? 44 : 58);
  if (zoom) {
    const double zoom_half = std::max(1.25 * half_after, min_half);
    section_title(page, y, "|a| after calibration, zoomed (m/s\u00b2)");
    p = make_panel(y + 10, 130, t.lo, t.hi, g - zoom_half, g + zoom_half);
    draw(p, false, true);
    y = p.y + p.h + 58;
  }
  if (drawn)
    page.text(kPlotLeft, y - 4,
              "Thick bars over the rests: |a| of each pose mean. Faint: during motion (|a| is not "
              "gravity there). Values outside the range are drawn at the panel's edge.",
              "class=\"cap\"");
  if (!before) {
    page.text(kPlotLeft, y + 11,
              run.have_nominal_accel
                  ? "before: the nominal model is not usable"
                  : "before not shown: no nominal accelerometer scale: give --accel-lsb-per-g",
              "class=\"cap\"");
    y += 15;
  }
  if (!after && before) {
    page.text(kPlotLeft, y + 11,
              "after not shown: accelerometer not calibrated" +
                  (run.accel_status.empty() ? std::string() : " (" + run.accel_status + ")"),
              "class=\"cap\"");
    y += 15;
  }
  return y + 26;
}

// One pair of bars (before, after) per item; a log scale when before dwarfs after.

}  // namespace imucal::cli::report
