#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# What the library costs on each core, as one Markdown table: exact instructions (QEMU's counting
# plugin, bench/run_insn_bench.sh) of Calibrator::add() per sample, of add_raw() per 16-bit frame
# (the recording's frames at 100 Hz, and a 1 kHz stream), of add_fifo() per frame in batches of 25,
# of the whole solve and its largest slice, of Corrector::apply(), and sizeof(Calibrator<float>).
# Then a second table: the field calibrator (bench_field_insn, a simulated life at 100 Hz with
# the magnetometer at 50 Hz): FieldCalibrator::add_raw() per frame at rest and moving with no
# solve under way, the mean of the calls that run a slice of a model's solve, and its largest
# call (a rest judged or a slice); the same with the temperature once a second rather than with every
# frame; add_fifo() per frame in batches of 25; from a stored calibration (the moves kept and walked): at rest and moving; the same built without the gyro's matrix and the magnetometer; add_mag() per call, sizeof(FieldCalibrator<float>) with and without the magnetometer's model (and without the gyro's matrix as well) and the stack its calls took (painted;
# not on the M0+).
# Each core's instruction-count programs are built in build/insn/CORE (-O2, assertions off, as
# firmware would) with that core's toolchain file; the cores without an FPU use soft float.
#   bench/insn_cores.sh                 m4f m7 m33 m3 m0plus
#   bench/insn_cores.sh m3 m0plus rv32  chosen cores (rv32: RV32IMAC, qemu-system-riscv32)
#   bench/insn_cores.sh --field m4f     the field calibrator's table only (--protocol: the first)
set -euo pipefail
cd "$(dirname "$0")/.."
protocol=1 field=1
case ${1:-} in
  --field) protocol=0; shift ;;
  --protocol) field=0; shift ;;
esac
cores=("$@")
[ ${#cores[@]} -gt 0 ] || cores=(m4f m7 m33 m3 m0plus)
declare -A toolchain=([m4f]=cortex-m4f [m7]=cortex-m7 [m33]=cortex-m33 [m3]=cortex-m3
                      [m0plus]=cortex-m0plus [rv32]=riscv32imac)
declare -A label=([m4f]="Cortex-M4F" [m7]="Cortex-M7 (FPU: single)" [m33]="Cortex-M33 (FPU)"
                  [m3]="Cortex-M3 (no FPU: soft float)" [m0plus]="Cortex-M0+ (ARMv6-M, soft float)"
                  [rv32]="RV32IMAC (no FPU: soft float)")
targets=() programs=()
[ $protocol = 1 ] && targets+=(bench_accel_insn bench_apply_insn bench_mag_insn bench_stream_insn)
[ $field = 1 ] && targets+=(bench_field_insn)
# The stream program runs only where the recording is (bench/run_insn_bench.sh).
for t in "${targets[@]}"; do
  [ "$t" = bench_stream_insn ] && [ ! -f ../shared/data/xsens/xsens_acc.mat ] && continue
  programs+=("$t")
done
field_rows=""
[ $protocol = 1 ] && echo "| core | add() per sample: at rest / moving / initial rest (largest call) | add_raw() per frame: at rest / moving, 100 Hz / after the initial rest, 1 kHz | add_fifo() per frame (batches of 25) | the whole solve (largest slice) | Corrector::apply() | sizeof(Calibrator<float>) |"
[ $protocol = 1 ] && echo "| --- | --- | --- | ---: | --- | ---: | ---: |"
for core in "${cores[@]}"; do
  dir=build/insn/$core
  cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 -g" \
    -DCMAKE_TOOLCHAIN_FILE="$PWD/toolchains/${toolchain[$core]}.cmake" \
    -DIMUCAL_BUILD_TESTS=OFF -DIMUCAL_BUILD_EXAMPLES=OFF -DIMUCAL_BUILD_TOOLS=OFF \
    -DIMUCAL_BUILD_BENCH=ON -DIMUCAL_BUILD_INSN_BENCH=ON -DIMUCAL_INSTALL=OFF \
    -DIMUCAL_WERROR=ON >/dev/null
  cmake --build "$dir" --target "${targets[@]}" >/dev/null
  table=$(IMUCAL_INSN_PROGRAMS="${programs[*]}" bench/run_insn_bench.sh "$core" "$PWD/$dir" 2>&1)
  # row TEXT COLUMN: the column of the row whose region contains TEXT (plain text, not a regular
  # expression: awk -v reads backslashes in its own way, which differs between awks).
  row() { printf '%s\n' "$table" | awk -F'|' -v r="$1" 'index($2, r) { gsub(/ /, "", $'"$2"'); print $'"$2"' }'; }
  if [ $field = 1 ]; then
    # The field calibrator: add_raw()'s ordinary frames, its largest call of any kind (the calls
    # that judge a rest have regions of their own), add_mag() in a rest / with none open.
    f_rest=$(row "field: add_raw(), still" 4) f_moving=$(row "field: add_raw(), moving" 4)
    f_slice=$(row "field: add_raw(), a solve slice" 4)
    f_largest=$(printf '%s\n' "$table" | awk -F'|' 'index($2, "field: add_raw()") { gsub(/ /, "", $5); if ($5 + 0 > m) m = $5 + 0 } END { print m }')
    f_1hz="$(row "temperature at 1 Hz: add_raw(), still" 4) / $(row "temperature at 1 Hz: add_raw(), moving" 4)"
    f_mag_rest=$(row "field: add_mag(), in a rest" 4) f_mag_none=$(row "field: add_mag(), no rest" 4)
    f_size=$(printf '%s\n' "$table" | sed -n 's/.*field: start.*sizeof \([0-9]*\), without a magnetometer \([0-9]*\), and without the gyro.s matrix \([0-9]*\).*/\1 (\2, \3)/p')
    f_stack=$(printf '%s\n' "$table" | awk -F'|' 'index($2, "field add_raw(), add_mag()") { sub(/^ +/, "", $3); sub(/ +$/, "", $3); print $3 }')
    case $f_stack in [0-9]*) ;; *) f_stack="(not measured)" ;; esac
    # From a stored calibration (the moves kept and walked for the gyro's matrix, in the frames
    # in motion): at rest, moving.
    f_stored="$(row "stored calibration: add_raw(), still" 4) / $(row "stored calibration: add_raw(), moving" 4)"
    # Built without the gyro's matrix and the magnetometer, from the same record.
    f_lean="$(row "without the gyro's matrix: add_raw(), still" 4) / $(row "without the gyro's matrix: add_raw(), moving" 4)"
    # In FIFO batches of 25 (the temperature once a batch): a frame's share of a batch's call,
    # every frame of it still / moving.
    per_frame() { printf '%s\n' "$table" | awk -F'|' -v r="$1" 'index($2, r) { printf "%d", ($4 + 12) / 25 }'; }
    f_fifo="$(per_frame "FIFO batches of 25: add_fifo(), still") / $(per_frame "FIFO batches of 25: add_fifo(), moving")"
    field_rows+="| ${label[$core]} | $f_rest / $f_moving / $f_slice / $f_largest | $f_1hz | $f_fifo | $f_stored | $f_lean | $f_mag_rest / $f_mag_none | $f_size | $f_stack |"$'\n'
  fi
  [ $protocol = 1 ] || continue
  rest=$(row "add(): still" 4) moving=$(row "add(): moving" 4) init=$(row "add(): initial" 4)
  largest=$(row "add(): moving" 5)
  # The stream program's solve() and solve_step() rows (not the accelerometer's or magnetometer's).
  solve=$(printf '%s\n' "$table" | awk -F'|' '$2 ~ /^ solve/ { gsub(/ /, "", $6); s += $6 } END { printf "%.2f M", s / 1e6 }')
  slice=$(printf '%s\n' "$table" | awk -F'|' '$2 ~ /^ solve/ { gsub(/ /, "", $5); if ($5 + 0 > m) m = $5 + 0 } END { print m }')
  apply=$(row "Corrector::apply(): accelerometer and gyro" 4)
  size=$(printf '%s\n' "$table" | sed -n 's/.*converged.*sizeof \([0-9]*\).*/\1/p')
  raw_rest=$(row "add_raw(): still" 4) raw_moving=$(row "add_raw(): moving" 4)
  raw_fast=$(row "add_raw() at 1 kHz: after" 4)
  fifo=$(printf '%s\n' "$table" | awk -F'|' '$2 == " add_fifo(): 25 frames " { printf "%d", ($4 + 12) / 25 }')
  echo "| ${label[$core]} | $rest / $moving / $init ($largest) | $raw_rest / $raw_moving / $raw_fast | $fifo | $solve ($slice) | $apply | $size |"
done
if [ $field = 1 ]; then
  [ $protocol = 1 ] && echo
  echo "| core | FieldCalibrator::add_raw() per frame: at rest / moving / a call with a solve slice (mean) / largest call | the same, temperature at 1 Hz instead of every frame: at rest / moving | add_fifo() per frame (batches of 25, the temperature once a batch): at rest / moving | from a stored calibration (moves kept and walked): at rest / moving | the same built without the gyro's matrix and the magnetometer (FieldCalibrator<float, 8, 0, false>): at rest / moving | add_mag() per call (50 Hz): in a rest / none open | sizeof(FieldCalibrator<float>) (without a magnetometer: MagCells 0; and without the gyro's matrix) | stack of add_raw() (painted) |"
  echo "| --- | --- | --- | --- | --- | --- | --- | ---: | ---: |"
  printf '%s' "$field_rows"
fi
