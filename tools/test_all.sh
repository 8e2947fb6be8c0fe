#!/usr/bin/env bash
# Every test: set up, check formatting, then build and run the test suite on the host (plain,
# then with ASan + UBSan) and, cross-built, on Cortex-M4F, M7 and M33 under qemu-system-arm
# (ctest with the emulator). The Arm builds also prove "no heap" at link time and print sizes;
# instruction counts follow.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup_debian.sh

echo "== clang-format"
git ls-files '*.hpp' '*.cpp' '*.c' | xargs clang-format --dry-run -Werror

# Where the real recording is beside the clone (always in CI), a test that cannot find it fails.
require_xsens=OFF
[ -f ../shared/data/xsens/xsens_acc.mat ] && require_xsens=ON

# host-asan: the host tests again under AddressSanitizer and UndefinedBehaviorSanitizer (leaks
# included; the first finding aborts the test).
for preset in host host-asan m4f m7 m33; do
  echo "== $preset: configure, build, test"
  cmake --preset "$preset" -DIMUCAL_REQUIRE_XSENS=$require_xsens >/dev/null
  log="build/$preset/build.log"
  if ! cmake --build --preset "$preset" >"$log" 2>&1; then
    cat "$log"
    exit 1
  fi
  grep -E "no-heap|text .* B" "$log" || true  # the footprint check's verdict and sizes
  ctest --preset "$preset"
done

tools/test_consumers.sh  # imucal from outside: add_subdirectory, FetchContent, find_package
tools/check_no_heap.sh m4f:-O2,-O3 m7:-O3 m33:-O3  # no heap, with and without -flto (-O2 on M7 and M33: their preset builds)

echo "== fuzzing the imucal tool's readers (libFuzzer, ASan + UBSan, 60 s)"
tools/fuzz.sh 60

echo "== instruction counts (Cortex-M4F, exact, QEMU TCG plugin)"
bench/run_insn_bench.sh m4f

echo "== whole-process time of imucal calibrate on the xsens recording"
bench/cli_time.sh
