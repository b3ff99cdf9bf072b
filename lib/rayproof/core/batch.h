// Batched variants over structure-of-arrays inputs: the same formulas as a scalar variant,
// written as one branch-free loop the compiler vectorises (AVX2 or AVX-512 chosen at run time
// once from the CPU's features, SSE2 otherwise). Answers are bit for bit those of the scalar variant
// under the nearest-contact rule: the same IEEE operations in the same order, no FMA.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "rayproof/core/hit.h"
#include "rayproof/core/query.h"
#include "rayproof/core/shapes.h"

namespace rayproof {

// Rays and shapes, one lane per query; every array has size() elements. T: double, or float for
// the float batches (each number rounded to the nearest float, as the scalar float variants see it).
template <class T>
struct RaysSoAOf {
  std::vector<T> ox, oy, oz, dx, dy, dz;
  void push(const Ray& r);
  size_t size() const { return ox.size(); }
};
template <class T>
struct SpheresSoAOf {
  std::vector<T> cx, cy, cz, r;
  void push(const Sphere& s);
};
template <class T>
struct TrianglesSoAOf {
  std::vector<T> x0, y0, z0, x1, y1, z1, x2, y2, z2;
  void push(const Triangle& t);
};
using RaysSoA = RaysSoAOf<double>;
using SpheresSoA = SpheresSoAOf<double>;
using TrianglesSoA = TrianglesSoAOf<double>;
using RaysSoAF = RaysSoAOf<float>;
using SpheresSoAF = SpheresSoAOf<float>;
using TrianglesSoAF = TrianglesSoAOf<float>;

// Results: class (HitClass as a byte) and t (NaN where there is none), in T.
template <class T>
struct HitsSoAOf {
  std::vector<std::uint8_t> cls;
  std::vector<T> t;
  void resize(size_t n) { cls.resize(n), t.resize(n); }
  Hit at(size_t i) const { return {static_cast<HitClass>(cls[i]), double(t[i])}; }
};
using HitsSoA = HitsSoAOf<double>;
using HitsSoAF = HitsSoAOf<float>;
// Float results as doubles (exact), for callers that read every batched variant alike.
void widen(const HitsSoAF& in, HitsSoA& out);

// The instruction sets each kernel is compiled for (one loop, three target attributes); the
// best the CPU runs is chosen once, and tests run every one the CPU can.
enum class BatchIsa { sse2, avx2, avx512 };
BatchIsa best_batch_isa();
std::vector<BatchIsa> runnable_batch_isas();

// sphere `stable`, batched.
void sphere_stable_batch(const RaysSoA& rays, const SpheresSoA& spheres, HitsSoA& out, BatchIsa isa = best_batch_isa());
// triangle `moller-trumbore`, batched.
void triangle_moller_trumbore_batch(const RaysSoA& rays, const TrianglesSoA& tris, HitsSoA& out,
                                    BatchIsa isa = best_batch_isa());
// The float twins: `stable-f32` and `moller-trumbore-f32` batched, 8 lanes per AVX2 register (16
// with AVX-512), bit-identical to the scalar float variants.
void sphere_stable_f32_batch(const RaysSoAF& rays, const SpheresSoAF& spheres, HitsSoAF& out,
                             BatchIsa isa = best_batch_isa());
void triangle_moller_trumbore_f32_batch(const RaysSoAF& rays, const TrianglesSoAF& tris, HitsSoAF& out,
                                        BatchIsa isa = best_batch_isa());

// Queries of one shape laid out once, outside any timed loop, as every batched kernel reads them.
struct QueriesSoA {
  RaysSoA rays;
  SpheresSoA spheres;      // filled for sphere queries
  TrianglesSoA triangles;  // filled for triangle queries
  RaysSoAF rays_f32;       // the same, rounded to float, for the float batches
  SpheresSoAF spheres_f32;
  TrianglesSoAF triangles_f32;
  explicit QueriesSoA(std::span<const Query> queries);
  size_t size() const { return rays.size(); }
};

struct BatchedVariant {
  std::string_view name;    // e.g. "stable-batch"
  std::string_view scalar;  // the scalar variant it reproduces
  ShapeKind shape;
  void (*intersect_all)(const QueriesSoA& queries, HitsSoA& out);  // its own kernel
};
std::span<const BatchedVariant> batched_variants();

}  // namespace rayproof
