// SPDX-License-Identifier: MIT
// Test support: GoogleTest prints imucal::Status by name.
#pragma once

#include <ostream>

#include "imucal/status.hpp"

namespace imucal {
inline void PrintTo(Status s, std::ostream* os) { *os << to_string(s); }
}  // namespace imucal
