// Whole tracers (docs/spec/tracer.md): code that answers for one ray and a whole triangle mesh
// with its own acceleration structure, box test, triangle test and precision. One interface for
// every kind — rayproof's own BVH with each triangle variant (here), Embree and CGAL's AABB tree
// (peers/), a user's plugin or exec command (peers/) — and one registry the commands enumerate.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "rayproof/core/answer.h"
#include "rayproof/core/geometry.h"
#include "rayproof/core/hit.h"
#include "rayproof/core/shapes.h"
#include "rayproof/core/variants.h"

namespace rayproof {

inline constexpr std::uint32_t kNoTriangle = 0xffffffffu;  // RAYPROOF_NO_TRIANGLE

// The ABI's mesh: vertices x, y, z each, triangle i = indices[3i .. 3i+2].
struct TriangleMesh {
  std::vector<double> vertices;
  std::vector<std::uint32_t> indices;
  std::size_t vertex_count() const { return vertices.size() / 3; }
  std::size_t triangle_count() const { return indices.size() / 3; }
  Vec3 vertex(std::size_t i) const { return Vec3(vertices[3 * i], vertices[3 * i + 1], vertices[3 * i + 2]); }
  Triangle triangle(std::size_t i) const {
    return Triangle{{vertex(indices[3 * i]), vertex(indices[3 * i + 1]), vertex(indices[3 * i + 2])}};
  }
  std::array<std::uint32_t, 3> corners(std::size_t i) const {
    return {indices[3 * i], indices[3 * i + 1], indices[3 * i + 2]};
  }
  // Whether triangle i is exactly collinear (degenerate): its contacts are optional (tracer.md).
  bool degenerate(std::size_t i) const;
};

struct Mesh;
// A scene mesh (core/mesh.h) as the ABI's mesh: its vertices indexed as in its file (shared edges
// stay shared by index), its placed triangles in order. A file vertex no triangle uses is kept
// at the position 0.
TriangleMesh triangle_mesh_of(const Mesh& mesh);
// `more` appended to `mesh`, its indices shifted past mesh's vertices.
void append_mesh(TriangleMesh& mesh, const TriangleMesh& more);

// Why a mesh cannot be traced (an index out of range, a NaN or infinite vertex, no triangles,
// more than 2^32 − 2 of anything), or nullopt. Readers and generators check with this.
std::optional<std::string> invalid_mesh_reason(const TriangleMesh& mesh);

// The ABI's ray: origin + t·direction with tmin < t < tmax (tmax may be +inf).
struct TracerRay {
  Ray ray;
  double tmin = 0;
  double tmax = std::numeric_limits<double>::infinity();
};
// Why a ray cannot be traced (non-finite origin or direction, a zero direction, tmin < 0 or NaN,
// tmax NaN or ≤ tmin), or nullopt.
std::optional<std::string> invalid_ray_reason(const TracerRay& ray);

// Every number rounded to the nearest float (infinity stays): what a float tracer is given and
// judged on. nullopt where a number overflows float.
std::optional<TriangleMesh> mesh_rounded_to_float(const TriangleMesh& mesh);
std::optional<TracerRay> ray_rounded_to_float(const TracerRay& ray);

// What a tracer said for one ray. `failure` (crash, timeout, protocol, stopped): no answer.
struct TraceAnswer {
  std::uint32_t triangle = kNoTriangle;
  double t = std::numeric_limits<double>::quiet_NaN();
  AnswerFailure failure = AnswerFailure::none;
  bool hit() const { return triangle != kNoTriangle; }
};
struct AllHitsAnswer {
  std::vector<std::uint32_t> triangles;
  AnswerFailure failure = AnswerFailure::none;
  bool unsupported = false;  // an exec tracer answered {"error": "unsupported"}: it has no any-hit mode
};

// A tracer's structure over one mesh. nearest and all_hits may be called from several threads.
class TracerScene {
 public:
  virtual ~TracerScene() = default;
  virtual void nearest(std::span<const TracerRay> rays, std::span<TraceAnswer> out) = 0;
  virtual void all_hits(std::span<const TracerRay> rays, std::span<AllHitsAnswer> out) = 0;
};

// What building a scene gave: the scene, or why not — `failure` none with a reason: the tracer
// declined (build returned NULL); crash or timeout: the tracer died building it.
struct BuiltScene {
  std::unique_ptr<TracerScene> scene;
  AnswerFailure failure = AnswerFailure::none;
  std::string reason;
};

struct Tracer {
  std::string name;
  RangeRule range = RangeRule::open;  // declared by the tracer (ABI 2) or by --tracer-range
  Precision precision = Precision::f64;
  std::string source;
  std::string origin = "built-in";  // "built-in", a plugin path, "exec: COMMAND", or the peer library
  bool has_all_hits = true;
  bool always_judged = false;  // --tracer-exec tracers are judged whatever --tracers says
  // Builds over a mesh already rounded to the tracer's precision. Thread-safe.
  std::function<BuiltScene(const TriangleMesh&)> build;
  // Why the tracer stopped (a crash, a timeout), empty while it runs.
  std::function<std::string()> stop_reason = [] { return std::string(); };
};

// Every tracer: the built-in BVH tracers (one per built-in triangle variant with a kernel),
// then those registered by higher layers (peers, plugins, exec commands).
std::vector<const Tracer*> all_tracers();
// Adds a tracer; throws std::runtime_error on a bad or clashing name (with tracers and variants).
const Tracer& register_tracer(Tracer t);
const Tracer* find_tracer(std::string_view name);
// --tracer-range NAME=open|closed: declares or overrides a loaded tracer's range; false when no
// tracer has that name.
bool set_tracer_range(std::string_view name, RangeRule range);

// rayproof's BVH (core/bvh.h, conservative traversal) with a triangle variant at the leaves:
// the tracer "bvh-VARIANT". Its answers are what the variant decides over every triangle within
// its leaf_reach of the exact ray (core/scene_rays.h), so what it gets wrong is the triangle
// test's alone.
BuiltScene build_bvh_tracer_scene(const Variant& triangle_variant, const TriangleMesh& mesh);

}  // namespace rayproof
