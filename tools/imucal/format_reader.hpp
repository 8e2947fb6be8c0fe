// SPDX-License-Identifier: MIT
// tools/imucal/format_reader.hpp: one reader per input format, behind SampleReader (host only):
// imucal CSV (a header line naming the columns, or the names given for a file without one),
// imu_tk's two `t x y z` files, and samples already in memory (the Python package's arrays).
// Each gives the good samples in order, in the input's units with the time in seconds, says what
// the input holds, and reports and skips what it cannot read.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "input.hpp"

namespace imucal::cli {

// What an input holds and how its columns were named.
struct InputLayout {
  bool accel = false, gyro = false, mag = false, temp = false, time = false;
  std::string names;   // the column names in file order ("-" for a skipped one)
  std::string source;  // how they were named: "header", "--columns", "columns= comment", ...
};

// The reader of one input format.
class FormatReader {
 public:
  virtual ~FormatReader() = default;
  // Reads what comes before the first sample (settings comments, a header line). False
  // (reported) if the input cannot be read as this format.
  virtual bool start(Diagnostics& diag) = 0;
  // The next good sample; bad ones on the way are reported and skipped. False at the end.
  virtual bool next(Record& r, Diagnostics& diag) = 0;
  virtual bool failed() const { return false; }  // a read error ended the input early (reported)
  virtual double fraction_read() const = 0;      // of all its bytes (0: unknown)

  const InputLayout& layout() const { return layout_; }
  const std::vector<FileSetting>& settings() const { return settings_; }
  long skipped() const { return skipped_; }
  // Settable until the first next() (SampleReader's).
  void set_time_unit(TimeUnit time);
  void set_rate(double hz) { rate_hz_ = hz; }

 protected:
  static std::string time_not_after(double t, double previous);
  double untimed_time() const;  // a sample's time without a t column: index / rate
  void taken(double t);         // a good sample: the next must come after t

  InputLayout layout_;
  std::vector<FileSetting> settings_;
  long skipped_ = 0;
  double time_scale_ = 1.0;
  double rate_hz_ = 0;
  long index_ = 0;  // good samples so far (their time without a t column)
  bool have_last_ = false;
  double last_t_ = 0;
};

// The columns of a CSV file or of the arrays: which holds what (-1: absent).
struct ColumnMap {
  int t = -1, acc[3] = {-1, -1, -1}, gyro[3] = {-1, -1, -1};
  int temp = -1, mag[3] = {-1, -1, -1};
  std::size_t count = 0;

  // Names the columns (lower-case names in file order). strict: an unknown name is an error (the
  // user's --columns), else ignored (a header's extra columns). False (why in `error`) if a name
  // is repeated, a sensor has some but not all of its axes, or neither the accelerometer nor
  // the magnetometer is there. On success the layout's parts and names are set.
  bool name(const std::vector<std::string>& names, bool strict, InputLayout& layout,
            std::string& error);
};

// A reader of text lines (CSV, imu_tk): one or two files, their settings comments.
class TextReader : public FormatReader {
 public:
  // The files' line readers, opened by SampleReader before start().
  LineReader& file(int i) { return in_[i]; }
  void set_files(int n) { files_ = n; }
  bool failed() const override;
  double fraction_read() const override;

 protected:
  // The next line that is neither blank nor a comment (settings in comments before the data are
  // collected; after it, reported).
  bool content_line(LineReader& in, std::string_view& line, Diagnostics& diag);
  // A field that must be a finite number; reported (with its column) and false otherwise.
  bool number_field(const LineReader& in, const Field& f, const char* name, double& out,
                    Diagnostics& diag);
  // Time must increase: t after `previous` (if there is one), else reported.
  bool after_previous(double t, bool have, double previous, const LineReader& in, long column,
                      Diagnostics& diag);
  void report(const LineReader& in, long column, std::string message, Diagnostics& diag);

  LineReader in_[2];
  int files_ = 0;
  bool data_started_ = false;
  std::vector<Field> fields_;
};

// imucal CSV: a header line naming the columns, or the names given (--columns, a `columns=`
// comment, or the default for a file without a header), then one sample per line.
class CsvReader : public TextReader {
 public:
  // given: --columns (wins over a header line, then skipped, and over a comment); headerless:
  // the names of a file without a header when none are given (empty: six numeric columns are
  // ax ay az gx gy gz).
  CsvReader(std::string given, std::string headerless)
      : given_(std::move(given)), headerless_(std::move(headerless)) {}
  bool start(Diagnostics& diag) override;
  bool next(Record& r, Diagnostics& diag) override;

 private:
  std::string given_, headerless_;
  ColumnMap cols_;
  std::string pending_;  // the first sample line of a file without a header, read by start()
  bool has_pending_ = false;
  // Lines of decimal commas (0,5;9,81): the first kListedAlike are listed, then a conclusion.
  static constexpr long kListedAlike = 3;
  long decimal_comma_lines_ = 0;
};

// imu_tk: two files of `t x y z` lines, the accelerometer's and the gyroscope's, paired by
// timestamp (within half a microsecond); an unmatched line is reported and skipped.
class ImuTkReader : public TextReader {
 public:
  ImuTkReader();
  bool start(Diagnostics& diag) override;
  bool next(Record& r, Diagnostics& diag) override;

 private:
  bool next_txyz(int which, double& t, double v[3], long& line, Diagnostics& diag);
  std::string pending_[2];  // the first sample line of each file, read by start()
  bool has_pending_[2] = {false, false};
  // One look-ahead sample per file.
  bool primed_ = false;
  bool have_[2] = {false, false};
  double t_[2] = {0, 0}, v_[2][3] = {};
  long vline_[2] = {0, 0};
  long matched_ = 0, unmatched_ = 0;
  double first_unmatched_[2] = {0, 0};
};

// Samples in memory (the Python package's arrays, read where they are), as a CSV file of their
// columns would give them: a required reading that is not finite, or a time not after the
// previous one, is reported (its index + 1 as the line) and the sample skipped.
class ArrayReader : public FormatReader {
 public:
  explicit ArrayReader(const SampleArrays& arrays) : arrays_(arrays) {}
  bool start(Diagnostics& diag) override;
  bool next(Record& r, Diagnostics& diag) override;
  double fraction_read() const override;

 private:
  SampleArrays arrays_;
  ColumnMap cols_;
  std::size_t next_ = 0;
};

// Shared by the readers: a lower-case copy; a field quoted for a message (at most 24 characters,
// the unprintable ones as \xNN).
std::string lower(std::string_view s);
std::string quoted(std::string_view s);
// The names of the columns the readers know, for messages.
constexpr const char* kRequiredColumns = "t, ax, ay, az, gx, gy, gz";

}  // namespace imucal::cli
