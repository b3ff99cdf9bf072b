// The error-bound vocabulary of the double kernel, in one place: the unit roundoff, pbrt's γ(n),
// distances in ulps, nudges by ulps, and the magnitude range inside which the bounds are proved.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <type_traits>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace rayproof {

// u = 2^-53: |fl(x ∘ y) − x ∘ y| ≤ u·|x ∘ y| for one rounding, while nothing under- or overflows.
inline constexpr double kUnitRoundoff = std::numeric_limits<double>::epsilon() * 0.5;

// γ(n) = n·u / (1 − n·u) (Higham, "Accuracy and Stability of Numerical Algorithms", §3.1; pbrt-v4
// util/float.h): a product of n factors (1 + δ_i), |δ_i| ≤ u, lies within 1 ± γ(n).
constexpr double gamma(int n) { return (n * kUnitRoundoff) / (1 - n * kUnitRoundoff); }

// The magnitudes between which the double filters' bounds are proved (error-free products and
// relative bounds γ(n)). FMA's product error a·b − fl(a·b) is itself a double unless underflow
// intervenes, which it cannot while e_a + e_b ≥ e_min + p − 1 = −1022 + 52 = −970 (Boldo & Muller,
// "Exact and Approximated Error of the FMA", IEEE TC 2011), i.e. for |a·b| ≥ 2^-969; a relative
// bound γ(n) likewise needs every rounded intermediate to stay normal. 2^-900 leaves 69 binades
// of headroom for the few products a formula forms after the guard; 2^+900 mirrors it below the
// overflow threshold 2^1024 with the same margin for the sums and products that follow.
inline constexpr double kSafeMagnitudeMin = 0x1p-900;
inline constexpr double kSafeMagnitudeMax = 0x1p+900;

// The number of doubles between a and b (0 when equal; +0 and −0 are one point), or nullopt
// when either is NaN. ±inf count as the doubles just beyond ±DBL_MAX.
inline std::optional<std::uint64_t> ulp_distance(double a, double b) {
  if (std::isnan(a) || std::isnan(b)) return std::nullopt;
  // Map the IEEE bit patterns onto a line where consecutive doubles are consecutive integers.
  auto ordered = [](double x) {
    std::int64_t bits;
    std::memcpy(&bits, &x, sizeof bits);
    return bits < 0 ? -(bits & INT64_MAX) : bits;
  };
  const std::int64_t ia = ordered(a), ib = ordered(b);
  return ia > ib ? std::uint64_t(ia) - std::uint64_t(ib) : std::uint64_t(ib) - std::uint64_t(ia);
}

// The number of floats between a and b (ulp_distance on the float grid), nullopt for NaN.
inline std::optional<std::uint64_t> ulp_distance_f32(float a, float b) {
  if (std::isnan(a) || std::isnan(b)) return std::nullopt;
  auto ordered = [](float x) {
    std::int32_t bits;
    std::memcpy(&bits, &x, sizeof bits);
    return std::int64_t(bits < 0 ? -(bits & INT32_MAX) : bits);
  };
  const std::int64_t ia = ordered(a), ib = ordered(b);
  return std::uint64_t(ia > ib ? ia - ib : ib - ia);
}

// x rounded to the nearest float (ties to even): ±inf from FLT_MAX + ½ulp = 0x1.ffffffp+127 on,
// where round-to-nearest overflows, NaN for NaN. The one double-to-float conversion of rayproof:
// casting an out-of-range double to float is undefined in C++, so the test comes first.
// On x86 the conversion instruction itself, whose IEEE rounding gives exactly that (±inf from
// 0x1.ffffffp+127 on) without the range test: float variants convert a dozen numbers a query.
inline float to_nearest_float(double x) {
  if (std::isnan(x)) return std::numeric_limits<float>::quiet_NaN();
#if defined(__SSE2__)
  return _mm_cvtss_f32(_mm_cvtsd_ss(_mm_setzero_ps(), _mm_set_sd(x)));
#else
  if (!(std::fabs(x) < 0x1.ffffffp+127))
    return x > 0 ? std::numeric_limits<float>::infinity() : -std::numeric_limits<float>::infinity();
  return static_cast<float>(x);
#endif
}

// A double as T: itself, or rounded to the nearest float (to_nearest_float): how the float twins
// and batches read a case, exact for a case already rounded to float.
template <class T>
T rounded_to(double x) {
  if constexpr (std::is_same_v<T, float>)
    return to_nearest_float(x);
  else
    return x;
}

// ⌊log2 x⌋ of a normal positive finite x, read from its exponent bits.
inline int binary_exponent(double x) {
  std::uint64_t bits;
  std::memcpy(&bits, &x, sizeof bits);
  return static_cast<int>((bits >> 52) & 0x7ff) - 1023;
}

// The neighbouring doubles of x: by the bits for nonzero finite x (the oracle's fast paths, where
// a libm call would cost more than the arithmetic it brackets: away from zero the bits grow, towards
// it they shrink, as nextafter's do, to ±inf past the largest and to a signed 0 past the least;
// from a zero, the least subnormal), else nextafter (infinities, NaN).
[[gnu::always_inline]] inline double next_double(double x, bool up) {
  if (x == 0) return up ? 0x1p-1074 : -0x1p-1074;  // from either zero, the least subnormal
  if (!std::isfinite(x)) return std::nextafter(x, up ? INFINITY : -INFINITY);
  std::uint64_t bits;
  std::memcpy(&bits, &x, sizeof bits);
  bits = (x > 0) == up ? bits + 1 : bits - 1;
  std::memcpy(&x, &bits, sizeof bits);
  return x;
}
[[gnu::always_inline]] inline double next_down(double x) { return next_double(x, false); }
[[gnu::always_inline]] inline double next_up(double x) { return next_double(x, true); }

// x moved by `ulps` representable doubles (negative: downwards).
inline double nudge(double x, int ulps) {
  for (; ulps > 0; --ulps) x = next_up(x);
  for (; ulps < 0; ++ulps) x = next_down(x);
  return x;
}

}  // namespace rayproof
