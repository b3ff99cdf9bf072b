// Rays through one kind's primitives of a scene, with one variant at the leaves: the rules that
// decide which contact counts, written once, for this process and for a plugin's worker that
// runs the same traversal where the plugin lives (peers/plugin.cpp), so both answer the same.
#pragma once

#include <cstdint>
#include <limits>
#include <span>

#include "rayproof/core/answer.h"
#include "rayproof/core/scene_index.h"
#include "rayproof/core/variants.h"

namespace rayproof {

// One ray with `intersect(shape) -> Hit or Answer` at the leaves. A contact without t (a ray
// lying in a plane) has no point to show and does not count; a failed answer reads as a miss.
//  - nearest: the contact with the smallest t ≥ 0, ties to the lower primitive id (the scene's
//    order, SceneIndex::listed_before); farther boxes are skipped as t drops.
//  - any_hit: the first primitive but `skip` met at 0 ≤ t < 1.
//  - lanes: the BVH's four-box instructions (with_best_box_lanes).
template <class Intersect, class Lanes = BaselineLanes>
SceneRayAnswer trace_scene_ray(const KindIndex& index, const SceneRay& r, Intersect&& intersect, Lanes lanes = {}) {
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
      lanes);
  return best;
}

// Every ray with `v` at the leaves under `rule`: external code that can runs the traversal
// where it lives (ExternalIntersector::trace_all, one round trip per batch), all other code
// here, leaf by leaf. `timing`: external code's time where it ran (AnswerTiming).
void trace_scene_rays(const Variant& v, const KindIndex& index, HitRule rule, std::span<const SceneRay> rays,
                      std::span<SceneRayAnswer> out, AnswerTiming* timing = nullptr);

}  // namespace rayproof
