// SPDX-License-Identifier: MIT
// tools/imucal/read_arrays.cpp: samples in memory (the Python package's arrays), read where they
// are, as a CSV file of the same columns would be.
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "format_reader.hpp"

namespace imucal::cli {

double ArrayColumn::at(std::size_t row, int axis) const {
  double v = 0;  // copied: a view of an array need not be aligned
  std::memcpy(&v, data + static_cast<std::ptrdiff_t>(row) * row_bytes + axis * axis_bytes,
              sizeof v);
  return v;
}

std::string SampleArrays::columns() const {
  std::string names;
  if (t) names += "t,";
  if (acc) names += "ax,ay,az,";
  if (gyro) names += "gx,gy,gz,";
  if (mag) names += "mx,my,mz,";
  if (temp) names += "temp,";
  if (!names.empty()) names.pop_back();
  return names;
}

bool ArrayReader::start(Diagnostics& diag) {
  std::vector<Field> parts;
  const std::string columns = arrays_.columns();
  split_fields(columns, parts);
  std::vector<std::string> names;
  for (const Field& f : parts) names.push_back(lower(f.text));
  layout_.source = "arrays";
  std::string error;
  if (cols_.name(names, true, layout_, error)) return true;
  diag.add({"<arrays>", 0, 0, error});
  return false;
}

double ArrayReader::fraction_read() const {
  return arrays_.rows == 0 ? 0 : static_cast<double>(next_) / static_cast<double>(arrays_.rows);
}

// The line of a report is the sample's index + 1.
bool ArrayReader::next(Record& r, Diagnostics& diag) {
  const SampleArrays& x = arrays_;
  while (next_ < x.rows) {
    const std::size_t i = next_++;
    const long line = static_cast<long>(i + 1);
    auto say = [&](const std::string& message) {
      diag.add({"<arrays>", line, 0, message + ": sample skipped"});
      ++skipped_;
    };
    r.t = x.t ? x.t.at(i) : 0;
    r.temp = x.temp ? x.temp.at(i) : kNaN;
    for (int a = 0; a < 3; ++a) {
      r.acc[a] = x.acc ? x.acc.at(i, a) : kNaN;
      r.gyro[a] = x.gyro ? x.gyro.at(i, a) : kNaN;
      r.mag[a] = x.mag ? x.mag.at(i, a) : kNaN;
    }
    bool finite = !x.t || std::isfinite(r.t);
    for (int a = 0; a < 3; ++a) {
      if (x.acc) finite = finite && std::isfinite(r.acc[a]);
      if (x.gyro) finite = finite && std::isfinite(r.gyro[a]);
    }
    if (!finite) {
      say("a time or a reading is not finite");
      continue;
    }
    // A magnetometer reading is all three axes or none; a temperature may be missing.
    if (!(std::isfinite(r.mag[0]) && std::isfinite(r.mag[1]) && std::isfinite(r.mag[2])))
      r.mag[0] = r.mag[1] = r.mag[2] = kNaN;
    if (!std::isfinite(r.temp)) r.temp = kNaN;
    if (x.t) {
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

}  // namespace imucal::cli
