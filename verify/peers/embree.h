// Intel Embree 3 as a peer (optional: built when libembree-dev is found). Embree computes in
// float, so each query is first rounded to float; the oracle then judges exactly those inputs.
#pragma once

#include <vector>

#include "rayproof/trade.h"

namespace rayproof::peers {

// Contenders "embree" and "embree-robust" (RTC_SCENE_FLAG_ROBUST) for triangles and spheres
// (RTC_GEOMETRY_TYPE_SPHERE_POINT), one single-primitive scene per query, rtcIntersect1.
std::vector<fuzz::Contender> embree_contenders();

// The query as Embree sees it (every number rounded to float), or nullopt when a number leaves
// the float range or the rounded shape degenerates.
std::optional<fuzz::Query> as_float_query(const fuzz::Query& q);

}  // namespace rayproof::peers
