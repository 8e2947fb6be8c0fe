#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# What a firmware pays for the parts it links: text, data and bss of imucal's share (each program
# minus the same program without imucal, bench/footprint/footprint.cpp) for each set of parts, on
# the given targets (Arm, rv32) and optimisation levels, as a Markdown table. Every program is also
# checked for heap symbols (cmake/CheckNoHeap.cmake).
#   bench/footprint_parts.sh                     m4f at -Os and -O2
#   bench/footprint_parts.sh m4f:-Os,-O2 m33:-Os  chosen targets and levels
#   FOOTPRINT_FLAGS=-DEIGEN_UNROLLING_LIMIT=0 bench/footprint_parts.sh m4f:-Os
#                                                 with compiler flags a firmware adds (;-separated)
set -euo pipefail
cd "$(dirname "$0")/.."
configs=("$@")
[ ${#configs[@]} -gt 0 ] || configs=(m4f:-Os,-O2)
declare -A toolchain=([m4f]=cortex-m4f [m7]=cortex-m7 [m33]=cortex-m33 [m3]=cortex-m3
                      [m0plus]=cortex-m0plus [rv32]=riscv32imac)
names=("load and apply (record store + corrector)"
       "accelerometer alone (solver from pose means, store, corrector)"
       "accelerometer + gyro: the streaming calibrator, store, corrector"
       "+ magnetometer (collector, solve, alignment)"
       "+ temperature (rest monitor, fit)"
       "+ field calibrator (its saves and resume): everything"
       "field calibrator alone (resume, frames, FIFO, magnetometer, save, corrector)"
       "the same without a magnetometer (FieldCalibrator<float, 8, 0>)"
       "the same without the gyro's matrix either (FieldCalibrator<float, 8, 0, false>)")
echo "| parts | target | level | text | data | bss |"
echo "| --- | --- | --- | ---: | ---: | ---: |"
for config in "${configs[@]}"; do
  target=${config%%:*}
  IFS=, read -ra levels <<<"${config#*:}"
  for level in "${levels[@]}"; do
    flags=${FOOTPRINT_FLAGS:-}
    dir="build/footprint/$target$level${flags:+-$(tr -c 'A-Za-z0-9_=\n-' _ <<<"$flags")}"
    cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE= \
      -DCMAKE_TOOLCHAIN_FILE="$PWD/toolchains/${toolchain[$target]}.cmake" \
      -DIMUCAL_BUILD_TESTS=OFF -DIMUCAL_BUILD_EXAMPLES=OFF -DIMUCAL_BUILD_TOOLS=OFF -DIMUCAL_BUILD_BENCH=ON \
      -DIMUCAL_BUILD_INSN_BENCH=OFF -DIMUCAL_INSTALL=OFF -DIMUCAL_WERROR=ON \
      -DIMUCAL_FOOTPRINT_OPT="$level${flags:+;$flags}" -DIMUCAL_FOOTPRINT_LTO=OFF >/dev/null
    for parts in 1 2 3 4 5 6 7 8 9; do
      program=imucal_footprint_parts$parts
      [ "$parts" = 6 ] && program=imucal_footprint
      log="$dir/$program.log"
      rm -f "$dir/bench/$program"  # relinked, so the size check prints its sizes again
      if ! cmake --build "$dir" --target "$program" >"$log" 2>&1; then
        cat "$log" >&2
        exit 1
      fi
      share=$(grep -o "imucal's share (footprint - baseline): .*" "$log" | tail -1)
      read -r text data bss < <(sed -E 's/.*text ([0-9]+) B, data ([0-9]+) B, bss ([0-9]+) B.*/\1 \2 \3/' <<<"$share")
      printf '| %s | %s | %s | %s | %s | %s |\n' "${names[$((parts - 1))]}" "$target" "$level" \
        "$text" "$data" "$bss"
    done
  done
done
