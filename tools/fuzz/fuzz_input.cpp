// libFuzzer target: the `imucal` tool's readers (CSV, or an imu_tk pair split at the first NUL)
// and the settings they carry. Whatever the bytes, the reader must not crash, and every record
// it returns must be finite with strictly increasing time. Built and run by tools/fuzz.sh.
#include <cmath>
#include <cstdint>
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
  if (!reader.open_memory(texts, format, diag)) return 0;
  reader.set_time_unit(static_cast<TimeUnit>((mode >> 2) % 3));
  Options options;
  std::string error;
  apply_file_settings(reader.file_settings(), options, error);
  Record r;
  bool first = true;
  double last = 0;
  while (reader.next(r, diag)) {
    bool finite = std::isfinite(r.t);
    for (int a = 0; a < 3; ++a)
      finite = finite && std::isfinite(r.acc[a]) && std::isfinite(r.gyro[a]);
    if (!finite || (!first && !(r.t > last))) std::abort();
    first = false;
    last = r.t;
  }
  for (const Diagnostic& d : diag.kept())
    if (d.text().empty()) std::abort();
  return 0;
}
