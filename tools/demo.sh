#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The main job: set up the host packages (tools/setup_debian.sh host: no cross toolchain, QEMU or
# GCC source), build the `imucal` command, and calibrate the bundled simulated recording (raw
# 16-bit counts, hand-turned poses, known truth) with the float streaming calibrator, as on the
# device; then compare with the truth and write the JSON, the firmware header and the report page
# into build/demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup_debian.sh host
cmake --preset host >/dev/null
cmake --build --preset host --target imucal_tool >/dev/null
mkdir -p build/demo
build/host/tools/imucal calibrate data/simulated_imu.csv --truth data/simulated_imu.truth.json \
  --json build/demo/calibration.json --header build/demo/imucal_calibration.h \
  --svg build/demo/report.svg
echo
echo "written: build/demo/calibration.json, build/demo/imucal_calibration.h, build/demo/report.svg"
