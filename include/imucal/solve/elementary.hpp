// SPDX-License-Identifier: MIT
// imucal/solve/elementary.hpp: log, exp and sin/cos for the library's float paths, written out. In
// float they are a few hundred bytes together where picolibc's logf, expf, powf, sinf and cosf
// (with its large-argument reduction tables) are about 6 KB of a firmware, and they are exact
// enough for what uses them: the stillness detector's levels, the gyro scale search and the
// rotation of a gyro segment. In double they are the standard library's.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "imucal/config.hpp"

namespace imucal {
namespace detail {

inline double log2_of(double x) { return std::log2(x); }
inline double exp2_of(double y) { return std::exp2(y); }

// log2 within 2e-7 (absolute) for positive finite x (subnormal too); -inf at 0, NaN below 0 and
// for NaN, +inf at +inf.
inline float log2_of(float x) {
  if (!(x >= std::numeric_limits<float>::min() && x <= std::numeric_limits<float>::max())) {
    if (x > 0.0f && x < std::numeric_limits<float>::min()) return log2_of(x * 0x1p64f) - 64.0f;
    if (x == 0.0f) return -std::numeric_limits<float>::infinity();
    if (x > 0.0f) return x;                          // +inf
    return std::numeric_limits<float>::quiet_NaN();  // below 0, or NaN
  }
  std::uint32_t bits;
  std::memcpy(&bits, &x, sizeof bits);
  int e = static_cast<int>(bits >> 23) - 127;  // x > 0: no sign bit
  bits = (bits & 0x007fffffu) | 0x3f800000u;   // the mantissa m in [1, 2)
  float m;
  std::memcpy(&m, &bits, sizeof m);
  if (m > 1.41421356f) {  // m in [sqrt(1/2), sqrt(2)): ln m = 2 atanh(t), |t| <= 0.1716
    m *= 0.5f;
    ++e;
  }
  const float t = (m - 1.0f) / (m + 1.0f), t2 = t * t;
  const float ln_m = t * (2.0f + t2 * (2.0f / 3.0f + t2 * (2.0f / 5.0f + t2 * (2.0f / 7.0f))));
  return static_cast<float>(e) + ln_m * 1.44269504f;
}

// 2^y within 2e-7 (relative) where the result is a normal float; subnormal results rounded to
// a multiple of 2^-149, +inf from 128 up, 0 below -150, NaN for NaN.
inline float exp2_of(float y) {
  if (!(y > -126.0f && y < 127.0f)) {  // NaN, overflow, or a subnormal result
    if (y != y) return y;
    if (y >= 128.0f) return std::numeric_limits<float>::infinity();
    if (y >= 127.0f) return 2.0f * exp2_of(y - 1.0f);
    return y < -150.0f ? 0.0f : std::ldexp(exp2_of(y + 64.0f), -64);
  }
  const int n = static_cast<int>(y + 128.5f) - 128;  // nearest integer (the sum is positive)
  const float z = (y - static_cast<float>(n)) * 0.693147181f;  // |z| <= ln(2) / 2
  const float p =
      1.0f +
      z * (1.0f + z * (0.5f + z * (1.0f / 6.0f +
                                   z * (1.0f / 24.0f +
                                        z * (1.0f / 120.0f + z * (1.0f / 720.0f + z / 5040.0f))))));
  const std::uint32_t bits = static_cast<std::uint32_t>(n + 127) << 23;  // 2^n, n in [-126, 127]
  float scale;
  std::memcpy(&scale, &bits, sizeof scale);
  return p * scale;
}

// Natural log and exp from the above (float: within about 2e-7 absolute / relative).
inline double log_of(double x) { return std::log(x); }
inline double exp_of(double y) { return std::exp(y); }
inline float log_of(float x) { return log2_of(x) * 0.693147181f; }
inline float exp_of(float y) { return exp2_of(y * 1.44269504f); }

inline void sin_cos(double x, double& s, double& c) {
  s = std::sin(x);
  c = std::cos(x);
}

// sin and cos within 2e-7 (absolute) for |x| up to 8192 rad: the argument reduced by the nearest
// multiple of pi/2 in three parts (Cody and Waite), then minimax polynomials on [-pi/4, pi/4].
// NaN and infinities give NaN. Beyond 8192 rad (no rotation of the library's comes near) they are
// those of 0: finite, in [-1, 1].
inline void sin_cos(float x, float& s, float& c) {
  if (!(std::abs(x) <= 8192.0f)) {
    const bool finite = std::abs(x) <= std::numeric_limits<float>::max();
    s = finite ? 0.0f : std::numeric_limits<float>::quiet_NaN();
    c = finite ? 1.0f : std::numeric_limits<float>::quiet_NaN();
    return;
  }
  const std::int32_t n = static_cast<std::int32_t>(x * 0.636619772f + (x < 0.0f ? -0.5f : 0.5f));
  const float q = static_cast<float>(n);  // |n| <= 5216: each q * part below is exact
  const float r = ((x - q * 1.5703125f) - q * 4.837512969970703125e-4f) - q * 7.54978995489e-8f;
  const float r2 = r * r;
  const float sr =
      r + r * r2 * (-1.6666654611e-1f + r2 * (8.3321608736e-3f + r2 * -1.9515295891e-4f));
  const float cr =
      1.0f - 0.5f * r2 +
      r2 * r2 *
          (4.166664568298827e-2f + r2 * (-1.388731625493765e-3f + r2 * 2.443315711809948e-5f));
  switch (n & 3) {  // the quadrant
    case 0:
      s = sr;
      c = cr;
      break;
    case 1:
      s = cr;
      c = -sr;
      break;
    case 2:
      s = -sr;
      c = -cr;
      break;
    default:
      s = -cr;
      c = sr;
      break;
  }
}

}  // namespace detail
}  // namespace imucal
