// Intel Embree 3 as a peer (optional: built when libembree-dev is found). Embree computes in
// float, so each query is first rounded to float; the oracle then judges exactly those inputs.
#pragma once

#include <embree3/rtcore.h>

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "rayproof/core/query.h"
#include "rayproof/studies/trade.h"

namespace rayproof::peers {

// The one Embree device of the process (single-threaded: rayproof times one core).
RTCDevice embree_device();

// The one Embree scene builder: every triangle in one triangle geometry, each sphere a
// RTC_GEOMETRY_TYPE_SPHERE_POINT; coordinates rounded to float; committed. Release with
// rtcReleaseScene.
RTCScene build_embree_scene(std::span<const Shape> shapes, bool robust);

// A single ray as Embree takes it (float, t from 0 to infinity, no hit yet).
RTCRayHit embree_ray(const Ray& ray);

// Contenders "embree" and "embree-robust" (RTC_SCENE_FLAG_ROBUST) for triangles and spheres,
// one single-primitive scene per query, rtcIntersect1.
std::vector<studies::Contender> embree_contenders();

// The query as Embree sees it (every number rounded to float), or nullopt when a number lies
// beyond Embree's ±1.844e18 or the rounded shape degenerates.
std::optional<Query> as_float_query(const Query& q);

// Watertightness on shared edges: pairs of triangles from the grazing family (rounded to float,
// one two-triangle scene per pair); a hole is a pair whose exact ray crosses the surface through
// the shared edge (verify/compare.h's rule) while Embree reports no hit.
struct HoleCount {
  std::uint64_t pairs = 0, crossing = 0, holes = 0;
  // Of those, pairs with a coordinate ≥ 2^40: Embree's float triple products (∝ size³ ≈ 2^120+)
  // run out of float range there, a different failure from an inconsistent edge test.
  std::uint64_t crossing_large = 0, holes_large = 0;
};
HoleCount embree_shared_edge_holes(std::uint64_t pairs, std::uint64_t seed, bool robust);

}  // namespace rayproof::peers
