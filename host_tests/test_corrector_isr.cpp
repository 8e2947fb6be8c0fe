// SPDX-License-Identifier: MIT
// A real interrupt applies the corrector while the main loop swaps calibrations (cross targets
// only: SysTick on the simulated Arm boards, the machine timer on RISC-V's virt). With
// CorrectorSwap every sample the interrupt corrects matches exactly one of the two calibrations,
// never a mix of the two. The same detector run on one corrector that the main loop overwrites
// in place (a store of many instructions, here byte by byte) does see mixed samples: the check
// can fail.
#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>

#include "imucal/corrector.hpp"
#include "support/example_calibration.hpp"
#include "support/gtest_status.hpp"

namespace imucal {
namespace {

CorrectorSwap<float> swap;
Corrector<float> in_place;  // the wrong way: set() on the corrector the interrupt applies
volatile bool use_swap = true;

const Vector3<float> kRaw(33000.0f, 30000.0f, 36000.0f);
Vector3<float> expected_a[2], expected_w[2];  // the corrected sample under each calibration
volatile std::uint32_t interrupts = 0, as_first = 0, as_second = 0, mixed = 0;

Calibration<double> calibration(int which) {
  Calibration<double> c = test::example_calibration();
  if (which == 1) {  // every matrix entry and offset differs
    for (int i = kScaleX; i <= kScaleZ; ++i) c.accel.params(i) *= 1.01;
    for (int i = kBiasX; i <= kBiasZ; ++i) c.accel.params(i) += 25.0;
    c.accel.params(kAlphaYz) += 0.001;
    c.accel.params(kAlphaZy) += 0.001;
    c.accel.params(kAlphaZx) += 0.001;
    for (int i = kGyroScaleX; i <= kGyroScaleZ; ++i) c.gyro.params(i) *= 1.02;
    for (int i = kGyroBiasX; i <= kGyroBiasZ; ++i) c.gyro.params(i) -= 40.0;
    for (int i = kGammaYz; i <= kGammaYx; ++i) c.gyro.params(i) += 0.002;
  }
  return c;
}

// What the interrupt does: apply the corrector in use and classify the result.
void on_timer() {
  const Corrector<float>& c = use_swap ? swap.active() : in_place;
  Vector3<float> a, w;
  c.apply(kRaw, kRaw, a, w);
  const bool first = a == expected_a[0] && w == expected_w[0];
  const bool second = a == expected_a[1] && w == expected_w[1];
  if (first) as_first = as_first + 1;
  if (second) as_second = as_second + 1;
  if (!first && !second) mixed = mixed + 1;
  interrupts = interrupts + 1;
}

}  // namespace
}  // namespace imucal

#if defined(__arm__)

// SysTick (ARMv7-M / ARMv8-M system control space).
namespace {
volatile std::uint32_t* const kSystCsr = reinterpret_cast<volatile std::uint32_t*>(0xE000E010u);
volatile std::uint32_t* const kSystRvr = reinterpret_cast<volatile std::uint32_t*>(0xE000E014u);
volatile std::uint32_t* const kSystCvr = reinterpret_cast<volatile std::uint32_t*>(0xE000E018u);
}  // namespace

// picolibc's vector table names the SysTick handler arm_systick_isr (weak).
extern "C" void arm_systick_isr(void) { imucal::on_timer(); }

namespace imucal {
namespace {
// An interrupt every 3000 processor clocks.
void start_timer() {
  *kSystRvr = 3000u - 1u;
  *kSystCvr = 0u;
  *kSystCsr = 7u;  // enable, interrupt, processor clock
}
void stop_timer() { *kSystCsr = 0u; }
}  // namespace
}  // namespace imucal

#elif defined(__riscv) && __riscv_xlen == 32

// The machine timer of qemu virt's CLINT (hart 0): mtime counts at 10 MHz, the interrupt is
// pending while mtime >= mtimecmp. Both are 64-bit registers, read and written as two words.
namespace {
volatile std::uint32_t* const kMtimecmp = reinterpret_cast<volatile std::uint32_t*>(0x02004000u);
volatile std::uint32_t* const kMtime = reinterpret_cast<volatile std::uint32_t*>(0x0200BFF8u);
constexpr std::uint32_t kPeriodTicks = 1200;  // 120 us: 3000 clocks at the mps2 boards' 25 MHz
constexpr std::uint32_t kMcauseMachineTimer = 0x80000007u;
constexpr std::uint32_t kMieMtie = 1u << 7;
constexpr std::uint32_t kMstatusMie = 1u << 3;
std::uint32_t saved_mtvec = 0;  // picolibc's trap handler (crt0 sets it), restored at the end

// A CSR instruction: -march=rv32imac leaves out Zicsr (ISA spec 20191213), which every core
// that takes traps has.
#define IMUCAL_CSR(insn) ".option push\n.option arch, +zicsr\n" insn "\n.option pop"

std::uint64_t mtime() {
  std::uint32_t hi, lo;
  do {
    hi = kMtime[1];
    lo = kMtime[0];
  } while (kMtime[1] != hi);
  return (std::uint64_t{hi} << 32) | lo;
}

// Sets mtimecmp without passing through a value below the target: high word at its maximum first.
void set_mtimecmp(std::uint64_t when) {
  kMtimecmp[1] = 0xFFFFFFFFu;
  kMtimecmp[0] = static_cast<std::uint32_t>(when);
  kMtimecmp[1] = static_cast<std::uint32_t>(when >> 32);
}
}  // namespace

// The trap handler while the timer runs (mtvec, direct mode: every trap comes here). Anything
// but the timer interrupt is a fault of the program: picolibc's handler is put back and the
// faulting instruction runs again, so that it reports the fault and exits.
extern "C" [[gnu::interrupt("machine"), gnu::aligned(4)]] void riscv_mtimer_isr() {
  std::uint32_t mcause;
  __asm__ volatile(IMUCAL_CSR("csrr %0, mcause") : "=r"(mcause));
  if (mcause != kMcauseMachineTimer) {
    __asm__ volatile(IMUCAL_CSR("csrw mtvec, %0")::"r"(saved_mtvec));
    return;
  }
  set_mtimecmp(mtime() + kPeriodTicks);
  imucal::on_timer();
}

namespace imucal {
namespace {
void start_timer() {
  __asm__ volatile(IMUCAL_CSR("csrr %0, mtvec") : "=r"(saved_mtvec));
  set_mtimecmp(mtime() + kPeriodTicks);
  __asm__ volatile(IMUCAL_CSR("csrw mtvec, %0")::"r"(&riscv_mtimer_isr));
  __asm__ volatile(IMUCAL_CSR("csrs mie, %0")::"r"(kMieMtie));
  __asm__ volatile(IMUCAL_CSR("csrs mstatus, %0")::"r"(kMstatusMie) : "memory");
}
void stop_timer() {
  __asm__ volatile(IMUCAL_CSR("csrc mstatus, %0")::"r"(kMstatusMie) : "memory");
  __asm__ volatile(IMUCAL_CSR("csrc mie, %0")::"r"(kMieMtie));
  __asm__ volatile(IMUCAL_CSR("csrw mtvec, %0")::"r"(saved_mtvec));
}
}  // namespace
}  // namespace imucal

#else
#error "test_corrector_isr.cpp: no timer interrupt for this target"
#endif

namespace imucal {
namespace {

void reset_counts() {
  interrupts = 0;
  as_first = as_second = mixed = 0;
}

// Swaps calibrations from the main loop until `wanted` interrupts have run; false if the
// interrupt never came.
// Overwrites a corrector in place the way any multi-word store does, one piece at a time.
void overwrite_in_place(Corrector<float>& dst, const Corrector<float>& src) {
  volatile unsigned char* d = reinterpret_cast<volatile unsigned char*>(&dst);
  const unsigned char* s = reinterpret_cast<const unsigned char*>(&src);
  for (std::size_t i = 0; i < sizeof dst; ++i) d[i] = s[i];
}

bool run(int wanted, int* swaps) {
  const Calibration<double> cal[2] = {calibration(0), calibration(1)};
  Corrector<float> staged[2];
  for (int k = 0; k < 2; ++k)
    if (staged[k].set(cal[k]) != Status::kOk) return false;
  *swaps = 0;
  std::uint32_t last = interrupts;
  long idle = 0;
  while (interrupts < static_cast<std::uint32_t>(wanted)) {
    const int next = (*swaps + 1) & 1;
    if (use_swap) {
      if (swap.spare().set(cal[next]) != Status::kOk) return false;
      swap.publish();
    } else {
      overwrite_in_place(in_place, staged[next]);
    }
    ++*swaps;
    if (interrupts == last) {
      if (++idle > 200000) return false;
    } else {
      idle = 0;
      last = interrupts;
    }
  }
  return true;
}

TEST(CorrectorIsr, SwappedWhileAnInterruptAppliesItNeverMixes) {
  for (int k = 0; k < 2; ++k) {
    Corrector<float> c;
    ASSERT_EQ(c.set(calibration(k)), Status::kOk);
    c.apply(kRaw, kRaw, expected_a[k], expected_w[k]);
  }
  ASSERT_NE(expected_a[0], expected_a[1]);
  ASSERT_EQ(swap.spare().set(calibration(0)), Status::kOk);
  swap.publish();
  ASSERT_EQ(in_place.set(calibration(0)), Status::kOk);

  use_swap = true;
  reset_counts();
  int swaps = 0;
  start_timer();
  const bool came = run(4000, &swaps);
  stop_timer();
  ASSERT_TRUE(came) << "no timer interrupt";
  std::printf("swap: %d swaps, %u interrupts: %u first, %u second, %u mixed\n", swaps,
              static_cast<unsigned>(interrupts), static_cast<unsigned>(as_first),
              static_cast<unsigned>(as_second), static_cast<unsigned>(mixed));
  EXPECT_EQ(mixed, 0u);
  EXPECT_GT(as_first, 100u);  // both calibrations were in use while interrupts came
  EXPECT_GT(as_second, 100u);
  EXPECT_GT(swaps, 1000);

  // The detector is not blind: set() in place under the same interrupt gives mixed samples.
  use_swap = false;
  reset_counts();
  start_timer();
  const bool came_again = run(4000, &swaps);
  stop_timer();
  ASSERT_TRUE(came_again);
  std::printf("in place: %d swaps, %u interrupts: %u first, %u second, %u mixed\n", swaps,
              static_cast<unsigned>(interrupts), static_cast<unsigned>(as_first),
              static_cast<unsigned>(as_second), static_cast<unsigned>(mixed));
  EXPECT_GT(mixed, 0u);
}

}  // namespace
}  // namespace imucal
