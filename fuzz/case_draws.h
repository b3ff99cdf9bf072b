// What fuzz/'s case generators share (private to fuzz/, not installed): the draws of one case
// and its scaling, and the entry points of the full-precision construction (full_construction.cpp)
// that the exact construction's families (generators.cpp) hand over to.
#pragma once

#include <cstdint>

#include "rayproof/fuzz/generators.h"

namespace rayproof::fuzz {

// One case's random stream (seeded per case: generators.h, SplitMix64).
struct CaseRng : SplitMix64 {
  double uniform(double lo, double hi) { return lo + (hi - lo) * unit(); }
  long integer(long lo, long hi) { return lo + static_cast<long>(next() % std::uint64_t(hi - lo + 1)); }
  Vec3 ivec(long r) {
    return vec_z_first([&] { return double(integer(-r, r)); });
  }
  Vec3 uvec(double r) {
    return vec_z_first([&] { return uniform(-r, r); });
  }
  Vec3 direction() {  // a random unit-ish vector (not exactly unit; any non-zero vector will do)
    Vec3 v;
    do v = uvec(1);
    while (dot(v, v) > 1 || dot(v, v) < 1e-4);
    return v;
  }
};

// The case with its shape and ray origin moved to scale 2^k and its direction to 2^k_direction
// (exact: powers of two, while nothing under- or overflows); its detail is the caller's to extend.
GeneratedCase at_scale(GeneratedCase c, int k, int k_direction);
GeneratedCase at_scale(GeneratedCase c, int k);

// Construction::full of the families that have one (has_full_construction): every number with a
// random 53-bit mantissa, the feature computed in double. `k`: the scale 2^k, drawn by the caller.
GeneratedCase tangent_full(CaseRng& rng, ShapeKind kind, int k);
GeneratedCase grazing_full(CaseRng& rng, ShapeKind kind, std::uint64_t index, std::uint64_t seed);
GeneratedCase exit_entry_full(CaseRng& rng, ShapeKind kind);

}  // namespace rayproof::fuzz
