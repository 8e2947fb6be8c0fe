// SPDX-License-Identifier: MIT
// tools/imucal/report_svg_magnetometer.cpp: the report page's magnetometer panels: raw readings
// against the calibrated sphere in three projections.
#include "report_svg_sections.hpp"

namespace imucal::cli::report {

namespace {

constexpr const char* kRawCloudColour = "#78909c";
constexpr const char* kCalCloudColour = "#1565c0";
constexpr const char* kHeldColour = "#ef6c00";
constexpr const char* kFitColour = "#111";
constexpr std::size_t kCloudPoints = 2000;  // readings drawn per cloud, at most

// A square scatter panel with the same scale on both axes, so that a sphere stays round.
struct Square {
  double x = 0, y = 0, size = 100;  // pixels
  double cx = 0, cy = 0, half = 1;  // data centre and half-span (both axes)
  double px(double v) const { return x + 0.5 * size + (v - cx) / half * 0.5 * size; }
  double py(double v) const { return y + 0.5 * size - (v - cy) / half * 0.5 * size; }
  bool inside(double vx, double vy) const {
    return std::fabs(vx - cx) <= half && std::fabs(vy - cy) <= half;
  }
};

void square_grid(Page& page, const Square& s, const std::string& x_label,
                 const std::string& y_label) {
  const double step = nice_step(2 * s.half, 5);
  for (double v : ticks(s.cx - s.half, s.cx + s.half, step)) {
    const double x = s.px(v);
    page.line(x, s.y, x, s.y + s.size, "class=\"g\"");
    page.line(x, s.y + s.size, x, s.y + s.size + 4, "class=\"tk\"");
    page.text(x, s.y + s.size + 16, tick_text(v, step), "class=\"n\" text-anchor=\"middle\"");
  }
  for (double v : ticks(s.cy - s.half, s.cy + s.half, step)) {
    const double y = s.py(v);
    page.line(s.x, y, s.x + s.size, y, "class=\"g\"");
    page.line(s.x - 4, y, s.x, y, "class=\"tk\"");
    page.text(s.x - 7, y + 4, tick_text(v, step), "class=\"n\" text-anchor=\"end\"");
  }
  page.text(s.x + 0.5 * s.size, s.y + s.size + 32, x_label, "class=\"ax\" text-anchor=\"middle\"");
  page.vertical_text(s.x - 52, s.y + 0.5 * s.size, y_label, "class=\"ax\"");
}

// Points as one path of tiny strokes (round caps make them dots): a few bytes each, whole
// pixels, one per pixel. Points outside the panel are not drawn.
std::string dot_path(const Square& s, const std::vector<Vector3<double>>& points, int i, int j) {
  std::string d;
  std::vector<long> seen;
  seen.reserve(points.size());
  for (const Vector3<double>& p : points) {
    if (!std::isfinite(p(i)) || !std::isfinite(p(j)) || !s.inside(p(i), p(j))) continue;
    const long x = std::lround(s.px(p(i))), y = std::lround(s.py(p(j)));
    seen.push_back(x * 100000 + y);  // pixels: 0 .. 99999 (the page is far smaller)
  }
  std::sort(seen.begin(), seen.end());
  seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
  // Relative moves between whole pixels, in sorted order: "m3-5h0" (zero-length strokes
  // with round caps are dots).
  long px = 0, py = 0;
  bool first = true;
  for (long key : seen) {
    const long x = key / 100000, y = key % 100000;
    const long dx = first ? x : x - px, dy = first ? y : y - py;
    d += (first ? "M" : "m") + std::to_string(dx) + (dy < 0 ? "" : " ") + std::to_string(dy) + "h0";
    px = x;
    py = y;
    first = false;
  }
  return d;
}

// Small rings (the collector's samples), as one path.
std::string ring_path(const Square& s, const std::vector<Vector3<double>>& points, int i, int j,
                      double r) {
  std::string d;
  const std::string rs = coord(r), ds = coord(2 * r);
  for (const Vector3<double>& p : points) {
    if (!std::isfinite(p(i)) || !std::isfinite(p(j)) || !s.inside(p(i), p(j))) continue;
    d += "M" + coord(s.px(p(i)) - r) + " " + coord(s.py(p(j))) + "a" + rs + " " + rs + " 0 1 0 " +
         ds + " 0a" + rs + " " + rs + " 0 1 0 -" + ds + " 0";
  }
  return d;
}

// The outline of the ellipsoid {c + A u : |u| = 1} projected on the axes i, j: the ellipse of
// the 2x2 block of A A^T (through its Cholesky factor).
std::string ellipse_path(const Square& s, const Vector3<double>& c, const Matrix3<double>& a, int i,
                         int j) {
  const Matrix3<double> q = a * a.transpose();
  const double l00 = std::sqrt(q(i, i));
  if (!(l00 > 0) || !std::isfinite(l00)) return {};
  const double l10 = q(j, i) / l00;
  const double l11 = std::sqrt(std::max(q(j, j) - l10 * l10, 0.0));
  PathBuilder path;
  for (int k = 0; k <= 96; ++k) {
    const double t = 2 * kPi * k / 96, u = std::cos(t), v = std::sin(t);
    const double x = c(i) + l00 * u, y = c(j) + l10 * u + l11 * v;
    path.point(s.px(x), s.py(y));
  }
  return path.str();
}

}  // namespace

double mag_section(Page& page, double y, const Run& run, const Options& options,
                   const std::vector<Sample>& samples) {
  const MagResult& mag = run.mag;
  // The readings drawn: every k-th finite one, at most ~kCloudPoints.
  std::size_t finite = 0;
  for (const Sample& s : samples) finite += finite3(s.mag);
  if (finite == 0 && mag.held.empty() && !mag.present) return y;
  const std::size_t stride = std::max<std::size_t>(1, (finite + kCloudPoints - 1) / kCloudPoints);
  std::vector<Vector3<double>> raw, held;
  raw.reserve(finite / stride + 1);
  std::size_t k = 0;
  for (const Sample& s : samples) {
    if (!finite3(s.mag)) continue;
    if (k++ % stride == 0) raw.emplace_back(s.mag[0], s.mag[1], s.mag[2]);
  }
  for (const std::array<double, 3>& h : mag.held)
    if (finite3(h.data())) held.emplace_back(h[0], h[1], h[2]);

  Matrix3<double> soft;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) soft(r, c) = mag.soft_iron[r][c];
  const Vector3<double> hard(mag.hard_iron[0], mag.hard_iron[1], mag.hard_iron[2]);
  const bool calibrated = mag.ok && soft.allFinite() && hard.allFinite() &&
                          std::isfinite(mag.field_ut) && mag.field_ut > 0 &&
                          std::fabs(soft.determinant()) > 0;

  const std::string unit = mag_unit_name(options.mag_unit);
  section_title(page, y, "Magnetometer: raw (" + unit + ") and calibrated (\u00b5T)");
  std::vector<LegendItem> items;
  items.push_back({stride > 1 ? "readings (1 in " + std::to_string(stride) + ")" : "readings",
                   kRawCloudColour, LegendItem::kBox});
  if (!held.empty()) items.push_back({"held by the collector", kHeldColour, LegendItem::kBox});
  if (calibrated)
    items.push_back({"fitted ellipsoid / field sphere", kFitColour, LegendItem::kDashed});
  legend(page, y, items);

  const int axes[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  const char* names[3] = {"x", "y", "z"};
  const double size = 290, gap = (kPlotWidth - 3 * size) / 2;
  const double held_r = 3.2;

  // Raw: one scale for the three panels, each centred on its data; the range from the 0.1 % and
  // 99.9 % quantiles per axis (a glitch does not squash the cloud) and the fitted ellipsoid.
  double lo[3], hi[3];
  const Matrix3<double> to_raw =
      calibrated ? Matrix3<double>(mag.field_ut * soft.inverse()) : Matrix3<double>::Identity();
  for (int a = 0; a < 3; ++a) {
    std::vector<double> v;
    for (const auto& p : raw) v.push_back(p(a));
    for (const auto& p : held) v.push_back(p(a));
    lo[a] = quantile(v, 0.001);
    hi[a] = quantile(v, 0.999);
    if (calibrated) {
      const double e = to_raw.row(a).norm();  // the ellipsoid's half-extent along axis a
      if (std::isfinite(e)) {
        lo[a] = std::isfinite(lo[a]) ? std::min(lo[a], -hard(a) - e) : -hard(a) - e;
        hi[a] = std::isfinite(hi[a]) ? std::max(hi[a], -hard(a) + e) : -hard(a) + e;
      }
    }
  }
  double half = 0;
  for (int a = 0; a < 3; ++a)
    if (std::isfinite(lo[a]) && std::isfinite(hi[a])) half = std::max(half, 0.5 * (hi[a] - lo[a]));
  half = half > 0 ? 1.08 * half : 1;

  double row_y = y + 16;
  std::size_t outside = 0;
  for (int pi = 0; pi < 3; ++pi) {
    const int i = axes[pi][0], j = axes[pi][1];
    Square s;
    s.x = kPlotLeft + pi * (size + gap);
    s.y = row_y;
    s.size = size;
    s.cx = std::isfinite(lo[i]) ? 0.5 * (lo[i] + hi[i]) : 0;
    s.cy = std::isfinite(lo[j]) ? 0.5 * (lo[j] + hi[j]) : 0;
    s.half = half;
    square_grid(page, s, std::string("m") + names[i] + " raw (" + unit + ")",
                std::string("m") + names[j] + " raw (" + unit + ")");
    for (const auto& p : raw) outside += pi == 0 && !s.inside(p(i), p(j));
    page.path(dot_path(s, raw, i, j), std::string("fill=\"none\" stroke=\"") + kRawCloudColour +
                                          "\" stroke-width=\"2.4\" stroke-linecap=\"round\"");
    if (calibrated) {
      page.path(ellipse_path(s, -hard, to_raw, i, j),
                std::string("fill=\"none\" stroke=\"") + kFitColour +
                    "\" stroke-width=\"1.3\" stroke-dasharray=\"6 4\"");
      const double hx = s.px(-hard(i)), hy = s.py(-hard(j));
      if (s.inside(-hard(i), -hard(j))) {
        page.line(hx - 6, hy, hx + 6, hy, "stroke=\"#111\" stroke-width=\"1.5\"");
        page.line(hx, hy - 6, hx, hy + 6, "stroke=\"#111\" stroke-width=\"1.5\"");
      }
    }
    page.path(ring_path(s, held, i, j, held_r),
              std::string("fill=\"none\" stroke=\"") + kHeldColour + "\" stroke-width=\"1.2\"");
    if (raw.empty() && held.empty())
      page.text(s.x + 0.5 * s.size, s.y + 0.5 * s.size, "no readings",
                "class=\"cap\" text-anchor=\"middle\"");
    page.rect(s.x, s.y, s.size, s.size, "class=\"fr\"");
    page.text(s.x + 6, s.y + 15, std::string(names[i]) + "\u2013" + names[j],
              "class=\"k\" fill-opacity=\"0.8\"");
  }
  row_y += size + 58;
  std::string raw_note =
      "Raw: an ellipsoid off centre (hard iron h shifts it, soft iron S shapes it)";
  if (calibrated) raw_note += "; dashed: the fitted ellipsoid's outline, cross: its centre \u2212h";
  raw_note += ".";
  if (outside > 0)
    raw_note +=
        " " + grouped(static_cast<long>(outside)) + " readings outside the range not drawn.";
  page.text(kPlotLeft, row_y - 12, raw_note, "class=\"cap\"");

  // Calibrated: S (m + h) about the origin, with the sphere of the fitted field.
  if (calibrated) {
    std::vector<Vector3<double>> cal, cal_held;
    cal.reserve(raw.size());
    for (const auto& p : raw) cal.push_back(soft * (p + hard));
    for (const auto& p : held) cal_held.push_back(soft * (p + hard));
    std::vector<double> extent;
    for (const auto& p : cal) extent.push_back(p.cwiseAbs().maxCoeff());
    double chalf = quantile(extent, 0.998);
    chalf = 1.12 *
            std::max(std::isfinite(chalf) ? std::min(chalf, 2 * mag.field_ut) : 0.0, mag.field_ut);
    const std::string frame_name = mag.aligned ? "accelerometer frame" : "sensor frame";
    for (int pi = 0; pi < 3; ++pi) {
      const int i = axes[pi][0], j = axes[pi][1];
      Square s;
      s.x = kPlotLeft + pi * (size + gap);
      s.y = row_y;
      s.size = size;
      s.half = chalf;
      square_grid(page, s, std::string("m") + names[i] + " calibrated (\u00b5T)",
                  std::string("m") + names[j] + " calibrated (\u00b5T)");
      page.path(dot_path(s, cal, i, j), std::string("fill=\"none\" stroke=\"") + kCalCloudColour +
                                            "\" stroke-width=\"2.4\" stroke-linecap=\"round\" "
                                            "stroke-opacity=\"0.75\"");
      const double r = mag.field_ut / s.half * 0.5 * s.size;
      page.circle(s.px(0), s.py(0), r,
                  std::string("fill=\"none\" stroke=\"") + kFitColour +
                      "\" stroke-width=\"1.3\" stroke-dasharray=\"6 4\"");
      page.path(ring_path(s, cal_held, i, j, held_r),
                std::string("fill=\"none\" stroke=\"") + kHeldColour + "\" stroke-width=\"1.2\"");
      page.rect(s.x, s.y, s.size, s.size, "class=\"fr\"");
      page.text(s.x + 6, s.y + 15, std::string(names[i]) + "\u2013" + names[j] + ", " + frame_name,
                "class=\"k\" fill-opacity=\"0.8\"");
    }
    row_y += size + 58;
    page.text(kPlotLeft, row_y - 12,
              "Calibrated: S (m + h), on a sphere of radius the field about the origin (dashed) "
              "\u00b7 field " +
                  value_text(mag.field_ut) + " \u00b5T \u00b7 fit error " +
                  value_text(mag.fit_error_pct) + " % \u00b7 coverage " +
                  value_text(100 * mag.coverage) + " % of the directions (needs " +
                  value_text(100 * options.mag_min_coverage) + " %) \u00b7 quality " + mag.quality,
              "class=\"cap\"");
    std::string align = std::to_string(mag.samples) + " readings held (rings) of " +
                        grouped(static_cast<long>(finite)) + " \u00b7 ";
    align += mag.aligned ? "aligned to the accelerometer frame over " + std::to_string(mag.rests) +
                               " rests: dip " + printf_string("%.2f", mag.dip_deg) + " \u00b1 " +
                               value_text(mag.dip_sigma_deg) + "\u00b0"
                         : "not aligned to the accelerometer frame" +
                               (mag.alignment_status.empty() ? std::string()
                                                             : " (" + mag.alignment_status + ")");
    page.text(kPlotLeft, row_y + 3, align, "class=\"cap\"");
    return row_y + 34;
  }
  page.text(kPlotLeft, row_y + 3,
            elide(clean_utf8("Not calibrated: " +
                             (mag.status.empty() ? std::string("no fit") : mag.status)),
                  170),
            "class=\"cap\"");
  std::string why;
  if (std::isfinite(mag.coverage))
    why += "coverage " + value_text(100 * mag.coverage) + " % of the directions (needs " +
           value_text(100 * options.mag_min_coverage) + " %) \u00b7 ";
  if (std::isfinite(mag.field_ut) && mag.field_ut > 0)
    why += "field " + value_text(mag.field_ut) + " \u00b5T \u00b7 ";
  if (std::isfinite(mag.fit_error_pct))
    why += "fit error " + value_text(mag.fit_error_pct) + " % \u00b7 ";
  why += std::to_string(mag.samples) + " readings held (rings) of " +
         grouped(static_cast<long>(finite));
  page.text(kPlotLeft, row_y + 18, why, "class=\"cap\"");
  return row_y + 49;
}

}  // namespace imucal::cli::report
