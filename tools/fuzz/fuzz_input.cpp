// SPDX-License-Identifier: MIT
// libFuzzer target: the `imucal` tool's readers (CSV, or an imu_tk pair split at the first NUL)
// and the settings they carry. Whatever the bytes, the reader must not crash, and every record
// it returns must be finite (NaN only for a sensor the input lacks) with strictly increasing time;
// the buffered stream reader must agree with the in-memory one. Built and run by tools/fuzz.sh.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>

#include "cli.hpp"
#include "input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace imucal::cli;
  if (size == 0) return 0;
  const std::uint8_t mode = data[0];
  std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  std::vector<std::string_view> texts{text};
  if (mode & 1) {  // imu_tk: two texts
    const std::size_t cut = text.find('\0');
    const std::size_t at = cut == std::string_view::npos ? text.size() / 2 : cut;
    texts = {text.substr(0, at), text.substr(std::min(at + 1, text.size()))};
  }
  Diagnostics diag(4);
  SampleReader reader;
  const Format format = (mode & 2) ? Format::kAuto : (mode & 1) ? Format::kImuTk : Format::kCsv;
  const auto unit = static_cast<TimeUnit>((mode >> 2) % 3);
  if (mode & 0x20) {
    // Differential: the buffered stream reader with tiny buffers (every block boundary and the
    // long-line skip are reached) must give exactly what the in-memory reader gives.
    constexpr std::size_t kLine = 100, kBlock = 64;
    std::vector<std::FILE*> files;
    for (std::string_view t : texts) {
      if (t.empty()) return 0;  // fmemopen needs a non-empty buffer
      files.push_back(fmemopen(const_cast<char*>(t.data()), t.size(), "r"));
    }
    SampleReader a, b;
    Diagnostics da(1000), db(1000);
    const bool oa = a.open_streams(files, format, da, kLine, kBlock);
    const bool ob = b.open_memory(texts, format, db, kLine);
    if (oa != ob) std::abort();
    if (oa) {
      a.set_time_unit(unit);
      b.set_time_unit(unit);
      Record ra, rb;
      for (;;) {
        const bool na = a.next(ra, da), nb = b.next(rb, db);
        if (na != nb) std::abort();
        if (!na) break;
        // Equal, or both NaN (a sensor the input lacks).
        auto same = [](double x, double y) { return x == y || (std::isnan(x) && std::isnan(y)); };
        bool equal = same(ra.t, rb.t) && same(ra.temp, rb.temp);
        for (int k = 0; k < 3; ++k)
          equal = equal && same(ra.acc[k], rb.acc[k]) && same(ra.gyro[k], rb.gyro[k]) &&
                  same(ra.mag[k], rb.mag[k]);
        if (!equal) std::abort();
      }
      if (da.count() != db.count()) std::abort();
    }
    for (std::FILE* f : files) std::fclose(f);
    return 0;
  }
  if (!reader.open_memory(texts, format, diag)) return 0;
  reader.set_time_unit(unit);
  Options options;
  std::string error;
  apply_file_settings(reader.file_settings(), options, error);
  Record r;
  bool first = true;
  double last = 0;
  while (reader.next(r, diag)) {
    // A sensor the input has is finite on every record; one it lacks is NaN on every record.
    bool finite = std::isfinite(r.t);
    for (int a = 0; a < 3; ++a)
      finite = finite && std::isfinite(r.acc[a]) == reader.has_accelerometer() &&
               std::isfinite(r.gyro[a]) == reader.has_gyroscope();
    if (!finite || (!first && !(r.t > last))) std::abort();
    first = false;
    last = r.t;
  }
  for (const Diagnostic& d : diag.kept())
    if (d.text().empty()) std::abort();
  return 0;
}
