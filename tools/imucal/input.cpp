// tools/imucal/input.cpp: line reading, field splitting, the CSV and imu_tk readers.
#include "input.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <tuple>
#include <utility>

namespace imucal::cli {

std::string Diagnostic::text() const {
  std::string s = file;
  if (line > 0) s += ":" + std::to_string(line);
  if (column > 0) s += ":" + std::to_string(column);
  return s + ": " + message;
}

void Diagnostics::add(Diagnostic d) {
  ++count_;
  if (kept_.size() < keep_) kept_.push_back(std::move(d));
}

// --- LineReader ---------------------------------------------------------------------------

LineReader::~LineReader() {
  if (owns_ && file_ != nullptr) std::fclose(file_);
}

bool LineReader::open(const std::string& path, Diagnostics& diag, std::size_t max_line,
                      std::size_t block) {
  if (path == "-") {
    open_stream(stdin, "<stdin>", max_line, block);
    return true;
  }
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) {
    diag.add({path, 0, 0, std::string("cannot open: ") + std::strerror(errno)});
    return false;
  }
  open_stream(f, path, max_line, block);
  owns_ = true;
  struct stat st {};
  if (fstat(fileno(f), &st) == 0 && S_ISREG(st.st_mode))
    size_ = static_cast<std::uint64_t>(st.st_size);
  return true;
}

void LineReader::open_stream(std::FILE* f, const std::string& name, std::size_t max_line,
                             std::size_t block) {
  file_ = f;
  name_ = name;
  max_line_ = max_line;
  // Room for a line of max_line and its CR, and one byte more to see what follows them.
  // Not zeroed: only what is read into it is ever looked at.
  buf_size_ = max_line + std::max<std::size_t>(block, 2);
  buf_.reset(new char[buf_size_]);
}

void LineReader::open_memory(std::string_view text, const std::string& name, std::size_t max_line) {
  name_ = name;
  memory_ = text;
  from_memory_ = true;
  size_ = text.size();
  max_line_ = max_line;
}

// Moves the unread bytes to the front and reads more; sets eof_ (and error_) when none came.
void LineReader::fill() {
  if (begin_ > 0) {
    std::memmove(buf_.get(), buf_.get() + begin_, end_ - begin_);
    end_ -= begin_;
    begin_ = 0;
  }
  const std::size_t got = std::fread(buf_.get() + end_, 1, buf_size_ - end_, file_);
  end_ += got;
  if (got == 0) {
    eof_ = true;
    if (std::ferror(file_) != 0) error_ = std::strerror(errno);
  }
}

std::string_view LineReader::unread() const {
  return from_memory_ ? memory_.substr(begin_)
                      : std::string_view(buf_.get() + begin_, end_ - begin_);
}

bool LineReader::next(std::string_view& line, Diagnostics& diag) {
  for (;;) {
    std::string_view rest = unread();
    const std::size_t nl = rest.find('\n');
    const bool complete = nl != std::string_view::npos;
    // An incomplete line that may still fit: read more, then look again (fill() moves the bytes).
    // max_line + 1: its last byte may be a CR, which ends the line at the end of the input.
    if (!complete && !from_memory_ && !eof_ && rest.size() <= max_line_ + 1) {
      fill();
      continue;
    }
    if (!complete && rest.empty()) {
      if (!error_.empty()) {
        diag.add({name_, line_ + 1, 0, "read error: " + error_ + "; the rest is lost"});
        error_.clear();
        failed_ = true;
      }
      return false;
    }
    std::size_t len = complete ? nl : rest.size();
    // A stream's incomplete line here is longer than max_line (the buffer's end, not the line's,
    // so a '\r' there is not its terminator).
    const bool whole = complete || from_memory_ || eof_;
    const std::size_t text_len = whole && len > 0 && rest[len - 1] == '\r' ? len - 1 : len;
    ++line_;
    if (text_len > max_line_) {
      diag.add({name_, line_, 0,
                "line longer than " + std::to_string(max_line_) + " characters: skipped"});
      // Skip to the end of this line, however long.
      for (;;) {
        rest = unread();
        const std::size_t at = rest.find('\n');
        if (at != std::string_view::npos) {
          begin_ += at + 1;
          consumed_ += at + 1;
          break;
        }
        begin_ += rest.size();
        consumed_ += rest.size();
        if (from_memory_ || eof_) break;
        fill();
      }
      continue;
    }
    line = rest.substr(0, text_len);
    begin_ += complete ? len + 1 : len;
    consumed_ += complete ? len + 1 : len;
    // A UTF-8 byte-order mark (spreadsheet exports) is not part of the first line.
    if (line_ == 1 && line.substr(0, 3) == "\xef\xbb\xbf") line.remove_prefix(3);
    return true;
  }
}

// --- fields and numbers -------------------------------------------------------------------

void split_fields(std::string_view line, std::vector<Field>& out) {
  out.clear();
  const std::size_t n = line.size();
  const char* const c = line.data();
  auto blank = [](char ch) { return ch == ' ' || ch == '\t'; };
  const bool comma =
      n > 0 && (std::memchr(c, ',', n) != nullptr || std::memchr(c, ';', n) != nullptr);
  if (!comma) {
    // Blank-separated (imu_tk's format): runs of blanks separate.
    std::size_t i = 0;
    while (i < n) {
      while (i < n && blank(c[i])) ++i;
      if (i >= n) break;
      const std::size_t start = i;
      while (i < n && !blank(c[i])) ++i;
      out.push_back({line.substr(start, i - start), start});
    }
    return;
  }
  // Comma- or semicolon-separated: every separator starts a field (an empty one is a field);
  // blanks around a field are trimmed.
  std::size_t start = 0;
  for (;;) {
    std::size_t stop = start;
    while (stop < n && c[stop] != ',' && c[stop] != ';') ++stop;
    std::size_t b = start, e = stop;
    while (b < e && blank(c[b])) ++b;
    while (e > b && blank(c[e - 1])) --e;
    out.push_back({line.substr(b, e - b), b});
    if (stop == n) break;
    start = stop + 1;
  }
}

namespace {

bool is_digit(char c) { return static_cast<unsigned>(c - '0') < 10; }

// The run of decimal digits at p, at most eight of them (p + 8 <= end): how many there are, with
// m * 10^count + their value in m. Eight bytes at once: each byte XOR '0' is its digit where it
// is one and 10 or more where it is not; the digits are moved to the top of the word, behind
// zeros, and combined in pairs, fours and eights.
inline __attribute__((always_inline)) int digits8(const char* p, std::uint64_t& m) {
  constexpr bool kLittleEndian = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;
  static constexpr std::uint64_t kPow10u[9] = {1,      10,      100,      1000,     10000,
                                               100000, 1000000, 10000000, 100000000};
  std::uint64_t w;
  std::memcpy(&w, p, 8);
  if constexpr (!kLittleEndian) w = __builtin_bswap64(w);
  const std::uint64_t x = w ^ 0x3030303030303030u;
  const std::uint64_t other =
      (((x & 0x7f7f7f7f7f7f7f7fu) + 0x7676767676767676u) | x) & 0x8080808080808080u;
  const int count = other == 0 ? 8 : __builtin_ctzll(other) / 8;
  if (count == 0) return 0;
  std::uint64_t v = x << (8 * (8 - count));  // the first digit is the lowest byte
  v = (v * 10) + (v >> 8);                   // pairs, in every other byte
  v = (((v & 0x000000ff000000ffu) * (100 + (1000000ull << 32))) +
       (((v >> 16) & 0x000000ff000000ffu) * (1 + (10000ull << 32)))) >>
      32;
  m = m * kPow10u[count] + v;
  return count;
}

// A decimal number as loggers write it ("-12.5", "3.3108000e+04"): at most 19 digits, their
// value at most 2^53 and a power of ten within 1e-22..1e22, so that one multiplication or
// division of two exact doubles gives it, correctly rounded (Clinger's fast path), as from_chars
// would. Returns the end of the number, or nullptr where from_chars must decide (and say). The
// value is always finite.
inline __attribute__((always_inline)) const char* decimal(const char* p, const char* end,
                                                          double& out) {
  const bool negative = p < end && *p == '-';
  if (negative) ++p;
  std::uint64_t m = 0;
  int digits = 0, exponent = 0;
  for (; p < end && is_digit(*p); ++p, ++digits) m = m * 10 + static_cast<std::uint64_t>(*p - '0');
  if (p < end && *p == '.') {
    ++p;
    if (end - p >= 8 && digits <= 11) {  // the decimals, eight at a time while they last
      int n;
      do {
        n = digits8(p, m);
        p += n;
        digits += n;
        exponent -= n;
      } while (n == 8 && end - p >= 8 && digits <= 11);
    }
    for (; p < end && is_digit(*p); ++p, ++digits, --exponent)
      m = m * 10 + static_cast<std::uint64_t>(*p - '0');
  }
  if (digits == 0 || digits > 19) return nullptr;
  if (p < end && (*p == 'e' || *p == 'E')) {
    const char* q = p + 1;
    const bool minus = q < end && *q == '-';
    if (q < end && (*q == '-' || *q == '+')) ++q;
    int e = 0, n = 0;
    // The common two digits ("e+04") at once.
    if (end - q >= 2 && is_digit(q[0]) && is_digit(q[1]) && (end - q == 2 || !is_digit(q[2]))) {
      e = (q[0] - '0') * 10 + (q[1] - '0');
      q += 2;
      n = 2;
    } else {
      for (; q < end && is_digit(*q) && n < 5; ++q, ++n) e = e * 10 + (*q - '0');
    }
    if (n == 5) return nullptr;
    if (n > 0) {  // else the number ends before the 'e', as from_chars reads it
      exponent += minus ? -e : e;
      p = q;
    }
  }
  static constexpr double kPow10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                        1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                        1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
  if (m > (std::uint64_t{1} << 53) || exponent < -22 || exponent > 22) return nullptr;
  const double v = static_cast<double>(m);
  const double x = exponent < 0 ? v / kPow10[-exponent] : v * kPow10[exponent];
  out = negative ? -x : x;
  return p;
}

// from_chars, through the fast path where it applies.
std::from_chars_result number_at(const char* p, const char* end, double& out) {
  if (const char* q = decimal(p, end, out)) return {q, std::errc()};
  return std::from_chars(p, end, out);
}

// Past the blanks (spaces and tabs) at p.
inline __attribute__((always_inline)) const char* skip_blanks(const char* p, const char* end) {
  while (p < end && (*p == ' ' || *p == '\t')) ++p;
  return p;
}

}  // namespace

const char* decimal_fast(const char* p, const char* end, double& out) {
  return decimal(p, end, out);
}

// A line of exactly n finite numbers, separated either by blanks or by commas or semicolons
// (with blanks around them), read in one pass: the common line, about twice as fast as fields
// first and numbers after. False for anything else (an empty field, NaN, a '+' sign, text, a
// field count other than n); split_fields and parse_number then read the line or say what is
// wrong with it, so a line this accepts reads the same either way.
bool plain_numbers(std::string_view line, double* out, std::size_t n) {
  const char* p = line.data();
  const char* const end = p + line.size();
  enum { kUnknown, kBlanks, kSeparators } mode = kUnknown;
  for (std::size_t k = 0; k < n; ++k) {
    p = skip_blanks(p, end);
    if (p == end || *p == '+') return false;
    const char* number_end = decimal(p, end, out[k]);
    if (number_end == nullptr) {  // from_chars decides
      const auto r = std::from_chars(p, end, out[k]);
      if (r.ec != std::errc() || !std::isfinite(out[k])) return false;
      number_end = r.ptr;
    }
    const char* q = skip_blanks(number_end, end);
    if (k + 1 == n) {
      p = q;
      break;
    }
    if (q < end && (*q == ',' || *q == ';')) {
      if (mode == kBlanks) return false;
      mode = kSeparators;
      p = q + 1;
    } else {
      if (mode == kSeparators || q == number_end) return false;  // no separator at all
      mode = kBlanks;
      p = q;
    }
  }
  return p == end;
}

bool parse_number(std::string_view text, double& out) {
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  if (text.empty()) return false;
  const char* end = text.data() + text.size();
  const auto r = number_at(text.data(), end, out);
  return r.ec == std::errc() && r.ptr == end;
}

namespace {

std::string lower(std::string_view s) {
  std::string r(s);
  for (char& c : r) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return r;
}

std::string quoted(std::string_view s) {
  constexpr std::size_t kShown = 24;
  std::string r = "'";
  for (std::size_t i = 0; i < s.size() && i < kShown; ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (std::isprint(c)) {
      r += static_cast<char>(c);
    } else {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      r += hex;
    }
  }
  if (s.size() > kShown) r += "...";
  return r + "'";
}

// "# imucal: key=value key=value" -> settings, separated by blanks, commas or semicolons. A
// piece without '=' continues the previous value after a comma: "accel-range=0,65535".
// False if the comment is not a settings comment. With out == nullptr it only tells.
bool parse_settings(std::string_view line, const LineReader& in, std::vector<FileSetting>* out) {
  std::string_view rest = line.substr(1);
  while (!rest.empty() && (rest.front() == ' ' || rest.front() == '\t')) rest.remove_prefix(1);
  constexpr std::string_view kTag = "imucal:";
  if (rest.substr(0, kTag.size()) != kTag) return false;
  if (out == nullptr) return true;
  rest.remove_prefix(kTag.size());
  auto separator = [](char c) { return c == ' ' || c == '\t' || c == ',' || c == ';'; };
  const std::size_t first = out->size();
  std::size_t i = 0;
  while (i < rest.size()) {
    while (i < rest.size() && separator(rest[i])) ++i;
    if (i >= rest.size()) break;
    const std::size_t start = i;
    while (i < rest.size() && !separator(rest[i])) ++i;
    const std::string_view piece = rest.substr(start, i - start);
    const std::size_t eq = piece.find('=');
    if (eq == std::string_view::npos && out->size() > first) {
      out->back().value += "," + std::string(piece);
      continue;
    }
    FileSetting s;
    s.key = std::string(piece.substr(0, eq));
    s.value = eq == std::string_view::npos ? "" : std::string(piece.substr(eq + 1));
    s.file = in.name();
    s.line = in.line_number();
    out->push_back(std::move(s));
  }
  return true;
}

constexpr const char* kAxisNames[3] = {"x", "y", "z"};
constexpr const char* kRequired = "t, ax, ay, az, gx, gy, gz";

}  // namespace

// --- SampleReader --------------------------------------------------------------------------

void SampleReader::report(const LineReader& in, long column, std::string message,
                          Diagnostics& diag) {
  diag.add({in.name(), in.line_number(), column, std::move(message)});
}

// The next line that is neither blank nor a comment (settings in comments are collected).
bool SampleReader::content_line(LineReader& in, std::string_view& line, Diagnostics& diag) {
  while (in.next(line, diag)) {
    std::size_t i = 0;
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    if (i == line.size()) continue;
    if (line[i] == '#') {
      if (!data_started_) {
        parse_settings(line.substr(i), in, &settings_);
      } else if (parse_settings(line.substr(i), in, nullptr)) {
        report(in, static_cast<long>(i + 1),
               "settings after the data started are ignored: put `# imucal:` lines before the "
               "header (or the first sample)",
               diag);
      }
      continue;
    }
    return true;
  }
  return false;
}

bool SampleReader::open(const std::vector<std::string>& files, Format format, Diagnostics& diag) {
  files_ = static_cast<int>(files.size());
  if (files_ < 1 || files_ > 2) {
    diag.add({"imucal", 0, 0,
              "expected one CSV file (or - for stdin), or the imu_tk accelerometer and gyroscope "
              "files"});
    return false;
  }
  if (files_ == 2 && files[0] == "-" && files[1] == "-") {
    diag.add({"<stdin>", 0, 0, "stdin can be only one of the two imu_tk files"});
    return false;
  }
  for (int i = 0; i < files_; ++i)
    if (!in_[i].open(files[static_cast<std::size_t>(i)], diag)) return false;
  return start(format, diag);
}

bool SampleReader::open_memory(const std::vector<std::string_view>& texts, Format format,
                               Diagnostics& diag, std::size_t max_line) {
  files_ = static_cast<int>(std::min<std::size_t>(texts.size(), 2));
  if (files_ < 1) return false;
  for (int i = 0; i < files_; ++i)
    in_[i].open_memory(texts[static_cast<std::size_t>(i)], i == 0 ? "<text>" : "<text2>", max_line);
  return start(format, diag);
}

bool SampleReader::open_streams(const std::vector<std::FILE*>& files, Format format,
                                Diagnostics& diag, std::size_t max_line, std::size_t block) {
  files_ = static_cast<int>(std::min<std::size_t>(files.size(), 2));
  if (files_ < 1) return false;
  for (int i = 0; i < files_; ++i)
    in_[i].open_stream(files[static_cast<std::size_t>(i)], i == 0 ? "<text>" : "<text2>", max_line,
                       block);
  return start(format, diag);
}

bool SampleReader::open_records(std::vector<Record> records, const std::string& columns,
                                Diagnostics& diag) {
  files_ = 1;
  in_[0].open_memory("", "<arrays>", LineReader::kMaxLine);
  format_ = Format::kCsv;
  from_records_ = true;
  records_ = std::move(records);
  std::vector<Field> parts;
  split_fields(columns, parts);
  std::vector<std::string> names;
  for (const Field& f : parts) names.push_back(lower(f.text));
  columns_source_ = "arrays";
  data_started_ = true;
  return name_columns(names, true, diag);
}

// The next good sample of open_records(); the line of a report is the sample's index + 1.
bool SampleReader::next_record(Record& r, Diagnostics& diag) {
  while (next_record_ < records_.size()) {
    const long line = static_cast<long>(++next_record_);
    r = records_[static_cast<std::size_t>(line - 1)];
    auto say = [&](const std::string& message) {
      diag.add({"<arrays>", line, 0, message + ": sample skipped"});
      ++skipped_;
    };
    bool finite = col_t_ < 0 || std::isfinite(r.t);
    for (int a = 0; a < 3; ++a) {
      if (col_acc_[0] >= 0) finite = finite && std::isfinite(r.acc[a]);
      if (col_gyro_[0] >= 0) finite = finite && std::isfinite(r.gyro[a]);
      if (col_acc_[0] < 0) r.acc[a] = kNaN;
      if (col_gyro_[0] < 0) r.gyro[a] = kNaN;
      if (col_mag_[0] < 0) r.mag[a] = kNaN;
    }
    if (col_temp_ < 0) r.temp = kNaN;
    if (!finite) {
      say("a time or a reading is not finite");
      continue;
    }
    // A magnetometer reading is all three axes or none; a temperature may be missing.
    if (!(std::isfinite(r.mag[0]) && std::isfinite(r.mag[1]) && std::isfinite(r.mag[2])))
      r.mag[0] = r.mag[1] = r.mag[2] = kNaN;
    if (!std::isfinite(r.temp)) r.temp = kNaN;
    if (col_t_ >= 0) {
      r.t *= time_scale_;
      if (have_last_ && !(r.t > last_t_)) {
        say(time_not_after(r.t, last_t_));
        continue;
      }
    } else {
      r.t = untimed_time();
    }
    taken(r.t);
    return true;
  }
  return false;
}

void SampleReader::set_time_unit(TimeUnit time) {
  time_scale_ = time == TimeUnit::kSeconds ? 1.0 : time == TimeUnit::kMilliseconds ? 1e-3 : 1e-6;
}

bool SampleReader::start(Format format, Diagnostics& diag) {
  format_ = format;
  if (format_ == Format::kAuto) format_ = files_ == 2 ? Format::kImuTk : Format::kCsv;
  if (format_ == Format::kImuTk && files_ != 2) {
    diag.add({in_[0].name(), 0, 0,
              "the imu_tk format needs two files: the accelerometer's and the gyroscope's"});
    return false;
  }
  if (format_ == Format::kCsv && files_ != 1) {
    diag.add({in_[0].name(), 0, 0, "the CSV format reads one file (or - for stdin)"});
    return false;
  }
  if (format_ == Format::kCsv) return read_header(diag);
  // imu_tk: the settings comments at the top of either file, before the first sample.
  for (int i = 0; i < 2; ++i) {
    std::string_view line;
    if (!content_line(in_[i], line, diag)) {
      diag.add({in_[i].name(), 0, 0, "no samples: expected lines of `t x y z`"});
      return false;
    }
    pending_[i] = std::string(line);
    has_pending_[i] = true;
  }
  data_started_ = true;
  return true;
}

// Names the columns (lower-case names in file order). strict: an unknown name is an error (the
// user's --columns), else ignored (a header's extra columns). False (reported) if a name is
// repeated, a sensor has some but not all of its axes, or neither the accelerometer nor the
// magnetometer is there.
bool SampleReader::name_columns(const std::vector<std::string>& names, bool strict,
                                Diagnostics& diag) {
  LineReader& in = in_[0];
  columns_ = names.size();
  for (std::size_t c = 0; c < names.size(); ++c) {
    const std::string& name = names[c];
    const int ci = static_cast<int>(c);
    int* slot = nullptr;
    if (name == "t" || name == "time") slot = &col_t_;
    if (name == "temp" || name == "temperature") slot = &col_temp_;
    for (int a = 0; a < 3; ++a) {
      if (name == std::string("a") + kAxisNames[a]) slot = &col_acc_[a];
      if (name == std::string("g") + kAxisNames[a] || name == std::string("w") + kAxisNames[a])
        slot = &col_gyro_[a];
      if (name == std::string("m") + kAxisNames[a]) slot = &col_mag_[a];
    }
    if (slot == nullptr) {
      if (strict && name != "-" && name != "_") {
        report(in, 0,
               "--columns: unknown column name " + quoted(name) +
                   " (known: t, ax, ay, az, gx, gy, gz, temp, mx, my, mz; - or _ skips a column)",
               diag);
        return false;
      }
      continue;  // unknown columns are ignored
    }
    if (*slot >= 0) {
      report(in, 0, "column " + quoted(name) + " named twice", diag);
      return false;
    }
    *slot = ci;
  }
  // A sensor is all three axes or none.
  for (const auto& [cols, prefix, what] : {std::make_tuple(col_acc_, "a", "accelerometer"),
                                           std::make_tuple(col_gyro_, "g", "gyroscope"),
                                           std::make_tuple(col_mag_, "m", "magnetometer")}) {
    const int n = (cols[0] >= 0) + (cols[1] >= 0) + (cols[2] >= 0);
    if (n == 0 || n == 3) continue;
    std::string missing;
    for (int a = 0; a < 3; ++a)
      if (cols[a] < 0)
        missing += (missing.empty() ? "" : ", ") + std::string(prefix) + kAxisNames[a];
    report(in, 0,
           std::string("the ") + what + " needs all three axes: no column " + missing +
               " (expected " + kRequired + ", or a sensor alone)",
           diag);
    return false;
  }
  if (col_acc_[0] < 0 && col_mag_[0] < 0) {
    report(in, 0,
           std::string("no column ax, ay, az (accelerometer) nor mx, my, mz (magnetometer): "
                       "expected ") +
               kRequired + ", or t, mx, my, mz for a magnetometer alone",
           diag);
    return false;
  }
  if (col_gyro_[0] >= 0 && col_acc_[0] < 0) {
    report(in, 0,
           "gx, gy, gz without ax, ay, az: the gyroscope is calibrated against gravity, it needs "
           "the accelerometer",
           diag);
    return false;
  }
  column_list_.clear();
  for (std::size_t c = 0; c < names.size(); ++c)
    column_list_ += (c ? ", " : "") + (names[c].empty() ? std::string("-") : names[c]);
  return true;
}

bool SampleReader::read_header(Diagnostics& diag) {
  LineReader& in = in_[0];
  std::string_view line;
  if (!content_line(in, line, diag)) {
    diag.add({in.name(), 0, 0,
              std::string("empty: expected a header line naming the columns (") + kRequired +
                  "; optional temp, mx, my, mz)"});
    return false;
  }
  split_fields(line, fields_);
  double number = 0;
  const bool numeric = !fields_.empty() && parse_number(fields_[0].text, number);
  // The names: --columns, else a `# imucal: columns=` comment, else the header line, else six
  // numeric columns are taken as ax ay az gx gy gz.
  std::string given = columns_given_;
  columns_source_ = "--columns";
  if (given.empty()) {
    for (const FileSetting& s : settings_)
      if (s.key == "columns") given = s.value;
    columns_source_ = "columns= comment";
  }
  if (given.empty() && numeric && !columns_default_.empty()) {
    given = columns_default_;
    columns_source_ = "assumed";
  }
  std::vector<std::string> names;
  if (!given.empty()) {
    std::vector<Field> parts;
    split_fields(given, parts);
    for (const Field& f : parts) names.push_back(lower(f.text));
  } else if (!numeric) {
    columns_source_ = "header";
    for (const Field& f : fields_) names.push_back(lower(f.text));
  } else if (fields_.size() == 6) {
    columns_source_ = "assumed";
    names = {"ax", "ay", "az", "gx", "gy", "gz"};
  } else {
    std::string msg = "no header line naming the columns (found numbers, " +
                      std::to_string(fields_.size()) +
                      " per line): give --columns NAMES in the file's order (t, ax, ay, az, gx, "
                      "gy, gz, temp, mx, my, mz; - skips a column), e.g. --columns ";
    if (fields_.size() == 7) {
      msg += "t,ax,ay,az,gx,gy,gz (or ax,ay,az,gx,gy,gz,temp)";
    } else if (fields_.size() == 4) {
      msg +=
          "t,ax,ay,az (an accelerometer alone) or t,mx,my,mz (a magnetometer alone); a pair of "
          "imu_tk files (t x y z): give the accelerometer file and the gyroscope file";
    } else if (fields_.size() == 3) {
      msg += "ax,ay,az (one pose per line; or --poses) or mx,my,mz (a magnetometer alone)";
    } else {
      msg += "t,ax,ay,az,gx,gy,gz";
    }
    report(in, 1, msg, diag);
    return false;
  }
  if (!name_columns(names, columns_source_ != "header", diag)) return false;
  // With the names given, a first line that is not numbers is a header: skipped. One of
  // numbers is the first sample.
  if (columns_source_ != "header" && numeric) {
    pending_[0] = std::string(line);
    has_pending_[0] = true;
  }
  data_started_ = true;
  return true;
}

// A field that must be a finite number; reported (with its column) and false otherwise.
bool SampleReader::number_field(const LineReader& in, const Field& f, const char* name, double& out,
                                Diagnostics& diag) {
  if (!parse_number(f.text, out)) {
    report(in, static_cast<long>(f.offset + 1),
           std::string("expected a number for ") + name + ", found " + quoted(f.text) +
               ": line skipped",
           diag);
    return false;
  }
  if (!std::isfinite(out)) {
    report(in, static_cast<long>(f.offset + 1),
           std::string(name) + " is not finite (" + std::string(f.text) + "): line skipped", diag);
    return false;
  }
  return true;
}

// Time must increase: t after `previous` (if there is one), else reported.
bool SampleReader::after_previous(double t, bool have, double previous, const LineReader& in,
                                  long column, Diagnostics& diag) {
  if (!have || t > previous) return true;
  report(in, column, time_not_after(t, previous) + ": line skipped", diag);
  return false;
}

std::string SampleReader::time_not_after(double t, double previous) {
  char msg[120];
  std::snprintf(msg, sizeof msg, "time %.9g s is not after the previous sample's %.9g s", t,
                previous);
  return msg;
}

double SampleReader::untimed_time() const {
  return rate_hz_ > 0 ? static_cast<double>(index_) / rate_hz_ : static_cast<double>(index_);
}

void SampleReader::taken(double t) {
  have_last_ = true;
  last_t_ = t;
  ++index_;
}

bool SampleReader::next_csv(Record& r, Diagnostics& diag) {
  LineReader& in = in_[0];
  std::string_view line;
  for (;;) {
    if (has_pending_[0]) {  // the first line of a file without a header
      has_pending_[0] = false;
      line = pending_[0];
    } else if (!content_line(in, line, diag)) {
      break;
    }
    // Every field a finite number (the common line): read in one pass; else field by field.
    constexpr std::size_t kFast = 16;
    double x[kFast];
    const bool plain = columns_ <= kFast && plain_numbers(line, x, columns_);
    if (!plain) {
      split_fields(line, fields_);
      if (fields_.size() != columns_) {
        report(in, 0,
               "expected " + std::to_string(columns_) + " fields (" + column_list_ + "), found " +
                   std::to_string(fields_.size()) + ": line skipped",
               diag);
        ++skipped_;
        continue;
      }
    }
    bool ok = true;
    auto get = [&](int col, const char* name, double& out) {
      if (ok && col >= 0) {
        if (plain)
          out = x[col];
        else
          ok = number_field(in, fields_[static_cast<std::size_t>(col)], name, out, diag);
      }
    };
    static constexpr const char* kAcc[3] = {"ax", "ay", "az"};
    static constexpr const char* kGyro[3] = {"gx", "gy", "gz"};
    static constexpr const char* kMag[3] = {"mx", "my", "mz"};
    double t = 0;
    get(col_t_, "t", t);
    for (int a = 0; a < 3; ++a) {
      r.acc[a] = r.gyro[a] = kNaN;  // NaN: no such sensor in the input
      get(col_acc_[a], kAcc[a], r.acc[a]);
      get(col_gyro_[a], kGyro[a], r.gyro[a]);
    }
    // The optional columns may be empty or NaN (a magnetometer slower than the IMU, a
    // temperature read now and then): no reading there, the line is still good.
    auto optional = [&](int col, const char* name, double& out) {
      out = kNaN;
      if (!ok || col < 0) return;
      if (plain) {
        out = x[col];
        return;
      }
      const Field& f = fields_[static_cast<std::size_t>(col)];
      if (f.text.empty()) return;
      double v = 0;
      if (parse_number(f.text, v) && std::isnan(v)) return;
      ok = number_field(in, f, name, out, diag);
    };
    optional(col_temp_, "temp", r.temp);
    for (int a = 0; a < 3; ++a) optional(col_mag_[a], kMag[a], r.mag[a]);
    // A magnetometer reading is all three axes or none.
    if (!(std::isfinite(r.mag[0]) && std::isfinite(r.mag[1]) && std::isfinite(r.mag[2])))
      r.mag[0] = r.mag[1] = r.mag[2] = kNaN;
    if (col_t_ >= 0) {
      r.t = t * time_scale_;
      if (ok && have_last_ && !(r.t > last_t_)) {  // not after the previous one: reported
        if (plain) split_fields(line, fields_);    // where the time's column is
        ok = after_previous(r.t, have_last_, last_t_, in,
                            static_cast<long>(fields_[static_cast<std::size_t>(col_t_)].offset + 1),
                            diag);
      }
    } else {
      // No time column: the good samples are evenly spaced at the rate given.
      r.t = untimed_time();
    }
    if (ok) {
      taken(r.t);
      return true;
    }
    ++skipped_;
  }
  return false;
}

// The next good `t x y z` line of imu_tk file `which`.
bool SampleReader::next_txyz(int which, double& t, double v[3], long& line_no, Diagnostics& diag) {
  LineReader& in = in_[which];
  std::string_view line;
  for (;;) {
    if (has_pending_[which]) {
      has_pending_[which] = false;
      line = pending_[which];
    } else if (!content_line(in, line, diag)) {
      break;
    }
    double x[4];
    bool ok = plain_numbers(line, x, 4);  // the common line; else field by field, saying why
    if (!ok) {
      split_fields(line, fields_);
      if (fields_.size() != 4) {
        report(in, 0,
               "expected 4 fields (t x y z), found " + std::to_string(fields_.size()) +
                   ": line skipped",
               diag);
        ++skipped_;
        continue;
      }
      ok = true;
      static constexpr const char* kNames[4] = {"t", "x", "y", "z"};
      for (int k = 0; k < 4 && ok; ++k)
        ok = number_field(in, fields_[static_cast<std::size_t>(k)], kNames[k], x[k], diag);
    }
    ok = ok && after_previous(x[0] * time_scale_, have_[which], t_[which], in, 1, diag);
    if (!ok) {
      ++skipped_;
      continue;
    }
    t = x[0] * time_scale_;
    for (int a = 0; a < 3; ++a) v[a] = x[a + 1];
    line_no = in.line_number();
    return true;
  }
  return false;
}

// Pairs the two files by timestamp (within half a microsecond); an unmatched line is reported.
bool SampleReader::next_imutk(Record& r, Diagnostics& diag) {
  while (have_[0] && have_[1]) {
    const double tol = 5e-7 + 1e-12 * std::abs(t_[0]);
    if (std::abs(t_[0] - t_[1]) <= tol) {
      r.t = t_[0];
      for (int a = 0; a < 3; ++a) {
        r.acc[a] = v_[0][a];
        r.gyro[a] = v_[1][a];
        r.mag[a] = kNaN;
      }
      r.temp = kNaN;
      for (int i = 0; i < 2; ++i) have_[i] = next_txyz(i, t_[i], v_[i], vline_[i], diag);
      ++matched_;
      return true;
    }
    const int early = t_[0] < t_[1] ? 0 : 1;
    if (matched_ == 0 && unmatched_++ == 0) {
      first_unmatched_[0] = t_[0];
      first_unmatched_[1] = t_[1];
    }
    char msg[200];
    std::snprintf(msg, sizeof msg, "no %s sample at time %.9g s (next there: %.9g s): line skipped",
                  early == 0 ? "gyroscope" : "accelerometer", t_[early], t_[1 - early]);
    diag.add({in_[early].name(), vline_[early], 1, msg});
    ++skipped_;
    have_[early] = next_txyz(early, t_[early], v_[early], vline_[early], diag);
  }
  for (int i = 0; i < 2; ++i) {
    if (!have_[i]) continue;
    // The other file ended: count what is left unmatched here.
    long left = 0;
    while (have_[i]) {
      ++left;
      have_[i] = next_txyz(i, t_[i], v_[i], vline_[i], diag);
    }
    diag.add({in_[i].name(), 0, 0,
              std::to_string(left) + " line(s) after the other file's last sample: skipped"});
    skipped_ += left;
  }
  if (matched_ == 0 && unmatched_ > 0) {
    char msg[240];
    std::snprintf(msg, sizeof msg,
                  "no timestamp of one file matches the other's (they start at %.9g s and "
                  "%.9g s): imu_tk's two files must be sampled together, one line per sample",
                  first_unmatched_[0], first_unmatched_[1]);
    diag.add({in_[0].name(), 0, 0, msg});
    unmatched_ = 0;
  }
  return false;
}

bool SampleReader::next(Record& r, Diagnostics& diag) {
  if (from_records_) return next_record(r, diag);
  if (format_ == Format::kCsv) return next_csv(r, diag);
  if (!primed_) {
    primed_ = true;
    for (int i = 0; i < 2; ++i) have_[i] = next_txyz(i, t_[i], v_[i], vline_[i], diag);
  }
  return next_imutk(r, diag);
}

bool SampleReader::failed() const {
  for (int i = 0; i < files_; ++i)
    if (in_[i].failed()) return true;
  return false;
}

double SampleReader::fraction_read() const {
  std::uint64_t done = 0, total = 0;
  for (int i = 0; i < files_; ++i) {
    if (in_[i].size() == 0) return 0;
    done += in_[i].bytes_read();
    total += in_[i].size();
  }
  return total == 0 ? 0 : static_cast<double>(done) / static_cast<double>(total);
}

}  // namespace imucal::cli
