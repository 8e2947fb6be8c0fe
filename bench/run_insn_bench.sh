#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Instruction counts of the benchmark regions on one Arm or RISC-V target, as a Markdown table.
# Usage: bench/run_insn_bench.sh PRESET [BUILD_DIR]
#   PRESET: m4f, m7, m33, m3, m0plus or rv32 (the machine QEMU emulates); BUILD_DIR: where the
#   programs were built (default build/PRESET; bench/insn_cores.sh builds them for the other
#   cores).
# IMUCAL_INSN_PROGRAMS="bench_field_insn ...": run only these programs (bench/insn_cores.sh sets
# it to what it built); otherwise every program that was built.
# Counts are exact guest instructions from the QEMU TCG plugin in bench/qemu_plugin (QEMU is
# not cycle-accurate: instructions, not cycles). Regions of the same name are summed: the table
# gives their number, the mean and the largest. Each region includes 2 instructions of marker
# overhead (the per-sample means are small enough for that to matter: 2 of ~150).
# After the table, a second one gives the stack depths the programs measured by painting the
# stack ("STACK" lines, bench/insn/stack_paint.hpp): the deepest call seen, in bytes below the
# caller's stack pointer at the call, including the call's own frame. Only the paths the run
# took: not a static worst case.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
preset=${1:-m4f}
build=${2:-$here/../build/$preset}
case $preset in
  m4f) machine=mps2-an386 ;;
  m7) machine=mps2-an500 ;;
  m33) machine=mps2-an505 ;;
  m3 | m0plus) machine=mps2-an385 ;;  # ARMv6-M code runs on its Cortex-M3
  rv32) machine=riscv32:virt ;;        # qemu-system-riscv32
  *) echo "unknown preset $preset" >&2; exit 2 ;;
esac
echo "| region ($preset, $machine, -O2) | calls | mean | largest | total |"
echo "| --- | ---: | ---: | ---: | ---: |"
if [ -n "${IMUCAL_INSN_PROGRAMS:-}" ]; then
  read -r -a programs <<<"$IMUCAL_INSN_PROGRAMS"
else
  programs=(bench_accel_insn)
  if [ -f "$build/bench/bench_apply_insn" ]; then
    programs+=(bench_apply_insn)
  fi
  if [ -f "$build/bench/bench_mag_insn" ]; then
    programs+=(bench_mag_insn)
  fi
  # The field calibrator on a simulated life (no data needed).
  if [ -f "$build/bench/bench_field_insn" ]; then
    programs+=(bench_field_insn)
  fi
  # The streaming benchmark reads the xsens recording beside the clone (CI always has it).
  if [ -f "$here/../../shared/data/xsens/xsens_acc.mat" ]; then
    programs+=(bench_stream_insn)
  else
    echo "(bench_stream_insn skipped: ../shared/data/xsens not found)" >&2
  fi
fi
stack=""
for program in "${programs[@]}"; do
  elf=$build/bench/$program
  out=$("$here/qemu_plugin/qemu_insn_count.sh" "$machine" "$elf")
  names=$(printf '%s\n' "$out" | sed -n 's/^BENCH //p')
  counts=$(printf '%s\n' "$out" | sed -n 's/^insn_count //p')
  if [ "$(printf '%s\n' "$names" | wc -l)" -ne "$(printf '%s\n' "$counts" | wc -l)" ] ||
     [ -z "$names" ]; then
    printf '%s\n' "$out" | tail -20 >&2
    echo "$program: region names and counts do not pair up" >&2
    exit 1
  fi
  paste -d '\t' <(printf '%s\n' "$names") <(printf '%s\n' "$counts") | awk -F '\t' '
    !($1 in n) { order[++k] = $1 }
    { n[$1]++; sum[$1] += $2; if ($2 > max[$1]) max[$1] = $2 }
    END { for (i = 1; i <= k; i++) { r = order[i];
            printf "| %s | %d | %d | %d | %d |\n", r, n[r], sum[r] / n[r] + 0.5, max[r], sum[r] } }'
  printf '%s\n' "$out" | sed -n 's/^RESULT /    /p' >&2
  stack+=$(printf '%s\n' "$out" | sed -n 's/^STACK \([^:]*\): \(.*\)$/| \1 | \2 |/p')$'\n'
done
if [ -n "${stack//$'\n'/}" ]; then
  echo
  echo "| stack ($preset, painted; bytes below the caller's SP, incl. the call's own frame) | deepest |"
  echo "| --- | ---: |"
  printf '%s' "$stack" | sed '/^$/d'
fi
