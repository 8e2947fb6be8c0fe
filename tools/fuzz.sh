#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Fuzzes the `imucal` tool's readers, then the calibration record decoder and store, with
# libFuzzer (clang, with AddressSanitizer and UndefinedBehaviorSanitizer) for a bounded time:
# tools/fuzz.sh [SECONDS] (default 60; both targets at once, one core each).
# Seeds: the bundled recording's head, imu_tk lines, malformed lines; the pinned version-1
# record. Exit code 0 only if
# nothing crashed; a crashing input is left in build/fuzz/ with its name printed.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
out=build/fuzz
mkdir -p "$out/corpus"
# Both programs are built, then both fuzzed, side by side (one core each).
clang++ -std=c++17 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined \
  -Itools/imucal -Iinclude -isystem /usr/include/eigen3 \
  tools/fuzz/fuzz_input.cpp tools/imucal/input.cpp tools/imucal/format_reader.cpp \
  tools/imucal/read_csv.cpp tools/imucal/read_imutk.cpp tools/imucal/read_arrays.cpp \
  tools/imucal/options.cpp \
  -o "$out/fuzz_input" &
build_input=$!
# The record's programs need the solvers only in float.
clang++ -std=c++17 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined \
  -DIMUCAL_FLOAT_ONLY -Iinclude -Iports/include -isystem /usr/include/eigen3 \
  tools/fuzz/fuzz_record.cpp lib/record.cpp lib/record_store.cpp lib/status.cpp \
  lib/accel_calibration.cpp lib/gyro_calibration.cpp -o "$out/fuzz_record" &
build_record=$!
wait "$build_input"
wait "$build_record"
# Seeds (the first byte selects the format and time unit, see fuzz_input.cpp).
{ printf '\x00'; head -c 2000 data/simulated_imu.csv; } >"$out/corpus/csv"
printf '\x01%s\0%s' "$(printf '0.01 1 2 3\n0.02 1 2 3\n')" "$(printf '0.01 4 5 6\n0.03 4 5 6\n')" \
  >"$out/corpus/imutk"
{ printf '\x20'; head -c 3000 data/simulated_imu.csv; } >"$out/corpus/csv_stream"
printf '\x00# imucal: gravity=9.81 accel-unit=g\nt;ax;ay;az;gx;gy;gz\n1;2;3\n1,nan,,x,1e999,+4,-5\r\n' \
  >"$out/corpus/bad"
"$out/fuzz_input" -max_total_time="$seconds" -max_len=4096 -timeout=10 \
  -artifact_prefix="$out/" "$out/corpus" >"$out/fuzz_input.log" 2>&1 &
fuzz_input=$!

# The calibration record decoder and the two-slot store.
mkdir -p "$out/corpus_record"
# Seeds: the pinned version-1 record (both sensors), the same cut short, and the pinned record
# with every part (magnetometer and temperature model too).
printf "$(sed -n '/^0x/{s/0x/\\x/g; s/[, ]//g; p}' host_tests/support/record_v1_bytes.inc | tr -d '\n')" \
  >"$out/corpus_record/v1"
head -c 100 "$out/corpus_record/v1" >"$out/corpus_record/v1_short"
printf "$(sed -n '/^0x/{s/0x/\\x/g; s/[, ]//g; p}' host_tests/support/record_full_bytes.inc | tr -d '\n')" \
  >"$out/corpus_record/every_part"
"$out/fuzz_record" -max_total_time="$seconds" -max_len=2048 -timeout=10 \
  -artifact_prefix="$out/record-" "$out/corpus_record" >"$out/fuzz_record.log" 2>&1 &
fuzz_record=$!
status=0
wait "$fuzz_input" || status=$?
echo "-- the tool's readers"
tail -n 4 "$out/fuzz_input.log"
wait "$fuzz_record" || status=$?
echo "-- record decoder and store"
tail -n 4 "$out/fuzz_record.log"
exit "$status"
