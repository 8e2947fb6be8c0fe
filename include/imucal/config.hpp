// SPDX-License-Identifier: MIT
// imucal/config.hpp: what every imucal header needs of the compiler, checked once, before any of
// imucal's code: C++17. Every public header reaches this file (through types.hpp or status.hpp),
// so an older standard stops at this one error, not in a template. Arduino and PlatformIO
// projects set the flag as docs/ecosystems.md shows.
#pragma once

#if (defined(_MSVC_LANG) && _MSVC_LANG < 201703L) || \
    (!defined(_MSVC_LANG) && (!defined(__cplusplus) || __cplusplus < 201703L))
#error "imucal needs C++17: compile with -std=gnu++17 (or -std=c++17)"
#endif
