// tools/imucal/main.cpp: the `imucal` command (see cli.hpp).
#include <csignal>
#include <string>
#include <vector>

#include "cli.hpp"

int main(int argc, char** argv) {
  // Past a file-size limit (ulimit -f) a write fails with EFBIG: reported, exit 2, the previous
  // output kept, instead of the process being killed.
  std::signal(SIGXFSZ, SIG_IGN);
  std::vector<std::string> args(argv + 1, argv + argc);
  return imucal::cli::imucal_main(args);
}
