// Exact floating-point expansions (Shewchuk, "Adaptive Precision Floating-Point Arithmetic and
// Fast Robust Geometric Predicates", DCG 18, 1997): a value is the exact sum of non-overlapping
// doubles, so +, − and × of doubles are exact without GMP, and the sign is the sign of the
// largest component. The oracle's fast exact path: no allocation, fixed capacity. Where a
// product could underflow or overflow, or the capacity would be exceeded, the expansion marks
// itself invalid and the caller falls back to GMP rationals.
#pragma once

#include <cmath>
#include <cstring>

#include "rayproof/core/eft.h"
#include "rayproof/core/fp.h"

namespace rayproof {

class Expansion {
 public:
  static constexpr int kCapacity = 64;

  Expansion() = default;
  Expansion(double x) {  // NOLINT(google-explicit-constructor): implicit, so templated formulas take doubles
    if (!std::isfinite(x))
      valid_ = false;
    else if (x != 0)
      c_[n_++] = x;
  }
  Expansion(const Expansion& o) : n_(o.n_), valid_(o.valid_) { std::memcpy(c_, o.c_, sizeof(double) * n_); }
  Expansion& operator=(const Expansion& o) {
    n_ = o.n_;
    valid_ = o.valid_;
    std::memcpy(c_, o.c_, sizeof(double) * n_);
    return *this;
  }

  bool valid() const { return valid_; }
  int size() const { return n_; }
  double component(int i) const { return c_[i]; }  // increasing magnitude; their sum is the value
  int sign() const { return n_ == 0 ? 0 : (c_[n_ - 1] > 0 ? 1 : -1); }
  // A double within a few ulps of the value: the components summed, smallest first.
  double estimate() const {
    double s = 0;
    for (int i = 0; i < n_; ++i) s += c_[i];
    return s;
  }

  friend Expansion operator+(const Expansion& a, const Expansion& b) { return sum(a, b, false); }
  friend Expansion operator-(const Expansion& a, const Expansion& b) { return sum(a, b, true); }
  Expansion operator-() const {
    Expansion r = *this;
    for (int i = 0; i < r.n_; ++i) r.c_[i] = -r.c_[i];
    return r;
  }
  // Every partial product a_i·b_j, split exactly by FMA into two doubles, grown into one
  // expansion in place (GROW-EXPANSION keeps it non-overlapping), then compressed once.
  friend Expansion operator*(const Expansion& a, const Expansion& b) {
    Expansion r;
    r.valid_ = a.valid_ && b.valid_;
    for (int j = 0; j < b.n_ && r.valid_; ++j) {
      for (int i = 0; i < a.n_; ++i) {
        const double p = a.c_[i] * b.c_[j];
        const double e = std::fma(a.c_[i], b.c_[j], -p);
        // The low part is exact only inside fp.h's safe range (far above the subnormals).
        if (!std::isfinite(p) || std::abs(p) < kSafeMagnitudeMin) r.valid_ = false;
        r.grow(e);
        r.grow(p);
      }
      r.compress();  // keeps the running sum short for the next row
    }
    return r;
  }
  friend int sgn(const Expansion& e) { return e.sign(); }

 private:
  void push(double x) {
    if (x == 0) return;
    if (n_ == kCapacity)
      valid_ = false;
    else
      c_[n_++] = x;
  }

  // this + x, in place (Shewchuk's GROW-EXPANSION with zero elimination): each output
  // component is written at or before the position just read.
  void grow(double x) {
    if (x == 0) return;
    double q = x;
    int out = 0;
    for (int i = 0; i < n_; ++i) {
      double s, e;
      two_sum(q, c_[i], s, e);
      if (e != 0) c_[out++] = e;
      q = s;
    }
    n_ = out;
    if (!std::isfinite(q)) valid_ = false;
    push(q);
  }

  // a ± b by merging components by magnitude and one TwoSum chain (FAST-EXPANSION-SUM with
  // zero elimination), then COMPRESS so lengths stay small.
  static Expansion sum(const Expansion& a, const Expansion& b, bool negate_b) {
    Expansion r;
    r.valid_ = a.valid_ && b.valid_;
    if (!r.valid_) return r;
    const double sb = negate_b ? -1.0 : 1.0;
    int i = 0, j = 0;
    auto next = [&]() {  // the smaller-magnitude next component of a or b
      if (j >= b.n_ || (i < a.n_ && std::abs(a.c_[i]) <= std::abs(b.c_[j]))) return a.c_[i++];
      return sb * b.c_[j++];
    };
    const int total = a.n_ + b.n_;
    if (total == 0) return r;
    double q = next();
    for (int k = 1; k < total; ++k) {
      double s, e;
      two_sum(q, next(), s, e);
      r.push(e);
      q = s;
    }
    if (!std::isfinite(q)) r.valid_ = false;
    r.push(q);
    r.compress();
    return r;
  }

  // Shewchuk's COMPRESS: the same value in fewer, larger components.
  void compress() {
    if (n_ < 2) return;
    double g[kCapacity];
    int bottom = n_ - 1;
    double q = c_[bottom];
    for (int i = n_ - 2; i >= 0; --i) {
      const double qnew = q + c_[i];
      const double small = c_[i] - (qnew - q);  // FAST-TWO-SUM: |q| ≥ |c_i|
      if (small != 0) {
        g[bottom--] = qnew;
        q = small;
      } else {
        q = qnew;
      }
    }
    g[bottom] = q;
    int top = 0;
    q = g[bottom];
    for (int i = bottom + 1; i < n_; ++i) {
      const double qnew = g[i] + q;
      const double small = q - (qnew - g[i]);
      if (small != 0) c_[top++] = small;
      q = qnew;
    }
    if (q != 0) c_[top++] = q;
    n_ = top;
  }

  double c_[kCapacity];  // increasing magnitude, non-overlapping, no zeros; first n_ used
  int n_ = 0;
  bool valid_ = true;
};

}  // namespace rayproof
