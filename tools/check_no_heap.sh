#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Proves "no heap" at link time at every optimisation level: for each target and level, a small
# build of only the footprint program (bench/footprint: the whole API in float), compiled once
# into fat LTO objects and linked twice, without and with -flto. cmake/CheckNoHeap.cmake fails
# the build if either program links malloc, free, operator new/delete, exception allocation or a
# thread-safe static guard, and prints its sizes.
#   tools/check_no_heap.sh                  m4f, m7 and m33 at -Os, -O2 and -O3
#   tools/check_no_heap.sh m4f:-Os,-O3 m7:-Os   chosen targets and levels (also m3, m0plus, rv32)
set -euo pipefail
cd "$(dirname "$0")/.."
configs=("$@")
[ ${#configs[@]} -gt 0 ] || configs=(m4f:-Os,-O2,-O3 m7:-Os,-O2,-O3 m33:-Os,-O2,-O3)
declare -A toolchain=([m4f]=cortex-m4f [m7]=cortex-m7 [m33]=cortex-m33 [m3]=cortex-m3
                      [m0plus]=cortex-m0plus [rv32]=riscv32imac)
# One target at one level: configure, build, print the verdict and sizes into its log.
check() {  # check TARGET LEVEL DIR
  local target=$1 level=$2 dir=$3
  echo "== no heap: $target $level, with and without -flto"
  cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE= \
    -DCMAKE_TOOLCHAIN_FILE="$PWD/toolchains/${toolchain[$target]}.cmake" \
    -DIMUCAL_BUILD_TESTS=OFF -DIMUCAL_BUILD_EXAMPLES=OFF -DIMUCAL_BUILD_TOOLS=OFF -DIMUCAL_BUILD_BENCH=ON \
    -DIMUCAL_BUILD_INSN_BENCH=OFF -DIMUCAL_INSTALL=OFF -DIMUCAL_WERROR=ON \
    -DIMUCAL_FOOTPRINT_OPT="$level" -DIMUCAL_FOOTPRINT_LTO=ON >/dev/null
  if ! cmake --build "$dir" --target imucal_footprint imucal_footprint_lto >"$dir/build.log" 2>&1
  then
    cat "$dir/build.log"
    return 1
  fi
  grep -E "no-heap|text .* B" "$dir/build.log"
}

# Two builds at a time (IMUCAL_NOHEAP_JOBS): each is mostly one long compile and two links, so
# one alone leaves a core idle much of its time. Each build's lines are printed together, in
# order, once all have ended.
jobs=${IMUCAL_NOHEAP_JOBS:-2}
dirs=()
for config in "${configs[@]}"; do
  target=${config%%:*}
  IFS=, read -ra levels <<<"${config#*:}"
  for level in "${levels[@]}"; do
    dir="build/noheap/$target$level"
    mkdir -p "$dir"
    rm -f "$dir/check.status"
    while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do wait -n || true; done
    { check "$target" "$level" "$dir" >"$dir/check.log" 2>&1; echo $? >"$dir/check.status"; } &
    dirs+=("$dir")
  done
done
wait
status=0
for dir in "${dirs[@]}"; do
  cat "$dir/check.log"
  [ "$(cat "$dir/check.status" 2>/dev/null)" = 0 ] || { echo "no-heap check failed: $dir"; status=1; }
done
exit "$status"
