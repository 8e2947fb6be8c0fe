// SPDX-License-Identifier: MIT
// imucal/stream/compensated_sum.hpp: a sum kept to about twice the scalar's precision, for long
// runs of small summands (means over hours of samples, Allan variances on raw counts). Header-only.
#pragma once

namespace imucal {

// hi + lo += x, keeping hi + lo exact to about twice the scalar's precision (TwoSum, then
// Fast2Sum renormalisation: |lo| stays within half an ulp of hi). Unlike a separate Neumaier
// term, lo never grows when many small summands are swallowed by a large sum (a drifting
// temperature over a day). Needs IEEE arithmetic: never build imucal with -ffast-math.
template <typename Scalar>
void compensated_add(Scalar& hi, Scalar& lo, Scalar x) {
  const Scalar s = hi + x;
  const Scalar bp = s - hi;
  const Scalar err = (hi - (s - bp)) + (x - bp);
  const Scalar l = lo + err;
  hi = s + l;
  lo = l - (hi - s);
}

}  // namespace imucal
