// Error-free transformations: a rounded sum or product and its rounding error, both doubles, whose
// sum is the exact result (Knuth's TwoSum, Dekker's FastTwoSum and TwoProduct, the FMA product),
// and Kahan's difference of products built on them. The one home of these for the kernel's
// fallbacks (lib) and the oracle's filters and expansions (verify).
#pragma once

#include <cmath>

namespace rayproof {

// s + e = a + b exactly, s = fl(a + b), for any a, b without overflow (Knuth, TAOCP vol. 2, 4.2.2).
[[gnu::always_inline]] inline void two_sum(double a, double b, double& s, double& e) {
  s = a + b;
  const double bb = s - a;
  e = (a - (s - bb)) + (b - bb);
}

// The same in three operations when |a| ≥ |b| (or a = 0) (Dekker 1971).
[[gnu::always_inline]] inline void fast_two_sum(double a, double b, double& s, double& e) {
  const double t = a + b;
  e = b - (t - a);
  s = t;
}

// p + e = a·b exactly, p = fl(a·b), by Veltkamp's split into 26-bit halves and Dekker's product:
// no FMA call (which costs more than the arithmetic where the hardware FMA is not inlined).
// Exact while the split a·(2^27 + 1) does not overflow (|a|, |b| < 2^996) and the partial
// products stay normal (|a·b| ≥ 2^-969; see fp.h's kSafeMagnitudeMin).
[[gnu::always_inline]] inline void split_veltkamp(double a, double& high, double& low) {
  const double c = 134217729.0 * a;  // 2^27 + 1
  high = c - (c - a);
  low = a - high;
}
[[gnu::always_inline]] inline void two_product_dekker(double a, double b, double& p, double& e) {
  p = a * b;
  double ah, al, bh, bl;
  split_veltkamp(a, ah, al);
  split_veltkamp(b, bh, bl);
  e = ((ah * bh - p) + ah * bl + al * bh) + al * bl;
}

// The same p and e by one FMA: e = fma(a, b, −p) is a·b − p rounded once, and a·b − p is a double
// (where e does not underflow: |a·b| ≥ 2^-969), so exact. Both products give the one pair (p, e)
// with p = fl(a·b) and p + e = a·b, so they are interchangeable bit for bit. Only for callers
// compiled for FMA (target("fma")): elsewhere std::fma is a library call, slower than Dekker's.
[[gnu::always_inline]] inline void two_product_fma(double a, double b, double& p, double& e) {
  p = a * b;
  e = __builtin_fma(a, b, -p);
}

// a·b − c·d by Kahan's algorithm: w = fl(c·d) and its exact error by one FMA, then one FMA for
// a·b − w. Its relative error is at most 2u (Jeannerod, Louvet & Muller, "Further analysis of
// Kahan's algorithm for the accurate computation of 2×2 determinants", Math. Comp. 82, 2013), so
// it is 0 exactly when a·b = c·d and otherwise has the exact sign. Holds while nothing overflows
// and the error w − c·d is a double, i.e. c·d = 0 or |c·d| ≥ 2^-969 (Boldo & Muller 2011; fp.h):
// where a product is smaller, the result still has relative error ≤ 2u plus a few 2^-1074.
template <class T>
[[gnu::always_inline]] inline T difference_of_products(T a, T b, T c, T d) {
  const T w = c * d;
  const T error = std::fma(-c, d, w);  // w − c·d, exactly
  const T rest = std::fma(a, b, -w);   // a·b − w, rounded once
  return rest + error;
}

}  // namespace rayproof
