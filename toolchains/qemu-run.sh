#!/usr/bin/env bash
# Runs a bare-metal Arm ELF under qemu-system-arm with semihosting and returns its exit code.
# Used as CMAKE_CROSSCOMPILING_EMULATOR: qemu-run.sh MACHINE PROGRAM.elf [ARGS...]
# Program arguments travel as arg= items of -semihosting-config (commas doubled), output goes to
# stdout through a chardev. IMUCAL_QEMU_TIMEOUT (seconds, default 900) turns a hang into a failure.
set -euo pipefail
machine=$1
elf=$2
shift 2
cfg="enable=on,target=native,chardev=out,arg=${elf//,/,,}"
for a in "$@"; do cfg+=",arg=${a//,/,,}"; done
exec timeout "${IMUCAL_QEMU_TIMEOUT:-900}" qemu-system-arm -M "$machine" -display none \
  -monitor none -serial none -chardev stdio,id=out,signal=off -semihosting-config "$cfg" \
  -kernel "$elf" </dev/null
