#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Runs a bare-metal ELF under QEMU with semihosting and returns its exit code.
# Used as CMAKE_CROSSCOMPILING_EMULATOR: qemu-run.sh [SYSTEM:]MACHINE PROGRAM.elf [ARGS...]
# SYSTEM picks qemu-system-SYSTEM: arm (the default; Cortex-M boards) or riscv32 (virt, started
# without firmware: the ELF's entry runs first, in machine mode).
# Program arguments travel as arg= items of -semihosting-config (commas doubled), output goes to
# stdout through a chardev. IMUCAL_QEMU_TIMEOUT (seconds, default 900) turns a hang into a failure.
set -euo pipefail
case $1 in
  *:*) system=${1%%:*} machine=${1#*:} ;;
  *) system=arm machine=$1 ;;
esac
elf=$2
shift 2
extra=()
[ "$system" = arm ] || extra=(-bios none)
cfg="enable=on,target=native,chardev=out,arg=${elf//,/,,}"
for a in "$@"; do cfg+=",arg=${a//,/,,}"; done
exec timeout "${IMUCAL_QEMU_TIMEOUT:-900}" "qemu-system-$system" -M "$machine" "${extra[@]}" \
  -display none -monitor none -serial none -chardev stdio,id=out,signal=off \
  -semihosting-config "$cfg" -kernel "$elf" </dev/null
