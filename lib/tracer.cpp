#include "rayproof/core/tracer.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <map>
#include <mutex>
#include <stdexcept>

#include "rayproof/core/bvh.h"
#include "rayproof/core/fp.h"
#include "rayproof/core/mesh.h"
#include "rayproof/core/scene_rays.h"

namespace rayproof {

bool TriangleMesh::degenerate(std::size_t i) const { return degenerate_reason(triangle(i)) != nullptr; }

TriangleMesh triangle_mesh_of(const Mesh& m) {
  TriangleMesh out;
  out.vertices.assign(3 * m.vertex_count, 0);
  for (std::size_t t = 0; t < m.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = m.corners[t][k];
      for (int c = 0; c < 3; ++c) out.vertices[3 * v + c] = m.triangles[t].v[k][c];
      out.indices.push_back(v);
    }
  return out;
}

void append_mesh(TriangleMesh& mesh, const TriangleMesh& more) {
  const auto base = static_cast<std::uint32_t>(mesh.vertex_count());
  mesh.vertices.insert(mesh.vertices.end(), more.vertices.begin(), more.vertices.end());
  for (std::uint32_t i : more.indices) mesh.indices.push_back(base + i);
}

std::optional<std::string> invalid_mesh_reason(const TriangleMesh& mesh) {
  constexpr std::size_t kMost = 0xfffffffeu;  // RAYPROOF_NO_TRIANGLE is not an index
  if (mesh.vertices.size() % 3 != 0) return "vertex array length is not a multiple of 3";
  if (mesh.indices.size() % 3 != 0) return "index array length is not a multiple of 3";
  if (mesh.triangle_count() == 0) return "no triangles";
  if (mesh.triangle_count() > kMost || mesh.vertex_count() > kMost) return "more than 2^32 - 2 triangles or vertices";
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    if (!std::isfinite(mesh.vertices[i]))
      return "vertex " + std::to_string(i / 3) + " coordinate " + std::to_string(i % 3) + " is not finite";
  for (std::size_t i = 0; i < mesh.indices.size(); ++i)
    if (mesh.indices[i] >= mesh.vertex_count())
      return "triangle " + std::to_string(i / 3) + " names vertex " + std::to_string(mesh.indices[i]) + " of " +
             std::to_string(mesh.vertex_count());
  return std::nullopt;
}

std::optional<std::string> invalid_ray_reason(const TracerRay& r) {
  if (!all_finite(r.ray.origin)) return "origin is not finite";
  if (!all_finite(r.ray.direction)) return "direction is not finite";
  if (r.ray.direction == Vec3::Zero()) return "direction is zero";
  if (!(r.tmin >= 0) || std::isinf(r.tmin)) return "tmin must be finite and >= 0";
  if (!(r.tmax > r.tmin)) return "tmax must be greater than tmin";
  return std::nullopt;
}

namespace {
std::optional<double> to_float(double x) {
  if (std::isinf(x)) return x;
  const float f = to_nearest_float(x);
  if (std::isinf(f)) return std::nullopt;
  return static_cast<double>(f);
}
}  // namespace

std::optional<TriangleMesh> mesh_rounded_to_float(const TriangleMesh& mesh) {
  TriangleMesh out = mesh;
  for (double& x : out.vertices) {
    const auto f = to_float(x);
    if (!f || std::isinf(*f)) return std::nullopt;
    x = *f;
  }
  return out;
}

std::optional<TracerRay> ray_rounded_to_float(const TracerRay& r) {
  TracerRay out = r;
  for (int k = 0; k < 3; ++k) {
    const auto o = to_float(r.ray.origin[k]), d = to_float(r.ray.direction[k]);
    if (!o || !d || std::isinf(*o) || std::isinf(*d)) return std::nullopt;
    out.ray.origin[k] = *o, out.ray.direction[k] = *d;
  }
  const auto lo = to_float(r.tmin), hi = to_float(r.tmax);
  if (!lo || !hi || std::isinf(*lo)) return std::nullopt;
  out.tmin = *lo, out.tmax = *hi;
  if (out.ray.direction == Vec3::Zero() || !(out.tmax > out.tmin)) return std::nullopt;
  return out;
}

// ------------------------------------------------------------------ rayproof's BVH as a tracer
namespace {

class BvhTracerScene final : public TracerScene {
 public:
  BvhTracerScene(const Variant& v, const TriangleMesh& mesh) : variant_(v) {
    std::vector<Bounds> boxes(mesh.triangle_count());
    std::vector<Triangle> tris(mesh.triangle_count());
    for (std::size_t i = 0; i < tris.size(); ++i) {
      tris[i] = mesh.triangle(i);
      for (const Vec3& p : tris[i].v) boxes[i].grow(p);
    }
    bvh_ = Bvh(boxes);
    for (std::int32_t i : bvh_.order()) triangles_.push_back(tris[i]), ids_.push_back(static_cast<std::uint32_t>(i));
  }

  void nearest(std::span<const TracerRay> rays, std::span<TraceAnswer> out) override {
    for (std::size_t r = 0; r < rays.size(); ++r) {
      const TracerRay& tr = rays[r];
      TraceAnswer best;
      double t_limit = tr.tmax;
      bvh_.traverse(
          tr.ray, t_limit,
          [&](std::int32_t i) {
            const Hit h = variant_.kernel(tr.ray, triangles_[i], HitRule::nearest_contact);
            if (h.cls == HitClass::miss || !h.has_t() || !(h.t > tr.tmin && h.t < tr.tmax)) return false;
            if (!best.hit() || h.t < best.t) best = {ids_[i], h.t}, t_limit = h.t;
            return false;
          },
          BaselineLanes{}, leaf_reach(variant_.precision));
      out[r] = best;
    }
  }

  void all_hits(std::span<const TracerRay> rays, std::span<AllHitsAnswer> out) override {
    for (std::size_t r = 0; r < rays.size(); ++r) {
      const TracerRay& tr = rays[r];
      out[r] = {};
      double t_limit = tr.tmax;
      bvh_.traverse(
          tr.ray, t_limit,
          [&](std::int32_t i) {
            const Hit h = variant_.kernel(tr.ray, triangles_[i], HitRule::nearest_contact);
            if (h.cls != HitClass::miss && h.has_t() && h.t > tr.tmin && h.t < tr.tmax)
              out[r].triangles.push_back(ids_[i]);
            return false;
          },
          BaselineLanes{}, leaf_reach(variant_.precision));
    }
  }

 private:
  const Variant& variant_;
  Bvh bvh_;
  std::vector<Triangle> triangles_;  // in the BVH's leaf order
  std::vector<std::uint32_t> ids_;   // each one's index in the mesh
};

std::mutex& registry_mutex() {
  static std::mutex m;
  return m;
}
std::deque<Tracer>& registered() {
  static std::deque<Tracer> all;
  return all;
}
// The built-in BVH tracers, made once per triangle variant with a kernel (certified-triangle,
// registered by verify/, included: the exact tracer every other is measured beside).
std::map<std::string, Tracer, std::less<>>& builtin() {
  static std::map<std::string, Tracer, std::less<>> all;
  for (const Variant* v : variants_for(ShapeKind::triangle)) {
    if (!v->kernel || v->precision != Precision::f64 || v->fixed_rule) continue;
    const std::string name = "bvh-" + std::string(v->name);
    if (all.contains(name)) continue;
    Tracer t;
    t.name = name;
    t.source =
        "rayproof BVH (binned SAH, conservative slabs) + " + std::string(v->name) + ": " + std::string(v->source);
    t.build = [v](const TriangleMesh& mesh) { return build_bvh_tracer_scene(*v, mesh); };
    all.emplace(name, std::move(t));
  }
  return all;
}

}  // namespace

BuiltScene build_bvh_tracer_scene(const Variant& v, const TriangleMesh& mesh) {
  return {std::make_unique<BvhTracerScene>(v, mesh)};
}

std::vector<const Tracer*> all_tracers() {
  std::lock_guard lock(registry_mutex());
  std::vector<const Tracer*> out;
  for (const auto& [name, t] : builtin()) out.push_back(&t);
  for (const Tracer& t : registered()) out.push_back(&t);
  return out;
}

const Tracer* find_tracer(std::string_view name) {
  for (const Tracer* t : all_tracers())
    if (t->name == name) return t;
  return nullptr;
}

bool set_tracer_range(std::string_view name, RangeRule range) {
  std::lock_guard lock(registry_mutex());
  if (const auto it = builtin().find(name); it != builtin().end()) return it->second.range = range, true;
  for (Tracer& t : registered())
    if (t.name == name) return t.range = range, true;
  return false;
}

const Tracer& register_tracer(Tracer t) {
  const bool valid = !t.name.empty() && std::all_of(t.name.begin(), t.name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-';
  });
  if (!valid) throw std::runtime_error("tracer name '" + t.name + "' must match [a-z0-9-]+");
  if (find_tracer(t.name) || find_variant(t.name))
    throw std::runtime_error("a tracer or variant named '" + t.name + "' exists already");
  std::lock_guard lock(registry_mutex());
  registered().push_back(std::move(t));
  return registered().back();
}

}  // namespace rayproof
