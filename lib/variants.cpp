// The double-precision intersection variants. This file is compiled with -ffp-contract=off:
// each variant's answer must be the same bits on every x86-64 machine, FMA or not. A variant
// that wants FMA says so with std::fma and is a variant of its own.
#include "rayproof/core/variants.h"

#include "rayproof/core/eft.h"
#include "rayproof/core/fp.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

namespace rayproof {
namespace {

// Every formula is written once, over the scalar type T it computes in: double for the variants
// of the case format, float for their NAME-f32 twins (what GPUs and Embree compute in). A float
// variant is given the case rounded to float (verify/ rounds it; plugin.md), so converting its
// doubles to float here is exact. Products and sums are written out in a fixed order, as in
// core/geometry.h, so the double instantiation is the same arithmetic as before.
template <class T>
using V3 = Vec3Of<T>;
template <class T>
V3<T> lift(const Vec3& v) {
  return {rounded_to<T>(v.x()), rounded_to<T>(v.y()), rounded_to<T>(v.z())};
}
template <class T>
V3<T> operator-(const V3<T>& a, const V3<T>& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
template <class T>
V3<T> operator*(T k, const V3<T>& a) {
  return {k * a.x, k * a.y, k * a.z};
}
template <class T>
T dot(const V3<T>& a, const V3<T>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <class T>
V3<T> cross(const V3<T>& a, const V3<T>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class T>
struct RayOf {
  V3<T> o, d;
  explicit RayOf(const Ray& r) : o(lift<T>(r.origin)), d(lift<T>(r.direction)) {}
  V3<T> at(T t) const { return {o.x + t * d.x, o.y + t * d.y, o.z + t * d.z}; }
};

// γ(n) in T's unit roundoff (fp.h's γ for double, checked below; 2^-24 for float).
template <class T>
constexpr T gamma_of(int n) {
  constexpr T u = std::numeric_limits<T>::epsilon() / 2;
  return (n * u) / (1 - n * u);
}

// From the two real roots t0 <= t1 of the sphere's quadratic to a Hit under a rule.
// `touching` says the variant computed a zero discriminant (it believes the ray is tangent).
template <class T>
Hit sphere_hit_from_roots(const RayOf<T>& ray, const V3<T>& center, T t0, T t1, bool touching, HitRule rule) {
  if (rule == HitRule::enter_only) {
    // First tutorial: a root counts only where the ray enters, (p − m)·d < 0, evaluated in T.
    for (T t : {t0, t1}) {
      if (t > 0 && dot(ray.at(t) - center, ray.d) < 0) return {HitClass::enter, double(t)};
    }
    return Hit::miss();
  }
  if (touching) return t0 > 0 ? Hit{HitClass::tangent, double(t0)} : Hit::miss();
  if (t0 > 0) return {HitClass::enter, double(t0)};
  if (t1 > 0) return {HitClass::exit, double(t1)};
  return Hit::miss();
}

// The sphere's quadratic a t² + b t + c = 0 with a = d·d, b = 2 d·(o−m), c = |o−m|² − r²
// (Rietmann 2020, Aufgabe 1), shared by the variants that start from it.
template <class T>
struct Quadratic {
  T a, b, c;
};
template <class T>
Quadratic<T> sphere_quadratic(const RayOf<T>& ray, const V3<T>& m, T r) {
  const V3<T> oc = ray.o - m;
  return {dot(ray.d, ray.d), 2 * dot(ray.d, oc), dot(oc, oc) - r * r};
}

// The stable roots q = −½(b + sgn(b)√D), q/a and c/q with sgn(0) = +1, sorted.
template <class T>
std::pair<T, T> stable_roots(const Quadratic<T>& k, T disc) {
  const T root = std::sqrt(disc);
  const T q = T(-0.5) * (k.b + (k.b >= 0 ? root : -root));
  const T x1 = q / k.a;
  const T x2 = q == 0 ? T(0) : k.c / q;  // q = 0 only when b = D = 0, hence c = 0: both roots 0
  return {std::min(x1, x2), std::max(x1, x2)};
}

// Textbook quadratic formula, t = (−b ± √(b² − 4ac)) / 2a (Rietmann, "Raytracing und
// Vektorgeometrie", 2020, Aufgabe 1). Cancels catastrophically in −b + √D when b² ≫ 4ac.
template <class T>
Hit textbook(const Ray& r, const Sphere& s, HitRule rule) {
  const RayOf<T> ray(r);
  const V3<T> m = lift<T>(s.center);
  const auto [a, b, c] = sphere_quadratic(ray, m, rounded_to<T>(s.radius));
  const T disc = b * b - 4 * a * c;
  if (disc < 0) return Hit::miss();
  const T root = std::sqrt(disc);
  const T t0 = (-b - root) / (2 * a);
  const T t1 = (-b + root) / (2 * a);
  return sphere_hit_from_roots(ray, m, t0, t1, disc == 0, rule);
}

// Stable quadratic roots q = −½(b + sgn(b)√D), t1 = q/a, t2 = c/q with sgn(0) = +1
// (DGL Wiki, "Tutorial Raytracing – Grundlagen I", 2012; Numerical Recipes §5.6).
template <class T>
Hit stable(const Ray& r, const Sphere& s, HitRule rule) {
  const RayOf<T> ray(r);
  const V3<T> m = lift<T>(s.center);
  const Quadratic<T> k = sphere_quadratic(ray, m, rounded_to<T>(s.radius));
  const T disc = k.b * k.b - 4 * k.a * k.c;
  if (disc < 0) return Hit::miss();
  const auto [t0, t1] = stable_roots(k, disc);
  return sphere_hit_from_roots(ray, m, t0, t1, disc == 0, rule);
}

// As `stable`, but the discriminant b² − 4ac is computed with Kahan's FMA-compensated
// difference of products (Kahan, "On the Cost of Floating-Point Computation Without
// Extra-Precise Arithmetic", 2004): D is accurate to a few ulps even when b² ≈ 4ac.
template <class T>
Hit stable_fma(const Ray& r, const Sphere& s, HitRule rule) {
  const RayOf<T> ray(r);
  const V3<T> m = lift<T>(s.center);
  const Quadratic<T> k = sphere_quadratic(ray, m, rounded_to<T>(s.radius));
  const T four_a = 4 * k.a;
  const T w = four_a * k.c;
  const T e = std::fma(-four_a, k.c, w);      // exact error of the product 4a·c
  const T disc = std::fma(k.b, k.b, -w) + e;  // b² − 4ac with one rounding in b²−w
  if (disc < 0) return Hit::miss();
  const auto [t0, t1] = stable_roots(k, disc);
  return sphere_hit_from_roots(ray, m, t0, t1, disc == 0, rule);
}

// Discriminant from the distance of the centre to the ray's line, Δ = r² − |f − (f·d/d·d) d|²
// with f = o − m, and the stable root choice q = b′ + sgn(b′)√(aΔ), b′ = −f·d, t0 = c/q,
// t1 = q/a (Haines, Günther, Akenine-Möller, Ray Tracing Gems ch. 7, eqs. 7–10, 2019).
template <class T>
Hit hearn_baker(const Ray& r, const Sphere& s, HitRule rule) {
  const RayOf<T> ray(r);
  const V3<T> m = lift<T>(s.center);
  const V3<T> f = ray.o - m;
  const T a = dot(ray.d, ray.d);
  const T f_dot_d = dot(f, ray.d);
  const T b_prime = -f_dot_d;
  const V3<T> l = f - (f_dot_d / a) * ray.d;  // f minus its projection on d
  const T r2 = rounded_to<T>(s.radius) * rounded_to<T>(s.radius);
  const T delta = r2 - dot(l, l);
  if (delta < 0) return Hit::miss();
  const T c = dot(f, f) - r2;
  const T root = std::sqrt(a * delta);
  const T q = b_prime + (b_prime >= 0 ? root : -root);
  const T t0 = q == 0 ? T(0) : c / q;
  const T t1 = q / a;
  return sphere_hit_from_roots(ray, m, std::min(t0, t1), std::max(t0, t1), delta == 0, rule);
}

// Plane in normal form n·x = d: t = (d − n·o) / (n·dir) (DGL Wiki tutorial, "Ebenen").
template <class T>
Hit direct(const Ray& r, const Plane& p, HitRule rule) {
  const RayOf<T> ray(r);
  const V3<T> n = lift<T>(p.normal);
  const T denom = dot(n, ray.d);
  const T num = rounded_to<T>(p.offset) - dot(n, ray.o);
  if (denom == 0) {
    // Parallel: the ray lies in the plane (tangent, no single t) or never meets it.
    return (num == 0 && rule == HitRule::nearest_contact) ? Hit{HitClass::tangent} : Hit::miss();
  }
  const T t = num / denom;
  if (!(t > 0)) return Hit::miss();
  if (denom < 0) return {HitClass::enter, double(t)};  // arrives from the side the normal points to
  return rule == HitRule::enter_only ? Hit::miss() : Hit{HitClass::exit, double(t)};
}

// Shared tail of the triangle variants: the hit is on the front face when `front`,
// on an edge or vertex when `on_edge`.
template <class T>
Hit triangle_hit(T t, bool front, bool on_edge, HitRule rule) {
  if (!(t > 0)) return Hit::miss();
  if (!front && rule == HitRule::enter_only) return Hit::miss();
  if (on_edge) return {HitClass::boundary, double(t)};
  return {front ? HitClass::enter : HitClass::exit, double(t)};
}

// Möller & Trumbore, "Fast, Minimum Storage Ray/Triangle Intersection", JGT 1997.
// det = e1·(d × e2) = −d·n, so det > 0 means the ray meets the front face.
template <class T>
Hit moller_trumbore(const Ray& r, const Triangle& tri, HitRule rule) {
  const RayOf<T> ray(r);
  const V3<T> v0 = lift<T>(tri.v[0]);
  const V3<T> e1 = lift<T>(tri.v[1]) - v0;
  const V3<T> e2 = lift<T>(tri.v[2]) - v0;
  const V3<T> p = cross(ray.d, e2);
  const T det = dot(e1, p);
  if (det == 0) return Hit::miss();  // parallel: MT cannot tell a coplanar ray
  const T inv_det = 1 / det;
  const V3<T> s = ray.o - v0;
  const T u = dot(s, p) * inv_det;
  if (u < 0 || u > 1) return Hit::miss();
  const V3<T> q = cross(s, e1);
  const T v = dot(ray.d, q) * inv_det;
  if (v < 0 || u + v > 1) return Hit::miss();
  const T t = dot(e2, q) * inv_det;
  return triangle_hit(t, det > 0, u == 0 || v == 0 || u + v == 1, rule);
}

// A zero edge function a·b − c·d recomputed so that its sign is exact (Woop et al. §3.3 use a
// wider type). Float inputs: in double — a product of two floats (24 + 24 bits) is exact in
// double's 53, and the difference of two exact products rounds once, keeping its sign (fl(x − y)
// = 0 only when x = y). Double inputs: Kahan's FMA difference of products (core/eft.h), relative
// error ≤ 2u, so exact in sign while the products are 0 or at least 2^-969 in magnitude. (Long
// double, used before, has 64 bits where a product of doubles needs 106, and is double itself on
// some platforms: it said 0 for 2^-70.)
template <class T>
T exact_sign_edge(T a, T b, T c, T d) {
  if constexpr (std::is_same_v<T, float>)
    return static_cast<float>(double(a) * double(b) - double(c) * double(d));
  else
    return difference_of_products(a, b, c, d);
}

// Woop, Benthin & Wald, "Watertight Ray/Triangle Intersection", JCGT 2(1), 2013: shear the
// vertices into the ray's frame, then 2D edge functions U, V, W; a zero edge function is
// recomputed in the wider type. With `top_left`, a zero edge function counts as inside only on
// edges the triangle owns — in the sheared frame, edges pointing up, or right when horizontal
// (the half-open half-plane rule rasterizers use, D3D's top-left rule in spirit). A shared edge
// is computed bit-identically, reversed, in both triangles (fl(x − y) = −fl(y − x)), so exactly
// one owns it; at a closed fan's centre exactly one triangle owns both its edges there: what DXR
// and Vulkan ray tracing promise, one hit per shared edge and vertex.
template <class T, bool top_left>
Hit watertight(const Ray& r, const Triangle& tri, HitRule rule) {
  const RayOf<T> ray(r);
  const V3<T>& d = ray.d;
  // The dominant axis and the sign tests below are written without branches (selects and bitwise
  // ors; the same results): random rays mispredict such branches about half the time.
  const T abs_x = std::abs(d.x), abs_y = std::abs(d.y);
  int kz = abs_y > abs_x ? 1 : 0;
  kz = std::abs(d.z) > (kz == 1 ? abs_y : abs_x) ? 2 : kz;
  int kx = (kz + 1) % 3;
  int ky = (kx + 1) % 3;
  if (d[kz] < 0) std::swap(kx, ky);  // keep the winding: det > 0 stays the front face
  const T sx = d[kx] / d[kz];
  const T sy = d[ky] / d[kz];
  const T sz = T(1) / d[kz];
  const V3<T> a = lift<T>(tri.v[0]) - ray.o;
  const V3<T> b = lift<T>(tri.v[1]) - ray.o;
  const V3<T> c = lift<T>(tri.v[2]) - ray.o;
  const T ax = a[kx] - sx * a[kz], ay = a[ky] - sy * a[kz];
  const T bx = b[kx] - sx * b[kz], by = b[ky] - sy * b[kz];
  const T cx = c[kx] - sx * c[kz], cy = c[ky] - sy * c[kz];
  T u = cx * by - cy * bx;
  T v = ax * cy - ay * cx;
  T w = bx * ay - by * ax;
  if (u == 0 || v == 0 || w == 0) {
    u = exact_sign_edge(cx, by, cy, bx);
    v = exact_sign_edge(ax, cy, ay, cx);
    w = exact_sign_edge(bx, ay, by, ax);
  }
  const bool some_negative = (u < 0) | (v < 0) | (w < 0), some_positive = (u > 0) | (v > 0) | (w > 0);
  if (some_negative & some_positive) return Hit::miss();
  const T det = u + v + w;
  if (det == 0) return Hit::miss();
  if constexpr (top_left) {  // u belongs to edge b→c, v to c→a, w to a→b
    auto owns = [](T ex, T ey) { return ey > 0 || (ey == 0 && ex > 0); };
    if (u == 0 && !owns(cx - bx, cy - by)) return Hit::miss();
    if (v == 0 && !owns(ax - cx, ay - cy)) return Hit::miss();
    if (w == 0 && !owns(bx - ax, by - ay)) return Hit::miss();
  }
  const T t_scaled = u * (sz * a[kz]) + v * (sz * b[kz]) + w * (sz * c[kz]);
  return triangle_hit(t_scaled / det, det > 0, u == 0 || v == 0 || w == 0, rule);
}

// Shared tail of the box variants: the ray's parameter interval inside the closed box.
template <class T>
Hit box_hit(T t_min, T t_max, HitRule rule) {
  if (!(t_min <= t_max)) return Hit::miss();
  if (t_min > 0) {
    if (t_min == t_max) return rule == HitRule::enter_only ? Hit::miss() : Hit{HitClass::tangent, double(t_min)};
    return {HitClass::enter, double(t_min)};
  }
  if (t_max > 0 && rule == HitRule::nearest_contact) return {HitClass::exit, double(t_max)};
  return Hit::miss();
}

// Naive slab test as usually written (Kay & Kajiya 1986; Scratchapixel's ray–box lesson):
// per-axis division by d and plain comparisons, no care for zero or −0.0 components — 0/0 is
// NaN when the origin lies on a slab plane, and a NaN bound then poisons the interval.
template <class T>
Hit slab(const Ray& r, const Box& box, HitRule rule) {
  const RayOf<T> ray(r);
  const V3<T> lo = lift<T>(box.min), hi = lift<T>(box.max);
  T t_min = (lo.x - ray.o.x) / ray.d.x;
  T t_max = (hi.x - ray.o.x) / ray.d.x;
  if (t_min > t_max) std::swap(t_min, t_max);
  for (int i = 1; i < 3; ++i) {
    T t0 = (lo[i] - ray.o[i]) / ray.d[i];
    T t1 = (hi[i] - ray.o[i]) / ray.d[i];
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > t_max || t_min > t1) return Hit::miss();
    if (t0 > t_min) t_min = t0;
    if (t1 < t_max) t_max = t1;
  }
  return box_hit(t_min, t_max, rule);
}

// Williams, Barrus, Morley & Shirley, "An Efficient and Robust Ray–Box Intersection
// Algorithm", JGT 2005 (inverse direction, near/far bound chosen by the sign bit so −0.0 works),
// with NaN-safe, boundary-inclusive min/max ordering and the far distance widened by
// 1 + 2γ(3) in T's own unit roundoff (Ize, "Robust BVH Ray Traversal", JCGT 2013).
template <class T>
Hit robust_slab(const Ray& r, const Box& box, HitRule rule) {
  const RayOf<T> ray(r);
  const V3<T> lo = lift<T>(box.min), hi = lift<T>(box.max);
  constexpr T kInf = std::numeric_limits<T>::infinity();
  T t_min = -kInf, t_max = kInf;
  for (int i = 0; i < 3; ++i) {
    const T inv = T(1) / ray.d[i];  // ±inf for ±0.0
    const bool negative = std::signbit(inv);
    const T near_plane = negative ? hi[i] : lo[i];
    const T far_plane = negative ? lo[i] : hi[i];
    const T t_near = (near_plane - ray.o[i]) * inv;
    const T t_far = (far_plane - ray.o[i]) * inv * (1 + 2 * gamma_of<T>(3));
    // Written so that a NaN (0·inf: origin on the slab plane, zero direction) leaves the bound alone.
    t_min = t_near > t_min ? t_near : t_min;
    t_max = t_far < t_max ? t_far : t_max;
  }
  return box_hit(t_min, t_max, rule);
}

static_assert(gamma_of<double>(3) == gamma(3), "one γ(n): fp.h's, for double");

}  // namespace

Hit sphere_textbook(const Ray& ray, const Sphere& s, HitRule rule) { return textbook<double>(ray, s, rule); }
Hit sphere_stable(const Ray& ray, const Sphere& s, HitRule rule) { return stable<double>(ray, s, rule); }
Hit sphere_stable_fma(const Ray& ray, const Sphere& s, HitRule rule) { return stable_fma<double>(ray, s, rule); }
Hit sphere_hearn_baker(const Ray& ray, const Sphere& s, HitRule rule) { return hearn_baker<double>(ray, s, rule); }
Hit plane_direct(const Ray& ray, const Plane& p, HitRule rule) { return direct<double>(ray, p, rule); }
Hit triangle_moller_trumbore(const Ray& ray, const Triangle& t, HitRule rule) {
  return moller_trumbore<double>(ray, t, rule);
}
Hit triangle_watertight(const Ray& ray, const Triangle& t, HitRule rule) {
  return watertight<double, false>(ray, t, rule);
}
Hit triangle_watertight_top_left(const Ray& ray, const Triangle& t, HitRule rule) {
  return watertight<double, true>(ray, t, rule);
}
Hit box_slab(const Ray& ray, const Box& b, HitRule rule) { return slab<double>(ray, b, rule); }
Hit box_robust_slab(const Ray& ray, const Box& b, HitRule rule) { return robust_slab<double>(ray, b, rule); }

namespace {
constexpr Variant f32(Variant v) {
  v.precision = Precision::f32;
  return v;
}

template <class S, Hit (*F)(const Ray&, const S&, HitRule)>
Hit erase(const Ray& ray, const Shape& shape, HitRule rule) {
  return F(ray, std::get<S>(shape), rule);
}

constexpr Variant kVariants[] = {
    {"textbook", ShapeKind::sphere, "Rietmann 2020: (-b ± sqrt(b^2-4ac)) / 2a", erase<Sphere, sphere_textbook>},
    {"stable", ShapeKind::sphere, "DGL Wiki 2012 / Numerical Recipes: q = -(b + sgn(b) sqrt D)/2",
     erase<Sphere, sphere_stable>},
    {"stable-fma", ShapeKind::sphere, "stable roots, Kahan 2004 FMA discriminant", erase<Sphere, sphere_stable_fma>},
    {"hearn-baker", ShapeKind::sphere, "Ray Tracing Gems ch. 7 eqs. 7-10", erase<Sphere, sphere_hearn_baker>},
    {"direct", ShapeKind::plane, "t = (d - n.o) / n.dir", erase<Plane, plane_direct>},
    {"moller-trumbore", ShapeKind::triangle, "Moller & Trumbore, JGT 1997", erase<Triangle, triangle_moller_trumbore>},
    {"watertight", ShapeKind::triangle, "Woop, Benthin & Wald, JCGT 2013", erase<Triangle, triangle_watertight>},
    {"watertight-top-left", ShapeKind::triangle,
     "Woop, Benthin & Wald 2013 + a top-left tie rule on zero edge functions",
     erase<Triangle, triangle_watertight_top_left>},
    {"slab", ShapeKind::box, "naive slab test, Kay & Kajiya 1986", erase<Box, box_slab>},
    {"robust-slab", ShapeKind::box, "Williams et al. 2005 + Ize 2013", erase<Box, box_robust_slab>},
    // The same formulas computed in float (what GPUs and Embree run): given the case rounded to
    // float and judged on it (verify/compare.cpp), as float plugins are.
    f32({"textbook-f32", ShapeKind::sphere, "textbook in float", erase<Sphere, textbook<float>>}),
    f32({"stable-f32", ShapeKind::sphere, "stable in float", erase<Sphere, stable<float>>}),
    f32({"stable-fma-f32", ShapeKind::sphere, "stable-fma in float (fmaf)", erase<Sphere, stable_fma<float>>}),
    f32({"hearn-baker-f32", ShapeKind::sphere, "hearn-baker in float", erase<Sphere, hearn_baker<float>>}),
    f32({"direct-f32", ShapeKind::plane, "direct in float", erase<Plane, direct<float>>}),
    f32({"moller-trumbore-f32", ShapeKind::triangle, "moller-trumbore in float",
         erase<Triangle, moller_trumbore<float>>}),
    f32({"watertight-f32", ShapeKind::triangle,
         "watertight in float, zero edge functions recomputed in double (exact in sign)",
         erase<Triangle, watertight<float, false>>}),
    f32({"watertight-top-left-f32", ShapeKind::triangle, "watertight-top-left in float",
         erase<Triangle, watertight<float, true>>}),
    f32({"slab-f32", ShapeKind::box, "slab in float", erase<Box, slab<float>>}),
    f32({"robust-slab-f32", ShapeKind::box, "robust-slab in float, widened by 1 + 2 gamma(3) of float",
         erase<Box, robust_slab<float>>}),
};
}  // namespace

// The built-ins first, then variants registered at run time by higher layers. Capacity is
// reserved once, so the pointers find_variant hands out never move.
constexpr size_t kRegistryCapacity = 256;
std::vector<Variant>& registry() {
  static std::vector<Variant> all = [] {
    std::vector<Variant> v;
    v.reserve(kRegistryCapacity);
    v.assign(std::begin(kVariants), std::end(kVariants));
    return v;
  }();
  return all;
}

std::span<const Variant> all_variants() { return registry(); }
std::span<const Variant> builtin_variants() { return kVariants; }

std::string_view to_string(Precision p) { return p == Precision::f32 ? "float" : "double"; }

Answer Variant::intersect(const Ray& ray, const Shape& shape, HitRule rule, AnswerTiming* timing) const {
  if (kernel) return kernel(ray, shape, rule_for(rule));
  Answer out;
  const Query q{ray, shape, {}};
  external->answer_all(std::span(&q, 1), std::span(&out, 1), timing);
  return out;
}

void Variant::intersect_all(std::span<const Query> qs, HitRule rule, std::span<Answer> out,
                            AnswerTiming* timing) const {
  if (!kernel) return external->answer_all(qs, out, timing);
  for (size_t i = 0; i < qs.size(); ++i) out[i] = kernel(qs[i].ray, qs[i].shape, rule_for(rule));
}

const Variant& register_variant(const Variant& v) {
  if (find_variant(v.name)) throw std::runtime_error("a variant named '" + std::string(v.name) + "' exists already");
  if (registry().size() == kRegistryCapacity) throw std::runtime_error("too many variants");
  registry().push_back(v);
  return registry().back();
}

const Variant* find_variant(std::string_view name) {
  for (const Variant& v : registry())
    if (v.name == name) return &v;
  return nullptr;
}

bool set_variant_range(std::string_view name, RangeRule range) {
  for (Variant& v : registry())
    if (v.name == name) return v.range = range, true;
  return false;
}

std::vector<const Variant*> variants_for(ShapeKind shape) {
  std::vector<const Variant*> out;
  for (const Variant& v : registry())
    if (v.handles(shape)) out.push_back(&v);
  return out;
}

const Variant& default_variant(ShapeKind shape) {
  switch (shape) {
    case ShapeKind::sphere: return *find_variant("stable");
    case ShapeKind::plane: return *find_variant("direct");
    case ShapeKind::triangle: return *find_variant("watertight");
    case ShapeKind::box: return *find_variant("robust-slab");
  }
  return kVariants[0];
}

}  // namespace rayproof

namespace rayproof {
std::string shapes_answered(const Variant& v) {
  if (!v.all_shapes) return std::string(to_string(v.shape));
  if (v.shape_mask == 0) return "any";
  std::string out;
  for (ShapeKind k : kAllShapeKinds)
    if (v.handles(k)) out += (out.empty() ? "" : ",") + std::string(to_string(k));
  return out;
}
}  // namespace rayproof
