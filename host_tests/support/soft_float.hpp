// SPDX-License-Identifier: MIT
// host_tests/support/soft_float.hpp: IMUCAL_TEST_SOFT_FLOAT is 1 on a target without a
// floating-point unit, where every float and double operation is a library call (RV32 without
// the F extension; Arm cores without an FPU: Cortex-M3, M0+), and 0 elsewhere. It comes from the
// compiler's own macros. The slowest statistical tests run fewer trials there, with their bands
// widened to what the smaller number of trials gives: they can still fail.
#pragma once

#if defined(__riscv) && !defined(__riscv_flen)
#define IMUCAL_TEST_SOFT_FLOAT 1
#elif defined(__ARM_ARCH) && !defined(__ARM_FP)
#define IMUCAL_TEST_SOFT_FLOAT 1
#else
#define IMUCAL_TEST_SOFT_FLOAT 0
#endif
