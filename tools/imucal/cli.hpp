// SPDX-License-Identifier: MIT
// tools/imucal/cli.hpp: the `imucal` command line (host only).
//   imucal calibrate [options] FILE...   calibrate a recording (CSV, imu_tk pair, or - for stdin)
//   imucal report -o PAGE.svg [options] FILE...   the same, plus the picture page
//   imucal simulate -o FILE [--truth FILE] [--seed N] ...   a recording with known truth
//   imucal record FILE   a device calibration record (calibrate --record), decoded and printed
//   imucal noise [options] FILE   the noise terms of a still recording (Allan deviation)
//   imucal field [options] FILE   the field calibrator over a recording: its gyro bias, timeline
// Exit codes: 0 a usable calibration (of the sensors the input holds) or a command done; 1 the
// recording did not give a usable calibration, or the record is not valid; 2 a usage error or an
// unreadable input.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "run.hpp"

namespace imucal {
struct CalibrationRecord;
}

namespace imucal::cli {

int imucal_main(const std::vector<std::string>& args);

// Parts exposed for the tests.
bool parse_calibrate_options(const std::vector<std::string>& args, Options& options,
                             std::string& error);
// Applies `# imucal: key=value` settings read from the input unless the command line set them.
bool apply_file_settings(const std::vector<FileSetting>& settings, Options& options,
                         std::string& error);
int calibrate_command(const std::vector<std::string>& args, bool report);
int simulate_command(const std::vector<std::string>& args);
int record_command(const std::vector<std::string>& args);
int noise_command(const std::vector<std::string>& args);
int field_command(const std::vector<std::string>& args);

// A calibration record's file (calibrate --record, a flash slot's bytes; "-": stdin), read and
// decoded: 0 a valid record, 1 not one, 2 unreadable; `error` says why, as `imucal record` does.
// `length`: the record's bytes; `file_size`: the bytes read (at most kRecordMaxBytes).
int read_record_file(const std::string& path, CalibrationRecord& record, std::string& error,
                     std::size_t* length = nullptr, std::size_t* file_size = nullptr);

// `imucal calibrate` over samples in memory (the Python package's arrays, read where they are,
// as often as a file would be: the memory kept is bounded by --memory whatever their length):
// `args` are the command's options (no input files). Returns the command's exit code; fills
// what it would print and write.
struct MemoryRun {
  std::string error;                 // exit code 2: why
  std::string summary;               // the summary the command prints
  std::string json;                  // what --json writes
  std::vector<std::uint8_t> record;  // what --record writes (empty if not usable)
};
int calibrate_memory(const std::vector<std::string>& args, const SampleArrays& arrays,
                     MemoryRun& out);
// The options (`args`, the input named <arrays>) and the reader over `arrays`, for the memory
// runs. False with the reason.
bool open_arrays(const std::vector<std::string>& args, const SampleArrays& arrays, Options& o,
                 SampleReader& reader, Diagnostics& diag, std::string& error);

// `imucal field` over samples in memory, from the record `prior` (its bytes; nullptr: the nominal
// prior): its summary and --json in `out` (`record` unused). Returns the command's exit code.
int field_memory(const std::vector<std::string>& args, const SampleArrays& arrays,
                 const std::vector<std::uint8_t>* prior, MemoryRun& out);

// `imucal noise` over samples in memory: its summary, --json, --kalibr and (with --svg) page.
struct NoiseRun {
  std::string error;                       // exit code 2: why
  std::string summary, json, kalibr, svg;  // kalibr: empty unless the units are SI
  std::vector<std::string> diagnostics;
};
int noise_memory(const std::vector<std::string>& args, const SampleArrays& arrays, NoiseRun& out);

}  // namespace imucal::cli
