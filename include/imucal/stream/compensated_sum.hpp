// SPDX-License-Identifier: MIT
// imucal/stream/compensated_sum.hpp: a sum kept to about twice the scalar's precision, for long
// runs of small summands (means over hours of samples, Allan variances on raw counts). Header-only.
#pragma once

#include <cstdint>

#include "imucal/types.hpp"

namespace imucal {

namespace detail {

// x is a whole number of magnitude below 2^23 (float) or 2^52 (double), read from its bits.
inline bool small_integer(float x) {
  const std::uint32_t b = bits_of(x) & 0x7FFFFFFFu;
  if (b == 0) return true;
  const std::uint32_t e = b >> 23;              // biased exponent: x in [2^(e-127), 2^(e-126))
  if (e < 127u || e > 149u) return false;       // a fraction, or 2^23 and beyond
  return (b & ((1u << (150u - e)) - 1u)) == 0;  // no bit below the binary point
}
inline bool small_integer(double x) {
  const std::uint64_t b = bits_of(x) & 0x7FFFFFFFFFFFFFFFull;
  if (b == 0) return true;
  const std::uint64_t e = b >> 52;
  if (e < 1023u || e > 1074u) return false;
  return (b & ((std::uint64_t{1} << (1075u - e)) - 1u)) == 0;
}

}  // namespace detail

// hi + lo += x, keeping hi + lo exact to about twice the scalar's precision (TwoSum, then
// Fast2Sum renormalisation: |lo| stays within half an ulp of hi). Unlike a separate Neumaier
// term, lo never grows when many small summands are swallowed by a large sum (a drifting
// temperature over a day). Needs IEEE arithmetic: never build imucal with -ffast-math.
template <typename Scalar>
void compensated_add(Scalar& hi, Scalar& lo, Scalar x) {
  if constexpr (!detail::hardware_float<Scalar>()) {
    // Where each operation is a runtime call: two whole numbers below 2^23 (2^52) add exactly,
    // so with lo zero the result is the plain sum and lo stays zero (sums of raw counts). Told
    // from the bits, in integer instructions.
    if (detail::bits_of(lo) == 0 && detail::small_integer(hi) && detail::small_integer(x)) {
      hi += x;
      return;
    }
  }
  const Scalar s = hi + x;
  const Scalar bp = s - hi;
  const Scalar err = (hi - (s - bp)) + (x - bp);
  const Scalar l = lo + err;
  hi = s + l;
  lo = l - (hi - s);
}

}  // namespace imucal
