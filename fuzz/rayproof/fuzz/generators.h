// Deterministic, seeded families of cases for every shape. The interesting geometry (a
// tangent, an edge, a point on a surface) is built in one of two constructions (below): exactly,
// from small integers and dyadic fractions nudged by a chosen number of ULPs, or at full
// precision, computed in double from random 53-bit coordinates. Case `index` of a family is a pure function of (seed,
// family, shape, index): any shard, thread count or machine produces the same case.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rayproof/core/fp.h"
#include "rayproof/core/query.h"

namespace rayproof::fuzz {

enum class Family { random, tangent, grazing, near_origin, exit_entry, extremes };
inline constexpr Family kAllFamilies[] = {Family::random,      Family::tangent,    Family::grazing,
                                          Family::near_origin, Family::exit_entry, Family::extremes};

std::string_view to_string(Family f);
std::optional<Family> family_from_string(std::string_view s);

// How an adversarial family builds its geometry. `exact`: small integers and dyadic fractions
// scaled by powers of two, the feature exact in rationals, then nudged by ±3 ulps — the answer
// is easy to know, and much of the double arithmetic is exact too. `full`: random 53-bit
// mantissas over a wide exponent range, the feature (tangent point, edge or vertex point,
// on-surface origin) computed in double, so the exact ray passes within rounding of it and the
// variants' arithmetic rounds everywhere. `random` and `near-origin` are full precision by
// construction and have only the one.
enum class Construction { exact, full };
std::string_view to_string(Construction c);
bool has_full_construction(Family f);
// The name a family's tallies and findings go by: "tangent", "tangent-full".
std::string family_label(Family f, Construction c);

struct GeneratedCase : Query {
  GeneratedCase() = default;
  GeneratedCase(const Ray& r, const Shape& s, std::string how) : Query{r, s, {}}, detail(std::move(how)) {}
  std::string detail;  // how it was built, e.g. "edge+2ulp"; goes into the finding's "found"
  // A grazing-triangle case that is half of a pair of triangles sharing the edge its ray passes
  // through (rather than a vertex, where the rest of the fan is absent and missing both is fair).
  // Case 2k and 2k + 1 of the family form the pair.
  bool shared_edge = false;
};

GeneratedCase generate(Family family, ShapeKind shape, std::uint64_t seed, std::uint64_t index,
                       Construction construction = Construction::exact);

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

// A vector of three draws, z drawn first. C++ leaves the order of `Vec3(draw(), draw(), draw())`
// to the compiler: GCC drew z first, clang x, and one seed built other cases under each. Every
// generator expression that draws more than once is written as named draws in sequence, in the order
// GCC chose, so that the cases (and the findings published from them) stay what they were
// (tests/test_generator_digest.cpp pins them).
template <class Draw>
[[gnu::always_inline]] inline Vec3 vec_z_first(Draw&& draw) {  // (inlined: a random case draws four)
  const double z = draw();
  const double y = draw();
  const double x = draw();
  return Vec3(x, y, z);
}

}  // namespace rayproof::fuzz
