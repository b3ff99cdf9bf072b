// A scene as the tracers see it: every object's primitives (a mesh's triangles one by one) and,
// per shape kind, a BVH over them, so the renderer, the exact tracer and the audit ask for the
// candidates of one kind at a time (an audited variant meets only its own shape).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "rayproof/core/bvh.h"
#include "rayproof/core/scene.h"

namespace rayproof {

struct Primitive {
  Shape shape;
  std::int32_t object = 0;   // index into Scene::objects: what visibility is about
  std::int32_t element = 0;  // the triangle's index within its mesh, else 0
};

class SceneIndex {
 public:
  // Keeps a reference to `scene`, which must outlive the index.
  explicit SceneIndex(const Scene& scene);

  const Scene& scene() const { return *scene_; }
  std::span<const Primitive> primitives() const { return primitives_; }
  const Primitive& primitive(std::int32_t i) const { return primitives_[i]; }
  // The scene's order of two contacts at the same t, the one order the renderer (render.h
  // nearer) and the exact tracer (exact_scene.h before) break ties with: the object listed
  // first, then the lower primitive.
  bool listed_before(std::int32_t a, std::int32_t b) const {
    const std::int32_t oa = primitives_[a].object, ob = primitives_[b].object;
    return oa != ob ? oa < ob : a < b;
  }
  // The kinds the scene has primitives of, in kAllShapeKinds order.
  const std::vector<ShapeKind>& shapes_used() const { return shapes_used_; }
  std::size_t count(ShapeKind kind) const { return by_kind_[static_cast<int>(kind)].size(); }

  // Calls visit(primitive id, its shape) for each primitive of `kind` that the ray may meet at
  // 0 ≤ t ≤ t_limit (conservatively: Bvh), nearer boxes first; planes, which no box holds, are
  // all visited. visit returns true to stop and may lower t_limit.
  template <class Visit>
  void traverse(ShapeKind kind, const Ray& ray, double& t_limit, Visit&& visit) const {
    const int k = static_cast<int>(kind);
    const std::vector<std::int32_t>& ids = by_kind_[k];
    const std::vector<Shape>& shapes = shapes_[k];
    auto at = [&](std::int32_t i) { return visit(ids[i], shapes[i]); };
    if (kind == ShapeKind::plane) {
      for (std::int32_t i = 0; i < static_cast<std::int32_t>(ids.size()); ++i)
        if (at(i)) return;
      return;
    }
    bvh_[k].traverse(ray, t_limit, at);
  }

  // Whether primitive b is a (the acne test's) neighbour of a: the same primitive, or a
  // triangle of the same mesh sharing a vertex with it.
  bool same_or_adjacent(std::int32_t a, std::int32_t b) const;

 private:
  const Scene* scene_;
  std::vector<Primitive> primitives_;
  // Per kind, the primitive ids and a copy of their shapes, both in the BVH's leaf order (the
  // traversal reads leaves as contiguous runs).
  std::array<std::vector<std::int32_t>, 4> by_kind_;
  std::array<std::vector<Shape>, 4> shapes_;
  std::array<Bvh, 4> bvh_;
  std::vector<ShapeKind> shapes_used_;
};

// A box certainly holding the shape (sphere: centre ± radius rounded outward); planes have none.
Bounds bounds_of(const Shape& shape);

}  // namespace rayproof
