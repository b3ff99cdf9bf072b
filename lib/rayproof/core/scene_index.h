// A scene as the tracers see it: every object's primitives (a mesh's triangles one by one) and,
// per shape kind, a BVH over them, so the renderer, the exact tracer and the audit ask for the
// candidates of one kind at a time (an audited variant meets only its own shape).
#pragma once

#include <array>
#include <atomic>
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

// One kind's primitives and the BVH over them (planes, which no box holds: none, all visited).
// Built from the primitives in ascending id order, and deterministic, so that code running in
// another process (a plugin's worker, peers/) that is sent the same shapes builds the same index
// and traverses in the same order as this process would.
class KindIndex {
 public:
  KindIndex() = default;
  // shapes[i] is primitive ids[i]; ids ascending.
  KindIndex(ShapeKind kind, std::span<const std::int32_t> ids, std::span<const Shape> shapes);

  ShapeKind kind() const { return kind_; }
  std::size_t size() const { return ids_.size(); }
  // Unique per index built in this process: where a copy lives elsewhere, which one it is.
  std::uint64_t serial() const { return serial_; }
  // The primitives in leaf order (ids_in_leaf_order()[i] is shape i).
  std::span<const std::int32_t> ids_in_leaf_order() const { return ids_; }
  std::span<const Shape> shapes_in_leaf_order() const { return shapes_; }

  // Calls visit(primitive id, its shape) for each primitive that the ray may meet at
  // 0 ≤ t ≤ t_limit (conservatively: Bvh), nearer boxes first; planes are all visited. visit
  // returns true to stop and may lower t_limit.
  // `lanes`: the BVH's four-box instructions (with_best_box_lanes). `reach`: how far off the
  // exact ray primitives are visited (Bvh::traverse; leaf_reach in scene_rays.h).
  template <class Visit, class Lanes = BaselineLanes>
  void traverse(const Ray& ray, double& t_limit, Visit&& visit, Lanes lanes = {}, double reach = 0) const {
    auto at = [&](std::int32_t i) { return visit(ids_[i], shapes_[i]); };
    if (kind_ == ShapeKind::plane) {
      for (std::int32_t i = 0; i < static_cast<std::int32_t>(ids_.size()); ++i)
        if (at(i)) return;
      return;
    }
    bvh_.traverse(ray, t_limit, at, lanes, reach);
  }

 private:
  ShapeKind kind_ = ShapeKind::sphere;
  std::vector<std::int32_t> ids_;  // in the BVH's leaf order (the traversal reads leaves as runs)
  std::vector<Shape> shapes_;      // a copy, in the same order
  Bvh bvh_;
  std::uint64_t serial_ = 0;
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
  // first, then the lower primitive — which is the lower id, as primitives are numbered object
  // by object (so code that sees only one kind's ids, a plugin's worker, breaks ties the same).
  static bool listed_before(std::int32_t a, std::int32_t b) { return a < b; }
  // The kinds the scene has primitives of, in kAllShapeKinds order.
  const std::vector<ShapeKind>& shapes_used() const { return shapes_used_; }
  std::size_t count(ShapeKind kind) const { return kinds_[static_cast<int>(kind)].size(); }
  const KindIndex& of_kind(ShapeKind kind) const { return kinds_[static_cast<int>(kind)]; }

  // KindIndex::traverse over the primitives of `kind`.
  template <class Visit>
  void traverse(ShapeKind kind, const Ray& ray, double& t_limit, Visit&& visit) const {
    of_kind(kind).traverse(ray, t_limit, visit);
  }

  // Whether primitive b is a (the acne test's) neighbour of a: the same primitive, or a
  // triangle of the same mesh sharing a vertex with it.
  bool same_or_adjacent(std::int32_t a, std::int32_t b) const;

 private:
  const Scene* scene_;
  std::vector<Primitive> primitives_;
  std::array<KindIndex, 4> kinds_;
  std::vector<ShapeKind> shapes_used_;
};

// A box certainly holding the shape (sphere: centre ± radius rounded outward); planes have none.
Bounds bounds_of(const Shape& shape);

}  // namespace rayproof
