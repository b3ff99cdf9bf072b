// Intel Embree 3 as a peer (optional: built when libembree-dev is found). Embree computes in
// float, so each query is first rounded to float; the oracle then judges exactly those inputs.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "rayproof/trade.h"

namespace rayproof::peers {

// Contenders "embree" and "embree-robust" (RTC_SCENE_FLAG_ROBUST) for triangles and spheres
// (RTC_GEOMETRY_TYPE_SPHERE_POINT), one single-primitive scene per query, rtcIntersect1.
std::vector<fuzz::Contender> embree_contenders();

// The query as Embree sees it (every number rounded to float), or nullopt when a number lies
// beyond Embree's ±1.844e18 or the rounded shape degenerates.
std::optional<fuzz::Query> as_float_query(const fuzz::Query& q);

// Watertightness on shared edges: pairs of triangles from the grazing family (rounded to float,
// one two-triangle scene per pair); a hole is a pair whose exact ray crosses the surface through
// the shared edge (not a silhouette) while Embree reports no hit.
struct HoleCount {
  std::uint64_t pairs = 0, crossing = 0, holes = 0;
  // Of those, pairs with a coordinate ≥ 2^40: Embree's float triple products (∝ size³ ≈ 2^120+)
  // run out of float range there, a different failure from an inconsistent edge test.
  std::uint64_t crossing_large = 0, holes_large = 0;
};
HoleCount embree_shared_edge_holes(std::uint64_t pairs, std::uint64_t seed, bool robust);

}  // namespace rayproof::peers
