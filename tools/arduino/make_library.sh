#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Assembles imucal as an Arduino library in OUT/imucal, in the layout the Arduino IDE and
# arduino-cli expect (the 1.5 library format: src/ is the only include path, and every source
# under it is compiled):
#   library.properties, LICENSE, CHANGELOG.md
#   src/imucal/            the headers (include/imucal, and ports/include/imucal: the flash port's
#                          simulated flashes)
#   src/imucal_lib/        the library's sources (lib/)
#   src/Eigen/<module>     forwarding headers for the Eigen modules imucal includes: the Arduino
#                          "Eigen" library (library.properties' depends=) keeps Eigen 3.4 under
#                          ArduinoEigen/ and is reached through its ArduinoEigenDense.h
#   examples/AccelCalibration/  the example sketch (examples/arduino)
# The repository keeps its own layout; a release for the Arduino Library Manager is this folder.
#   tools/arduino/make_library.sh OUT
set -euo pipefail
cd "$(dirname "$0")/../.."
[ $# -eq 1 ] || { echo "usage: $0 OUT" >&2; exit 2; }
lib="$1/imucal"
rm -rf "$lib"
mkdir -p "$lib/src/imucal_lib" "$lib/src/Eigen" "$lib/examples"
cp tools/arduino/library.properties LICENSE CHANGELOG.md "$lib/"
cp -r include/imucal "$lib/src/"
cp -r ports/include/imucal/. "$lib/src/imucal/"
cp lib/*.cpp lib/*.hpp "$lib/src/imucal_lib/"
cp -r examples/arduino/. "$lib/examples/"
modules=$(grep -rhoE '#include <Eigen/[A-Za-z]+>' include lib ports/include | sort -u |
  sed -E 's/.*<Eigen\/([A-Za-z]+)>/\1/')
for m in $modules; do
  cat >"$lib/src/Eigen/$m" <<EOT
// Eigen/$m for the Arduino build of imucal (written by tools/arduino/make_library.sh): the
// Arduino "Eigen" library keeps Eigen 3.4 under ArduinoEigen/; its ArduinoEigenDense.h includes
// it after replacing the core's macros that clash with Eigen (abs, round, B0, B1 ...).
#pragma once
#include <ArduinoEigenDense.h>
EOT
done
echo "Arduino library: $lib ($(find "$lib/src" -name '*.cpp' | wc -l) sources, Eigen modules: $(echo $modules))"
