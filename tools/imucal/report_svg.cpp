// SPDX-License-Identifier: MIT
// tools/imucal/report_svg.cpp: the `imucal` tool's SVG report page (host only).
//
// One self-contained SVG (no scripts, no external resources, no fonts to fetch): a title block,
// the raw accelerometer and gyroscope over time with the rests shaded and numbered, |a| before
// and after the calibration, the per-pose and per-move residuals, and the pose directions on two
// hemispheres; with a magnetometer, its raw readings and the calibrated ones in three projections
// (the raw ellipsoid against the calibrated sphere, the collector's samples marked); with a
// temperature column, the biases against temperature (the rests and the fitted b(T)). Long
// recordings are drawn with the minimum and maximum of each pixel column, and point clouds are
// decimated, so the page's size does not grow with the number of samples and spikes stay
// visible. Every coordinate is checked: a non-finite point is skipped, never written.
#include <cmath>
#include <string>
#include <vector>

#include "report_svg_sections.hpp"

namespace imucal::cli {
namespace report {
namespace {

const char* quality_colour(const std::string& q) {
  if (q == "good") return "#2e7d32";
  if (q == "fair") return "#ef8f00";
  if (q == "poor") return "#c62828";
  return "#757575";
}

// One line each for the title block: what the magnetometer's fit and the temperature model gave.
std::string mag_summary(const MagResult& m) {
  std::string s = m.status.empty() ? std::string("?") : m.status;
  if (m.ok)
    s += " \u00b7 field " + value_text(m.field_ut) + " \u00b5T \u00b7 fit error " +
         value_text(m.fit_error_pct) + " % \u00b7 coverage " + value_text(100 * m.coverage) +
         " % \u00b7 quality " + m.quality;
  else if (std::isfinite(m.coverage))
    s += " \u00b7 coverage " + value_text(100 * m.coverage) + " %";
  if (m.ok && m.aligned) s += " \u00b7 aligned, dip " + printf_string("%.1f", m.dip_deg) + "\u00b0";
  return s;
}

std::string temperature_summary(const TemperatureResult& t) {
  std::string s = t.status.empty() ? std::string("?") : t.status;
  if (std::isfinite(t.min_c) && std::isfinite(t.max_c))
    s += " \u00b7 " + std::to_string(t.rests) + " rests over " + printf_string("%.1f", t.min_c) +
         " \u2026 " + printf_string("%.1f", t.max_c) + " \u00b0C";
  if (std::isfinite(t.reference_c))
    s += " \u00b7 T0 " + printf_string("%.2f", t.reference_c) + " \u00b0C";
  s += " \u00b7 accelerometer " + (t.accel.status.empty() ? std::string("?") : t.accel.status) +
       ", gyroscope " + (t.gyro.status.empty() ? std::string("?") : t.gyro.status);
  return s;
}

}  // namespace

double title_block(Page& page, const Run& run, const Options& options) {
  page.text(30, 38, "imucal calibration report", "class=\"t\"");
  // Quality badge, top right.
  const std::string quality = run.quality.empty() ? "none" : run.quality;
  const char* qc = quality_colour(quality);
  page.rect(
      kPlotRight - 170, 14, 170, 48,
      std::string("rx=\"6\" fill=\"") + qc + "\" fill-opacity=\"0.12\" stroke=\"" + qc + "\"");
  page.text(kPlotRight - 85, 32, "quality", "class=\"lg\" text-anchor=\"middle\"");
  page.text(kPlotRight - 85, 54, quality,
            std::string("text-anchor=\"middle\" font-size=\"19\" font-weight=\"bold\" fill=\"") +
                qc + "\"");
  page.text(kPlotRight - 85, 78, run.usable ? "usable" : "not usable",
            "class=\"cap\" text-anchor=\"middle\"");

  std::string files;
  for (const std::string& f : options.files) files += (files.empty() ? "" : ", ") + f;
  if (files.empty()) files = "(no file)";
  files = elide(clean_utf8(files), 110);

  const double duration = run.t_last - run.t_first;
  const double g = gravity(options);
  auto or_unknown = [](const std::string& text) { return text.empty() ? std::string("?") : text; };
  std::string recording =
      or_unknown(run.format) + " \u00b7 " + grouped(run.samples) + " samples \u00b7 " +
      (run.samples > 1 && std::isfinite(duration) ? value_text(duration) + " s" : "no duration") +
      " \u00b7 " + (run.rate_hz > 0 ? value_text(run.rate_hz) + " Hz" : "rate n/a");
  if (run.lines_skipped > 0)
    recording += " \u00b7 " + grouped(run.lines_skipped) + " lines skipped";
  if (run.diagnostic_count > 0)
    recording += " \u00b7 " + grouped(run.diagnostic_count) + " input diagnostics";
  struct Row {
    std::string key, value;
  };
  std::vector<Row> rows = {
      {"input", files},
      {"recording", recording},
      {"calibrator", or_unknown(run.scalar) + " \u00b7 gravity " + printf_string("%.6g", g) +
                         " m/s\u00b2 \u00b7 " + std::to_string(run.poses) + " poses, " +
                         std::to_string(run.faces_covered) + " of 6 faces \u00b7 " +
                         std::to_string(run.moves) + " moves"},
      {"accelerometer", or_unknown(run.accel_status) +
                            " \u00b7 pose RMS of |g| \u2212 |a|, before \u2192 after: " +
                            value_text(run.accel_pose_rms_before) + " \u2192 " +
                            value_text(run.accel_pose_rms_after) + " m/s\u00b2"},
      {"gyroscope",
       or_unknown(run.gyro_status) + " \u00b7 RMS angle per move, before \u2192 after: " +
           value_text(run.gyro_rms_before) + " \u2192 " + value_text(run.gyro_rms_after) + " deg" +
           (run.gyro_bias_refined ? " \u00b7 bias refined" : "")},
  };
  if (run.mag.present)
    rows.push_back({"magnetometer", elide(clean_utf8(mag_summary(run.mag)), 140)});
  if (run.temperature.present)
    rows.push_back({"temperature", elide(clean_utf8(temperature_summary(run.temperature)), 140)});
  double y = 66;
  for (const Row& r : rows) {
    page.text(30, y, r.key, "class=\"k\"");
    page.text(150, y, r.value, "class=\"v\"");
    y += 19;
  }
  return y + 10;
}

// The value range of a raw panel: all the values, unless a few outliers (a saturated sample, a
// glitch) would squash the rest; then the 0.05 % .. 99.95 % quantiles, widened, and the outliers
// are drawn at the panel's edge.

}  // namespace report

std::string report_svg(const Run& run, const Options& options, const std::vector<Sample>& samples) {
  using namespace report;
  Page page;
  const TimeAxis t = time_axis(run, samples);
  double y = title_block(page, run, options) + 14;

  int split = 0;
  for (const PoseResult& pose : run.pose_list) split += pose.continues > 0 ? 1 : 0;
  y = signal_section(page, y, 190, run, samples, t, false,
                     "Accelerometer, raw (" + std::string(accel_unit_name(options.accel_unit)) +
                         "), rests shaded and numbered" +
                         (split > 0 ? std::string("; in orange, ") + std::to_string(split) +
                                          (split == 1 ? " rest" : " rests") +
                                          " split from the one before by a bump"
                                    : std::string()),
                     std::string(accel_unit_name(options.accel_unit)), true, false);
  y = signal_section(page, y, 160, run, samples, t, true,
                     "Gyroscope, raw (" + std::string(gyro_unit_name(options.gyro_unit)) + ")",
                     std::string(gyro_unit_name(options.gyro_unit)), false, true);
  y = norm_section(page, y, run, options, samples, t);

  Bars poses;
  poses.title = "Residual per pose: |g| \u2212 |a| of the pose mean (bars: magnitude)";
  poses.unit = "m/s\u00b2";
  poses.after_colour = kAfterColour;
  poses.empty_text = "no poses: nothing to show";
  poses.item_name = "pose";
  poses.rms_before = run.accel_pose_rms_before;
  poses.rms_after = run.accel_pose_rms_after;
  for (std::size_t i = 0; i < run.pose_list.size(); ++i) {
    const PoseResult& p = run.pose_list[i];
    poses.before.push_back(p.residual_before);
    poses.after.push_back(p.residual_after);
    poses.tips.push_back(printf_string(
        "pose %zu (%.2f .. %.2f s): before %s, after %s m/s\u00b2", i + 1, p.t_begin, p.t_end,
        value_text(p.residual_before).c_str(), value_text(p.residual_after).c_str()));
  }
  y = bar_section(page, y, poses);

  Bars moves;
  moves.title = "Residual per move: angle between carried and measured gravity";
  moves.unit = "deg";
  moves.after_colour = kAfterColour;
  moves.empty_text = "no moves: nothing to show";
  moves.item_name = "move";
  moves.rms_before = run.gyro_rms_before;
  moves.rms_after = run.gyro_rms_after;
  for (std::size_t i = 0; i < run.move_list.size(); ++i) {
    const MoveResult& m = run.move_list[i];
    moves.before.push_back(m.angle_before);
    moves.after.push_back(m.angle_after);
    moves.tips.push_back(printf_string(
        "move %zu: pose %ld \u2192 %ld, %.2f s, %d segments: before %s, after %s deg", i + 1,
        static_cast<long>(m.from) + 1, static_cast<long>(m.to) + 1, m.duration, m.segments,
        value_text(m.angle_before).c_str(), value_text(m.angle_after).c_str()));
  }
  y = bar_section(page, y, moves);

  y = sphere_section(page, y, run);
  y = mag_section(page, y, run, options, samples);
  y = temperature_section(page, y, run, options);

  return svg_document(page, y, "imucal calibration report");
}

}  // namespace imucal::cli
