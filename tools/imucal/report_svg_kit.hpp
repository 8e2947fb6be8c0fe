// SPDX-License-Identifier: MIT
// tools/imucal/report_svg_kit.hpp: what every panel of the `imucal` tool's SVG report page
// draws with (host only): the layout and colours, text and number formatting, the SVG
// primitives, scales and ticks, panels on a time axis, the accelerometer model.
#pragma once

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdarg>
#include <cstddef>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include "imucal/models/accel_model.hpp"
#include "run.hpp"

namespace imucal::cli::report {

// --- Layout and colours ----------------------------------------------------------------------

inline constexpr double kWidth = 1200;
inline constexpr double kPlotLeft = 90;     // left edge of every plot area
inline constexpr double kPlotRight = 1165;  // right edge
inline constexpr double kPlotWidth = kPlotRight - kPlotLeft;

inline constexpr const char* kAxisColour[3] = {"#d62728", "#2ca02c", "#1f77b4"};
inline constexpr const char* kBeforeColour = "#9e9e9e";
inline constexpr const char* kAfterColour = "#1565c0";
inline constexpr const char* kMissingColour = "#c62828";
inline constexpr const char* kCoveredColour = "#2e7d32";

// The page's classes: titles, labels, numbers, grid, frames, rest bands, series, dots.
inline constexpr const char* kPageStyle =
    "<style>"
    ".t{font-size:22px;font-weight:bold;fill:#111}"
    ".h{font-size:14px;font-weight:bold;fill:#222}"
    ".k{font-size:13px;font-weight:bold;fill:#333}"
    ".v{font-size:13px;fill:#222}"
    ".lg{font-size:11.5px;fill:#333}"
    ".n{font-size:11px;fill:#444}"
    ".ax{font-size:12px;fill:#333}"
    ".cap{font-size:11.5px;fill:#555}"
    ".g{stroke:#e4e4e4;stroke-width:1}"
    ".gl{font-size:9px;fill:#999}"
    ".tk{stroke:#555;stroke-width:1}"
    ".fr{fill:none;stroke:#555;stroke-width:1}"
    ".b{fill:#ffc940;fill-opacity:0.22}"
    ".bn{font-size:9px;fill:#8d6e00;text-anchor:middle}"
    ".bs{fill:#ef6c00;fill-opacity:0.35}"
    ".bsn{font-size:9px;font-weight:bold;fill:#bf360c;text-anchor:middle}"
    ".s{fill:none;stroke-width:1;stroke-linejoin:round}"
    ".d{fill:#1565c0;fill-opacity:0.85;stroke:#fff;stroke-width:1}"
    ".dn{font-size:8.5px;font-weight:bold;fill:#fff;text-anchor:middle}"
    "</style>\n";

// --- Text and numbers ------------------------------------------------------------------------

inline std::string printf_string(const char* format, ...) __attribute__((format(printf, 1, 2)));
inline std::string printf_string(const char* format, ...) {
  char buf[256];
  va_list args;
  va_start(args, format);
  const int n = std::vsnprintf(buf, sizeof buf, format, args);
  va_end(args);
  if (n < 0) return {};
  const auto size = static_cast<std::size_t>(n);
  if (size < sizeof buf) return std::string(buf, size);
  std::string out(size + 1, '\0');
  va_start(args, format);
  std::vsnprintf(out.data(), out.size(), format, args);
  va_end(args);
  out.resize(size);
  return out;
}

// Valid UTF-8 without the control characters XML 1.0 forbids; anything else becomes '?'.
inline std::string clean_utf8(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  std::size_t i = 0;
  while (i < s.size()) {
    const auto c = static_cast<unsigned char>(s[i]);
    std::size_t len = 0;
    if (c < 0x80) {
      out += (c < 0x20 && c != '\t') || c == 0x7f ? '?' : static_cast<char>(c);
      ++i;
      continue;
    }
    if (c >= 0xc2 && c <= 0xdf) len = 2;
    if (c >= 0xe0 && c <= 0xef) len = 3;
    if (c >= 0xf0 && c <= 0xf4) len = 4;
    bool ok = len > 0 && i + len <= s.size();
    for (std::size_t k = 1; ok && k < len; ++k)
      ok = (static_cast<unsigned char>(s[i + k]) & 0xc0) == 0x80;
    if (ok && len >= 3) {  // no overlong forms, surrogates, U+FFFE/U+FFFF or beyond U+10FFFF
      const auto c1 = static_cast<unsigned char>(s[i + 1]);
      if (c == 0xe0 && c1 < 0xa0) ok = false;
      if (c == 0xed && c1 >= 0xa0) ok = false;
      if (c == 0xf0 && c1 < 0x90) ok = false;
      if (c == 0xf4 && c1 >= 0x90) ok = false;
      if (c == 0xef && c1 == 0xbf && static_cast<unsigned char>(s[i + 2]) >= 0xbe) ok = false;
    }
    if (ok) {
      out.append(s.substr(i, len));
      i += len;
    } else {
      out += '?';
      ++i;
    }
  }
  return out;
}

// At most `max_chars` characters (code points) of a clean UTF-8 string, the middle elided.
inline std::string elide(const std::string& s, std::size_t max_chars) {
  std::vector<std::size_t> starts;  // byte offset of each code point
  for (std::size_t i = 0; i < s.size(); ++i)
    if ((static_cast<unsigned char>(s[i]) & 0xc0) != 0x80) starts.push_back(i);
  if (starts.size() <= max_chars || max_chars < 5) return s;
  const std::size_t head = (max_chars - 1) / 2, tail = max_chars - 1 - head;
  return s.substr(0, starts[head]) + "\u2026" + s.substr(starts[starts.size() - tail]);
}

// The number of characters (code points) of UTF-8 text, for estimating its width.
inline std::size_t characters(std::string_view s) {
  std::size_t n = 0;
  for (char c : s) n += (static_cast<unsigned char>(c) & 0xc0) != 0x80;
  return n;
}

// Text content or an attribute value: escaped, valid UTF-8.
inline std::string xml(std::string_view s) {
  const std::string clean = clean_utf8(s);
  std::string out;
  out.reserve(clean.size());
  for (char c : clean) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

// A coordinate: one decimal, no trailing ".0". Callers skip non-finite points; should one get
// here anyway it is written as 0, so the file stays valid.
inline void put_coord(std::string& out, double v) {
  if (!std::isfinite(v)) v = 0;
  v = std::clamp(v, -1e6, 1e6);
  char buf[32];
  int n = std::snprintf(buf, sizeof buf, "%.1f", v);
  if (n >= 2 && buf[n - 2] == '.' && buf[n - 1] == '0') n -= 2;
  if (n == 2 && buf[0] == '-' && buf[1] == '0') {
    out += '0';
    return;
  }
  out.append(buf, static_cast<std::size_t>(std::max(n, 0)));
}

inline std::string coord(double v) {
  std::string s;
  put_coord(s, v);
  return s;
}

// A value for a label: three significant digits, "n/a" when unknown.
inline std::string value_text(double v) {
  if (!std::isfinite(v)) return "n/a";
  const double a = std::fabs(v);
  if (a == 0) return "0";
  if (a >= 1000 && a < 1e7) return printf_string("%.0f", v);
  if (a >= 1e-4 && a < 1000) return printf_string("%.3g", v);
  return printf_string("%.2e", v);
}

// 51175 -> "51,175".
inline std::string grouped(long n) {
  std::string digits = std::to_string(n < 0 ? -n : n), out;
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return n < 0 ? "-" + out : out;
}

inline bool finite3(const double v[3]) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

// --- SVG primitives --------------------------------------------------------------------------

class Page {
 public:
  void line(double x1, double y1, double x2, double y2, std::string_view attrs) {
    out_ += "<line x1=\"" + coord(x1) + "\" y1=\"" + coord(y1) + "\" x2=\"" + coord(x2) +
            "\" y2=\"" + coord(y2) + "\" " + std::string(attrs) + "/>\n";
  }
  void rect(double x, double y, double w, double h, std::string_view attrs,
            std::string_view tooltip = {}) {
    out_ += "<rect x=\"" + coord(x) + "\" y=\"" + coord(y) + "\" width=\"" +
            coord(std::max(w, 0.0)) + "\" height=\"" + coord(std::max(h, 0.0)) + "\" " +
            std::string(attrs);
    close("rect", tooltip);
  }
  void circle(double x, double y, double r, std::string_view attrs, std::string_view tooltip = {}) {
    out_ += "<circle cx=\"" + coord(x) + "\" cy=\"" + coord(y) + "\" r=\"" + coord(r) + "\" " +
            std::string(attrs);
    close("circle", tooltip);
  }
  // `text` is plain text (escaped here).
  void text(double x, double y, std::string_view text, std::string_view attrs = {}) {
    markup(x, y, xml(text), attrs);
  }
  // `content` is already markup (escaped text and <tspan>s).
  void markup(double x, double y, std::string_view content, std::string_view attrs = {}) {
    out_ += "<text x=\"" + coord(x) + "\" y=\"" + coord(y) + "\"";
    if (!attrs.empty()) out_ += " " + std::string(attrs);
    out_ += ">" + std::string(content) + "</text>\n";
  }
  void vertical_text(double x, double y, std::string_view text, std::string_view attrs) {
    out_ += "<text transform=\"translate(" + coord(x) + " " + coord(y) +
            ") rotate(-90)\" text-anchor=\"middle\" " + std::string(attrs) + ">" + xml(text) +
            "</text>\n";
  }
  void path(const std::string& d, std::string_view attrs) {
    if (d.empty()) return;
    out_ += "<path d=\"" + d + "\" " + std::string(attrs) + "/>\n";
  }
  const std::string& str() const { return out_; }

 private:
  // Ends an element, with a tooltip (a <title> child) if there is one.
  void close(const char* tag, std::string_view tooltip) {
    if (tooltip.empty())
      out_ += "/>\n";
    else
      out_ += "><title>" + xml(tooltip) + "</title></" + tag + ">\n";
  }
  std::string out_;
};

// Builds an SVG path from points, compactly: "M x y", then "L x y x y ...", and "V y" for a point
// straight above or below the previous one (the min/max pairs of a pixel column). lift() starts
// a new subpath.
class PathBuilder {
 public:
  void point(double x, double y) {
    if (!std::isfinite(x) || !std::isfinite(y)) return;
    const std::string xs = coord(x);
    if (last_ == Last::kNone) {
      d_ += "M" + xs + " ";
      last_ = Last::kMove;
    } else if (xs == last_x_) {
      d_ += "V";
      last_ = Last::kVertical;
    } else {
      d_ += (last_ == Last::kLine ? " " : "L") + xs + " ";
      last_ = Last::kLine;
    }
    put_coord(d_, y);
    last_x_ = xs;
  }
  void lift() { last_ = Last::kNone; }
  const std::string& str() const { return d_; }

 private:
  enum class Last { kNone, kMove, kLine, kVertical };
  std::string d_, last_x_;
  Last last_ = Last::kNone;
};

// The page as an SVG document: y pixels high, titled, with the page's classes and a white ground.
inline std::string svg_document(const Page& page, double y, std::string_view title) {
  const std::string height = coord(std::ceil(y));
  std::string svg = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  svg += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + coord(kWidth) + "\" height=\"" +
         height + "\" viewBox=\"0 0 " + coord(kWidth) + " " + height +
         "\" font-family=\"DejaVu Sans, Helvetica, Arial, sans-serif\" font-size=\"12\">\n";
  svg += "<title>" + xml(title) + "</title>\n";
  svg += kPageStyle;
  svg += "<rect width=\"100%\" height=\"100%\" fill=\"#fff\"/>\n";
  svg += page.str();
  svg += "</svg>\n";
  return svg;
}

// --- Scales and ticks ------------------------------------------------------------------------

// Data to pixels along one axis, linear or log10.
struct Scale {
  double d0 = 0, d1 = 1;  // data range (positive for log)
  double p0 = 0, p1 = 1;  // pixel range
  bool log = false;
  double operator()(double v) const {
    const double a = log ? std::log10(d0) : d0, b = log ? std::log10(d1) : d1;
    const double x = log ? std::log10(v) : v;
    if (!(b != a)) return 0.5 * (p0 + p1);  // a degenerate range: the middle
    return p0 + (x - a) / (b - a) * (p1 - p0);
  }
};

inline double nice_step(double span, double target) {
  if (!(span > 0) || !std::isfinite(span)) return 1;
  const double raw = span / target;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / magnitude;
  return (f < 1.5 ? 1 : f < 3 ? 2 : f < 7 ? 5 : 10) * magnitude;
}

inline std::vector<double> ticks(double lo, double hi, double step) {
  std::vector<double> out;
  const double first = std::ceil(lo / step - 1e-9);
  for (double k = first; k * step <= hi + 1e-9 * step && out.size() < 100; k += 1)
    out.push_back(std::fabs(k) < 0.5 ? 0.0 : k * step);
  return out;
}

inline std::string tick_text(double v, double step) {
  const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  return printf_string("%.*f", decimals, v);
}

// "10^k" with a raised exponent.
inline std::string decade_markup(int k) {
  if (k == 0) return "1";
  if (k == 1) return "10";
  return "10<tspan dy=\"-5\" font-size=\"8\">" + std::string(k < 0 ? "\u2212" : "") +
         std::to_string(std::abs(k)) + "</tspan>";
}

// A range with a margin; a degenerate one is widened.
inline void pad_range(double& lo, double& hi, double fraction) {
  if (!std::isfinite(lo) || !std::isfinite(hi) || lo > hi) {
    lo = 0;
    hi = 1;
    return;
  }
  double span = hi - lo;
  if (span <= 1e-12 * std::max(1.0, std::fabs(hi))) span = std::max(1.0, std::fabs(hi) * 0.01);
  const double mid = 0.5 * (lo + hi), half = 0.5 * span * (1 + 2 * fraction);
  lo = mid - half;
  hi = mid + half;
}

// The q-quantile (0..1) of values (reordered).
inline double quantile(std::vector<double>& values, double q) {
  if (values.empty()) return kNaN;
  const auto k = static_cast<std::size_t>(std::clamp(q * static_cast<double>(values.size() - 1),
                                                     0.0, static_cast<double>(values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

// --- Panels ----------------------------------------------------------------------------------

struct Panel {
  double x = kPlotLeft, y = 0, w = kPlotWidth, h = 100;  // plot area, pixels
  Scale sx, sy;
};

inline Panel make_panel(double y, double h, double x_lo, double x_hi, double y_lo, double y_hi,
                        bool y_log = false) {
  Panel p;
  p.y = y;
  p.h = h;
  p.sx = {x_lo, x_hi, p.x, p.x + p.w, false};
  p.sy = {y_lo, y_hi, p.y + p.h, p.y, y_log};
  return p;
}

// The time axis shared by the signal panels: input time, labelled relative to `offset` when the
// timestamps are large (Unix time).
struct TimeAxis {
  double lo = 0, hi = 1, offset = 0;
  bool valid = false;
  std::string name;  // the axis title when not the input time's
  std::string label() const {
    if (!name.empty()) return name;
    if (offset == 0) return "time (s)";
    return "time \u2212 t0 (s), t0 = " + printf_string("%.3f", offset) + " s";
  }
};

inline TimeAxis time_axis(const Run& run, const std::vector<Sample>& samples) {
  TimeAxis t;
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (const Sample& s : samples) {
    if (!std::isfinite(s.t)) continue;
    lo = std::min(lo, s.t);
    hi = std::max(hi, s.t);
  }
  if (!(lo <= hi) && std::isfinite(run.t_first) && std::isfinite(run.t_last) &&
      run.t_first <= run.t_last && run.samples > 0) {
    lo = run.t_first;
    hi = run.t_last;
  }
  for (const PoseResult& p : run.pose_list) {
    if (!std::isfinite(p.t_begin) || !std::isfinite(p.t_end)) continue;
    if (samples.empty()) {
      lo = std::min(lo, p.t_begin);
      hi = std::max(hi, p.t_end);
    }
  }
  if (!(lo <= hi)) return t;
  if (hi - lo <= 1e-9 * std::max(1.0, std::fabs(hi))) {
    lo -= 0.5;
    hi += 0.5;
  }
  t.lo = lo;
  t.hi = hi;
  t.valid = true;
  t.offset = std::fabs(lo) >= 1e5 ? lo : 0;
  return t;
}

inline void section_title(Page& page, double y, std::string_view title) {
  page.text(kPlotLeft, y, title, "class=\"h\"");
}

// Legend entries at the right end of a section's title line, right to left.
struct LegendItem {
  std::string label, colour;
  enum Kind { kLine, kBox, kDashed } kind = kLine;
};

inline void legend(Page& page, double y, const std::vector<LegendItem>& items) {
  double x = kPlotRight;
  for (auto it = items.rbegin(); it != items.rend(); ++it) {
    const double text_width = 6.6 * static_cast<double>(characters(it->label));
    x -= text_width;
    page.text(x, y, it->label, "class=\"lg\"");
    x -= 24;
    if (it->kind == LegendItem::kBox) {
      page.rect(x + 6, y - 9, 12, 10, "fill=\"" + it->colour + "\"");
    } else {
      page.line(x, y - 4, x + 18, y - 4,
                "stroke=\"" + it->colour + "\" stroke-width=\"2\"" +
                    (it->kind == LegendItem::kDashed ? " stroke-dasharray=\"5 3\"" : ""));
    }
    x -= 14;
  }
}

inline void frame(Page& page, const Panel& p) { page.rect(p.x, p.y, p.w, p.h, "class=\"fr\""); }

inline void caption_in(Page& page, const Panel& p, std::string_view text) {
  page.text(p.x + p.w / 2, p.y + p.h / 2 + 4, text, "class=\"cap\" text-anchor=\"middle\"");
}

inline void time_grid(Page& page, const Panel& p, const TimeAxis& t, bool with_title) {
  const double step = nice_step(t.hi - t.lo, 12);
  for (double v : ticks(t.lo - t.offset, t.hi - t.offset, step)) {
    const double x = p.sx(v + t.offset);
    if (!std::isfinite(x)) continue;
    page.line(x, p.y, x, p.y + p.h, "class=\"g\"");
    page.line(x, p.y + p.h, x, p.y + p.h + 4, "class=\"tk\"");
    page.text(x, p.y + p.h + 16, tick_text(v, step), "class=\"n\" text-anchor=\"middle\"");
  }
  if (with_title)
    page.text(p.x + p.w / 2, p.y + p.h + 32, t.label(), "class=\"ax\" text-anchor=\"middle\"");
}

inline void value_grid(Page& page, const Panel& p, std::string_view label) {
  if (p.sy.log) {
    const int k0 = static_cast<int>(std::lround(std::log10(p.sy.d0)));
    const int k1 = static_cast<int>(std::lround(std::log10(p.sy.d1)));
    const double decade = p.h / std::max(1, k1 - k0);                         // pixels
    const int every = std::max(1, static_cast<int>(std::ceil(14 / decade)));  // labelled decades
    for (int k = k0; k <= k1; ++k) {
      const double y = p.sy(std::pow(10.0, k));
      page.line(p.x, y, p.x + p.w, y, "class=\"g\"");
      page.line(p.x - 4, y, p.x, y, "class=\"tk\"");
      if ((k1 - k) % every == 0)
        page.markup(p.x - 7, y + 4, decade_markup(k), "class=\"n\" text-anchor=\"end\"");
      for (int m = 2; m <= 9 && k < k1 && decade >= 30; ++m) {
        const double ym = p.sy(m * std::pow(10.0, k));
        page.line(p.x - 2, ym, p.x, ym, "class=\"tk\"");
      }
    }
  } else {
    const double step = nice_step(p.sy.d1 - p.sy.d0, p.h / 32);
    for (double v : ticks(p.sy.d0, p.sy.d1, step)) {
      const double y = p.sy(v);
      page.line(p.x, y, p.x + p.w, y, "class=\"g\"");
      page.line(p.x - 4, y, p.x, y, "class=\"tk\"");
      page.text(p.x - 7, y + 4, tick_text(v, step), "class=\"n\" text-anchor=\"end\"");
    }
  }
  page.vertical_text(p.x - 62, p.y + p.h / 2, label, "class=\"ax\"");
}

// The rests as translucent bands (a rest split from the one before by a bump in orange); with
// `numbers`, numbered from 1 where there is room for the number, and with a tooltip.
inline void rest_bands(Page& page, const Panel& p, const Run& run, bool numbers) {
  double last_label_end = -HUGE_VAL;
  for (std::size_t i = 0; i < run.pose_list.size(); ++i) {
    const PoseResult& pose = run.pose_list[i];
    if (!std::isfinite(pose.t_begin) || !std::isfinite(pose.t_end)) continue;
    if (pose.t_end < p.sx.d0 || pose.t_begin > p.sx.d1) continue;
    double x0 = std::clamp(p.sx(pose.t_begin), p.x, p.x + p.w);
    double x1 = std::clamp(p.sx(pose.t_end), p.x, p.x + p.w);
    if (!std::isfinite(x0) || !std::isfinite(x1) || x1 < x0) continue;
    if (x1 - x0 < 1) x1 = std::min(x0 + 1, p.x + p.w);
    // A rest split by a bump (it holds the previous rest's orientation) in its own colour.
    const bool split = pose.continues > 0;
    const char* band = split ? "class=\"bs\"" : "class=\"b\"";
    if (!numbers) {
      page.rect(x0, p.y, x1 - x0, p.h, band);
      continue;
    }
    std::string tip = printf_string("rest %zu: %.3f .. %.3f s, %d samples", i + 1, pose.t_begin,
                                    pose.t_end, pose.samples);
    if (split)
      tip += printf_string(
          "; the orientation of rest %d (%.2f deg) after %.2f s of motion: one rest split by a "
          "bump",
          pose.continues, pose.angle_to_previous, pose.gap_before);
    page.rect(x0, p.y, x1 - x0, p.h, band, tip);
    const std::string label = std::to_string(i + 1);
    const double half = 3.0 * static_cast<double>(label.size()) + 1;
    const double xc = 0.5 * (x0 + x1);
    if (xc - half < last_label_end) continue;
    page.text(xc, p.y + 11, label, split ? "class=\"bsn\"" : "class=\"bn\"");
    last_label_end = xc + half + 2;
  }
}

// One series over time as a path: every sample when there are few, else the minimum and the
// maximum of each pixel column in time order (so spikes stay visible). value_of(i) is the value
// of samples[i]. Values are clamped to the panel's range; non-finite ones are skipped; a gap in
// time longer than `gap` s lifts the pen.
template <typename ValueOf>
inline std::string series_path(const Panel& p, const std::vector<Sample>& samples,
                               const ValueOf& value_of, double gap) {
  const double lo = std::min(p.sy.d0, p.sy.d1), hi = std::max(p.sy.d0, p.sy.d1);
  const double t_lo = p.sx.d0, t_hi = p.sx.d1;
  const int columns = std::max(1, static_cast<int>(p.w));
  const bool every_sample = samples.size() <= 2 * static_cast<std::size_t>(columns);
  PathBuilder path;
  // The current column: its extremes and which came first.
  int column = -1;
  double v_min = 0, v_max = 0;
  std::size_t i_min = 0, i_max = 0;
  auto flush = [&] {
    if (column < 0) return;
    const double x = p.x + (column + 0.5) * p.w / columns;
    const bool min_first = i_min <= i_max;
    path.point(x, p.sy(min_first ? v_min : v_max));
    if (v_min != v_max) path.point(x, p.sy(min_first ? v_max : v_min));
    column = -1;
  };
  double last_t = kNaN;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const double t = samples[i].t;
    double v = value_of(i);
    if (!std::isfinite(t) || !std::isfinite(v) || t < t_lo || t > t_hi) continue;
    v = std::clamp(v, lo, hi);
    const bool gap_before = std::isfinite(last_t) && t - last_t > gap;
    last_t = t;
    if (every_sample) {
      if (gap_before) path.lift();
      path.point(p.sx(t), p.sy(v));
      continue;
    }
    const int c =
        std::clamp(static_cast<int>((t - t_lo) / (t_hi - t_lo) * columns), 0, columns - 1);
    if (c != column || gap_before) {
      flush();
      if (gap_before) path.lift();
      column = c;
      v_min = v_max = v;
      i_min = i_max = i;
    } else if (v < v_min) {
      v_min = v;
      i_min = i;
    } else if (v > v_max) {
      v_max = v;
      i_max = i;
    }
  }
  flush();
  return path.str();
}

// A time longer than any ordinary spacing of the samples read (the page may hold fewer): where
// the recording has a hole.
inline double gap_threshold(const Run& run, const TimeAxis& t) {
  const double n = static_cast<double>(std::max(run.samples, 2L) - 1);
  return std::max(10 * (t.hi - t.lo) / n, 2 * (t.hi - t.lo) / kPlotWidth);
}

// --- The accelerometer model -----------------------------------------------------------------

// The library's a_cal = T K (a_raw + b), with M = T K computed once (it runs per sample).
struct AccelModel {
  Matrix3<double> m;
  Vector3<double> b;
  explicit AccelModel(const std::array<double, 9>& p) {
    const AccelVector<double> v = Eigen::Map<const AccelVector<double>>(p.data());
    m = accel_matrix(v);
    b = v.tail<3>();
  }
  double norm(const double raw[3]) const {
    return (m * (Vector3<double>(raw[0], raw[1], raw[2]) + b)).norm();
  }
};

inline bool usable_params(const std::array<double, 9>& p) {
  for (double v : p)
    if (!std::isfinite(v)) return false;
  return p[3] != 0 || p[4] != 0 || p[5] != 0;
}

// The local gravity to draw against (the standard one if the option is not a plausible value).
inline double gravity(const Options& options) {
  const double g = options.gravity;
  return g > 0.1 * kStandardGravity && g < 10 * kStandardGravity ? g : kStandardGravity;
}

}  // namespace imucal::cli::report
