#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Installs what imucal needs on Debian 12, by set, or the named packages (the benchmarks'):
#   host    the host build and its tests (preset host): the library, the `imucal` command, the
#           Python package (and its pip install, offline, with mypy for its types), GoogleTest,
#           Google Benchmark, clang-format, librsvg
#   cross   the Arm and RISC-V cross toolchains with picolibc, QEMU, and GCC's source for the
#           RISC-V libstdc++: the cross presets and their tests under QEMU
#   checks  what the other checks of tools/test_all.sh use: Clang with its sanitizer runtimes
#           (host-asan, fuzzing), pkg-config, pykwalify and kconfiglib (the Zephyr module)
#   all     the three sets (the default)
# Uses sudo when not root. Idempotent: skips apt-get when everything is already there.
#   tools/setup_debian.sh [host|cross|checks|all]...
#   tools/setup_debian.sh PACKAGE...
set -euo pipefail
host=(cmake ninja-build ccache g++ libeigen3-dev googletest libgtest-dev libbenchmark-dev
  clang-format nlohmann-json3-dev librsvg2-bin python3 pybind11-dev python3-dev python3-numpy
  python3-pytest python3-venv python3-setuptools python3-wheel python3-pybind11 python3-mypy)
cross=(gcc-arm-none-eabi picolibc-arm-none-eabi libstdc++-arm-none-eabi-picolibc qemu-system-arm
  gcc-riscv64-unknown-elf picolibc-riscv64-unknown-elf qemu-system-misc gcc-12-source)
checks=(clang libclang-rt-14-dev pkgconf python3-yaml python3-pykwalify python3-ruamel.yaml
  python3-dateutil python3-kconfiglib)
[ $# -gt 0 ] || set -- all
packages=()
for arg in "$@"; do
  case $arg in
    host) packages+=("${host[@]}") ;;
    cross) packages+=("${cross[@]}") ;;
    checks) packages+=("${checks[@]}") ;;
    all) packages+=("${host[@]}" "${cross[@]}" "${checks[@]}") ;;
    *) packages+=("$arg") ;;
  esac
done
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo=sudo
  echo "installing: ${missing[*]}"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
