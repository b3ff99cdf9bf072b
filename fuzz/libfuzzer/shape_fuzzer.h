// Shared body of the per-shape libFuzzer harnesses: bytes → a query (any bit pattern, NaN and
// infinity included). Every variant must survive it; on valid input the oracle must be
// self-consistent: a t exactly where its class has one, the exact t inside the rounding
// interval of the returned double, and the same answer with its filters off.
#pragma once

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "rayproof/core/query.h"
#include "rayproof/verify/oracle.h"
#include "rayproof/core/variants.h"

namespace rayproof::fuzz::harness {

class Bytes {
 public:
  Bytes(const std::uint8_t* data, size_t size) : data_(data), size_(size) {}
  double next() {  // 8 bytes → a double, all bit patterns; zero-padded at the end
    std::uint8_t raw[8] = {};
    const size_t n = size_ < 8 ? size_ : 8;
    std::memcpy(raw, data_, n);
    data_ += n, size_ -= n;
    double x;
    std::memcpy(&x, raw, 8);
    return x;
  }
  Vec3 vec() {
    const double x = next(), y = next(), z = next();
    return Vec3(x, y, z);
  }

 private:
  const std::uint8_t* data_;
  size_t size_;
};

inline void check(bool ok) {
  if (!ok) __builtin_trap();
}

inline void exercise(const Ray& ray, const Shape& shape) {
  for (const Variant* v : variants_for(kind_of(shape)))
    for (HitRule rule : {HitRule::nearest_contact, HitRule::enter_only}) {
      const Hit h = v->intersect(ray, shape, rule);
      check(static_cast<int>(h.cls) >= 0 && static_cast<int>(h.cls) <= 4);
    }
  if (!is_valid_query(ray, shape)) return;
  Oracle oracle(Oracle::Options{.keep_exact_parameter = true});
  Oracle exact_only(Oracle::Options{.filter = false});
  const Verdict v = oracle.judge(ray, shape);
  const Verdict w = exact_only.judge(ray, shape);
  check(v.cls == w.cls && v.t == w.t);
  switch (v.cls) {
    case HitClass::miss: check(!v.t); break;
    case HitClass::tangent: break;  // with or without t
    default: check(v.t.has_value());
  }
  if (v.t) {
    check(*v.t >= 0 && v.exact_t != nullptr);
    const double t = *v.t;
    // The exact t lies within the rounding interval of t: between the midpoints to its neighbours.
    if (!std::isinf(t)) {
      const double below = std::nextafter(t, -INFINITY), above = std::nextafter(t, INFINITY);
      const mpq_class mid_low = (mpq_class(below) + mpq_class(t)) / 2;
      check(compare(*v.exact_t, mid_low) >= 0);
      if (!std::isinf(above)) check(compare(*v.exact_t, (mpq_class(t) + mpq_class(above)) / 2) <= 0);
    } else {
      mpz_class top = 1;
      top <<= 1024;
      check(compare(*v.exact_t, (mpq_class(DBL_MAX) + mpq_class(top)) / 2) >= 0);
    }
  }
}

}  // namespace rayproof::fuzz::harness
