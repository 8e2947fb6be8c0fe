// tools/imucal/main.cpp: the `imucal` command (see cli.hpp).
#include <string>
#include <vector>

#include "cli.hpp"

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  return imucal::cli::imucal_main(args);
}
