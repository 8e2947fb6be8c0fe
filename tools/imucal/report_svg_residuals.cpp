// SPDX-License-Identifier: MIT
// tools/imucal/report_svg_residuals.cpp: the report page's residual bars (per pose, per move) and
// the pose directions on two hemispheres.
#include "report_svg_sections.hpp"

namespace imucal::cli::report {

double bar_section(Page& page, double y, const Bars& bars) {
  section_title(page, y, bars.title);
  const std::size_t n = bars.after.size();
  bool any_before = false;
  double lo = HUGE_VAL, hi = 0;
  std::vector<double> sizes[2];  // the nonzero magnitudes, before and after
  for (std::size_t i = 0; i < n; ++i) {
    const double values[2] = {bars.before[i], bars.after[i]};
    for (int k = 0; k < 2; ++k) {
      const double a = std::fabs(values[k]);
      if (!std::isfinite(a) || a == 0) continue;
      lo = std::min(lo, a);
      hi = std::max(hi, a);
      sizes[k].push_back(a);
    }
    any_before = any_before || std::isfinite(bars.before[i]);
  }
  for (double r : {bars.rms_before, bars.rms_after}) {
    if (!std::isfinite(r) || r <= 0) continue;
    lo = std::min(lo, r);
    hi = std::max(hi, r);
  }
  // A log scale when the typical before is more than ten times the typical after.
  const bool log = !sizes[0].empty() && !sizes[1].empty() &&
                   quantile(sizes[0], 0.5) > 10 * quantile(sizes[1], 0.5);
  double y_lo = 0, y_hi = 1;
  if (log) {
    y_lo = std::pow(10.0, std::floor(std::log10(lo) + 1e-9));
    y_hi = std::pow(10.0, std::ceil(std::log10(hi) - 1e-9));
    y_lo = std::max(y_lo, y_hi * 1e-12);  // smaller ones (rounding noise) sit on the axis
    if (y_hi <= y_lo) y_hi = y_lo * 10;
  } else if (hi > 0) {
    const double step = nice_step(hi, 4);
    y_hi = std::ceil(hi * 1.05 / step) * step;
  }
  std::vector<LegendItem> items;
  if (any_before) items.push_back({"before", kBeforeColour, LegendItem::kBox});
  items.push_back({"after", bars.after_colour, LegendItem::kBox});
  if (any_before && std::isfinite(bars.rms_before))
    items.push_back(
        {"RMS before " + value_text(bars.rms_before), kBeforeColour, LegendItem::kDashed});
  if (std::isfinite(bars.rms_after))
    items.push_back(
        {"RMS after " + value_text(bars.rms_after), bars.after_colour, LegendItem::kDashed});
  if (n > 0) legend(page, y, items);

  const Panel p =
      make_panel(y + 10, 150, 0, static_cast<double>(std::max<std::size_t>(n, 1)), y_lo, y_hi, log);
  if (n == 0 || hi <= 0) {
    caption_in(page, p, n == 0 ? bars.empty_text : "no nonzero values to show");
    frame(page, p);
    return p.y + p.h + 30;
  }
  value_grid(page, p, bars.unit + (log ? ", log scale" : ""));
  const double group = p.w / static_cast<double>(n);
  const double bar_w = any_before ? std::min(group * 0.4, 16.0) : std::min(group * 0.6, 22.0);
  const double base = p.y + p.h;
  auto bar = [&](double x, double v, const std::string& colour, const std::string& tip) {
    if (!std::isfinite(v) || v == 0) return;
    const double a = std::clamp(std::fabs(v), log ? y_lo : 0.0, y_hi);
    const double top = p.sy(a);
    if (!std::isfinite(top)) return;
    page.rect(x, top, bar_w, base - top, "fill=\"" + colour + "\"", tip);
  };
  std::size_t label_every = 1;
  for (std::size_t k : {1u, 2u, 5u, 10u, 20u, 50u, 100u, 200u, 500u, 1000u}) {
    label_every = k;
    if (group * static_cast<double>(k) >= 24) break;
  }
  for (std::size_t i = 0; i < n; ++i) {
    const double xc = p.x + (static_cast<double>(i) + 0.5) * group;
    if (any_before) {
      bar(xc - bar_w, bars.before[i], kBeforeColour, bars.tips[i]);
      bar(xc, bars.after[i], bars.after_colour, bars.tips[i]);
    } else {
      bar(xc - bar_w / 2, bars.after[i], bars.after_colour, bars.tips[i]);
    }
    if ((i + 1) % label_every == 0 || i == 0) {
      page.line(xc, base, xc, base + 4, "class=\"tk\"");
      page.text(xc, base + 16, std::to_string(i + 1), "class=\"n\" text-anchor=\"middle\"");
    }
  }
  for (int which = 0; which < 2; ++which) {
    const double r = which == 0 ? bars.rms_before : bars.rms_after;
    if (!std::isfinite(r) || r <= 0 || (which == 0 && !any_before)) continue;
    if (r < (log ? y_lo : 0.0) || r > y_hi) continue;
    const double yr = p.sy(r);
    page.line(p.x, yr, p.x + p.w, yr,
              std::string("stroke=\"") + (which == 0 ? kBeforeColour : bars.after_colour.c_str()) +
                  "\" stroke-width=\"1.5\" stroke-dasharray=\"6 4\"");
  }
  frame(page, p);
  page.text(p.x + p.w / 2, base + 32, bars.item_name, "class=\"ax\" text-anchor=\"middle\"");
  return base + 58;
}

namespace {

// One hemisphere seen from outside along its pole: the grid, the faces, the pose directions.
void hemisphere(Page& page, double cx, double cy, double r, bool upper, const Run& run) {
  const double flip = upper ? -1 : 1;  // screen y of body +y: up in the +z view, down in -z
  page.circle(cx, cy, r, "fill=\"#fafafa\" stroke=\"#555\"");
  for (double lat : {30.0, 60.0}) {
    const double rr = r * std::cos(lat / kDeg);
    page.circle(cx, cy, rr, "fill=\"none\" class=\"g\" stroke-dasharray=\"3 3\"");
    page.text(cx + rr * 0.7071 + 2, cy - rr * 0.7071 - 2,
              printf_string("%s%.0f\u00b0", upper ? "+" : "\u2212", lat), "class=\"gl\"");
  }
  for (int lon = 0; lon < 180; lon += 30) {
    const double a = lon / kDeg;
    page.line(cx - r * std::cos(a), cy - r * std::sin(a), cx + r * std::cos(a),
              cy + r * std::sin(a), "class=\"g\"");
  }
  // The faces: +x, -x, +y, -y on the rim, the pole in the middle.
  struct Face {
    int bit;
    double x, y;
    const char* name;
  };
  const Face faces[5] = {{0, 1, 0, "+x"},
                         {1, -1, 0, "\u2212x"},
                         {2, 0, flip, "+y"},
                         {3, 0, -flip, "\u2212y"},
                         {upper ? 4 : 5, 0, 0, upper ? "+z" : "\u2212z"}};
  for (const Face& f : faces) {
    const bool covered = (run.faces >> f.bit) & 1u;
    const double fx = cx + r * f.x, fy = cy + r * f.y;
    const char* colour = covered ? kCoveredColour : kMissingColour;
    page.rect(fx - 5, fy - 5, 10, 10,
              std::string("fill=\"") + (covered ? colour : "#fff") + "\" stroke=\"" + colour +
                  "\" stroke-width=\"1.5\"",
              std::string(f.name) + (covered ? ": has a pose" : ": no pose"));
    const bool pole = f.x == 0 && f.y == 0;
    const double lx = pole ? fx + 9 : cx + (r + 18) * f.x;
    const double ly = pole ? fy + 18 : cy + (r + 18) * f.y + 5;
    page.text(lx, ly, f.name,
              std::string("font-weight=\"bold\" font-size=\"13\" text-anchor=\"") +
                  (pole ? "start" : "middle") + "\" fill=\"" + colour + "\"");
  }
  const bool numbered = run.pose_list.size() <= 100;  // beyond, numbers would only cover dots
  for (std::size_t i = 0; i < run.pose_list.size(); ++i) {
    const double* u = run.pose_list[i].up;
    if (!finite3(u)) continue;
    const double len = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    if (!(len > 1e-9)) continue;
    const double ux = u[0] / len, uy = u[1] / len, uz = u[2] / len;
    if ((uz >= 0) != upper) continue;
    const double px = cx + r * ux, py = cy + r * flip * uy;
    const std::string tip = printf_string("pose %zu: up = (%.3f, %.3f, %.3f)", i + 1, ux, uy, uz);
    if (numbered) {
      page.circle(px, py, 8, "class=\"d\"", tip);
      page.text(px, py + 3.5, std::to_string(i + 1), "class=\"dn\"");
    } else {
      page.circle(px, py, 4, "class=\"d\"", tip);
    }
  }
}

}  // namespace

double sphere_section(Page& page, double y, const Run& run) {
  section_title(page, y,
                "Directions covered: calibrated gravity direction (up) of each pose, body frame");
  const double r = 165, cy = y + 40 + r;
  const double cx1 = kPlotLeft + 20 + r, cx2 = cx1 + 2 * r + 110;
  hemisphere(page, cx1, cy, r, true, run);
  hemisphere(page, cx2, cy, r, false, run);
  page.text(cx1, cy + r + 42, "upper hemisphere (z \u2265 0), seen from +z",
            "class=\"ax\" text-anchor=\"middle\"");
  page.text(cx2, cy + r + 42, "lower hemisphere (z < 0), seen from \u2212z",
            "class=\"ax\" text-anchor=\"middle\"");

  // The faces' coverage and a key, to the right.
  const double x = cx2 + r + 60;
  double ty = y + 50;
  page.text(x, ty, printf_string("faces covered: %d of 6", run.faces_covered), "class=\"k\"");
  ty += 22;
  const char* names[6] = {"+x", "\u2212x", "+y", "\u2212y", "+z", "\u2212z"};
  for (unsigned bit = 0; bit < 6; ++bit) {
    const bool covered = (run.faces >> bit) & 1u;
    const char* colour = covered ? kCoveredColour : kMissingColour;
    page.rect(x, ty - 10, 10, 10,
              std::string("fill=\"") + (covered ? colour : "#fff") + "\" stroke=\"" + colour +
                  "\" stroke-width=\"1.5\"");
    page.text(x + 18, ty, std::string(names[bit]) + (covered ? "  has a pose" : "  no pose"),
              std::string("fill=\"") + colour + "\"");
    ty += 19;
  }
  ty += 12;
  for (const char* line :
       {"Dots: the poses, numbered as the", "rests above. Each view is seen from",
        "outside the sphere, x to the right", "(so +y points down in the \u2212z view).",
        "Grid: latitude \u00b130\u00b0, \u00b160\u00b0;", "longitude every 30\u00b0."}) {
    page.text(x, ty, line, "class=\"cap\"");
    ty += 15;
  }
  if (run.pose_list.empty()) {
    page.text(x, ty + 10, "no poses: nothing to show", "class=\"cap\"");
  }
  return cy + r + 70;
}

}  // namespace imucal::cli::report
