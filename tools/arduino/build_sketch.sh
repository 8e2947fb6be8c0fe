#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Compiles the Arduino layout of imucal (tools/arduino/make_library.sh) and its example sketch as
# the Arduino build does for a SAMD21 (Arduino Zero, MKR), links it for the Cortex-M0+ with the
# board's memory (256 KB flash, 32 KB RAM) and runs it under QEMU:
# - every .cpp under the library's src/ compiled on its own, with the SAMD core's flags
#   (-mcpu=cortex-m0plus -mthumb -Os -ffunction-sections -fdata-sections -fno-rtti -fno-exceptions
#   -fno-threadsafe-statics) and its standard, -std=gnu++11, followed by the -std=gnu++17 that
#   docs/ecosystems.md has the user add (compiler.cpp.extra_flags in platform.local.txt), and
#   the include path the build finds: the library's src/, the core, the "Eigen" library;
# - with the core's -std=gnu++11 alone, the first error is imucal's C++17 #error;
# - the sketch (.ino) as the build turns it into C++: #include <Arduino.h> first;
# - the core is tests/arduino/core (Serial over semihosting, the core's clashing macros) and the
#   "Eigen" library tests/arduino/eigen over Debian's Eigen (/usr/include/eigen3);
# - linked with arm-none-eabi-g++ and picolibc (as toolchains/cortex-m0plus.cmake), no heap
#   symbol (cmake/CheckNoHeap.cmake), no compiler warning, and the sketch's output checked:
#   the accelerometer calibrated, the record saved and loaded, the readings corrected.
#   tools/arduino/build_sketch.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
work=$PWD/build/arduino
rm -rf "$work"
mkdir -p "$work/obj" "$work/eigen/ArduinoEigen"
tools/arduino/make_library.sh "$work"
lib="$work/imucal"
cp tests/arduino/eigen/ArduinoEigenDense.h "$work/eigen/"
ln -s /usr/include/eigen3/Eigen "$work/eigen/ArduinoEigen/Eigen"

cxx=arm-none-eabi-g++
launcher=()
command -v ccache >/dev/null && launcher=(ccache)
cpu=(-mcpu=cortex-m0plus -mthumb)
core_flags=("${cpu[@]}" -c -g -Os -std=gnu++11 -ffunction-sections -fdata-sections
  -fno-threadsafe-statics -nostdlib --param max-inline-insns-single=500 -fno-rtti -fno-exceptions
  -DF_CPU=48000000L -DARDUINO=10819 -DARDUINO_SAMD_ZERO -DARDUINO_ARCH_SAMD -D__SAMD21G18A__
  --specs=picolibcpp.specs)
includes=(-I"$PWD/tests/arduino/core" -I"$lib/src" -I"$work/eigen")

# The core's standard alone: imucal's #error comes first.
if "$cxx" "${core_flags[@]}" -Wfatal-errors "${includes[@]}" "$lib/src/imucal_lib/status.cpp" \
    -o "$work/obj/gnu++11.o" 2>"$work/gnu++11.log"; then
  echo "compiled as gnu++11: the C++17 check is not reached"
  exit 1
fi
if ! grep -m1 "error" "$work/gnu++11.log" | grep -q "imucal needs C++17"; then
  cat "$work/gnu++11.log"
  exit 1
fi
echo "with the core's -std=gnu++11: $(grep -m1 -o '#error.*' "$work/gnu++11.log")"

flags=("${core_flags[@]}" -std=gnu++17)  # compiler.cpp.extra_flags=-std=gnu++17
{
  echo "#include <Arduino.h>"
  echo "#line 1 \"AccelCalibration.ino\""
  cat "$lib/examples/AccelCalibration/AccelCalibration.ino"
} >"$work/AccelCalibration.ino.cpp"
sources=("$work/AccelCalibration.ino.cpp" "$PWD/tests/arduino/core/main.cpp")
while IFS= read -r -d '' f; do sources+=("$f"); done < <(find "$lib/src" -name '*.cpp' -print0)
objects=()
pids=()
failed=0
for src in "${sources[@]}"; do  # two at a time, each on its own as the Arduino build does
  obj="$work/obj/$(basename "$src").o"
  "${launcher[@]}" "$cxx" "${flags[@]}" "${includes[@]}" "$src" -o "$obj" 2>"$obj.log" &
  pids+=($!)
  objects+=("$obj")
  [ ${#pids[@]} -lt 2 ] || { wait "${pids[0]}" || failed=1; pids=("${pids[@]:1}"); }
done
for pid in "${pids[@]}"; do wait "$pid" || failed=1; done
[ "$failed" = 0 ] || { cat "$work"/obj/*.log; exit 1; }
cat "$work"/obj/*.log >"$work/compile.log"
if grep -q "warning:" "$work/compile.log"; then
  cat "$work/compile.log"
  echo "the Arduino build warns"
  exit 1
fi
echo "compiled ${#sources[@]} files (the sketch, the core's main, $(( ${#sources[@]} - 2 )) library sources)"

elf="$work/AccelCalibration.elf"
# The SAMD21G18: 256 KB of flash at 0, 32 KB of RAM at 0x20000000; an 8 KB stack.
"$cxx" "${cpu[@]}" -Os --specs=picolibcpp.specs --oslib=semihost --crt0=semihost -Wl,--gc-sections \
  -Wl,--defsym=__flash=0 -Wl,--defsym=__flash_size=0x40000 -Wl,--defsym=__ram=0x20000000 \
  -Wl,--defsym=__ram_size=0x8000 -Wl,--defsym=__stack_size=0x2000 -T picolibcpp.ld \
  "${objects[@]}" -o "$elf"
cmake -DNM=arm-none-eabi-nm -DSIZE=arm-none-eabi-size -DELF="$elf" -P cmake/CheckNoHeap.cmake

# The SAMD21's memory map lies inside mps2-an385's; its Cortex-M3 runs ARMv6-M code.
out=$(toolchains/qemu-run.sh mps2-an385 "$elf")
echo "$out" | grep -E "accelerometer|corrector|calibrated" | head -4
echo "$out" | grep -q "^corrector: ok" || { echo "$out"; echo "the sketch did not calibrate"; exit 1; }
norm=$(echo "$out" | grep -m1 -oE '\|a\| [0-9.]+' | cut -d' ' -f2)
awk -v n="$norm" 'BEGIN { exit !(n > 9.80 && n < 9.82) }' ||
  { echo "the corrected reading's norm is $norm, not 9.81 m/s^2"; exit 1; }
echo "Arduino sketch: built for the SAMD21 and ran"
