#include "rayproof/core/scene_rays.h"

namespace rayproof {

void trace_scene_rays(const Variant& v, const KindIndex& index, HitRule rule, std::span<const SceneRay> rays,
                      std::span<SceneRayAnswer> out, AnswerTiming* timing) {
  if (v.external && v.external->trace_all(index, rule, rays, out, timing)) return;
  if (v.kernel) {
    const HitRule own = v.rule_for(rule);
    with_best_box_lanes([&](auto lanes) {
      for (size_t i = 0; i < rays.size(); ++i)
        out[i] = trace_scene_ray(
            index, rays[i], [&](const Shape& shape) { return v.kernel(rays[i].ray, shape, own); }, lanes);
    });
    return;
  }
  for (size_t i = 0; i < rays.size(); ++i)  // leaf by leaf: one round trip each
    out[i] = trace_scene_ray(index, rays[i], [&](const Shape& shape) { return v.intersect(rays[i].ray, shape, rule); });
}

}  // namespace rayproof
