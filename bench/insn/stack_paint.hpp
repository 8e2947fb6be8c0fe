// SPDX-License-Identifier: MIT
// bench/insn/stack_paint.hpp: maximum stack depth of calls, measured by painting the stack (Arm
// Cortex-M with Thumb-2 and RV32, picolibc's memory layout; run under QEMU by
// bench/run_insn_bench.sh). On ARMv6-M (Cortex-M0/M0+) the calls compile to nothing and no depth
// is reported.
//
// What is measured: the bytes below the caller's stack pointer at the call, including the call's
// own frame (the registers it pushes, its locals) and everything it calls in turn: what must be
// free below the caller's frame for the call not to overflow. Code the compiler inlined into the
// caller runs in the caller's frame and is not included (it is part of the caller's own frame,
// as -fstack-usage reports it). Exceptions/interrupts would add to it; there are none here.
//
// How: before the call the free stack below the caller's SP is filled with a pattern; after it,
// the deepest word that no longer holds the pattern marks the depth. Stack that the call reserves
// but never writes (an unused local) is invisible, as is a word it writes with the pattern value.
//
// Usage, in the function that makes the measured calls (the "caller"; one series at a time):
//     stack_series_start(window);                      before painting: it has a frame
//     loop { ...  stack_paint();  call();  stack_measure();  ... }
//     const StackSeries s = stack_series_result();     after the last measure
// The first stack_paint() of a series paints all of the free stack, [limit, caller's SP); the
// later ones only the `window` bytes below the caller's SP (all of it again if window is 0), cheap
// enough per call when there are many. The stack below the window keeps the first paint, and
// stack_series_result() checks that nothing (neither the measured calls nor anything else the
// caller did in between) wrote there: otherwise the window was too small and the result says so.
// All paints and measures of a series must see the same SP (true of a caller without dynamic
// stack allocation; checked).
//
// The paint and measure routines are assembly that uses no stack at all (no push, no locals; the
// return address stays in LR): the SP they see is the caller's SP at the call, and they neither
// paint over nor count a frame of their own. They keep their state in a global (the caller's
// registers r0-r3 are saved there too) and are called from inline assembly that clobbers only
// IP, LR and the flags, from always_inline wrappers: so they run in the caller, and the caller's
// code around the measured call changes as little as possible (bench_stream.cpp counts the
// instructions of that code: those counts must not move because the stack is measured).
// On RV32 the same, with a0-a3 saved, the return address in t0 (jal t0: ra, the caller's own
// return address, stays untouched) and the area's address in t1: the call clobbers t0 and t1.
//
// Lower limit of the stack (never painted below): picolibc.ld puts the initial SP at __stack (the
// top of RAM) and reserves __stack_size bytes below it. The heap grows up from the end of .bss
// towards __heap_end, which picolibc.ld also derives from __stack_size, but only if the symbol is
// defined when the script is read: given by -Wl,--defsym after the specs file's -T, it is not,
// and __heap_end is then __stack - 2 KB. So the limit is the higher of __stack - __stack_size and
// the heap's current end (sbrk(0) at stack_series_start()): painting never touches .bss or the
// heap (provided the heap does not grow into the stack's region during a series).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>

#if !defined(__arm__) && !(defined(__riscv) && __riscv_xlen == 32)
#error "stack_paint.hpp: Arm Cortex-M or RV32 only"
#endif

namespace imucal::bench {
// State of the series, shared with the assembly routines (offsets fixed; checked below).
struct StackPaintArea {
  std::uint32_t saved[4];  //  0: the caller's r0-r3 during a routine
  std::uintptr_t limit;    // 16: lowest address painted
  std::uint32_t pattern;   // 20
  std::uintptr_t window;   // 24: bytes below the SP repainted after the first paint; 0: all
  std::uintptr_t sp;       // 28: the caller's SP at the first paint; 0 before it
  std::uintptr_t lo;       // 32: lower end of the last paint
  std::uintptr_t max;      // 36: deepest measure: SP minus the lowest changed word's address
  std::uint32_t measures;  // 40
  std::uint32_t sp_moved;  // 44: a paint or measure saw another SP than the first paint
};
static_assert(offsetof(StackPaintArea, limit) == 16 && offsetof(StackPaintArea, pattern) == 20 &&
                  offsetof(StackPaintArea, window) == 24 && offsetof(StackPaintArea, sp) == 28 &&
                  offsetof(StackPaintArea, lo) == 32 && offsetof(StackPaintArea, max) == 36 &&
                  offsetof(StackPaintArea, measures) == 40 &&
                  offsetof(StackPaintArea, sp_moved) == 44 && sizeof(StackPaintArea) == 48,
              "the assembly routines use these offsets");
}  // namespace imucal::bench

#if defined(__thumb2__) || defined(__riscv)

extern "C" {
// picolibc.ld: the initial stack pointer (top of RAM) and the stack size (an absolute symbol:
// its address is the value).
extern char __stack[];
extern char __stack_size[];
// picolibc's heap break (malloc grows the heap through it). Declared here: <unistd.h> declares it
// only with BSD extensions visible, not under -std=c++17.
void* sbrk(std::ptrdiff_t increment);
// Defined in the assembly below (weak: one per program however many files include this).
extern imucal::bench::StackPaintArea imucal_stack_area;
}

// imucal_stack_paint: fills [lo, sp) with the pattern, sp being the caller's SP; lo = limit on the
// series' first paint or if window is 0, else max(limit, sp - window).
// imucal_stack_measure: finds the lowest word in [lo, sp) that no longer holds the pattern (sp if
// none), and keeps the deepest sp - that address.
// Both preserve every register but IP, LR and the flags (RV32: t0, t1), and touch no memory below
// the SP but the painted range. Weak, each in its own section: --gc-sections drops what a program
// does not use.
#if defined(__thumb2__)
__asm__(R"(
  .pushsection .bss.imucal_stack_area,"aw",%nobits
  .balign 4
  .weak imucal_stack_area
  .type imucal_stack_area, %object
imucal_stack_area:
  .space 48
  .size imucal_stack_area, 48
  .popsection

  .pushsection .text.imucal_stack_paint,"ax",%progbits
  .syntax unified
  .thumb
  .balign 4
  .weak imucal_stack_paint
  .type imucal_stack_paint, %function
  .thumb_func
imucal_stack_paint:
  movw ip, #:lower16:imucal_stack_area
  movt ip, #:upper16:imucal_stack_area
  stmia ip, {r0-r3}
  mov r3, sp
  ldr r0, [ip, #16]
  ldr r1, [ip, #28]
  cbz r1, 2f
  cmp r1, r3
  itt ne
  movne r2, #1
  strne r2, [ip, #44]
  ldr r1, [ip, #24]
  cbz r1, 3f
  subs r1, r3, r1
  cmp r1, r0
  it hi
  movhi r0, r1
  b 3f
2:
  str r3, [ip, #28]
3:
  str r0, [ip, #32]
  ldr r2, [ip, #20]
4:
  cmp r0, r3
  bhs 5f
  str r2, [r0], #4
  b 4b
5:
  ldmia ip, {r0-r3}
  bx lr
  .size imucal_stack_paint, . - imucal_stack_paint
  .popsection

  .pushsection .text.imucal_stack_measure,"ax",%progbits
  .syntax unified
  .thumb
  .balign 4
  .weak imucal_stack_measure
  .type imucal_stack_measure, %function
  .thumb_func
imucal_stack_measure:
  movw ip, #:lower16:imucal_stack_area
  movt ip, #:upper16:imucal_stack_area
  stmia ip, {r0-r3}
  mov r3, sp
  ldr r1, [ip, #28]
  cmp r1, r3
  itt ne
  movne r2, #1
  strne r2, [ip, #44]
  ldr r0, [ip, #32]
  ldr r2, [ip, #20]
1:
  cmp r0, r3
  bhs 2f
  ldr r1, [r0]
  cmp r1, r2
  bne 2f
  adds r0, #4
  b 1b
2:
  subs r0, r3, r0
  ldr r1, [ip, #36]
  cmp r0, r1
  it hi
  strhi r0, [ip, #36]
  ldr r1, [ip, #40]
  adds r1, #1
  str r1, [ip, #40]
  ldmia ip, {r0-r3}
  bx lr
  .size imucal_stack_measure, . - imucal_stack_measure
  .popsection
)");
#define IMUCAL_STACK_CALL(routine) "bl " routine
#define IMUCAL_STACK_CLOBBERS "ip", "lr", "cc", "memory"
#else
__asm__(R"(
  .pushsection .bss.imucal_stack_area,"aw",%nobits
  .balign 4
  .weak imucal_stack_area
  .type imucal_stack_area, %object
imucal_stack_area:
  .space 48
  .size imucal_stack_area, 48
  .popsection

  .pushsection .text.imucal_stack_paint,"ax",%progbits
  .balign 4
  .weak imucal_stack_paint
  .type imucal_stack_paint, %function
imucal_stack_paint:
  lui t1, %hi(imucal_stack_area)
  addi t1, t1, %lo(imucal_stack_area)
  sw a0, 0(t1)
  sw a1, 4(t1)
  sw a2, 8(t1)
  sw a3, 12(t1)
  mv a3, sp
  lw a0, 16(t1)
  lw a1, 28(t1)
  beqz a1, 2f
  beq a1, a3, 1f
  li a2, 1
  sw a2, 44(t1)
1:
  lw a1, 24(t1)
  beqz a1, 3f
  sub a1, a3, a1
  bleu a1, a0, 3f
  mv a0, a1
  j 3f
2:
  sw a3, 28(t1)
3:
  sw a0, 32(t1)
  lw a2, 20(t1)
4:
  bgeu a0, a3, 5f
  sw a2, 0(a0)
  addi a0, a0, 4
  j 4b
5:
  lw a0, 0(t1)
  lw a1, 4(t1)
  lw a2, 8(t1)
  lw a3, 12(t1)
  jr t0
  .size imucal_stack_paint, . - imucal_stack_paint
  .popsection

  .pushsection .text.imucal_stack_measure,"ax",%progbits
  .balign 4
  .weak imucal_stack_measure
  .type imucal_stack_measure, %function
imucal_stack_measure:
  lui t1, %hi(imucal_stack_area)
  addi t1, t1, %lo(imucal_stack_area)
  sw a0, 0(t1)
  sw a1, 4(t1)
  sw a2, 8(t1)
  sw a3, 12(t1)
  mv a3, sp
  lw a1, 28(t1)
  beq a1, a3, 1f
  li a2, 1
  sw a2, 44(t1)
1:
  lw a0, 32(t1)
  lw a2, 20(t1)
2:
  bgeu a0, a3, 3f
  lw a1, 0(a0)
  bne a1, a2, 3f
  addi a0, a0, 4
  j 2b
3:
  sub a0, a3, a0
  lw a1, 36(t1)
  bleu a0, a1, 4f
  sw a0, 36(t1)
4:
  lw a1, 40(t1)
  addi a1, a1, 1
  sw a1, 40(t1)
  lw a0, 0(t1)
  lw a1, 4(t1)
  lw a2, 8(t1)
  lw a3, 12(t1)
  jr t0
  .size imucal_stack_measure, . - imucal_stack_measure
  .popsection
)");
// call: auipc + jalr, which the linker relaxes to one jal where the routine is in reach.
#define IMUCAL_STACK_CALL(routine) "call t0, " routine
#define IMUCAL_STACK_CLOBBERS "t0", "t1", "memory"
#endif

namespace imucal::bench {

inline constexpr std::uint32_t kStackPattern = 0x57AC5EEDu;

// Starts a series (see the top of the file). Call it before painting: it has a frame of its own.
[[gnu::noinline]] inline void stack_series_start(std::uintptr_t window) {
  StackPaintArea& a = imucal_stack_area;
  const std::uintptr_t stack_lo =
      reinterpret_cast<std::uintptr_t>(__stack) - reinterpret_cast<std::uintptr_t>(__stack_size);
  const std::uintptr_t heap_end = (reinterpret_cast<std::uintptr_t>(sbrk(0)) + 7u) & ~7u;
  a = StackPaintArea{};
  a.limit = heap_end > stack_lo ? heap_end : stack_lo;
  a.pattern = kStackPattern;
  a.window = window & ~std::uintptr_t{3};
}

// Paints the free stack below the caller's SP. always_inline: it must run in the caller.
[[gnu::always_inline]] inline void stack_paint() {
  __asm__ volatile(IMUCAL_STACK_CALL("imucal_stack_paint")::: IMUCAL_STACK_CLOBBERS);
}

// Measures the call made since stack_paint(). always_inline: it must run in the caller.
[[gnu::always_inline]] inline void stack_measure() {
  __asm__ volatile(IMUCAL_STACK_CALL("imucal_stack_measure")::: IMUCAL_STACK_CLOBBERS);
}
#undef IMUCAL_STACK_CALL
#undef IMUCAL_STACK_CLOBBERS

struct StackSeries {
  std::uintptr_t max_bytes = 0;  // the deepest measured call, bytes below the caller's SP
  unsigned measures = 0;         // how many calls were measured
  bool sp_moved = false;         // the caller's SP was not the same at every paint and measure
  bool window_overflow = false;  // something wrote below the window: max_bytes means nothing
  std::uintptr_t window = 0;     // as given to stack_series_start()
};

// The series' result. Call it after the last stack_measure(), from the caller or from a function
// the caller calls: its frame and theirs must lie within the window (it reads below the window).
[[gnu::noinline]] inline StackSeries stack_series_result() {
  const StackPaintArea& a = imucal_stack_area;
  StackSeries s;
  s.max_bytes = a.max;
  s.measures = a.measures;
  s.sp_moved = a.sp_moved != 0;
  s.window = a.window;
  if (a.sp != 0 && a.window != 0 && a.sp - a.limit > a.window) {
    for (std::uintptr_t p = a.limit; p < a.sp - a.window; p += 4) {
      if (*reinterpret_cast<const volatile std::uint32_t*>(p) != a.pattern) {
        s.window_overflow = true;
        break;
      }
    }
  }
  return s;
}

}  // namespace imucal::bench

#else  // ARMv6-M (Cortex-M0/M0+): the routines are Thumb-2; nothing is measured.

namespace imucal::bench {
struct StackSeries {
  std::uintptr_t max_bytes = 0;
  unsigned measures = 0;  // 0: not measured
  bool sp_moved = false;
  bool window_overflow = false;
  std::uintptr_t window = 0;
};
inline void stack_series_start(std::uintptr_t) {}
inline void stack_paint() {}
inline void stack_measure() {}
inline StackSeries stack_series_result() { return StackSeries{}; }
}  // namespace imucal::bench

#endif

namespace imucal::bench {
// Prints the stack series just measured as "STACK <name>: <bytes> B".
[[gnu::noinline]] inline void report_stack(const char* name) {
  const bench::StackSeries s = stack_series_result();
  if (s.measures == 0) {
    std::printf("STACK %s: not measured (no paint routine for this core)\n", name);
  } else if (s.sp_moved) {
    std::printf("STACK %s: not measured (main's SP moved between the calls)\n", name);
  } else if (s.window_overflow) {
    std::printf("STACK %s: not measured (something went deeper than the %u B window)\n", name,
                static_cast<unsigned>(s.window));
  } else {
    std::printf("STACK %s: %u B\n", name, static_cast<unsigned>(s.max_bytes));
  }
}
}  // namespace imucal::bench
