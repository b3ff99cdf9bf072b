// Rays through one kind's primitives of a scene, with one variant at the leaves: the rules that
// decide which contact counts, written once, for this process and for a plugin's worker that
// runs the same traversal where the plugin lives (peers/plugin.cpp), so both answer the same.
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "rayproof/core/answer.h"
#include "rayproof/core/scene_index.h"
#include "rayproof/core/variants.h"

namespace rayproof {

// How far off the exact ray code computing in `p` may still find a contact, as a fraction of
// M, the largest magnitude among the scene's coordinates and the ray's origin: the leaves are
// then asked about every primitive within that distance (KindIndex::traverse's reach), so what
// the code answers through the tree is what it answers testing every primitive, and a hole or a
// wrong primitive charged to it is its own, not the tree's.
//  - Such code sees the origin, the direction and the shape rounded to p (unit roundoff u:
//    2^-24 float, 2^-53 double). Where it reports a contact at t, the point it found lies within
//    its own error of the rounded shape, hence within e + u·|p| of the shape's box, and the
//    exact ray at t lies within u·(|o| + t·|d|) + e of that point, e the code's error in
//    position. |p|, |o| ≤ √3·M and t·|d| ≤ |p| + |o| (up to the same errors), so a box grown by
//    e + 3√3·u·M on each side holds the exact ray at t, which then enters it (exactly, and so as
//    widened) no later than t: not skipped, nor pruned at a nearer t_limit.
//  - 2^-16 = 256 u_float and 2^-45 = 256 u_double cover e up to about 250 u·M: intersectors of
//    tens of roundings on the scene's coordinates. Code wrong by more than that finds contacts
//    rounding does not explain; the tree may then hide some of them, which changes only which
//    of its errors is seen.
// Differences of p's values decide nothing exact: the reach only widens the candidate set.
constexpr double leaf_reach(Precision p) { return p == Precision::f32 ? 0x1p-16 : 0x1p-45; }
// The reach trace_scene_rays takes unless told: leaf_reach(v.precision).
constexpr double kLeafReach = -1;

// One ray with `intersect(shape) -> Hit or Answer` at the leaves, asked about every primitive
// within `reach` (leaf_reach) of the ray. A contact without t (a ray
// lying in a plane) has no point to show and does not count; a failed answer reads as a miss.
//  - nearest: the contact with the smallest t ≥ 0, ties to the lower primitive id (the scene's
//    order, SceneIndex::listed_before); farther boxes are skipped as t drops.
//  - any_hit: the first primitive but `skip` met at 0 ≤ t < 1.
//  - lanes: the BVH's four-box instructions (with_best_box_lanes).
template <class Intersect, class Lanes = BaselineLanes>
SceneRayAnswer trace_scene_ray(const KindIndex& index, const SceneRay& r, Intersect&& intersect, Lanes lanes,
                               double reach) {
  SceneRayAnswer best;
  double t_limit = r.any_hit ? 1.0 : std::numeric_limits<double>::infinity();
  index.traverse(
      r.ray, t_limit,
      [&](std::int32_t id, const Shape& shape) {
        if (id == r.skip) return false;
        const Hit h = intersect(shape);
        if (h.cls == HitClass::miss || !h.has_t()) return false;
        if (r.any_hit) {
          if (!(h.t < 1)) return false;
          best = {id, h};
          return true;
        }
        if (!(h.t >= 0)) return false;
        if (best.primitive < 0 || h.t < best.answer.t ||
            (h.t == best.answer.t && SceneIndex::listed_before(id, best.primitive))) {
          best = {id, h};
          t_limit = h.t;
        }
        return false;
      },
      lanes, reach);
  return best;
}

// Every ray with `v` at the leaves under `rule`: external code that can runs the traversal
// where it lives (ExternalIntersector::trace_all, one round trip per batch), all other code
// here, leaf by leaf. `timing`: external code's time where it ran (AnswerTiming). `reach`: how
// far off the ray the leaves are asked (leaf_reach; calibrated_reach for a scene).
void trace_scene_rays(const Variant& v, const KindIndex& index, HitRule rule, std::span<const SceneRay> rays,
                      std::span<SceneRayAnswer> out, AnswerTiming* timing = nullptr, double reach = kLeafReach);

// The reach `v` needs in `index`: leaf_reach(v.precision), grown 16-fold at a time (past 2^-4,
// every primitive) until v answers each nearest-contact ray of `sample` through the tree as it
// does visiting every primitive (small steps: code whose contacts stray a little further than
// rounding explains, a test with a tolerance, gets boxes grown a little, not a sweep a ray).
// Code whose errors exceed rounding (a textbook sphere at 10^7, drawing noise far outside the
// sphere) is then traced as if it tested every primitive, not clipped by rayproof's boxes. Code
// that answers leaf by leaf (an --exec command: a round trip per test) keeps leaf_reach, as
// visiting every primitive would cost a round trip per primitive.
double calibrated_reach(const Variant& v, const KindIndex& index, HitRule rule, std::span<const SceneRay> sample);

// Primary rays through an n × n grid of pixel centres spread over the image: calibrated_reach's
// sample.
std::vector<SceneRay> primary_sample(const Camera& camera, int n = 16);

}  // namespace rayproof
