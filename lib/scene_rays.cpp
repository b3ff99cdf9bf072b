#include "rayproof/core/scene_rays.h"

#include <bit>
#include <cmath>

namespace rayproof {

void trace_scene_rays(const Variant& v, const KindIndex& index, HitRule rule, std::span<const SceneRay> rays,
                      std::span<SceneRayAnswer> out, AnswerTiming* timing, double reach) {
  if (reach < 0) reach = leaf_reach(v.precision);
  if (v.external && v.external->trace_all(index, rule, rays, out, timing, reach)) return;
  if (v.kernel) {
    const HitRule own = v.rule_for(rule);
    with_best_box_lanes([&](auto lanes) {
      for (size_t i = 0; i < rays.size(); ++i)
        out[i] = trace_scene_ray(
            index, rays[i], [&](const Shape& shape) { return v.kernel(rays[i].ray, shape, own); }, lanes, reach);
    });
    return;
  }
  for (size_t i = 0; i < rays.size(); ++i)  // leaf by leaf: one round trip each
    out[i] = trace_scene_ray(
        index, rays[i], [&](const Shape& shape) { return v.intersect(rays[i].ray, shape, rule); }, BaselineLanes{},
        reach);
}

double calibrated_reach(const Variant& v, const KindIndex& index, HitRule rule, std::span<const SceneRay> sample) {
  std::vector<SceneRay> rays;
  for (const SceneRay& r : sample)
    if (!r.any_hit) rays.push_back(r);  // which blocker an any-hit ray reports depends on the order
  const double leaf = leaf_reach(v.precision);
  if (rays.empty() || (!v.kernel && !(v.external && v.external->can_trace())) || index.kind() == ShapeKind::plane)
    return leaf;  // planes: every one is visited anyway
  std::vector<SceneRayAnswer> every(rays.size()), through(rays.size());
  trace_scene_rays(v, index, rule, rays, every, nullptr, kEveryPrimitive);
  for (double reach = leaf; reach <= 0x1p-4; reach = reach > 0 ? reach * 0x1p4 : 0x1p-64) {
    trace_scene_rays(v, index, rule, rays, through, nullptr, reach);
    bool same = true;
    for (size_t i = 0; i < rays.size() && same; ++i)
      same = every[i].primitive == through[i].primitive && every[i].answer.cls == through[i].answer.cls &&
             every[i].answer.failure == through[i].answer.failure &&
             std::bit_cast<std::uint64_t>(every[i].answer.t) == std::bit_cast<std::uint64_t>(through[i].answer.t);
    if (same) return reach;
  }
  return kEveryPrimitive;
}

std::vector<SceneRay> primary_sample(const Camera& camera, int n) {
  std::vector<SceneRay> rays;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      rays.push_back({camera.ray_through(std::floor((i + 0.5) * camera.width / n) + 0.5,
                                         std::floor((j + 0.5) * camera.height / n) + 0.5)});
  return rays;
}

}  // namespace rayproof
