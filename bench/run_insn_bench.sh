#!/usr/bin/env bash
# Instruction counts of the benchmark regions on one Arm target, as a Markdown table.
# Usage: bench/run_insn_bench.sh PRESET   (m4f, m7 or m33; the preset must be built)
# Counts are exact guest instructions from the QEMU TCG plugin in bench/qemu_plugin (QEMU is
# not cycle-accurate: instructions, not cycles). Each region includes 2 instructions of marker
# overhead.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
preset=${1:-m4f}
case $preset in
  m4f) machine=mps2-an386 ;;
  m7) machine=mps2-an500 ;;
  m33) machine=mps2-an505 ;;
  *) echo "unknown preset $preset" >&2; exit 2 ;;
esac
elf=$here/../build/$preset/bench/bench_accel_insn
out=$("$here/qemu_plugin/qemu_insn_count.sh" "$machine" "$elf")
mapfile -t names < <(printf '%s\n' "$out" | sed -n 's/^BENCH //p')
mapfile -t counts < <(printf '%s\n' "$out" | sed -n 's/^insn_count //p')
if [ "${#names[@]}" -ne "${#counts[@]}" ] || [ "${#names[@]}" -eq 0 ]; then
  printf '%s\n' "$out" >&2
  echo "region names and counts do not pair up" >&2
  exit 1
fi
echo "| region ($preset, $machine, -O2) | instructions |"
echo "| --- | ---: |"
for i in "${!names[@]}"; do printf '| %s | %s |\n' "${names[$i]}" "${counts[$i]}"; done
