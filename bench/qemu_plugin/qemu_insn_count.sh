#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# qemu_insn_count.sh - run a bare-metal (picolibc semihosting) ELF under
# qemu-system-arm or qemu-system-riscv32 with the insn_count TCG plugin and
# report exact instruction counts of the regions between calls to
# imucal_bench_begin()/imucal_bench_end().
#
# Usage: qemu_insn_count.sh [SYSTEM:]MACHINE ELF [program args...]
#   MACHINE: e.g. mps2-an386 (M4F), mps2-an500 (M7), mps2-an505 (M33);
#            riscv32:virt (RV32, qemu-system-riscv32 started without firmware)
# Output:  the program's stdout, then one "insn_count <N>" line per region.
# Exit:    the program's exit code; 124 on timeout (600 s); non-zero (3) if the
#          program exited 0 but no region was counted; 2 on usage/setup errors.
# Env:     IMUCAL_PLUGIN_DIR  where the plugin is built/cached
#                             (default ${TMPDIR:-/tmp}/imucal_qemu_plugin-$UID)
#          CC                 host C compiler (default cc)
#          IMUCAL_INSN_PROFILE=PATH  also count the regions' instructions by address into
#                             PATH (bench/insn_profile.py reads it)
#          IMUCAL_INSN_PROFILE_REGIONS=N  ... in the first N regions only
# Note: picolibc's semihost crt0 sets argv[0]="program-name", argv[1]=ELF name,
#       program args follow; args are space-joined by semihosting (no spaces).
set -u

if [ $# -lt 2 ]; then
    echo "usage: $0 MACHINE ELF [program args...]" >&2
    exit 2
fi
case $1 in
    *:*) system=${1%%:*} machine=${1#*:} ;;
    *) system=arm machine=$1 ;;
esac
elf=$2
shift 2
nm=arm-none-eabi-nm extra=()
if [ "$system" != arm ]; then
    nm=riscv64-unknown-elf-nm extra=(-bios none)
fi

here=$(cd "$(dirname "$0")" && pwd)
src=$here/insn_count.c
plugin_dir=${IMUCAL_PLUGIN_DIR:-${TMPDIR:-/tmp}/imucal_qemu_plugin-$(id -u)}
so=$plugin_dir/libinsn_count.so

# Build (or rebuild if the source is newer) the plugin; atomic rename so that
# parallel invocations never see a half-written .so.
if [ ! -f "$so" ] || [ "$src" -nt "$so" ]; then
    mkdir -p "$plugin_dir" || exit 2
    tmp=$(mktemp "$plugin_dir/.libinsn_count.XXXXXX") || exit 2
    if ! "${CC:-cc}" -shared -fPIC -O2 -o "$tmp" "$src"; then
        rm -f "$tmp"; echo "$0: building the QEMU plugin failed" >&2; exit 2
    fi
    chmod 755 "$tmp" && mv -f "$tmp" "$so"
fi

[ -f "$elf" ] || { echo "$0: no such ELF: $elf" >&2; exit 2; }
syms=$("$nm" "$elf") || exit 2
begin=$(awk '$3 == "imucal_bench_begin" { print $1 }' <<<"$syms")
end=$(awk '$3 == "imucal_bench_end" { print $1 }' <<<"$syms")
if [ -z "$begin" ] || [ -z "$end" ]; then
    echo "$0: imucal_bench_begin/imucal_bench_end not found in $elf" >&2
    exit 2
fi

# QemuOpts values: a literal comma is written as ",,".
esc() { printf '%s' "${1//,/,,}"; }
semi="enable=on,target=native,chardev=out,arg=$(esc "$elf")"
for a in "$@"; do semi+=",arg=$(esc "$a")"; done

log=$(mktemp "${TMPDIR:-/tmp}/imucal_insn_count.XXXXXX.log") || exit 2
trap 'rm -f "$log"' EXIT

timeout 600 "qemu-system-$system" -M "$machine" "${extra[@]}" -display none -monitor none \
    -serial none -chardev stdio,id=out -semihosting-config "$semi" \
    -kernel "$elf" -plugin "$(esc "$so"),begin=0x$begin,end=0x$end${IMUCAL_INSN_PROFILE:+,profile=$(esc "$IMUCAL_INSN_PROFILE")}${IMUCAL_INSN_PROFILE_REGIONS:+,profile_regions=$IMUCAL_INSN_PROFILE_REGIONS}" \
    -d plugin -D "$log"
rc=$?
[ $rc -eq 124 ] && echo "$0: qemu timed out after 600 s" >&2

counts=$(grep '^insn_count ' "$log")
if [ -n "$counts" ]; then
    printf '%s\n' "$counts"
else
    echo "$0: no insn_count regions recorded (qemu exit $rc)" >&2
    [ $rc -eq 0 ] && rc=3
fi
exit $rc
