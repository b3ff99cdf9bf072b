// Compiled with -O3 -fno-math-errno -fno-trapping-math (sqrt and the selects may then vectorise;
// no result changes: nothing here reads errno or traps) and -ffp-contract=off like every variant.
#include "rayproof/core/batch.h"
#include "rayproof/core/fp.h"

#include <cmath>
#include <type_traits>
#include <limits>

namespace rayproof {

template <class T>
void RaysSoAOf<T>::push(const Ray& r) {
  ox.push_back(rounded_to<T>(r.origin.x())), oy.push_back(rounded_to<T>(r.origin.y())),
      oz.push_back(rounded_to<T>(r.origin.z()));
  dx.push_back(rounded_to<T>(r.direction.x())), dy.push_back(rounded_to<T>(r.direction.y())),
      dz.push_back(rounded_to<T>(r.direction.z()));
}
template <class T>
void SpheresSoAOf<T>::push(const Sphere& s) {
  cx.push_back(rounded_to<T>(s.center.x())), cy.push_back(rounded_to<T>(s.center.y())),
      cz.push_back(rounded_to<T>(s.center.z())), r.push_back(rounded_to<T>(s.radius));
}
template <class T>
void TrianglesSoAOf<T>::push(const Triangle& t) {
  x0.push_back(rounded_to<T>(t.v[0].x())), y0.push_back(rounded_to<T>(t.v[0].y())),
      z0.push_back(rounded_to<T>(t.v[0].z()));
  x1.push_back(rounded_to<T>(t.v[1].x())), y1.push_back(rounded_to<T>(t.v[1].y())),
      z1.push_back(rounded_to<T>(t.v[1].z()));
  x2.push_back(rounded_to<T>(t.v[2].x())), y2.push_back(rounded_to<T>(t.v[2].y())),
      z2.push_back(rounded_to<T>(t.v[2].z()));
}
template struct RaysSoAOf<double>;
template struct RaysSoAOf<float>;
template struct SpheresSoAOf<double>;
template struct SpheresSoAOf<float>;
template struct TrianglesSoAOf<double>;
template struct TrianglesSoAOf<float>;

namespace {
constexpr double kMiss = 0, kEnter = 1, kExit = 2, kTangent = 3, kBoundary = 4;  // HitClass values
}  // namespace

// Same steps as sphere_stable + sphere_hit_from_roots (nearest contact), every branch turned
// into a select so the loop vectorises; T is the precision the scalar twin computes in (double:
// `stable`, float: `stable-f32`, 4 or 8 lanes per AVX2 register). The arrays are restrict
// parameters: GCC's dependence analysis honours restrict on parameters, not on local pointers.
template <class T>
[[gnu::always_inline]] static inline void sphere_stable_loop(size_t n, const T* __restrict ox, const T* __restrict oy,
                                                             const T* __restrict oz, const T* __restrict dx,
                                                             const T* __restrict dy, const T* __restrict dz,
                                                             const T* __restrict cx, const T* __restrict cy,
                                                             const T* __restrict cz, const T* __restrict rr,
                                                             std::uint8_t* __restrict cls, T* __restrict tt) {
  constexpr T nan = std::numeric_limits<T>::quiet_NaN();
  for (size_t i = 0; i < n; ++i) {
    const T fx = ox[i] - cx[i], fy = oy[i] - cy[i], fz = oz[i] - cz[i];
    const T a = dx[i] * dx[i] + dy[i] * dy[i] + dz[i] * dz[i];
    const T b = 2 * (dx[i] * fx + dy[i] * fy + dz[i] * fz);
    const T c = (fx * fx + fy * fy + fz * fz) - rr[i] * rr[i];
    const T disc = b * b - 4 * a * c;
    const T root = std::sqrt(disc < 0 ? T(0) : disc);
    const T q = T(-0.5) * (b + (b >= 0 ? root : -root));
    const T x1 = q / a;
    const T c_over_q = c / q;  // computed in every lane, used only where q ≠ 0
    const T x2 = q == 0 ? T(0) : c_over_q;
    const T t0 = x2 < x1 ? x2 : x1, t1 = x1 < x2 ? x2 : x1;  // std::min, std::max
    const bool miss = disc<0, touching = disc == 0, near = t0> 0, far = t1 > 0;
    const T k_far = far ? T(kExit) : T(kMiss), t_far = far ? t1 : nan;
    const T k_open = near ? T(kEnter) : k_far, t_open = near ? t0 : t_far;
    const T k_touch = near ? T(kTangent) : T(kMiss), t_touch = near ? t0 : nan;
    const T k_hit = touching ? k_touch : k_open, t_hit = touching ? t_touch : t_open;
    cls[i] = static_cast<std::uint8_t>(static_cast<int>(miss ? T(kMiss) : k_hit));
    tt[i] = miss ? nan : t_hit;
  }
}

#define RAYPROOF_SPHERE_PARAMS(T)                                                                           \
  size_t n, const T *__restrict ox, const T *__restrict oy, const T *__restrict oz, const T *__restrict dx, \
      const T *__restrict dy, const T *__restrict dz, const T *__restrict cx, const T *__restrict cy,       \
      const T *__restrict cz, const T *__restrict rr, std::uint8_t *__restrict cls, T *__restrict tt
#define RAYPROOF_SPHERE_ARGS n, ox, oy, oz, dx, dy, dz, cx, cy, cz, rr, cls, tt
template <class T>
__attribute__((target("avx512f"))) static void sphere_stable_avx512(RAYPROOF_SPHERE_PARAMS(T)) {
  sphere_stable_loop<T>(RAYPROOF_SPHERE_ARGS);
}
template <class T>
__attribute__((target("avx2"))) static void sphere_stable_avx2(RAYPROOF_SPHERE_PARAMS(T)) {
  sphere_stable_loop<T>(RAYPROOF_SPHERE_ARGS);
}
template <class T>
static void sphere_stable_sse2(RAYPROOF_SPHERE_PARAMS(T)) {
  sphere_stable_loop<T>(RAYPROOF_SPHERE_ARGS);
}

template <class T>
static void sphere_stable_batch_of(const RaysSoAOf<T>& rays, const SpheresSoAOf<T>& s, std::uint8_t* cls, T* t,
                                   BatchIsa isa) {
  auto* kernel = isa == BatchIsa::avx512 ? sphere_stable_avx512<T>
                 : isa == BatchIsa::avx2 ? sphere_stable_avx2<T>
                                         : sphere_stable_sse2<T>;
  kernel(rays.size(), rays.ox.data(), rays.oy.data(), rays.oz.data(), rays.dx.data(), rays.dy.data(), rays.dz.data(),
         s.cx.data(), s.cy.data(), s.cz.data(), s.r.data(), cls, t);
}

void sphere_stable_batch(const RaysSoA& rays, const SpheresSoA& s, HitsSoA& out, BatchIsa isa) {
  out.resize(rays.size());
  sphere_stable_batch_of<double>(rays, s, out.cls.data(), out.t.data(), isa);
}
void sphere_stable_f32_batch(const RaysSoAF& rays, const SpheresSoAF& s, HitsSoAF& out, BatchIsa isa) {
  out.resize(rays.size());
  sphere_stable_batch_of<float>(rays, s, out.cls.data(), out.t.data(), isa);
}

// Same steps as triangle_moller_trumbore (nearest contact), branch-free; T as for spheres.
template <class T>
[[gnu::always_inline]] static inline void moller_trumbore_loop(
    size_t n, const T* __restrict ox, const T* __restrict oy, const T* __restrict oz, const T* __restrict dx_,
    const T* __restrict dy_, const T* __restrict dz_, const T* __restrict x0, const T* __restrict y0,
    const T* __restrict z0, const T* __restrict x1, const T* __restrict y1, const T* __restrict z1,
    const T* __restrict x2, const T* __restrict y2, const T* __restrict z2, std::uint8_t* __restrict cls,
    T* __restrict tt) {
  constexpr T nan = std::numeric_limits<T>::quiet_NaN();
  for (size_t i = 0; i < n; ++i) {
    const T e1x = x1[i] - x0[i], e1y = y1[i] - y0[i], e1z = z1[i] - z0[i];
    const T e2x = x2[i] - x0[i], e2y = y2[i] - y0[i], e2z = z2[i] - z0[i];
    const T dx = dx_[i], dy = dy_[i], dz = dz_[i];
    const T px = dy * e2z - dz * e2y, py = dz * e2x - dx * e2z, pz = dx * e2y - dy * e2x;  // d × e2
    const T det = e1x * px + e1y * py + e1z * pz;
    const T inv_det = 1 / det;
    const T sx = ox[i] - x0[i], sy = oy[i] - y0[i], sz = oz[i] - z0[i];
    const T u = (sx * px + sy * py + sz * pz) * inv_det;
    const T qx = sy * e1z - sz * e1y, qy = sz * e1x - sx * e1z, qz = sx * e1y - sy * e1x;  // s × e1
    const T v = (dx * qx + dy * qy + dz * qz) * inv_det;
    const T t = (e2x * qx + e2y * qy + e2z * qz) * inv_det;
    const T uv = u + v;
    // Written as the scalar variant's rejections, negated, so NaNs pass or fail the same way.
    const bool inside = (det != 0) & !(u < 0) & !(u > 1) & !(v < 0) & !(uv > 1) & (t > 0);
    const bool edge = (u == 0) | (v == 0) | (uv == 1);
    const T k_face = det > 0 ? T(kEnter) : T(kExit);
    const T k_hit = edge ? T(kBoundary) : k_face;
    cls[i] = static_cast<std::uint8_t>(static_cast<int>(inside ? k_hit : T(kMiss)));
    tt[i] = inside ? t : nan;
  }
}

#define RAYPROOF_TRIANGLE_PARAMS(T)                                                                          \
  size_t n, const T *__restrict ox, const T *__restrict oy, const T *__restrict oz, const T *__restrict dx_, \
      const T *__restrict dy_, const T *__restrict dz_, const T *__restrict x0, const T *__restrict y0,      \
      const T *__restrict z0, const T *__restrict x1, const T *__restrict y1, const T *__restrict z1,        \
      const T *__restrict x2, const T *__restrict y2, const T *__restrict z2, std::uint8_t *__restrict cls,  \
      T *__restrict tt
#define RAYPROOF_TRIANGLE_ARGS n, ox, oy, oz, dx_, dy_, dz_, x0, y0, z0, x1, y1, z1, x2, y2, z2, cls, tt
template <class T>
__attribute__((target("avx512f"))) static void moller_trumbore_avx512(RAYPROOF_TRIANGLE_PARAMS(T)) {
  moller_trumbore_loop<T>(RAYPROOF_TRIANGLE_ARGS);
}
template <class T>
__attribute__((target("avx2"))) static void moller_trumbore_avx2(RAYPROOF_TRIANGLE_PARAMS(T)) {
  moller_trumbore_loop<T>(RAYPROOF_TRIANGLE_ARGS);
}
template <class T>
static void moller_trumbore_sse2(RAYPROOF_TRIANGLE_PARAMS(T)) {
  moller_trumbore_loop<T>(RAYPROOF_TRIANGLE_ARGS);
}

template <class T>
static void moller_trumbore_batch_of(const RaysSoAOf<T>& rays, const TrianglesSoAOf<T>& tr, std::uint8_t* cls, T* t,
                                     BatchIsa isa) {
  auto* kernel = isa == BatchIsa::avx512 ? moller_trumbore_avx512<T>
                 : isa == BatchIsa::avx2 ? moller_trumbore_avx2<T>
                                         : moller_trumbore_sse2<T>;
  kernel(rays.size(), rays.ox.data(), rays.oy.data(), rays.oz.data(), rays.dx.data(), rays.dy.data(), rays.dz.data(),
         tr.x0.data(), tr.y0.data(), tr.z0.data(), tr.x1.data(), tr.y1.data(), tr.z1.data(), tr.x2.data(), tr.y2.data(),
         tr.z2.data(), cls, t);
}

void triangle_moller_trumbore_batch(const RaysSoA& rays, const TrianglesSoA& tr, HitsSoA& out, BatchIsa isa) {
  out.resize(rays.size());
  moller_trumbore_batch_of<double>(rays, tr, out.cls.data(), out.t.data(), isa);
}
void triangle_moller_trumbore_f32_batch(const RaysSoAF& rays, const TrianglesSoAF& tr, HitsSoAF& out, BatchIsa isa) {
  out.resize(rays.size());
  moller_trumbore_batch_of<float>(rays, tr, out.cls.data(), out.t.data(), isa);
}

BatchIsa best_batch_isa() {
  static const BatchIsa best = __builtin_cpu_supports("avx512f") ? BatchIsa::avx512
                               : __builtin_cpu_supports("avx2")  ? BatchIsa::avx2
                                                                 : BatchIsa::sse2;
  return best;
}

std::vector<BatchIsa> runnable_batch_isas() {
  std::vector<BatchIsa> out = {BatchIsa::sse2};
  if (__builtin_cpu_supports("avx2")) out.push_back(BatchIsa::avx2);
  if (__builtin_cpu_supports("avx512f")) out.push_back(BatchIsa::avx512);
  return out;
}

QueriesSoA::QueriesSoA(std::span<const Query> queries) {
  for (const Query& q : queries) {
    rays.push(q.ray), rays_f32.push(q.ray);  // float: each number rounded to nearest, as rounded_to_float does
    if (const auto* s = std::get_if<Sphere>(&q.shape)) spheres.push(*s), spheres_f32.push(*s);
    if (const auto* t = std::get_if<Triangle>(&q.shape)) triangles.push(*t), triangles_f32.push(*t);
  }
}

namespace {
constexpr BatchedVariant kBatched[] = {
    {"stable-batch", "stable", ShapeKind::sphere,
     [](const QueriesSoA& q, HitsSoA& out) { sphere_stable_batch(q.rays, q.spheres, out); }},
    {"moller-trumbore-batch", "moller-trumbore", ShapeKind::triangle,
     [](const QueriesSoA& q, HitsSoA& out) { triangle_moller_trumbore_batch(q.rays, q.triangles, out); }},
    {"stable-f32-batch", "stable-f32", ShapeKind::sphere,
     [](const QueriesSoA& q, HitsSoA& out) {
       thread_local HitsSoAF f;
       sphere_stable_f32_batch(q.rays_f32, q.spheres_f32, f, best_batch_isa());
       widen(f, out);
     }},
    {"moller-trumbore-f32-batch", "moller-trumbore-f32", ShapeKind::triangle,
     [](const QueriesSoA& q, HitsSoA& out) {
       thread_local HitsSoAF f;
       triangle_moller_trumbore_f32_batch(q.rays_f32, q.triangles_f32, f, best_batch_isa());
       widen(f, out);
     }},
};
}  // namespace

void widen(const HitsSoAF& in, HitsSoA& out) {
  out.resize(in.cls.size());
  out.cls = in.cls;
  for (size_t i = 0; i < in.t.size(); ++i) out.t[i] = in.t[i];
}

std::span<const BatchedVariant> batched_variants() { return kBatched; }

}  // namespace rayproof
