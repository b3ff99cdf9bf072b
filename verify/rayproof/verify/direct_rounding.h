// The oracle's direct rounding of t (oracle.cpp's round_static, one per shape): t's exact terms
// evaluated once in double-double with error bounds fixed a priori from the inputs' magnitudes,
// as the static filters bound their signs, then one quotient test that proves which double t
// rounds to. No bookkeeping per operation (FilteredDD's magnitude, round count and validity
// flags) and no midpoint walk: where the test cannot prove the rounding (t within about 2^-40
// of an ulp of a midpoint, or inputs outside a path's range) the generic stages decide.
// Unproved is NaN, not an empty std::optional: an optional is built in memory part by part and
// read back whole, which stalls store-to-load forwarding (a fifth of a sphere's judge), while a
// NaN stays in its register and fails every later range check by itself.
#pragma once

#include <cstdint>
#include <cstring>
#include <limits>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "rayproof/verify/filtered.h"

namespace rayproof {

// An exact value known to lie within `error` of hi + lo (hi + lo need not be normalised).
struct BoundedDD {
  double hi, lo, error;
};

// A double-double value without bounds (each shape's round_static bounds its terms a priori),
// normalised (|lo| ≤ u·|hi|), and exact differences of two doubles.
//  - Products: dd_product (filtered.h), within 7u² of their exact result, relatively.
//  - Sums: the "sloppy" sum with an exact last step: (s, e) = TwoSum(xh, yh), w = fl(e + fl(xl +
//    yl)), (zh, zl) = TwoSum(s, w). Its error, fl(xl + yl)'s and w's roundings, is at most
//    u²(|xh| + |yh|) + 2u²(1 + u)(|xh| + |yh|) < 4u²(|x| + |y|): not relative to |x + y| (it is
//    when the signs agree), but filtered.h's bound needs only that much of a sum, error ≤
//    ε·(|x̂| + |ŷ|), as its induction shows (|x̂| ≤ (1 + θ)·M_x for each operand). ε = 2^-100
//    covers both. Half the latency of AccurateDWPlusDW, which sets the time of the sphere's t.
struct PlainDD {
  double hi, lo;
};
[[gnu::always_inline]] inline PlainDD exact_difference(double a, double b) {
  PlainDD r;
  two_sum(a, -b, r.hi, r.lo);
  return r;
}
[[gnu::always_inline]] inline PlainDD dd_sum_within_magnitudes(double ah, double al, double bh, double bl) {
  double s, e;
  two_sum(ah, bh, s, e);
  PlainDD r;
  two_sum(s, e + (al + bl), r.hi, r.lo);
  return r;
}
[[gnu::always_inline]] inline PlainDD operator+(const PlainDD& a, const PlainDD& b) {
  return dd_sum_within_magnitudes(a.hi, a.lo, b.hi, b.lo);
}
[[gnu::always_inline]] inline PlainDD operator-(const PlainDD& a, const PlainDD& b) {
  return dd_sum_within_magnitudes(a.hi, a.lo, -b.hi, -b.lo);
}
template <class Product>
[[gnu::always_inline]] inline PlainDD product(const PlainDD& a, const PlainDD& b) {
  PlainDD r;
  dd_product<Product>(a.hi, a.lo, b.hi, b.lo, r.hi, r.lo);
  return r;
}
// The same with a double factor (dd_product with b's low part 0, which the compiler cannot drop
// itself: x·0 is not 0 for every double x), and of two doubles (TwoProduct: exact).
template <class Product>
[[gnu::always_inline]] inline PlainDD product(const PlainDD& a, double b) {
  PlainDD r;
  double ch, cl1;
  Product::two_product(a.hi, b, ch, cl1);
  fast_two_sum(ch, cl1 + a.lo * b, r.hi, r.lo);
  return r;
}
template <class Product>
[[gnu::always_inline]] inline PlainDD product(double a, double b) {
  PlainDD r;
  Product::two_product(a, b, r.hi, r.lo);
  return r;
}

// x·y over three terms in double-double (each operation one rounding at ε = 2^-100), for factors
// of either kind above.
template <class Product, class X, class Y>
[[gnu::always_inline]] inline PlainDD dd_dot(const X (&x)[3], const Y (&y)[3]) {
  return (product<Product>(x[0], y[0]) + product<Product>(x[1], y[1])) + product<Product>(x[2], y[2]);
}

// c + x·y over three terms, as Ogita, Rump & Oishi's Dot2 ("Accurate sum and dot product", SIAM
// J. Sci. Comput. 26(6), 2005) keeps it before its last rounding: the cascade of rounded sums p
// and the rounded sum s of every exact error (TwoProduct's r_i, TwoSum's q_i).
//  - Exactly: c + x·y = p + Σ q_i + Σ r_i (error-free transformations, while no product error
//    underflows: each that does is off by at most 2^-1075).
//  - With S = |c| + Σ|x_i·y_i|: |r_i| ≤ u|x_i·y_i|, |q_i| ≤ u|p_i| ≤ u(1 + u)^4·S, so the six
//    corrections sum in magnitude to at most 6u(1 + u)^4·S and their rounded sum s is within
//    γ(5)·6u(1 + u)^4·S < 31u² S < 2^-100·S of theirs (Higham Lemma 3.1 for a recursive sum).
//  - S ≤ Ŝ·(1 + γ(4)) for Ŝ the rounded sum of |c| and the |fl(x_i·y_i)|, so the bound used,
//    fl(2^-99·Ŝ + 2^-1070), covers 2^-100·S with its own rounding and three underflows to spare.
// (The plane's terms: den = n·d with c = 0, num = k − n·o.)
// (kAddend false: c is 0, and the first TwoSum, 0 + h, is skipped.)
template <class Product, bool kAddend = true>
[[gnu::always_inline]] inline BoundedDD compensated_dot(double c, const double (&x)[3], const double (&y)[3]) {
  double h[3], r[3];
  for (int i = 0; i < 3; ++i) Product::two_product(x[i], y[i], h[i], r[i]);
  double p = kAddend ? c : h[0], q[3] = {0, 0, 0};
  for (int i = kAddend ? 0 : 1; i < 3; ++i) two_sum(p, h[i], p, q[i]);
  const double s = kAddend ? ((q[0] + r[0]) + (q[1] + r[1])) + (q[2] + r[2]) : (r[0] + (q[1] + r[1])) + (q[2] + r[2]);
  const double magnitude = ((std::abs(c) + std::abs(h[0])) + std::abs(h[1])) + std::abs(h[2]);
  BoundedDD sum;
  two_sum(p, s, sum.hi, sum.lo);  // normalised (round_quotient needs |lo| small beside hi), exactly
  sum.error = 0x1p-99 * magnitude + 0x1p-1070;
  return sum;
}

// √X as an enclosure, from an enclosure x of X > 0; hi NaN where X is not known well enough.
//  - σ = fl(√xh) and ρ = X − σ² exactly; then √X = σ + ρ/(2σ) − (√X − σ)²/(2σ) (expand
//    (√X − σ)(√X + σ) = ρ), and |√X − σ| ≤ |ρ|/σ, so |√X − σ − ρ/(2σ)| ≤ ρ²/(2σ³).
//  - ρ = (xh − p − e) + xl + (X − xh − xl) with (p, e) = TwoProduct(σ, σ); xh − p is exact
//    (Sterbenz: p is within a factor 2 of xh), and ρ̂ = fl(fl(xh − p − e) + xl) is within
//    2^-52·(|fl(xh − p − e)| + |ρ̂|) of the first three, so |ρ − ρ̂| ≤ E_ρ = that + x.error.
//  - κ = fl(ρ̂·fl(0.5/σ)) is within 2u(1 + u)|κ| of ρ̂/(2σ). Where |ρ̂| + E_ρ ≤ 2^-45·σ² (checked), the
//    square term is at most 2^-45·(|ρ̂| + E_ρ)/(2σ), so |√X − (σ + κ)| ≤ E_ρ/σ + 2^-44·|κ|
//    (E_ρ/σ pays for 2·E_ρ/(2σ) after its rounding).
//  - Range: xh in [2^-400, 2^400]: σ² neither under- nor overflows, TwoProduct is exact.
template <class Product>
[[gnu::always_inline]] inline BoundedDD bounded_sqrt(const BoundedDD& x) {
  constexpr double unproved = std::numeric_limits<double>::quiet_NaN();
  if (!(x.hi >= 0x1p-400 && x.hi <= 0x1p400)) return {unproved, 0, 0};
#if defined(__SSE2__)  // the instruction: std::sqrt is a library call (errno), with every register saved
  const double sigma = _mm_cvtsd_f64(_mm_sqrt_pd(_mm_set1_pd(x.hi)));  // (both lanes: valgrind decodes this)
#else
  const double sigma = std::sqrt(x.hi);
#endif
  double p, e;
  Product::two_product(sigma, sigma, p, e);
  const double half_inverse = 0.5 / sigma;  // (a product by it below: the division overlaps ρ's work)
  const double g = (x.hi - p) - e, rho = g + x.lo;
  const double rho_error = 0x1p-52 * (std::abs(g) + std::abs(rho)) + x.error;
  if (!(std::abs(rho) + rho_error <= 0x1p-45 * (sigma * sigma))) return {unproved, 0, 0};
  const double kappa = rho * half_inverse;
  BoundedDD root;
  fast_two_sum(sigma, kappa, root.hi, root.lo);  // |κ| ≤ 2^-45·σ: exact
  root.error = rho_error / sigma + 0x1p-44 * std::abs(kappa);
  return root;
}

// The double nearest t = N/D > 0, where N and D are known as enclosures num and den; NaN where
// this test cannot prove it (then the generic stages decide).
//  - A candidate c: nh/dh corrected once by its residual (its accuracy decides only how often
//    the test below passes: nh/dh alone is off by up to an ulp where nl, dl are that large).
//  - t = c + R/D exactly with R = N − c·D. If |R| < H·D, H half the gap below c (the smaller of
//    c's two gaps: no side to choose), t lies strictly inside c's rounding interval (no tie), so
//    t rounds to c. Otherwise NaN: t is near a midpoint (about 2^-40 of random cases) or
//    the candidate missed.
//  - R = (nh − c·dh) + nl − c·dl + (N − nh − nl) − c·(D − dh − dl). With (p, e) = TwoProduct(c, dh)
//    exact, r = fl(fl(fl(nh − p) − e) + fl(nl − fl(c·dl))) has five roundings, each within u of
//    its result, so |R − r| ≤ E = 2^-51·(|g| + |r₀| + |nl| + |a|) + num.error + c·den.error +
//    2^-1073 with g = fl(nh − p), r₀ = fl(g − e), a = fl(c·dl) (3u(1 + u)² < 2^-51).
//  - Ê below computes E with 2^-50 in place of 2^-51 (its own roundings) and 2^-1060 for every
//    underflow; (|r| + Ê)·(1 + 2^-40) rounded is then ≥ |R|.
//  - D ≥ dh·(1 − 2^-50) where fl(|dl| + den.error) ≤ 2^-51·dh (checked), and H·dh is exact (H a
//    power of two), so fl(H·dh·(1 − 2^-40)) ≤ H·D.
//  - Range: nh, dh and c in [2^-400, 2^400] (NaN refused): TwoProduct is exact (|c·dh| ≥ 2^-969 as
//    c·dh ≥ nh/2 wherever the test can pass), nothing overflows, and H·dh does not underflow.
template <class Product>
[[gnu::always_inline]] inline double round_quotient(const BoundedDD& num, const BoundedDD& den) {
  constexpr double unproved = std::numeric_limits<double>::quiet_NaN();
  const double nh = num.hi, dh = den.hi, nl = num.lo, dl = den.lo;
  const double inverse = 1 / dh, q = nh * inverse;  // (a denominator known early takes the division off the path)
  double p, e;
  Product::two_product(q, dh, p, e);
  const double c = q + (((nh - p) - e) + (nl - q * dl)) * inverse;
  auto in_range = [](double x) { return x >= 0x1p-400 && x <= 0x1p400; };
  if (!(in_range(nh) & in_range(dh) & in_range(c)) || !(std::abs(dl) + den.error <= 0x1p-51 * dh)) return unproved;
  Product::two_product(c, dh, p, e);
  const double g = nh - p, r0 = g - e, a = c * dl;
  const double r = r0 + (nl - a);
  const double bound =
      (num.error + c * den.error) + 0x1p-50 * (((std::abs(g) + std::abs(r0)) + std::abs(nl)) + std::abs(a));
  std::uint64_t bits;
  std::memcpy(&bits, &c, sizeof bits);
  --bits;
  double below;
  std::memcpy(&below, &bits, sizeof bits);
  const double half_gap = (c - below) * 0.5;
  return ((std::abs(r) + bound) + 0x1p-1060) * (1 + 0x1p-40) < half_gap * dh * (1 - 0x1p-40) ? c : unproved;
}

// t = N/D > 0 for a D of either sign: both negated where D̂ < 0 (exact), then round_quotient.
template <class Product>
[[gnu::always_inline]] inline double round_ratio(const BoundedDD& num, const BoundedDD& den) {
  const double sign = den.hi < 0 ? -1 : 1;
  return round_quotient<Product>({sign * num.hi, sign * num.lo, num.error}, {sign * den.hi, sign * den.lo, den.error});
}

}  // namespace rayproof
