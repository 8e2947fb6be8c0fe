// SPDX-License-Identifier: MIT
// imucal/config.hpp: what every imucal header needs of the compiler, checked once, before any of
// imucal's code: C++17. Every public header reaches this file (through types.hpp or status.hpp),
// so an older standard stops at this one error, not in a template. Arduino and PlatformIO
// projects set the flag as docs/ecosystems.md shows.
//
// An Arduino build (every core defines ARDUINO), which cannot pass a definition to a library's
// sources, compiles the solvers in float only, as IMUCAL_FLOAT_ONLY does in the other builds.
#pragma once

#if (defined(_MSVC_LANG) && _MSVC_LANG < 201703L) || \
    (!defined(_MSVC_LANG) && (!defined(__cplusplus) || __cplusplus < 201703L))
#error "imucal needs C++17: compile with -std=gnu++17 (or -std=c++17)"
#endif

#if defined(ARDUINO) && !defined(IMUCAL_FLOAT_ONLY)
#define IMUCAL_FLOAT_ONLY 1
#endif
