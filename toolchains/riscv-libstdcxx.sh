#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Builds libstdc++ (static, single-threaded) for one bare-metal RISC-V multilib with picolibc as
# its C library, from Debian's GCC source (package gcc-12-source: the source Debian builds
# riscv64-unknown-elf-gcc 12.2.0 from). Debian 12 ships the RISC-V compiler and picolibc but no
# C++ library for them; the tests need one (GoogleTest uses iostreams). The library itself does
# not: imucal's parts, the footprint program and the example firmware use no libstdc++ code.
#   toolchains/riscv-libstdcxx.sh ARCH ABI PREFIX        e.g. rv32imac ilp32 build/libstdcxx/...
# Installs the headers in PREFIX/include/c++/VERSION and libstdc++.a, libsupc++.a in PREFIX/lib.
# About three minutes on 2 cores (no debug information: a sixth less).
# toolchains/riscv-picolibc.cmake runs it when PREFIX has no library yet.
# IMUCAL_GCC_SOURCE_TARBALL: the GCC source tarball, if not Debian's.
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: $0 ARCH ABI PREFIX" >&2; exit 2; }
arch=$1 abi=$2
mkdir -p "$3"
prefix=$(cd "$3" && pwd)
tarball=${IMUCAL_GCC_SOURCE_TARBALL:-/usr/src/gcc-12/gcc-12.2.0-dfsg.tar.xz}
if [ ! -f "$tarball" ]; then
  echo "$0: no GCC source at $tarball: install it with tools/setup_debian.sh gcc-12-source" >&2
  exit 1
fi
gcc_version=$(riscv64-unknown-elf-gcc -dumpversion)

# One build at a time per prefix (configure runs of several build folders may ask together).
exec 9>"$prefix.lock"
flock 9
if [ -f "$prefix/lib/libstdc++.a" ]; then
  exit 0
fi

work=$(mktemp -d "${TMPDIR:-/tmp}/imucal-libstdcxx.XXXXXX")
trap 'rm -rf "$work"' EXIT
top=gcc-$gcc_version
# libstdc++-v3 and what its build reads from beside it: libgcc's gthr headers, libiberty's
# demangler, the shared include/ and config/ folders, the version files, the autotools scripts.
# Its test suite and documentation stay packed, but for the two files configure generates from.
tar -xJf "$tarball" -C "$work" \
  --exclude="$top/libstdc++-v3/testsuite" --exclude="$top/libstdc++-v3/doc" \
  "$top/libstdc++-v3" "$top/libgcc" "$top/libiberty" "$top/include" "$top/config" \
  "$top/gcc/BASE-VER" "$top/gcc/DATESTAMP" "$top/gcc/DEV-PHASE" \
  "$top/config-ml.in" "$top/config.guess" "$top/config.sub" "$top/install-sh" "$top/ltmain.sh" \
  "$top/missing" "$top/mkinstalldirs" "$top/move-if-change" "$top/compile" "$top/depcomp"
tar -xJf "$tarball" -C "$work" "$top/libstdc++-v3/testsuite/Makefile.in" \
  "$top/libstdc++-v3/doc/Makefile.in" "$top/libstdc++-v3/doc/xsl/customization.xsl.in"
if [ "$(cat "$work/$top/gcc/BASE-VER")" != "$gcc_version" ]; then
  echo "$0: $tarball is GCC $(cat "$work/$top/gcc/BASE-VER"), the compiler $gcc_version" >&2
  exit 1
fi
# picolibc.specs puts picolibc's include folder before the C++ headers, so an #include_next of a
# C header from them would search past it and find none: they include it plainly, as in Debian's
# Arm build of libstdc++ for picolibc (the same three headers changed the same way).
inc=$work/$top/libstdc++-v3/include
sed -i 's/#include_next <math\.h>/#include <math.h>/; s/#include_next <stdlib\.h>/#include <stdlib.h>/' \
  "$inc/c_global/cmath" "$inc/c_global/cstdlib"
sed -i 's/# include_next <math\.h>/# include <math.h>/; s/#include_next <stdlib\.h>/#include <stdlib.h>/' \
  "$inc/bits/std_abs.h"
if grep -q include_next "$inc/c_global/cmath" "$inc/c_global/cstdlib" "$inc/bits/std_abs.h"; then
  echo "$0: an #include_next left in cmath, cstdlib or bits/std_abs.h" >&2
  exit 1
fi

# --with-newlib: picolibc keeps newlib's interface (libstdc++'s newlib configuration). The link
# tests of configure need a start-up file and the semihosting system calls, as the tests have.
# No threads (one core, no RTOS), no TLS, a terse terminate handler; exceptions and RTTI stay on
# inside the library, as in Debian's Arm build of it. No wchar_t streams: picolibc has no
# wide-character stdio (getwc, putwc, wcsftime), which the wide standard streams would link;
# Debian's Arm build has none either. std::wstring stays (a header template, instantiated where
# it is used).
flags="-march=$arch -mabi=$abi --specs=picolibc.specs"
mkdir "$work/build"
cd "$work/build"
"../$top/libstdc++-v3/configure" --build="$(gcc -dumpmachine)" \
  --host=riscv64-unknown-elf --target=riscv64-unknown-elf --prefix="$prefix.tmp" \
  --disable-multilib --disable-shared --enable-static \
  --disable-libstdcxx-pch --disable-nls --disable-threads --disable-tls --with-newlib \
  --disable-libstdcxx-verbose --disable-wchar_t \
  CC="riscv64-unknown-elf-gcc $flags" CXX="riscv64-unknown-elf-g++ $flags -nostdinc++" \
  AR=riscv64-unknown-elf-ar RANLIB=riscv64-unknown-elf-ranlib NM=riscv64-unknown-elf-nm \
  AS=riscv64-unknown-elf-as LD=riscv64-unknown-elf-ld CFLAGS="-O2" CXXFLAGS="-O2" \
  LDFLAGS="--oslib=semihost --crt0=semihost" >configure.log 2>&1 ||
  { tail -30 configure.log >&2; echo "$0: configure failed" >&2; exit 1; }
make -j"$(nproc)" >make.log 2>&1 || { grep -B5 -m5 'rror' make.log >&2; exit 1; }
rm -rf "$prefix.tmp"
make install >install.log 2>&1 || { tail -30 install.log >&2; exit 1; }
# The libraries straight in lib/ (make install puts them in the multilib's subfolder).
find "$prefix.tmp/lib" -name '*.a' -exec mv {} "$prefix.tmp/lib/" \;
find "$prefix.tmp/lib" -mindepth 1 -maxdepth 1 -type d -exec rm -rf {} +
rm -rf "$prefix"
mv "$prefix.tmp" "$prefix"
echo "libstdc++ $gcc_version for $arch/$abi in $prefix"
