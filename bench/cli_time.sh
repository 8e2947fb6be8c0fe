#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Whole-process time of `imucal calibrate` on the xsens recording (two 3.3 MB text files, parsing
# included): the median of N runs (default 21) of the built tool, float and double.
#   bench/cli_time.sh [RUNS]     (after `cmake --build --preset host`)
set -euo pipefail
cd "$(dirname "$0")/.."
runs="${1:-21}"
dir="${IMUCAL_XSENS_DIR:-../shared/data/xsens}"
tool=build/host/tools/imucal
if [ ! -f "$dir/xsens_acc.mat" ]; then
  echo "cli_time: xsens recording not found in $dir: skipped"
  exit 0
fi
args=("$dir/xsens_acc.mat" "$dir/xsens_gyro.mat" --accel-unit counts --accel-lsb-per-g 4070
  --accel-zero 32768 --gyro-unit counts --gyro-lsb-per-dps 83.2522 --gravity 9.81744
  --initial-rest 40 --quiet)
for mode in float double; do
  extra=()
  [ "$mode" = double ] && extra=(--double)
  times=()
  for _ in $(seq "$runs"); do
    start=$(date +%s%N)
    "$tool" calibrate "${args[@]}" "${extra[@]}" >/dev/null
    end=$(date +%s%N)
    times+=($(((end - start) / 1000)))
  done
  printf '%s\n' "${times[@]}" | sort -n | awk -v mode="$mode" -v n="$runs" '
    { t[NR] = $1 }
    END { printf "imucal calibrate xsens (%s): median %.1f ms over %d runs (min %.1f, max %.1f)\n",
                 mode, t[int((n + 1) / 2)] / 1000, n, t[1] / 1000, t[n] / 1000 }'
done
