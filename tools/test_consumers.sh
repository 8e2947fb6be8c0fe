#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Builds tests/consumer (a project outside imucal) against imucal through add_subdirectory,
# FetchContent and find_package after `cmake --install` into a temporary prefix, for the host and
# for the Cortex-M4F (its own toolchain file), and runs it (M4F: under qemu-system-arm). Checks
# that only the library's files are compiled, and of them only the parts the consumer links
# (core, calibrator, store): no test, benchmark, tool or GoogleTest target, and that a sub-project
# gets the float-only solvers. Two more ways on the installed library:
#   pkgconfig  main.cpp compiled and linked with `pkg-config --cflags --libs imucal` alone (host)
#   sysroot    find_package(imucal) with CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY, imucal installed
#              in the sysroot and Eigen not: fails on Eigen3 until Eigen3_DIR names its package,
#              as docs/consuming.md says
# With the M4F, a top-level configure for its toolchain without imucal's IMUCAL_BUILD_* options
# must build the library alone (the installed M4F library is built that way too).
#   tools/test_consumers.sh                                 every way, host and M4F
#   tools/test_consumers.sh host:package m4f:fetchcontent   chosen platforms and ways
set -euo pipefail
cd "$(dirname "$0")/.."
src=$PWD
work=$PWD/build/consumers
rm -rf "$work"; mkdir -p "$work"
parts_file=cmake/imucal_parts.cmake
part_sources() {  # part_sources PART...: the number of the parts' sources
  local n=0 part
  for part in "$@"; do
    n=$((n + $(grep "^set(IMUCAL_PART_SOURCES_$part " "$parts_file" | wc -w) - 1))
  done
  echo "$n"
}
library_sources=$(part_sources core calibrator magnetometer temperature store)
linked_objects=$(( $(part_sources core calibrator store) + 1 ))  # + the consumer's main.cpp

run() {  # run PLATFORM PROGRAM
  if [ "$1" = host ]; then
    "$2"
  else
    timeout 60 qemu-system-arm -M mps2-an386 -display none -monitor none -serial none \
      -chardev stdio,id=out,signal=off -semihosting-config enable=on,target=native,chardev=out,arg="$2" \
      -kernel "$2" </dev/null
  fi
}

count_objects() { find "$1" -name '*.o' -o -name '*.obj' | wc -l; }

# A top-level configure for a cross toolchain, none of the IMUCAL_BUILD_* options given: the
# library alone (configure only: the build's targets are the part libraries).
cross_defaults() {
  local b="$work/cross-defaults"
  cmake -S . -B "$b" -G Ninja -DCMAKE_TOOLCHAIN_FILE="$src/tests/consumer/cortex-m4f.cmake" \
    >/dev/null
  local extra
  extra=$(ninja -C "$b" -t targets all | grep -E "^[A-Za-z0-9_]+: " | cut -d: -f1 |
    grep -vE "^((cmake_object_order_depends_target_)?imucal_(core|calibrator|magnetometer|temperature|store)|all|clean|help|edit_cache|rebuild_cache|install.*|list_install_components|test)$" || true)
  if [ -n "$extra" ]; then
    echo "a top-level cross configure builds more than the library: $extra"
    exit 1
  fi
  echo "== top-level cross configure: the library's parts alone"
}

configs=("$@")
[ ${#configs[@]} -gt 0 ] ||
  configs=(host:subdirectory,fetchcontent,package,pkgconfig,sysroot
           m4f:subdirectory,fetchcontent,package)
[[ " ${configs[*]}" == *" m4f:"* ]] && cross_defaults
for config in "${configs[@]}"; do
  platform=${config%%:*}
  IFS=, read -ra modes <<<"${config#*:}"
  toolchain=()
  [ "$platform" = m4f ] && toolchain=(-DCMAKE_TOOLCHAIN_FILE="$src/tests/consumer/cortex-m4f.cmake")
  if [[ " ${modes[*]} " =~ " "(package|pkgconfig|sysroot)" " ]]; then  # the installed library
    # Unoptimised, as the consumer itself is built: this checks the package, not the code's speed
    # (an optimised build of every part takes minutes of Eigen's templates).
    options=(-DIMUCAL_BUILD_TESTS=OFF -DIMUCAL_BUILD_BENCH=OFF -DIMUCAL_BUILD_TOOLS=OFF
             -DIMUCAL_BUILD_EXAMPLES=OFF)
    # The firmware's library: float only, and none of the four options given.
    [ "$platform" = m4f ] && options=(-DIMUCAL_FLOAT_ONLY=ON)
    b="$work/imucal-$platform"
    cmake -S . -B "$b" -G Ninja -DCMAKE_BUILD_TYPE= "${toolchain[@]}" "${options[@]}" \
      -DCMAKE_INSTALL_PREFIX="$work/prefix-$platform" >/dev/null
    cmake --build "$b" >/dev/null
    objects=$(count_objects "$b")
    echo "== installed library, $platform: compiled objects: $objects"
    if [ "$objects" != "$library_sources" ] && [ "$platform" = m4f ]; then
      echo "a top-level cross configure compiles more than the library's $library_sources sources"
      find "$b" -name '*.o' | grep -v "/lib/" | head
      exit 1
    fi
    cmake --install "$b" >/dev/null
    DESTDIR="$work/sysroot-$platform" cmake --install "$b" --prefix /usr >/dev/null
  fi
  for mode in "${modes[@]}"; do
    echo "== consumer: $platform, $mode"
    b="$work/consumer-$platform-$mode"
    mkdir -p "$b"
    if [ "$mode" = pkgconfig ]; then
      [ "$platform" = host ] || { echo "pkgconfig: host only"; exit 1; }
      pc_dir=$(dirname "$(find "$work/prefix-$platform" -name imucal.pc)")
      flags=$(PKG_CONFIG_PATH="$pc_dir" pkg-config --cflags --libs imucal)
      echo "pkg-config --cflags --libs imucal: $flags"
      # shellcheck disable=SC2086  # the flags are words
      c++ -std=c++17 tests/consumer/main.cpp $flags -o "$b/test_record"
      run "$platform" "$b/test_record"
      continue
    fi
    configure=(cmake -S tests/consumer -B "$b" -G Ninja "${toolchain[@]}"
               -DIMUCAL_CONSUMER_MODE=$mode -DIMUCAL_SOURCE_DIR="$src")
    if [ "$mode" = sysroot ]; then
      configure+=(-DIMUCAL_CONSUMER_MODE=package -DCMAKE_FIND_ROOT_PATH="$work/sysroot-$platform"
                  -DCMAKE_FIND_ROOT_PATH_MODE_PACKAGE=ONLY)
      # Eigen is not in the sysroot: the package cannot find it, and says which package it is.
      if "${configure[@]}" >"$b/configure.log" 2>&1 || ! grep -q '"Eigen3"' "$b/configure.log"
      then
        cat "$b/configure.log"
        echo "sysroot: find_package(imucal) without Eigen3_DIR should fail on Eigen3"
        exit 1
      fi
      rm -rf "$b"
      configure+=(-DEigen3_DIR="$(dirname "$(find /usr/share /usr/lib -name Eigen3Config.cmake |
                                             head -1)")")
    else
      configure+=(-DCMAKE_PREFIX_PATH="$work/prefix-$platform")
    fi
    "${configure[@]}" >/dev/null
    cmake --build "$b" >"$b/build.log"
    objects=$(count_objects "$b")
    expected=1  # the installed library: the consumer's main.cpp alone
    [[ "$mode" =~ ^(subdirectory|fetchcontent)$ ]] && expected=$linked_objects
    echo "compiled objects: $objects (expected $expected)"
    if [ "$objects" != "$expected" ]; then
      find "$b" -name '*.o' -o -name '*.obj'
      exit 1
    fi
    if ninja -C "$b" -t targets all | grep -E "^(gtest|imucal_tool|imucal_footprint|bench_|test_)" \
        | grep -v "^test_record"; then
      echo "imucal's own programs are part of the consumer's build"
      exit 1
    fi
    if [[ "$mode" =~ ^(subdirectory|fetchcontent)$ ]] &&
       ! grep -q "^IMUCAL_FLOAT_ONLY:BOOL=ON" "$b/CMakeCache.txt"; then
      echo "a sub-project should get the float-only solvers (IMUCAL_FLOAT_ONLY ON)"
      exit 1
    fi
    [ "$(ctest --test-dir "$b" -N | grep -c 'Test *#')" = 1 ] || { echo "imucal's tests leak"; exit 1; }
    run "$platform" "$b/test_record"
  done
done
echo "consumers: all passed"
