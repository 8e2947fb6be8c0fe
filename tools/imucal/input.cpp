// SPDX-License-Identifier: MIT
// tools/imucal/input.cpp: line reading, field splitting, the CSV and imu_tk readers.
#include "input.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <utility>

#include "format_reader.hpp"

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
  struct stat st {};
  const bool known = fstat(fileno(f), &st) == 0;
  if (known && S_ISDIR(st.st_mode)) {
    std::fclose(f);
    diag.add({path, 0, 0, "is a directory, not a recording"});
    return false;
  }
  open_stream(f, path, max_line, block);
  owns_ = true;
  if (known && S_ISREG(st.st_mode)) size_ = static_cast<std::uint64_t>(st.st_size);
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

namespace {

// Why the start of an input (its first line, at most max_line + 1 bytes of it) is not the text
// of a recording: a UTF-16 or UTF-32 text, NUL bytes only, binary data, lines ended by a
// carriage return alone; empty if it can be.
std::string not_text(std::string_view head) {
  auto starts = [&](std::string_view prefix) { return head.substr(0, prefix.size()) == prefix; };
  const char* const save_as = ": save it as UTF-8 or ASCII (e.g. iconv -f ";
  if (starts(std::string_view("\xff\xfe\0\0", 4)) || starts(std::string_view("\0\0\xfe\xff", 4)))
    return std::string("UTF-32 text (a byte-order mark)") + save_as + "UTF-32 -t UTF-8)";
  if (starts("\xff\xfe") || starts("\xfe\xff"))
    return std::string("UTF-16 text (the byte-order mark ") +
           (head[0] == '\xff' ? "FF FE" : "FE FF") + ")" + save_as + "UTF-16 -t UTF-8)";
  const std::size_t nul = head.find('\0');
  if (nul != std::string_view::npos) {
    if (head.find_first_not_of('\0') == std::string_view::npos)
      return "NUL bytes only (the first " + std::to_string(head.size()) +
             " bytes): not a text recording (a file never written, or an erased card?)";
    // Every other byte NUL, the others ASCII: UTF-16 without a byte-order mark.
    std::size_t at[2] = {0, 0}, n = std::min<std::size_t>(head.size(), 256) & ~std::size_t{1};
    for (std::size_t k = 0; k < n; ++k) at[k & 1] += head[k] == '\0';
    for (int odd = 0; odd < 2; ++odd)
      if (n >= 4 && at[odd] == n / 2 && at[1 - odd] == 0)
        return std::string("UTF-16 text (") + (odd ? "little" : "big") +
               "-endian, no byte-order mark: every other byte is NUL)" + save_as +
               (odd ? "UTF-16LE" : "UTF-16BE") + " -t UTF-8)";
    return "binary data, not a text recording (a NUL byte at byte " + std::to_string(nul + 1) +
           " of line 1)";
  }
  for (std::size_t cr = head.find('\r'); cr != std::string_view::npos; cr = head.find('\r', cr + 1))
    if (cr + 1 < head.size() && head[cr + 1] != '\r' && head[cr + 1] != '\n')
      return "the lines end in a carriage return alone (CR, as classic Mac OS wrote them): "
             "convert them to LF (e.g. tr '\\r' '\\n')";
  return "";
}

// How many fields a line of `text` has (commas and semicolons separate them).
std::uint64_t separators(std::string_view text) {
  std::uint64_t n = 0;
  for (char c : text) n += c == ',' || c == ';';
  return n;
}

}  // namespace

bool LineReader::next(std::string_view& line, Diagnostics& diag) {
  if (ended_) return false;
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
    // The first line says whether this is text at all (not UTF-16, binary, NUL bytes, or lines
    // ended by CR alone): if not, the input ends here.
    if (line_ == 0) {
      const std::string why = not_text(rest.substr(0, std::min(len, max_line_ + 1)));
      if (!why.empty()) {
        diag.add({name_, 1, 0, why});
        ended_ = true;
        return false;
      }
    }
    // A stream's incomplete line here is longer than max_line (the buffer's end, not the line's,
    // so a '\r' there is not its terminator).
    const bool whole = complete || from_memory_ || eof_;
    const std::size_t text_len = whole && len > 0 && rest[len - 1] == '\r' ? len - 1 : len;
    ++line_;
    if (text_len > max_line_) {
      // Skip to the end of this line, up to max_skip characters: a longer one (an endless line,
      // binary data without a line end) ends the input there.
      std::uint64_t chars = 0, fields = 1;
      for (;;) {
        rest = unread();
        const std::size_t at = rest.find('\n');
        const std::size_t take = at != std::string_view::npos ? at : rest.size();
        chars += take;
        fields += separators(rest.substr(0, take));
        if (chars > max_skip()) {
          ended_ = true;
          break;
        }
        begin_ += at != std::string_view::npos ? at + 1 : take;
        consumed_ += at != std::string_view::npos ? at + 1 : take;
        if (at != std::string_view::npos || from_memory_ || eof_) break;
        fill();
      }
      if (ended_) {
        diag.add({name_, line_, 0,
                  "line longer than " + std::to_string(max_skip()) +
                      " characters (no line end within them): not a recording of text lines; "
                      "the input is read no further"});
        return false;
      }
      ++long_lines_;
      diag.add({name_, line_, 0,
                "line longer than " + std::to_string(max_line_) + " characters (" +
                    std::to_string(chars) + " characters, " + std::to_string(fields) +
                    " fields): skipped"});
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

// --- SampleReader --------------------------------------------------------------------------

SampleReader::SampleReader() = default;
SampleReader::~SampleReader() = default;

// The reader of `format` (auto: two files are imu_tk, one is CSV) over `files` line readers,
// opened by `open_file(reader, i)`; then its start(). A count of files the format does not take
// is said by start(), after the files were opened (an unopenable file is said first).
template <class OpenFile>
bool SampleReader::open_text(int files, Format format, Diagnostics& diag, OpenFile&& open_file) {
  format_ = format == Format::kAuto ? (files == 2 ? Format::kImuTk : Format::kCsv) : format;
  std::unique_ptr<TextReader> text;
  if (format_ == Format::kCsv)
    text = std::make_unique<CsvReader>(columns_given_, columns_default_);
  else
    text = std::make_unique<ImuTkReader>();
  text->set_files(files);
  for (int i = 0; i < files; ++i)
    if (!open_file(text->file(i), i)) return false;
  reader_ = std::move(text);
  return reader_->start(diag);
}

bool SampleReader::open(const std::vector<std::string>& files, Format format, Diagnostics& diag) {
  const int n = static_cast<int>(files.size());
  if (n < 1 || n > 2) {
    diag.add({"imucal", 0, 0,
              "expected one CSV file (or - for stdin), or the imu_tk accelerometer and gyroscope "
              "files"});
    return false;
  }
  if (n == 2 && files[0] == "-" && files[1] == "-") {
    diag.add({"<stdin>", 0, 0, "stdin can be only one of the two imu_tk files"});
    return false;
  }
  return open_text(n, format, diag, [&](LineReader& in, int i) {
    return in.open(files[static_cast<std::size_t>(i)], diag);
  });
}

bool SampleReader::open_memory(const std::vector<std::string_view>& texts, Format format,
                               Diagnostics& diag, std::size_t max_line) {
  const int n = static_cast<int>(std::min<std::size_t>(texts.size(), 2));
  if (n < 1) return false;
  return open_text(n, format, diag, [&](LineReader& in, int i) {
    in.open_memory(texts[static_cast<std::size_t>(i)], i == 0 ? "<text>" : "<text2>", max_line);
    return true;
  });
}

bool SampleReader::open_streams(const std::vector<std::FILE*>& files, Format format,
                                Diagnostics& diag, std::size_t max_line, std::size_t block) {
  const int n = static_cast<int>(std::min<std::size_t>(files.size(), 2));
  if (n < 1) return false;
  return open_text(n, format, diag, [&](LineReader& in, int i) {
    in.open_stream(files[static_cast<std::size_t>(i)], i == 0 ? "<text>" : "<text2>", max_line,
                   block);
    return true;
  });
}

bool SampleReader::open_arrays(const SampleArrays& arrays, Diagnostics& diag) {
  format_ = Format::kCsv;
  from_arrays_ = true;
  reader_ = std::make_unique<ArrayReader>(arrays);
  return reader_->start(diag);
}

void SampleReader::set_time_unit(TimeUnit time) {
  if (reader_) reader_->set_time_unit(time);
}

void SampleReader::set_rate(double hz) {
  if (reader_) reader_->set_rate(hz);
}

bool SampleReader::next(Record& r, Diagnostics& diag) { return reader_ && reader_->next(r, diag); }

const InputLayout& SampleReader::layout() const {
  static const InputLayout kNothing;
  return reader_ ? reader_->layout() : kNothing;
}

bool SampleReader::has_temperature() const { return layout().temp; }
bool SampleReader::has_magnetometer() const { return layout().mag; }
bool SampleReader::has_accelerometer() const { return layout().accel; }
bool SampleReader::has_gyroscope() const { return layout().gyro; }
bool SampleReader::has_time() const { return layout().time; }
const std::string& SampleReader::columns_source() const { return layout().source; }
const std::string& SampleReader::column_names() const { return layout().names; }
long SampleReader::lines_skipped() const { return reader_ ? reader_->skipped() : 0; }
bool SampleReader::failed() const { return reader_ && reader_->failed(); }
double SampleReader::fraction_read() const { return reader_ ? reader_->fraction_read() : 0; }

const std::vector<FileSetting>& SampleReader::file_settings() const {
  static const std::vector<FileSetting> kNone;
  return reader_ ? reader_->settings() : kNone;
}

}  // namespace imucal::cli
