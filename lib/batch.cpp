// Compiled with -O3 -fno-math-errno -fno-trapping-math (sqrt and the selects may then vectorise;
// no result changes: nothing here reads errno or traps) and -ffp-contract=off like every variant.
#include "rayproof/core/batch.h"

#include <cmath>
#include <limits>

namespace rayproof {

void RaysSoA::push(const Ray& r) {
  ox.push_back(r.origin.x()), oy.push_back(r.origin.y()), oz.push_back(r.origin.z());
  dx.push_back(r.direction.x()), dy.push_back(r.direction.y()), dz.push_back(r.direction.z());
}
void SpheresSoA::push(const Sphere& s) {
  cx.push_back(s.center.x()), cy.push_back(s.center.y()), cz.push_back(s.center.z()), r.push_back(s.radius);
}
void TrianglesSoA::push(const Triangle& t) {
  x0.push_back(t.v[0].x()), y0.push_back(t.v[0].y()), z0.push_back(t.v[0].z());
  x1.push_back(t.v[1].x()), y1.push_back(t.v[1].y()), z1.push_back(t.v[1].z());
  x2.push_back(t.v[2].x()), y2.push_back(t.v[2].y()), z2.push_back(t.v[2].z());
}

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kMiss = 0, kEnter = 1, kExit = 2, kTangent = 3, kBoundary = 4;  // HitClass values
}  // namespace

// Same steps as sphere_stable + sphere_hit_from_roots (nearest contact), every branch turned
// into a select so the loop vectorises. The arrays are restrict parameters: GCC's dependence
// analysis honours restrict on parameters, not on local pointers.
[[gnu::always_inline]] static inline void sphere_stable_loop(
    size_t n, const double* __restrict ox, const double* __restrict oy, const double* __restrict oz,
    const double* __restrict dx, const double* __restrict dy, const double* __restrict dz,
    const double* __restrict cx, const double* __restrict cy, const double* __restrict cz,
    const double* __restrict rr, std::uint8_t* __restrict cls, double* __restrict tt) {
  for (size_t i = 0; i < n; ++i) {
    const double fx = ox[i] - cx[i], fy = oy[i] - cy[i], fz = oz[i] - cz[i];
    const double a = dx[i] * dx[i] + dy[i] * dy[i] + dz[i] * dz[i];
    const double b = 2 * (dx[i] * fx + dy[i] * fy + dz[i] * fz);
    const double c = (fx * fx + fy * fy + fz * fz) - rr[i] * rr[i];
    const double disc = b * b - 4 * a * c;
    const double root = std::sqrt(disc < 0 ? 0.0 : disc);
    const double q = -0.5 * (b + (b >= 0 ? root : -root));
    const double x1 = q / a;
    const double c_over_q = c / q;  // computed in every lane, used only where q ≠ 0
    const double x2 = q == 0 ? 0.0 : c_over_q;
    const double t0 = x2 < x1 ? x2 : x1, t1 = x1 < x2 ? x2 : x1;  // std::min, std::max
    const bool miss = disc < 0, touching = disc == 0, near = t0 > 0, far = t1 > 0;
    const double k_far = far ? kExit : kMiss, t_far = far ? t1 : kNaN;
    const double k_open = near ? kEnter : k_far, t_open = near ? t0 : t_far;
    const double k_touch = near ? kTangent : kMiss, t_touch = near ? t0 : kNaN;
    const double k_hit = touching ? k_touch : k_open, t_hit = touching ? t_touch : t_open;
    cls[i] = static_cast<std::uint8_t>(static_cast<int>(miss ? kMiss : k_hit));
    tt[i] = miss ? kNaN : t_hit;
  }
}

#define RAYPROOF_SPHERE_PARAMS                                                                               \
  size_t n, const double *__restrict ox, const double *__restrict oy, const double *__restrict oz,           \
      const double *__restrict dx, const double *__restrict dy, const double *__restrict dz,                \
      const double *__restrict cx, const double *__restrict cy, const double *__restrict cz,                \
      const double *__restrict rr, std::uint8_t *__restrict cls, double *__restrict tt
#define RAYPROOF_SPHERE_ARGS n, ox, oy, oz, dx, dy, dz, cx, cy, cz, rr, cls, tt
__attribute__((target("avx512f"))) static void sphere_stable_avx512(RAYPROOF_SPHERE_PARAMS) {
  sphere_stable_loop(RAYPROOF_SPHERE_ARGS);
}
__attribute__((target("avx2"))) static void sphere_stable_avx2(RAYPROOF_SPHERE_PARAMS) {
  sphere_stable_loop(RAYPROOF_SPHERE_ARGS);
}
static void sphere_stable_sse2(RAYPROOF_SPHERE_PARAMS) { sphere_stable_loop(RAYPROOF_SPHERE_ARGS); }

void sphere_stable_batch(const RaysSoA& rays, const SpheresSoA& s, HitsSoA& out, BatchIsa isa) {
  out.resize(rays.size());
  auto* kernel = isa == BatchIsa::avx512 ? sphere_stable_avx512 : isa == BatchIsa::avx2 ? sphere_stable_avx2 : sphere_stable_sse2;
  kernel(rays.size(), rays.ox.data(), rays.oy.data(), rays.oz.data(), rays.dx.data(), rays.dy.data(),
                       rays.dz.data(), s.cx.data(), s.cy.data(), s.cz.data(), s.r.data(), out.cls.data(), out.t.data());
}

// Same steps as triangle_moller_trumbore (nearest contact), branch-free.
[[gnu::always_inline]] static inline void moller_trumbore_loop(
    size_t n, const double* __restrict ox, const double* __restrict oy, const double* __restrict oz,
    const double* __restrict dx_, const double* __restrict dy_, const double* __restrict dz_,
    const double* __restrict x0, const double* __restrict y0, const double* __restrict z0,
    const double* __restrict x1, const double* __restrict y1, const double* __restrict z1,
    const double* __restrict x2, const double* __restrict y2, const double* __restrict z2,
    std::uint8_t* __restrict cls, double* __restrict tt) {
  for (size_t i = 0; i < n; ++i) {
    const double e1x = x1[i] - x0[i], e1y = y1[i] - y0[i], e1z = z1[i] - z0[i];
    const double e2x = x2[i] - x0[i], e2y = y2[i] - y0[i], e2z = z2[i] - z0[i];
    const double dx = dx_[i], dy = dy_[i], dz = dz_[i];
    const double px = dy * e2z - dz * e2y, py = dz * e2x - dx * e2z, pz = dx * e2y - dy * e2x;  // d × e2
    const double det = e1x * px + e1y * py + e1z * pz;
    const double inv_det = 1 / det;
    const double sx = ox[i] - x0[i], sy = oy[i] - y0[i], sz = oz[i] - z0[i];
    const double u = (sx * px + sy * py + sz * pz) * inv_det;
    const double qx = sy * e1z - sz * e1y, qy = sz * e1x - sx * e1z, qz = sx * e1y - sy * e1x;  // s × e1
    const double v = (dx * qx + dy * qy + dz * qz) * inv_det;
    const double t = (e2x * qx + e2y * qy + e2z * qz) * inv_det;
    const double uv = u + v;
    // Written as the scalar variant's rejections, negated, so NaNs pass or fail the same way.
    const bool inside = (det != 0) & !(u < 0) & !(u > 1) & !(v < 0) & !(uv > 1) & (t > 0);
    const bool edge = (u == 0) | (v == 0) | (uv == 1);
    const double k_face = det > 0 ? kEnter : kExit;
    const double k_hit = edge ? kBoundary : k_face;
    cls[i] = static_cast<std::uint8_t>(static_cast<int>(inside ? k_hit : kMiss));
    tt[i] = inside ? t : kNaN;
  }
}

#define RAYPROOF_TRIANGLE_PARAMS                                                                             \
  size_t n, const double *__restrict ox, const double *__restrict oy, const double *__restrict oz,           \
      const double *__restrict dx_, const double *__restrict dy_, const double *__restrict dz_,             \
      const double *__restrict x0, const double *__restrict y0, const double *__restrict z0,                \
      const double *__restrict x1, const double *__restrict y1, const double *__restrict z1,                \
      const double *__restrict x2, const double *__restrict y2, const double *__restrict z2,                \
      std::uint8_t *__restrict cls, double *__restrict tt
#define RAYPROOF_TRIANGLE_ARGS n, ox, oy, oz, dx_, dy_, dz_, x0, y0, z0, x1, y1, z1, x2, y2, z2, cls, tt
__attribute__((target("avx512f"))) static void moller_trumbore_avx512(RAYPROOF_TRIANGLE_PARAMS) {
  moller_trumbore_loop(RAYPROOF_TRIANGLE_ARGS);
}
__attribute__((target("avx2"))) static void moller_trumbore_avx2(RAYPROOF_TRIANGLE_PARAMS) {
  moller_trumbore_loop(RAYPROOF_TRIANGLE_ARGS);
}
static void moller_trumbore_sse2(RAYPROOF_TRIANGLE_PARAMS) { moller_trumbore_loop(RAYPROOF_TRIANGLE_ARGS); }

void triangle_moller_trumbore_batch(const RaysSoA& rays, const TrianglesSoA& tr, HitsSoA& out, BatchIsa isa) {
  out.resize(rays.size());
  auto* kernel = isa == BatchIsa::avx512 ? moller_trumbore_avx512 : isa == BatchIsa::avx2 ? moller_trumbore_avx2 : moller_trumbore_sse2;
  kernel(rays.size(), rays.ox.data(), rays.oy.data(), rays.oz.data(), rays.dx.data(), rays.dy.data(),
                         rays.dz.data(), tr.x0.data(), tr.y0.data(), tr.z0.data(), tr.x1.data(), tr.y1.data(),
                         tr.z1.data(), tr.x2.data(), tr.y2.data(), tr.z2.data(), out.cls.data(), out.t.data());
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
    rays.push(q.ray);
    if (const auto* s = std::get_if<Sphere>(&q.shape)) spheres.push(*s);
    if (const auto* t = std::get_if<Triangle>(&q.shape)) triangles.push(*t);
  }
}

namespace {
constexpr BatchedVariant kBatched[] = {
    {"stable-batch", "stable", ShapeKind::sphere,
     [](const QueriesSoA& q, HitsSoA& out) { sphere_stable_batch(q.rays, q.spheres, out); }},
    {"moller-trumbore-batch", "moller-trumbore", ShapeKind::triangle,
     [](const QueriesSoA& q, HitsSoA& out) { triangle_moller_trumbore_batch(q.rays, q.triangles, out); }},
};
}  // namespace

std::span<const BatchedVariant> batched_variants() { return kBatched; }

}  // namespace rayproof
