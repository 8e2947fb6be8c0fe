// SPDX-License-Identifier: MIT
// tools/imucal/outputs.hpp: what `imucal calibrate` writes: the summary, the JSON record of the
// run, the C header for firmware, the comparison with a simulator's truth file.
#pragma once

#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "run.hpp"

namespace imucal::cli {

void print_summary(const Run& run, const Options& options, std::FILE* out);
// The JSON record of the run (as --json writes it).
std::string run_json(const Run& run, const Options& options);
bool write_json(const Run& run, const Options& options, const std::string& path);
bool write_header(const Run& run, const Options& options, const std::string& path);
// Prints each parameter's error in sigmas against the truth file `imucal simulate` wrote.
bool compare_with_truth(const Run& run, const std::string& truth_path, std::FILE* out);
// "-" is stdout. A file is replaced whole or not at all (written under a temporary name beside
// it, then renamed); a device or a pipe is written in place; a directory is refused. False
// (the reason on stderr) if it cannot be written.
bool write_text_file(const std::string& path, const std::string& text);
// An output (option and path) that is the same file as an input, by device and inode (so
// another name of it, a link, too): refused, the reason on stderr, false. "" and "-" are no
// file; an output that does not exist yet is no input.
struct NamedPath {
  const char* option;
  std::string path;
};
bool outputs_apart_from_inputs(const std::vector<std::string>& inputs,
                               const std::vector<NamedPath>& outputs);
// What `print` writes to a stream, as a string (a summary kept rather than printed).
std::string printed(const std::function<void(std::FILE*)>& print);
// printf into a string (at most 1023 characters).
std::string format_text(const char* format, ...) __attribute__((format(printf, 1, 2)));
// One number in `format`, or "n/a" if it is not finite.
std::string fmt(const char* format, double v);
// "1 pose", "3 poses": n and the word for it.
std::string plural(long n, const char* one, const char* many);

// The models, said once for the summary, the JSON, the header and the record's print.
extern const char* const kAccelModel;
extern const char* const kGyroModel;
extern const char* const kConvention;
extern const char* const kMagModel;
extern const char* const kTemperatureModel;

// One line per parameter: name, value, sigma, unit (rad for the first scale_index, then the
// scales in (out_unit)/unit, then the biases in unit).
void print_params(std::FILE* out, const char* const* names, const double* p, const double* sd,
                  int n, int scale_index, const char* unit, const char* out_unit);
// "[x, y, z] +- [sx, sy, sz]", the values in `format`.
std::string vec_pm(const double* v, const double* sd, const char* format);

}  // namespace imucal::cli
