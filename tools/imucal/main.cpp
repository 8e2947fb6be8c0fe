// SPDX-License-Identifier: MIT
// tools/imucal/main.cpp: the `imucal` command (see cli.hpp).
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "cli.hpp"

int main(int argc, char** argv) {
  // Not a terminal: stdout is written when the command ends (flushed by imucal_main), so that a
  // write that fails (a full disk) fails there and says why.
  static char stdout_buffer[1 << 20];
  if (isatty(STDOUT_FILENO) == 0) std::setvbuf(stdout, stdout_buffer, _IOFBF, sizeof stdout_buffer);
  // Past a file-size limit (ulimit -f) a write fails with EFBIG: reported, exit 2, the previous
  // output kept, instead of the process being killed.
  std::signal(SIGXFSZ, SIG_IGN);
  std::vector<std::string> args(argv + 1, argv + argc);
  const int code = imucal::cli::imucal_main(args);
  // imucal_main flushed stdout and said so if that failed; closing it can still fail (a file
  // system that reports its write errors at close).
  if (std::fclose(stdout) != 0 && code != 2) {
    std::fprintf(stderr, "imucal: cannot write to stdout: %s\n", std::strerror(errno));
    return 2;
  }
  return code;
}
