// SPDX-License-Identifier: MIT
// bench/insn/markers.hpp: region markers for instruction counting under QEMU. The TCG plugin in
// bench/qemu_plugin counts guest instructions executed from the entry of imucal_bench_begin to
// the entry of imucal_bench_end; each region is announced on stdout first ("BENCH <name>").
#pragma once

#include <cstdio>

extern "C" {
__attribute__((noinline, used)) inline void imucal_bench_begin() {
  __asm volatile("" ::: "memory");
}
__attribute__((noinline, used)) inline void imucal_bench_end() { __asm volatile("" ::: "memory"); }
}

inline void bench_announce(const char* name) { std::printf("BENCH %s\n", name); }
