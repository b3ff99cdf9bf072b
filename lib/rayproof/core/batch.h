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

// Rays and shapes, one lane per query; every array has size() elements.
struct RaysSoA {
  std::vector<double> ox, oy, oz, dx, dy, dz;
  void push(const Ray& r);
  size_t size() const { return ox.size(); }
};
struct SpheresSoA {
  std::vector<double> cx, cy, cz, r;
  void push(const Sphere& s);
};
struct TrianglesSoA {
  std::vector<double> x0, y0, z0, x1, y1, z1, x2, y2, z2;
  void push(const Triangle& t);
};

// Results: class (HitClass as a byte) and t (NaN where there is none).
struct HitsSoA {
  std::vector<std::uint8_t> cls;
  std::vector<double> t;
  void resize(size_t n) { cls.resize(n), t.resize(n); }
  Hit at(size_t i) const { return {static_cast<HitClass>(cls[i]), t[i]}; }
};

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

// Queries of one shape laid out once, outside any timed loop, as every batched kernel reads them.
struct QueriesSoA {
  RaysSoA rays;
  SpheresSoA spheres;      // filled for sphere queries
  TrianglesSoA triangles;  // filled for triangle queries
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
