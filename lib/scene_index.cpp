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

KindIndex::KindIndex(ShapeKind kind, std::span<const std::int32_t> ids, std::span<const Shape> shapes) : kind_(kind) {
  static std::atomic<std::uint64_t> next_serial{1};
  serial_ = next_serial.fetch_add(1);
  std::vector<std::int32_t> order(ids.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<std::int32_t>(i);
  if (kind != ShapeKind::plane) {
    std::vector<Bounds> boxes;
    boxes.reserve(shapes.size());
    for (const Shape& s : shapes) boxes.push_back(bounds_of(s));
    bvh_ = Bvh(boxes);
    order.assign(bvh_.order().begin(), bvh_.order().end());  // into the BVH's leaf order
  }
  ids_.reserve(order.size()), shapes_.reserve(order.size());
  for (std::int32_t i : order) ids_.push_back(ids[i]), shapes_.push_back(shapes[i]);
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
  std::array<std::vector<std::int32_t>, 4> ids;
  std::array<std::vector<Shape>, 4> shapes;
  for (size_t i = 0; i < primitives_.size(); ++i) {
    ids[primitives_[i].shape.index()].push_back(static_cast<std::int32_t>(i));
    shapes[primitives_[i].shape.index()].push_back(primitives_[i].shape);
  }
  for (ShapeKind kind : kAllShapeKinds) {
    const int k = static_cast<int>(kind);
    kinds_[k] = KindIndex(kind, ids[k], shapes[k]);
    if (!ids[k].empty()) shapes_used_.push_back(kind);
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
