// The oracle's two fast filter stages, as number types for its templated terms: each evaluates
// the same expression as the exact stages, in floating point, and carries a proved bound on its
// error, so a sign is reported only when the bound makes it certain (otherwise nullopt, and the
// next stage decides).
//
//   FilteredDouble   plain doubles: the semi-static filter in front of the intervals. No
//                    rounding-mode switches; the bound comes from the operands' magnitudes.
//   FilteredDD       double-double values (~106 bits): enclosures of t tight enough to prove
//                    the correct rounding by midpoint tests before expansions are needed.
//
// The bound (Higham, "Accuracy and Stability of Numerical Algorithms", Lemmas 3.1 and 3.3; the
// idea of CGAL's Static_filters). An expression of +, − and × over exact doubles, evaluated with
// rounding that obeys fl(x ∘ y) = (x ∘ y)(1 + δ), |δ| ≤ ε, expands into monomials each carrying
// at most k factors (1 + δ_i), where k counts the roundings on its deepest path (a sum: one more
// than its deeper operand; a product: the sum of both operands' counts plus one). Hence
//     |computed − exact| ≤ γ_ε(k) · M,   γ_ε(k) = kε / (1 − kε),
// with M the same expression over |leaves| with every − read as +, evaluated exactly. We carry m,
// M evaluated in doubles alongside; its own roundings (k of them, u = 2^-53) give m ≥ M (1 − γ(k)),
// so M ≤ m / (1 − γ(k)). The bound used, fl(γ_ε(k + 2) · m), exceeds γ_ε(k) / (1 − γ(k)) · m even
// after its own rounding down by (1 − u), for every k < 2^40: the two spare roundings pay for it.
//
// Where the model holds: sums of doubles are exact when their result is subnormal, so only
// products can underflow, and only overflow can break sums. A product whose magnitude m_a·m_b
// is non-zero and outside [2^-800, 2^+800] (FilteredDD) or fp.h's safe range [2^-900, 2^+900]
// (FilteredDouble) marks the value invalid. Inside it, an underflowing product (possible when
// its value cancels far below its magnitude) adds at most a few times 2^-1075 absolutely, below
// 2^-170 · ε · m_a·m_b: the spare roundings absorb it. A value with m = 0 is exactly zero; a
// final m that is not finite, or below the safe minimum, gives no sign.
#pragma once

#include <array>
#include <cmath>
#include <optional>

#include "rayproof/core/eft.h"
#include "rayproof/core/fp.h"

namespace rayproof {

namespace filter_detail {
// The unit of one double-double operation in the model above (dd_sum, dd_product below: their
// proved relative errors 3u² + 13u³ and 7u² lie below it; tests/test_oracle_stages.cpp meets
// errors over 4u² on adversarial pairs, so a unit of u² would not be a bound).
inline constexpr double kEpsilonDD = 0x1p-100;
// γ_ε(k + 2) for k = 0 … 63.
constexpr std::array<double, 64> gamma_table(double eps) {
  std::array<double, 64> g{};
  for (int k = 0; k < 64; ++k) g[k] = ((k + 2) * eps) / (1 - (k + 2) * eps);
  return g;
}
inline constexpr auto kGammaDouble = gamma_table(kUnitRoundoff);
inline constexpr auto kGammaDD = gamma_table(kEpsilonDD);

// Whether a product of magnitudes ma·mb = m keeps the model valid: a zero factor makes it exactly
// zero; otherwise m must lie in [lo, hi] (an underflow to 0 must not pass for an exact zero).
inline bool product_in_range(double ma, double mb, double m, double lo, double hi) {
  return ma == 0 || mb == 0 || (m >= lo && m <= hi);
}
}  // namespace filter_detail

// A value, its magnitude m and round count k. Invalid (outside the model's range) is m = +inf or
// NaN, which every later operation keeps and sign() refuses: no flag to carry.
class FilteredDouble {
 public:
  FilteredDouble() = default;
  // Implicit, so that terms lift doubles.
  FilteredDouble(double x)  // NOLINT(google-explicit-constructor)
      : v_(x), m_(std::isfinite(x) ? std::abs(x) : INFINITY), k_(0) {}

  [[gnu::always_inline]] friend FilteredDouble operator+(const FilteredDouble& a, const FilteredDouble& b) {
    return {a.v_ + b.v_, a.m_ + b.m_, (a.k_ > b.k_ ? a.k_ : b.k_) + 1};
  }
  [[gnu::always_inline]] friend FilteredDouble operator-(const FilteredDouble& a, const FilteredDouble& b) {
    return {a.v_ - b.v_, a.m_ + b.m_, (a.k_ > b.k_ ? a.k_ : b.k_) + 1};
  }
  [[gnu::always_inline]] FilteredDouble operator-() const { return {-v_, m_, k_}; }
  [[gnu::always_inline]] friend FilteredDouble operator*(const FilteredDouble& a, const FilteredDouble& b) {
    const double m = a.m_ * b.m_;
    const bool in_model = filter_detail::product_in_range(a.m_, b.m_, m, kSafeMagnitudeMin, kSafeMagnitudeMax);
    return {a.v_ * b.v_, in_model ? m : INFINITY, a.k_ + b.k_ + 1};
  }

  // The sign of the exact value, when the bound makes it certain.
  [[gnu::always_inline]] std::optional<int> sign() const {
    if (!(m_ <= kSafeMagnitudeMax) || k_ >= 64) return std::nullopt;  // also NaN: invalid
    if (m_ == 0) return 0;
    if (m_ < kSafeMagnitudeMin) return std::nullopt;
    const double bound = filter_detail::kGammaDouble[k_] * m_;
    if (v_ > bound) return 1;
    if (v_ < -bound) return -1;
    return std::nullopt;
  }

 private:
  FilteredDouble(double v, double m, int k) : v_(v), m_(m), k_(k) {}
  // Left uninitialised by the default constructor, as a double is: terms fill what they use, and
  // zeroing unused slots (a box's missing axes) would cost more than the filter itself.
  double v_, m_;
  int k_;
};

// The exact product inside a double-double product (core/eft.h): Dekker's by Veltkamp splitting
// (any x86-64), or one FMA (code compiled for FMA: the oracle's dispatch). Both give the same
// (p, e), so every FilteredDD value and bound below is the same with either.
struct DekkerProduct {
  [[gnu::always_inline]] static void two_product(double a, double b, double& p, double& e) {
    two_product_dekker(a, b, p, e);
  }
};
struct FmaProduct {
  [[gnu::always_inline]] static void two_product(double a, double b, double& p, double& e) {
    two_product_fma(a, b, p, e);
  }
};

// Double-double arithmetic with the accurate algorithms of Joldes, Muller & Popescu, "Tight and
// Rigorous Error Bounds for Basic Building Blocks of Double-Word Arithmetic", ACM TOMS 44(2),
// 2017, on normalised pairs (|lo| ≤ ulp(hi)/2; both return such pairs): AccurateDWPlusDW
// (Algorithm 6, relative error ≤ 3u² + 13u³) and DWTimesDW1 (Algorithm 10, ≤ 7u²), with an
// exact TwoProduct (Product: Dekker's, or the FMA's where the CPU has one). ε = 2^-100 = 64u²
// covers both with room: each is one rounding of the model above at that ε.
[[gnu::always_inline]] inline void dd_sum(double ah, double al, double bh, double bl, double& rh, double& rl) {
  double sh, sl, th, tl, vh, vl;
  two_sum(ah, bh, sh, sl);
  two_sum(al, bl, th, tl);
  fast_two_sum(sh, sl + th, vh, vl);
  fast_two_sum(vh, tl + vl, rh, rl);
}
template <class Product>
[[gnu::always_inline]] inline void dd_product(double ah, double al, double bh, double bl, double& rh, double& rl) {
  double ch, cl1;
  Product::two_product(ah, bh, ch, cl1);
  const double cl2 = ah * bl + al * bh;  // RN(RN(xh·yl) + RN(xl·yh))
  fast_two_sum(ch, cl1 + cl2, rh, rl);
}

// Double-double values that carry their error bounds (the oracle's generic stage). Splitting
// cannot overflow below the 2^800 magnitude cap; an underflowing partial product (or FMA error
// term) adds a few 2^-1075, which the argument above absorbs.
template <class Product>
class FilteredDDWith {
 public:
  // The magnitudes a double-double may reach: Veltkamp splitting (a multiply by 2^27 + 1) cannot
  // overflow below 2^+800, and the low parts (~2^-106 of the high) stay clear of underflow above
  // 2^-800 but for the absorbed few 2^-1075 of the argument above.
  static constexpr double kMagnitudeMin = 0x1p-800, kMagnitudeMax = 0x1p+800;

  FilteredDDWith() = default;
  // Implicit, so that terms lift doubles.
  FilteredDDWith(double x)  // NOLINT(google-explicit-constructor)
      : hi_(x), lo_(0), m_(std::abs(x)), k_(0), valid_(std::isfinite(x)) {}

  [[gnu::always_inline]] friend FilteredDDWith operator+(const FilteredDDWith& a, const FilteredDDWith& b) {
    return sum(a, b.hi_, b.lo_, b);
  }
  [[gnu::always_inline]] friend FilteredDDWith operator-(const FilteredDDWith& a, const FilteredDDWith& b) {
    return sum(a, -b.hi_, -b.lo_, b);
  }
  [[gnu::always_inline]] FilteredDDWith operator-() const {
    FilteredDDWith r = *this;
    r.hi_ = -hi_, r.lo_ = -lo_;
    return r;
  }
  [[gnu::always_inline]] friend FilteredDDWith operator*(const FilteredDDWith& a, const FilteredDDWith& b) {
    FilteredDDWith r;
    dd_product<Product>(a.hi_, a.lo_, b.hi_, b.lo_, r.hi_, r.lo_);
    r.m_ = a.m_ * b.m_;
    r.k_ = a.k_ + b.k_ + 1;
    r.valid_ = a.valid_ && b.valid_ && std::isfinite(r.hi_) &&
               filter_detail::product_in_range(a.m_, b.m_, r.m_, kMagnitudeMin, kMagnitudeMax);
    return r;
  }

  bool valid() const { return valid_ && m_ <= kMagnitudeMax && k_ < 64; }
  double estimate() const { return hi_ + lo_; }
  // A bound on |exact − (hi + lo)| (valid() values only), as sign() uses it.
  double error_bound() const { return filter_detail::kGammaDD[k_] * m_; }
  [[gnu::always_inline]] std::optional<int> sign() const {
    if (!valid()) return std::nullopt;
    if (m_ == 0) return 0;
    if (m_ < kMagnitudeMin) return std::nullopt;
    const double bound = filter_detail::kGammaDD[k_] * m_;
    // |lo| ≤ ulp(hi)/2, so |hi + lo| ≥ |hi|·(1 − 2^-52).
    if (std::abs(hi_) * (1 - 0x1p-52) > bound) return hi_ > 0 ? 1 : -1;
    return std::nullopt;
  }

 private:
  // a + (bh + bl), with b's magnitude and round count.
  [[gnu::always_inline]] static FilteredDDWith sum(const FilteredDDWith& a, double bh, double bl,
                                                   const FilteredDDWith& b) {
    FilteredDDWith r;
    dd_sum(a.hi_, a.lo_, bh, bl, r.hi_, r.lo_);
    r.m_ = a.m_ + b.m_;
    r.k_ = std::max(a.k_, b.k_) + 1;
    r.valid_ = a.valid_ && b.valid_ && std::isfinite(r.hi_);
    return r;
  }
  double hi_, lo_, m_;  // uninitialised by default, as a double is (see FilteredDouble)
  int k_;
  bool valid_;
};
using FilteredDD = FilteredDDWith<DekkerProduct>;
using FilteredDDFma = FilteredDDWith<FmaProduct>;

// The shapes' static filters (oracle.cpp's decide_static, CGAL's Static_filters/Orientation_3 in
// spirit) are written by hand per shape: each term evaluated in plain doubles, its bound
// filter_detail::kGammaDouble[k]·m with k its roundings counted and m a bound on its monomials'
// magnitudes from the inputs' maxima, the derivation and the input range beside each filter.
// This is the sign of such a value, with a positive bound: 0 when the sign is uncertain (an exact
// zero included, which the filters term by term then decide). No branch on which sign: random
// rays take either about half the time, and a mispredicted branch costs more than the arithmetic.
[[gnu::always_inline]] inline int certain_sign(double value, double bound) {
  return (value > bound) - (value < -bound);
}

[[gnu::always_inline]] inline std::optional<int> sign_of(const FilteredDouble& x) { return x.sign(); }
template <class Product>
[[gnu::always_inline]] inline std::optional<int> sign_of(const FilteredDDWith<Product>& x) {
  return x.sign();
}

}  // namespace rayproof
