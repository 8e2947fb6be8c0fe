#!/bin/sh
# SPDX-License-Identifier: MIT
# A firmware that only loads and applies a stored calibration compiles the record, the store and
# the corrector: none of the calibrator's, the solvers' or the stillness detector's headers.
#   load_and_apply_headers.sh CXX EIGEN_INCLUDE_DIR SOURCE_DIR
cxx="$1"
eigen="$2"
src="$3"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
printf '#include "imucal/corrector.hpp"\n#include "imucal/store/record_store.hpp"\nint main() { return 0; }\n' \
  >"$work/lap.cpp"
if ! "$cxx" -std=c++17 -fsyntax-only -H -I"$src/include" -I"$src/ports/include" -isystem "$eigen" \
  "$work/lap.cpp" 2>"$work/headers.txt"; then
  cat "$work/headers.txt"
  exit 1
fi
headers=$(grep -oE 'imucal/[a-z_/]+\.hpp' "$work/headers.txt" | sort -u)
heavy=$(echo "$headers" | grep -E 'calibrator|_calibration|levenberg|normal_equations|stillness|pose_store|gyro_segment|temperature_fit|rest_monitor|allan')
if [ -n "$heavy" ]; then
  echo "load and apply compiles the calibrator's headers: $heavy"
  exit 1
fi
echo "load and apply compiles only:" $headers
