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

#include "imucal/accel_model.hpp"
#include "run.hpp"

namespace imucal::cli {
namespace {

// --- Layout and colours ----------------------------------------------------------------------

constexpr double kWidth = 1200;
constexpr double kPlotLeft = 90;     // left edge of every plot area
constexpr double kPlotRight = 1165;  // right edge
constexpr double kPlotWidth = kPlotRight - kPlotLeft;

constexpr const char* kAxisColour[3] = {"#d62728", "#2ca02c", "#1f77b4"};
constexpr const char* kBeforeColour = "#9e9e9e";
constexpr const char* kAfterColour = "#1565c0";
constexpr const char* kMissingColour = "#c62828";
constexpr const char* kCoveredColour = "#2e7d32";

// --- Text and numbers ------------------------------------------------------------------------

std::string printf_string(const char* format, ...) __attribute__((format(printf, 1, 2)));
std::string printf_string(const char* format, ...) {
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
std::string clean_utf8(std::string_view s) {
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
std::string elide(const std::string& s, std::size_t max_chars) {
  std::vector<std::size_t> starts;  // byte offset of each code point
  for (std::size_t i = 0; i < s.size(); ++i)
    if ((static_cast<unsigned char>(s[i]) & 0xc0) != 0x80) starts.push_back(i);
  if (starts.size() <= max_chars || max_chars < 5) return s;
  const std::size_t head = (max_chars - 1) / 2, tail = max_chars - 1 - head;
  return s.substr(0, starts[head]) + "\u2026" + s.substr(starts[starts.size() - tail]);
}

// The number of characters (code points) of UTF-8 text, for estimating its width.
std::size_t characters(std::string_view s) {
  std::size_t n = 0;
  for (char c : s) n += (static_cast<unsigned char>(c) & 0xc0) != 0x80;
  return n;
}

// Text content or an attribute value: escaped, valid UTF-8.
std::string xml(std::string_view s) {
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
void put_coord(std::string& out, double v) {
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

std::string coord(double v) {
  std::string s;
  put_coord(s, v);
  return s;
}

// A value for a label: three significant digits, "n/a" when unknown.
std::string value_text(double v) {
  if (!std::isfinite(v)) return "n/a";
  const double a = std::fabs(v);
  if (a == 0) return "0";
  if (a >= 1000 && a < 1e7) return printf_string("%.0f", v);
  if (a >= 1e-4 && a < 1000) return printf_string("%.3g", v);
  return printf_string("%.2e", v);
}

// 51175 -> "51,175".
std::string grouped(long n) {
  std::string digits = std::to_string(n < 0 ? -n : n), out;
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return n < 0 ? "-" + out : out;
}

bool finite3(const double v[3]) {
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

double nice_step(double span, double target) {
  if (!(span > 0) || !std::isfinite(span)) return 1;
  const double raw = span / target;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / magnitude;
  return (f < 1.5 ? 1 : f < 3 ? 2 : f < 7 ? 5 : 10) * magnitude;
}

std::vector<double> ticks(double lo, double hi, double step) {
  std::vector<double> out;
  const double first = std::ceil(lo / step - 1e-9);
  for (double k = first; k * step <= hi + 1e-9 * step && out.size() < 100; k += 1)
    out.push_back(std::fabs(k) < 0.5 ? 0.0 : k * step);
  return out;
}

std::string tick_text(double v, double step) {
  const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  return printf_string("%.*f", decimals, v);
}

// "10^k" with a raised exponent.
std::string decade_markup(int k) {
  if (k == 0) return "1";
  if (k == 1) return "10";
  return "10<tspan dy=\"-5\" font-size=\"8\">" + std::string(k < 0 ? "\u2212" : "") +
         std::to_string(std::abs(k)) + "</tspan>";
}

// A range with a margin; a degenerate one is widened.
void pad_range(double& lo, double& hi, double fraction) {
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
double quantile(std::vector<double>& values, double q) {
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

Panel make_panel(double y, double h, double x_lo, double x_hi, double y_lo, double y_hi,
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
  std::string label() const {
    if (offset == 0) return "time (s)";
    return "time \u2212 t0 (s), t0 = " + printf_string("%.3f", offset) + " s";
  }
};

TimeAxis time_axis(const Run& run, const std::vector<Sample>& samples) {
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

void section_title(Page& page, double y, std::string_view title) {
  page.text(kPlotLeft, y, title, "class=\"h\"");
}

// Legend entries at the right end of a section's title line, right to left.
struct LegendItem {
  std::string label, colour;
  enum Kind { kLine, kBox, kDashed } kind = kLine;
};

void legend(Page& page, double y, const std::vector<LegendItem>& items) {
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

void frame(Page& page, const Panel& p) { page.rect(p.x, p.y, p.w, p.h, "class=\"fr\""); }

void caption_in(Page& page, const Panel& p, std::string_view text) {
  page.text(p.x + p.w / 2, p.y + p.h / 2 + 4, text, "class=\"cap\" text-anchor=\"middle\"");
}

void time_grid(Page& page, const Panel& p, const TimeAxis& t, bool with_title) {
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

void value_grid(Page& page, const Panel& p, std::string_view label) {
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

// The rests as translucent bands; with `numbers`, numbered from 1 where there is room for the
// number, and with a tooltip.
void rest_bands(Page& page, const Panel& p, const Run& run, bool numbers) {
  double last_label_end = -HUGE_VAL;
  for (std::size_t i = 0; i < run.pose_list.size(); ++i) {
    const PoseResult& pose = run.pose_list[i];
    if (!std::isfinite(pose.t_begin) || !std::isfinite(pose.t_end)) continue;
    if (pose.t_end < p.sx.d0 || pose.t_begin > p.sx.d1) continue;
    double x0 = std::clamp(p.sx(pose.t_begin), p.x, p.x + p.w);
    double x1 = std::clamp(p.sx(pose.t_end), p.x, p.x + p.w);
    if (!std::isfinite(x0) || !std::isfinite(x1) || x1 < x0) continue;
    if (x1 - x0 < 1) x1 = std::min(x0 + 1, p.x + p.w);
    if (!numbers) {
      page.rect(x0, p.y, x1 - x0, p.h, "class=\"b\"");
      continue;
    }
    page.rect(x0, p.y, x1 - x0, p.h, "class=\"b\"",
              printf_string("rest %zu: %.3f .. %.3f s, %d samples", i + 1, pose.t_begin, pose.t_end,
                            pose.samples));
    const std::string label = std::to_string(i + 1);
    const double half = 3.0 * static_cast<double>(label.size()) + 1;
    const double xc = 0.5 * (x0 + x1);
    if (xc - half < last_label_end) continue;
    page.text(xc, p.y + 11, label, "class=\"bn\"");
    last_label_end = xc + half + 2;
  }
}

// One series over time as a path: every sample when there are few, else the minimum and the
// maximum of each pixel column in time order (so spikes stay visible). value_of(i) is the value
// of samples[i]. Values are clamped to the panel's range; non-finite ones are skipped; a gap in
// time longer than `gap` s lifts the pen.
template <typename ValueOf>
std::string series_path(const Panel& p, const std::vector<Sample>& samples, const ValueOf& value_of,
                        double gap) {
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
double gap_threshold(const Run& run, const TimeAxis& t) {
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

bool usable_params(const std::array<double, 9>& p) {
  for (double v : p)
    if (!std::isfinite(v)) return false;
  return p[3] != 0 || p[4] != 0 || p[5] != 0;
}

// --- Sections --------------------------------------------------------------------------------

// The local gravity to draw against (the standard one if the option is not a plausible value).
double gravity(const Options& options) {
  const double g = options.gravity;
  return g > 0.1 * kStandardGravity && g < 10 * kStandardGravity ? g : kStandardGravity;
}

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
struct Bars {
  std::string title, unit, after_colour, empty_text, item_name;
  std::vector<double> before, after;
  std::vector<std::string> tips;
  double rms_before = kNaN, rms_after = kNaN;
};

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

// --- Magnetometer ----------------------------------------------------------------------------

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

// --- Temperature -----------------------------------------------------------------------------

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

constexpr const char* kStyle =
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
    ".s{fill:none;stroke-width:1;stroke-linejoin:round}"
    ".d{fill:#1565c0;fill-opacity:0.85;stroke:#fff;stroke-width:1}"
    ".dn{font-size:8.5px;font-weight:bold;fill:#fff;text-anchor:middle}"
    "</style>\n";

}  // namespace

std::string report_svg(const Run& run, const Options& options, const std::vector<Sample>& samples) {
  Page page;
  const TimeAxis t = time_axis(run, samples);
  double y = title_block(page, run, options) + 14;

  y = signal_section(page, y, 190, run, samples, t, false,
                     "Accelerometer, raw (" + std::string(accel_unit_name(options.accel_unit)) +
                         "), rests shaded and numbered",
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

  const std::string height = coord(std::ceil(y));
  std::string svg = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  svg += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + coord(kWidth) + "\" height=\"" +
         height + "\" viewBox=\"0 0 " + coord(kWidth) + " " + height +
         "\" font-family=\"DejaVu Sans, Helvetica, Arial, sans-serif\" font-size=\"12\">\n";
  svg += "<title>imucal calibration report</title>\n";
  svg += kStyle;
  svg += "<rect width=\"100%\" height=\"100%\" fill=\"#fff\"/>\n";
  svg += page.str();
  svg += "</svg>\n";
  return svg;
}

}  // namespace imucal::cli
