// Deterministic, seeded families of cases for every shape. The interesting geometry (a
// tangent, an edge, a point on a surface) is built exactly — small integers and dyadic
// fractions scaled by powers of two, so every relation holds in rationals — and then nudged by
// a chosen number of ULPs. Case `index` of a family is a pure function of (seed, family, shape,
// index): any shard, thread count or machine produces the same case.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rayproof/shapes.h"

namespace rayproof::fuzz {

enum class Family { random, tangent, grazing, near_origin, exit_entry, extremes };
inline constexpr Family kAllFamilies[] = {Family::random,      Family::tangent,    Family::grazing,
                                          Family::near_origin, Family::exit_entry, Family::extremes};

std::string_view to_string(Family f);
std::optional<Family> family_from_string(std::string_view s);

struct GeneratedCase {
  Ray ray;
  Shape shape;
  std::string detail;  // how it was built, e.g. "edge+2ulp"; goes into the finding's "found"
};

GeneratedCase generate(Family family, ShapeKind shape, std::uint64_t seed, std::uint64_t index);

// The exact construction before nudging, for tests: the same as generate() with every ULP
// nudge set to zero (tangent family: the ray is exactly tangent; grazing: exactly through an
// edge or vertex).
GeneratedCase generate_unnudged(Family family, ShapeKind shape, std::uint64_t seed, std::uint64_t index);

// SplitMix64 (Steele, Lea & Flood 2014): tiny, fast, good enough to spread seeds; every
// generated case draws from one seeded by its own (seed, …, index), never from a shared stream.
struct SplitMix64 {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double unit() { return (next() >> 11) * 0x1p-53; }  // [0, 1)
};

// x moved by `ulps` representable doubles (negative: downwards).
double nudge(double x, int ulps);

}  // namespace rayproof::fuzz
