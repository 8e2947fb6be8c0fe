#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Every test: set up, check formatting, then build and run the test suite on the host (plain,
# then built by Clang with ASan + UBSan) and, cross-built, on Cortex-M4F, M7, M33, M3 and M0+
# under qemu-system-arm and on RV32IMAC under qemu-system-riscv32 (ctest with the emulator). The
# estimator's long tests run on the host and on one target per architecture, the M4F and RV32;
# the other targets run the tests of what can differ between targets and the example firmware.
# The cross builds also prove "no heap" at link time and print sizes; consumers, the Python
# package as pip installs it, fuzzing and the instruction counts (M4F and RV32) follow. Each step
# prints its wall time. It ends with every test that skipped and why (ctest reports a test whose
# cases all skipped as "Skipped"); where the real recordings are beside the clone, a test skipped
# for want of one fails the run.
set -euo pipefail
cd "$(dirname "$0")/.."
start=$SECONDS
step_start=$SECONDS
step() {  # step NAME: closes the previous step (its time) and opens the next
  [ "$step_start" = "$start" ] || echo "-- $((SECONDS - step_start)) s (total $((SECONDS - start)) s)"
  step_start=$SECONDS
  echo "== $1"
}

step "set up"
tools/setup_debian.sh host cross checks

# A compiler cache in build/ccache: the consumers' builds compile the library's sources again
# with the same flags, and a second run of this script compiles only what changed.
if command -v ccache >/dev/null; then
  export CCACHE_DIR="$PWD/build/ccache" CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=1 \
    CCACHE_SLOPPINESS=include_file_mtime,include_file_ctime,time_macros CCACHE_MAXSIZE=4G
  export CMAKE_C_COMPILER_LAUNCHER=ccache CMAKE_CXX_COMPILER_LAUNCHER=ccache
fi

step "clang-format, licence identifiers"
git ls-files '*.hpp' '*.cpp' '*.c' | xargs clang-format --dry-run -Werror
tools/check_spdx.sh

# RV32's libstdc++ (toolchains/riscv-libstdcxx.sh: GCC's source configured and built, minutes,
# mostly one process at a time) builds in the background at the lowest priority from here on: it
# takes the cores the steps before RV32's leave idle (their configures, links and the tails of
# their test runs). RV32's configure waits for it (the script's lock) and then finds it built.
libstdcxx_log=build/libstdcxx.log
mkdir -p build
nice -n 19 toolchains/riscv-libstdcxx.sh rv32imac ilp32 build/libstdcxx/rv32imac-ilp32 \
  >"$libstdcxx_log" 2>&1 &
libstdcxx_pid=$!

# Where the real recording is beside the clone (always in CI), a test that cannot find it fails.
require_xsens=OFF
[ -f ../shared/data/xsens/xsens_acc.mat ] && require_xsens=ON

# host-asan: the host tests again, built by Clang (a second compiler, which also compiles Eigen's
# templates in under half GCC's time), under AddressSanitizer and UndefinedBehaviorSanitizer
# (leaks included; the first finding aborts the test), but the long numeric runs (simulated
# protocols, noise statistics, lives: not built, IMUCAL_NUMERIC_RUNS), which reach no code the
# others do not, and the command-line tool (host code; tools/fuzz.sh runs its readers under the
# same sanitizers). RV32 leaves out the two the M4F and the host already hold (CMakePresets.json says which).
# Without debug information (a third of the compile time of Eigen's templates); host-asan keeps
# its line tables for the sanitizers' reports.
for preset in host host-asan m4f m7 m33 m3 m0plus rv32; do
  step "$preset: configure, build, test"
  if [ "$preset" = rv32 ] && ! wait "$libstdcxx_pid"; then
    cat "$libstdcxx_log"
    exit 1
  fi
  flags=()
  [ "$preset" = host-asan ] || flags=(-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -DCMAKE_C_FLAGS_RELWITHDEBINFO=-O2)
  cmake --preset "$preset" -DIMUCAL_REQUIRE_XSENS=$require_xsens "${flags[@]}" >/dev/null
  log="build/$preset/build.log"
  if ! cmake --build --preset "$preset" >"$log" 2>&1; then
    cat "$log"
    exit 1
  fi
  grep -E "no-heap|text .* B" "$log" || true  # the footprint check's verdict and sizes
  ctest --preset "$preset"
done

# imucal from outside: add_subdirectory, FetchContent, find_package, pkg-config and a strict
# sysroot on the host; the Cortex-M4F through FetchContent (its toolchain file carried into the
# fetched build), and a top-level configure for it builds the library alone.
step "consumers"
tools/test_consumers.sh host:subdirectory,fetchcontent,package,pkgconfig,sysroot m4f:fetchcontent

# The Python package as a user installs it: `pip install --no-build-isolation .` into a fresh
# virtual environment, its tests (and mypy on its types) against the installed package.
step "python package: pip install, tests against the installed package"
IMUCAL_REQUIRE_XSENS=$require_xsens tools/test_python.sh

# The ecosystems' manifests against their formats, the Zephyr module with Zephyr's Kconfig tool
# and its CMake file, and the Arduino layout's sketch built as the Arduino build does it for a
# SAMD21 and run under QEMU. (Debian's python3: pykwalify and kconfiglib are Debian packages.)
step "ecosystems: Zephyr, PlatformIO, ESP-IDF, Arduino"
/usr/bin/python3 tests/zephyr/check_module.py
/usr/bin/python3 tools/check_manifests.py
tools/arduino/build_sketch.sh

# No heap with and without -flto at -Os, -O2 and -O3 on the Cortex-M4F, and at -Os on the
# other two instruction sets and their soft float, the M0+ and RV32 (every target's preset build
# proves it at -O2 without LTO; the M7, M33 and M3 are the same compiler and C library as the
# M4F and M0+, other multilibs of them).
step "no heap at other levels"
tools/check_no_heap.sh m4f:-Os,-O2,-O3 m0plus:-Os rv32:-Os

step "fuzzing the imucal tool's readers (libFuzzer, ASan + UBSan, 60 s)"
tools/fuzz.sh 60

# The counts are exact whatever the load, and QEMU runs a program on one core: RV32's run on the
# other core meanwhile, its table printed after the M4F's (the one step's time is both).
step "instruction counts (Cortex-M4F and RV32IMAC side by side, exact, QEMU TCG plugin)"
rv32_log=build/rv32/insn_counts.md
bench/run_insn_bench.sh rv32 >"$rv32_log" 2>&1 &
rv32_pid=$!
bench/run_insn_bench.sh m4f
# Where add()'s instructions go on the recording (the plugin's profile mode), and where the code
# goes.
if [ "$require_xsens" = ON ]; then
  bench/insn_profile.py m4f build/m4f/bench/bench_stream_insn . 51175 12
fi
bench/footprint_breakdown.py build/m4f/bench/imucal_footprint build/m4f/bench/imucal_footprint_baseline

rv32_status=0
wait "$rv32_pid" || rv32_status=$?
echo "RV32IMAC (soft float):"
cat "$rv32_log"
[ "$rv32_status" = 0 ] || { echo "bench/run_insn_bench.sh rv32 failed ($rv32_status)"; exit 1; }

step "whole-process time of imucal calibrate on the xsens recording"
bench/cli_time.sh
command -v ccache >/dev/null && ccache --show-stats | grep -E "^(Cacheable calls|  Hits|  Misses):" || true

step "what was skipped, and why"
data_flag=()
[ "$require_xsens" = ON ] && data_flag=(--data-present)
tools/skipped_tests.py "${data_flag[@]}" build/host build/host-asan build/m4f build/m7 build/m33 \
  build/m3 build/m0plus build/rv32
step "done"
