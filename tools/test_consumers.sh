#!/usr/bin/env bash
# Builds tests/consumer (a project outside imucal) against imucal through add_subdirectory,
# FetchContent and find_package after `cmake --install` into a temporary prefix, for the host and
# for the Cortex-M4F (its own toolchain file), and runs it (M4F: under qemu-system-arm). Checks
# that only the library's files are compiled: no test, benchmark, tool or GoogleTest target,
# and at most the library's sources plus the consumer's one.
#   tools/test_consumers.sh                                 every way, host and M4F
#   tools/test_consumers.sh host:package m4f:fetchcontent   chosen platforms and ways
set -euo pipefail
cd "$(dirname "$0")/.."
src=$PWD
work=$PWD/build/consumers
rm -rf "$work"; mkdir -p "$work"
lib_lines=$(grep -c "^set(IMUCAL_PART_SOURCES_" CMakeLists.txt)  # one line per part
max_objects=$(( $(grep "^set(IMUCAL_PART_SOURCES_" CMakeLists.txt | wc -w) - lib_lines + 2 ))  # + port_file + main

run() {  # run PLATFORM PROGRAM
  if [ "$1" = host ]; then
    "$2"
  else
    timeout 60 qemu-system-arm -M mps2-an386 -display none -monitor none -serial none \
      -chardev stdio,id=out,signal=off -semihosting-config enable=on,target=native,chardev=out,arg="$2" \
      -kernel "$2" </dev/null
  fi
}

configs=("$@")
[ ${#configs[@]} -gt 0 ] ||
  configs=(host:subdirectory,fetchcontent,package m4f:subdirectory,fetchcontent,package)
for config in "${configs[@]}"; do
  platform=${config%%:*}
  IFS=, read -ra modes <<<"${config#*:}"
  toolchain=()
  # The firmware builds the library as a firmware would: its solvers in float only.
  [ "$platform" = m4f ] &&
    toolchain=(-DCMAKE_TOOLCHAIN_FILE="$src/tests/consumer/cortex-m4f.cmake" -DIMUCAL_FLOAT_ONLY=ON)
  if [[ " ${modes[*]} " == *" package "* ]]; then  # the installed package to find
    # Unoptimised, as the consumer itself is built: this checks the package, not the code's speed
    # (an optimised build of every part takes minutes of Eigen's templates).
    cmake -S . -B "$work/imucal-$platform" -G Ninja -DCMAKE_BUILD_TYPE= "${toolchain[@]}" \
      -DIMUCAL_BUILD_TESTS=OFF -DIMUCAL_BUILD_BENCH=OFF -DIMUCAL_BUILD_TOOLS=OFF \
      -DIMUCAL_BUILD_EXAMPLES=OFF -DCMAKE_INSTALL_PREFIX="$work/prefix-$platform" >/dev/null
    cmake --build "$work/imucal-$platform" >/dev/null
    cmake --install "$work/imucal-$platform" >/dev/null
  fi
  for mode in "${modes[@]}"; do
    echo "== consumer: $platform, $mode"
    b="$work/consumer-$platform-$mode"
    cmake -S tests/consumer -B "$b" -G Ninja "${toolchain[@]}" -DIMUCAL_CONSUMER_MODE=$mode \
      -DIMUCAL_SOURCE_DIR="$src" -DCMAKE_PREFIX_PATH="$work/prefix-$platform" >/dev/null
    cmake --build "$b" >"$b/build.log"
    objects=$(find "$b" -name '*.o' -o -name '*.obj' | wc -l)
    echo "compiled objects: $objects (at most $max_objects)"
    if [ "$objects" -gt "$max_objects" ]; then
      find "$b" -name '*.o' -o -name '*.obj'
      exit 1
    fi
    if ninja -C "$b" -t targets all | grep -E "^(gtest|imucal_tool|imucal_footprint|bench_|test_)" \
        | grep -v "^test_record"; then
      echo "imucal's own programs are part of the consumer's build"
      exit 1
    fi
    [ "$(ctest --test-dir "$b" -N | grep -c 'Test *#')" = 1 ] || { echo "imucal's tests leak"; exit 1; }
    run "$platform" "$b/test_record"
  done
done
echo "consumers: all passed"
