// SPDX-License-Identifier: MIT
// tools/imucal/input.hpp: the `imucal` tool's input (host only, not library code): lines,
// fields and numbers, and the samples of an input whatever its format (SampleReader; the
// formats' readers are in format_reader.hpp).
//
// Two text formats, read line by line in bounded memory (a serial logger can pipe in):
//  - imucal CSV: a header line naming the columns (t, ax, ay, az, gx, gy, gz, temp, mx, my, mz;
//    any order, unknown names ignored), then one sample per line. A sensor is all three of its
//    axes or none; the accelerometer or the magnetometer must be there; without t the samples
//    are at i / rate (set_rate). Without a header line, the columns are named by set_columns()
//    (or a `# imucal: columns=...` comment), or six numeric columns are ax ay az gx gy gz. Fields
//    are separated by commas and/or blanks. The optional fields may be empty or NaN: no reading at
//    that sample (a magnetometer slower than the IMU); a magnetometer reading is all three axes
//    or none. Lines starting with # are comments; a comment
//    `# imucal: key=value ...` carries settings for the tool (see options.hpp).
//  - imu_tk: two files of `t x y z` lines, accelerometer and gyroscope, paired by timestamp.
// A bad line is reported (file, line, column, what was expected) and skipped; the good lines
// are kept. Timestamps must increase.
#pragma once

#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace imucal::cli {

enum class Format { kAuto, kCsv, kImuTk };
enum class TimeUnit { kSeconds, kMilliseconds, kMicroseconds };

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// One input sample in the input's own units, time in seconds.
struct Record {
  double t = 0;
  double acc[3] = {0, 0, 0};   // NaN (all three, every record): no accelerometer in the input
  double gyro[3] = {0, 0, 0};  // NaN (all three, every record): no gyroscope in the input
  double temp = kNaN;          // deg C; NaN: none at this sample
  double mag[3] = {kNaN, kNaN, kNaN};  // input units; NaN (all three): none at this sample
};

struct Diagnostic {
  std::string file;
  long line = 0;    // 1-based; 0: the file as a whole
  long column = 0;  // 1-based; 0: the line as a whole
  std::string message;
  std::string text() const;  // "file:line:column: message"
};

// Keeps the first `keep` diagnostics in full and counts the rest.
class Diagnostics {
 public:
  explicit Diagnostics(std::size_t keep = 20) : keep_(keep) {}
  void add(Diagnostic d);
  std::size_t count() const { return count_; }
  const std::vector<Diagnostic>& kept() const { return kept_; }

 private:
  std::size_t keep_;
  std::size_t count_ = 0;
  std::vector<Diagnostic> kept_;
};

// Lines of a file or of stdin ("-"), read in blocks. A line longer than `max_line` characters is
// reported (its length and fields) and skipped; one longer than max_skip() ends the input there
// (reported: an endless line, binary data), so that any input ends in bounded time. CR before LF
// is dropped; a last line without LF still counts; a UTF-8 byte-order mark before the first line
// is dropped. An input whose first line is not text (UTF-16 or UTF-32, NUL bytes, binary data,
// lines ended by CR alone) ends there, reported. A directory is refused. A read error is
// reported and ends the input.
class LineReader {
 public:
  static constexpr std::size_t kMaxLine = 1 << 16;
  static constexpr std::size_t kBlock = 1 << 16;

  LineReader() = default;
  LineReader(const LineReader&) = delete;
  LineReader& operator=(const LineReader&) = delete;
  ~LineReader();
  bool open(const std::string& path, Diagnostics& diag, std::size_t max_line = kMaxLine,
            std::size_t block = kBlock);  // false (reported) if it cannot be opened
  // An open stream (not closed here); small sizes let the fuzz target reach every boundary.
  void open_stream(std::FILE* f, const std::string& name, std::size_t max_line = kMaxLine,
                   std::size_t block = kBlock);
  // Reads from memory instead of a file (the fuzz target and the tests).
  void open_memory(std::string_view text, const std::string& name, std::size_t max_line = kMaxLine);
  bool next(std::string_view& line, Diagnostics& diag);
  long line_number() const { return line_; }
  const std::string& name() const { return name_; }
  std::uint64_t bytes_read() const { return consumed_; }
  std::uint64_t size() const { return size_; }  // 0 if unknown (a pipe)
  bool failed() const { return failed_; }       // a read error ended the input early
  // The input ended before its end (reported): not text, or a line beyond max_skip().
  bool ended() const { return ended_; }
  long long_lines() const { return long_lines_; }  // lines skipped as longer than max_line
  std::size_t max_line() const { return max_line_; }
  std::uint64_t max_skip() const { return kSkipLines * static_cast<std::uint64_t>(max_line_); }
  static constexpr std::uint64_t kSkipLines = 256;  // max_skip(): 16 MB at the default max_line

 private:
  void fill();
  std::string_view unread() const;
  std::FILE* file_ = nullptr;
  bool owns_ = false;
  bool eof_ = false;
  bool failed_ = false;
  bool ended_ = false;
  long long_lines_ = 0;
  std::string error_;
  std::string name_;
  std::size_t max_line_ = kMaxLine;
  std::unique_ptr<char[]> buf_;
  std::size_t buf_size_ = 0;
  std::size_t begin_ = 0, end_ = 0;
  std::string_view memory_;
  bool from_memory_ = false;
  long line_ = 0;
  std::uint64_t consumed_ = 0, size_ = 0;
};

// Splits a line into fields at commas, semicolons and blanks. Positions are 0-based offsets.
struct Field {
  std::string_view text;
  std::size_t offset;
};
void split_fields(std::string_view line, std::vector<Field>& out);

// A number or nothing: the whole field must parse (std::from_chars, so no locale).
bool parse_number(std::string_view text, double& out);

// The end of the decimal number at p, its value in `out`, or nullptr where std::from_chars must
// decide: the common numbers read faster, to the same double (see input.cpp).
const char* decimal_fast(const char* p, const char* end, double& out);

// A line of exactly n finite numbers (blank- or comma-separated) read in one pass, to the same
// values as split_fields and parse_number give; false for any other line.
bool plain_numbers(std::string_view line, double* out, std::size_t n);

// Samples in memory, one array per quantity, read where they are (the Python package's numpy
// arrays: any strides, not copied): each column's first value and the bytes from one row to the
// next and from one axis to the next; data null: not in the input.
struct ArrayColumn {
  const char* data = nullptr;
  std::ptrdiff_t row_bytes = 0, axis_bytes = 0;
  double at(std::size_t row, int axis = 0) const;
  explicit operator bool() const { return data != nullptr; }
};
struct SampleArrays {
  std::size_t rows = 0;
  ArrayColumn t, acc, gyro, mag, temp;  // t, temp: one axis; the others three
  // The columns present, comma-separated, as --columns names them ("t,ax,ay,az,gx,gy,gz").
  std::string columns() const;
};

// The `# imucal: key=value ...` settings found in comments, in order.
struct FileSetting {
  std::string key, value;
  std::string file;
  long line;
};

class FormatReader;
struct InputLayout;

// The samples of an input, whatever its format: a facade over the format's reader
// (format_reader.hpp).
class SampleReader {
 public:
  SampleReader();
  ~SampleReader();
  SampleReader(const SampleReader&) = delete;
  SampleReader& operator=(const SampleReader&) = delete;

  // files: one CSV file (or "-" for stdin), or the imu_tk accelerometer and gyroscope files.
  // False (reported) if nothing can be read: missing file, empty file, no usable header.
  bool open(const std::vector<std::string>& files, Format format, Diagnostics& diag);
  // For the fuzz target and the tests: CSV text or two imu_tk texts.
  bool open_memory(const std::vector<std::string_view>& texts, Format format, Diagnostics& diag,
                   std::size_t max_line = LineReader::kMaxLine);
  // Open streams, not closed here (the fuzz target: small buffers reach every boundary).
  bool open_streams(const std::vector<std::FILE*>& files, Format format, Diagnostics& diag,
                    std::size_t max_line, std::size_t block);
  // Samples in memory (the Python package's arrays, which must outlive the reader), as a CSV
  // file of their columns would give them: a required reading that is not finite, or a time not
  // after the previous one, is reported and the sample skipped. Opened again, they are read
  // again from the first.
  bool open_arrays(const SampleArrays& arrays, Diagnostics& diag);
  // Settable until the first next(): a `# imucal: time-unit=ms` comment may say it.
  void set_time_unit(TimeUnit time);
  // Without a t column, sample i (0-based, good samples) is at i / hz seconds (hz 0: at i s).
  // Settable until the first next().
  void set_rate(double hz);
  // The column names, comma-separated (t, ax, ay, az, gx, gy, gz, temp, mx, my, mz; - or _ skip
  // a column), given before open(): they win over a header line (then skipped) and over a
  // `# imucal: columns=...` comment.
  void set_columns(std::string names) { columns_given_ = std::move(names); }
  // The names of a file without a header when none are given (instead of six numeric columns
  // as ax ay az gx gy gz): e.g. "ax,ay,az" for a file of poses.
  void set_headerless_columns(std::string names) { columns_default_ = std::move(names); }
  // The next good sample; bad lines on the way are reported and skipped. False at the end.
  bool next(Record& r, Diagnostics& diag);

  Format format() const { return format_; }
  bool from_arrays() const { return from_arrays_; }  // open_arrays()
  bool has_temperature() const;
  bool has_magnetometer() const;
  // Both for an imu_tk pair; for CSV, as the columns say.
  bool has_accelerometer() const;
  bool has_gyroscope() const;
  bool has_time() const;
  // How the columns were named: "header", "--columns", "columns= comment", or "assumed" (six
  // numeric columns without a header); and the names in file order ("-" for a skipped one).
  const std::string& columns_source() const;
  const std::string& column_names() const;
  long lines_skipped() const;
  bool failed() const;  // a read error ended an input early (reported)
  const std::vector<FileSetting>& file_settings() const;
  // Progress over all files: bytes read / bytes in total (0 if unknown).
  double fraction_read() const;

 private:
  template <class OpenFile>
  bool open_text(int files, Format format, Diagnostics& diag, OpenFile&& open_file);
  const InputLayout& layout() const;

  std::unique_ptr<FormatReader> reader_;
  Format format_ = Format::kAuto;
  bool from_arrays_ = false;
  std::string columns_given_, columns_default_;
};

}  // namespace imucal::cli
