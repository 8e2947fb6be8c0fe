// SPDX-License-Identifier: MIT
// host_tests/support/sanitizers.hpp: IMUCAL_TEST_ASAN when the test is built with
// AddressSanitizer (GCC says so with __SANITIZE_ADDRESS__, Clang with __has_feature). Tests that
// repeat the same code paths for statistics or drift run fewer repetitions there: the sanitizer
// run looks for memory errors, and the plain host run keeps the full counts.
#pragma once

#if defined(__SANITIZE_ADDRESS__)
#define IMUCAL_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define IMUCAL_TEST_ASAN 1
#endif
#endif
