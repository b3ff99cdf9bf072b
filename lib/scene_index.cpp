#include "rayproof/core/scene_index.h"

#include <cmath>
#include <limits>

#include "rayproof/core/mesh.h"

namespace rayproof {

Bounds bounds_of(const Shape& shape) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  Bounds b;
  if (const auto* s = std::get_if<Sphere>(&shape)) {
    // c ± r rounds by at most half an ulp: one more double outward covers it.
    for (int k = 0; k < 3; ++k) {
      b.lo[k] = next_down(s->center[k] - s->radius);
      b.hi[k] = next_up(s->center[k] + s->radius);
    }
  } else if (const auto* t = std::get_if<Triangle>(&shape)) {
    for (const Vec3& v : t->v) b.grow(v);
  } else if (const auto* x = std::get_if<Box>(&shape)) {
    b.lo = x->min;
    b.hi = x->max;
  } else {
    b.lo = Vec3::Constant(-inf);
    b.hi = Vec3::Constant(inf);
  }
  return b;
}

SceneIndex::SceneIndex(const Scene& scene) : scene_(&scene) {
  for (size_t o = 0; o < scene.objects.size(); ++o) {
    const SceneObject& obj = scene.objects[o];
    if (obj.mesh) {
      for (size_t e = 0; e < obj.mesh->triangles.size(); ++e)
        primitives_.push_back({obj.mesh->triangles[e], static_cast<std::int32_t>(o), static_cast<std::int32_t>(e)});
    } else {
      primitives_.push_back({obj.shape, static_cast<std::int32_t>(o), 0});
    }
  }
  for (size_t i = 0; i < primitives_.size(); ++i)
    by_kind_[primitives_[i].shape.index()].push_back(static_cast<std::int32_t>(i));
  for (ShapeKind kind : kAllShapeKinds) {
    if (kind == ShapeKind::plane) continue;
    const std::vector<std::int32_t>& ids = by_kind_[static_cast<int>(kind)];
    std::vector<Bounds> boxes;
    boxes.reserve(ids.size());
    for (std::int32_t id : ids) boxes.push_back(bounds_of(primitives_[id].shape));
    bvh_[static_cast<int>(kind)] = Bvh(boxes);
  }
  for (ShapeKind kind : kAllShapeKinds) {
    const int k = static_cast<int>(kind);
    if (kind != ShapeKind::plane) {  // into the BVH's leaf order
      std::vector<std::int32_t> sorted;
      for (std::int32_t i : bvh_[k].order()) sorted.push_back(by_kind_[k][i]);
      by_kind_[k] = std::move(sorted);
    }
    for (std::int32_t id : by_kind_[k]) shapes_[k].push_back(primitives_[id].shape);
    if (!by_kind_[k].empty()) shapes_used_.push_back(kind);
  }
}

bool SceneIndex::same_or_adjacent(std::int32_t a, std::int32_t b) const {
  if (a == b) return true;
  const Primitive &pa = primitives_[a], &pb = primitives_[b];
  if (pa.object != pb.object) return false;
  const SceneObject& obj = scene_->objects[pa.object];
  return obj.mesh && share_a_vertex(obj.mesh->corners[pa.element], obj.mesh->corners[pb.element]);
}

}  // namespace rayproof
