#!/usr/bin/env bash
# Installs what imucal needs on Debian 12 (host build, Arm and RISC-V cross toolchains with
# picolibc, QEMU, GCC's source for the RISC-V libstdc++, the Python package's build), or with
# arguments those packages instead (the benchmarks').
# Uses sudo when not root. Idempotent: skips apt-get when everything is already there.
#   tools/setup_debian.sh [PACKAGE...]
set -euo pipefail
packages=(cmake ninja-build ccache g++ libeigen3-dev googletest libgtest-dev libbenchmark-dev
  clang-format gcc-arm-none-eabi picolibc-arm-none-eabi libstdc++-arm-none-eabi-picolibc
  qemu-system-arm gcc-riscv64-unknown-elf picolibc-riscv64-unknown-elf qemu-system-misc
  gcc-12-source nlohmann-json3-dev clang libclang-rt-14-dev librsvg2-bin python3
  pybind11-dev python3-dev python3-numpy python3-pytest)
[ $# -eq 0 ] || packages=("$@")
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
