// tools/imucal/read_arrays.cpp: samples already in memory (the Python package's arrays), read as
// a CSV file of the same columns would be.
#include <cmath>
#include <string>
#include <vector>

#include "format_reader.hpp"

namespace imucal::cli {

bool ArrayReader::start(Diagnostics& diag) {
  std::vector<Field> parts;
  split_fields(columns_, parts);
  std::vector<std::string> names;
  for (const Field& f : parts) names.push_back(lower(f.text));
  layout_.source = "arrays";
  std::string error;
  if (cols_.name(names, true, layout_, error)) return true;
  diag.add({"<arrays>", 0, 0, error});
  return false;
}

// The line of a report is the sample's index + 1.
bool ArrayReader::next(Record& r, Diagnostics& diag) {
  while (next_ < records_.size()) {
    const long line = static_cast<long>(++next_);
    r = records_[static_cast<std::size_t>(line - 1)];
    auto say = [&](const std::string& message) {
      diag.add({"<arrays>", line, 0, message + ": sample skipped"});
      ++skipped_;
    };
    bool finite = cols_.t < 0 || std::isfinite(r.t);
    for (int a = 0; a < 3; ++a) {
      if (cols_.acc[0] >= 0) finite = finite && std::isfinite(r.acc[a]);
      if (cols_.gyro[0] >= 0) finite = finite && std::isfinite(r.gyro[a]);
      if (cols_.acc[0] < 0) r.acc[a] = kNaN;
      if (cols_.gyro[0] < 0) r.gyro[a] = kNaN;
      if (cols_.mag[0] < 0) r.mag[a] = kNaN;
    }
    if (cols_.temp < 0) r.temp = kNaN;
    if (!finite) {
      say("a time or a reading is not finite");
      continue;
    }
    // A magnetometer reading is all three axes or none; a temperature may be missing.
    if (!(std::isfinite(r.mag[0]) && std::isfinite(r.mag[1]) && std::isfinite(r.mag[2])))
      r.mag[0] = r.mag[1] = r.mag[2] = kNaN;
    if (!std::isfinite(r.temp)) r.temp = kNaN;
    if (cols_.t >= 0) {
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
