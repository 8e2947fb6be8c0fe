#!/bin/sh
# SPDX-License-Identifier: MIT
# Compiled as C++11 or C++14 (an Arduino core's -std=gnu++11, a PlatformIO default), every public
# header stops at imucal/config.hpp's one #error naming the flag, never at a template error first.
# A header that is valid C++14 on its own compiles; the umbrella header must not.
#   cxx17_required.sh CXX EIGEN_INCLUDE_DIR SOURCE_DIR [STANDARDS]
# STANDARDS: the -std values to check, "gnu++11 gnu++14" unless given.
cxx="$1"
eigen="$2"
src="$3"
standards=${4:-"gnu++11 gnu++14"}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# GCC prints the directive (error: #error "..."), Clang its text (fatal error: "...").
expected='"imucal needs C++17: compile with -std=gnu++17 (or -std=c++17)"'
headers=$(cd "$src" && find include ports/include -name '*.hpp' | sort)
failed=0
checked=0
for std in $standards; do
  for h in $headers; do
    rel=${h#include/}
    rel=${rel#ports/include/}
    printf '#include "%s"\n' "$rel" >"$work/one.cpp"
    # -Wfatal-errors: the first error is the only one printed.
    if "$cxx" -std=$std -fsyntax-only -Wfatal-errors -I"$src/include" -I"$src/ports/include" \
      -isystem "$eigen" "$work/one.cpp" >"$work/out.txt" 2>&1; then
      if [ "$rel" = imucal/imucal.hpp ]; then
        echo "$std: $rel compiles: the C++17 check is not reached"
        failed=1
      fi
      continue
    fi
    checked=$((checked + 1))
    first=$(grep -m1 'error' "$work/out.txt")
    case "$first" in
      *"imucal/config.hpp"*"$expected"*) ;;
      *)
        echo "$std: $rel: the first error is not imucal's C++17 check:"
        cat "$work/out.txt"
        failed=1
        ;;
    esac
  done
done
[ "$failed" = 0 ] || exit 1
echo "C++17 required: $checked header compilations stop at config.hpp's #error first"
