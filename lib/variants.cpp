// The double-precision intersection variants. This file is compiled with -ffp-contract=off:
// each variant's answer must be the same bits on every x86-64 machine, FMA or not. A variant
// that wants FMA says so with std::fma and is a variant of its own.
#include "rayproof/core/variants.h"

#include "rayproof/core/fp.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace rayproof {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// From the two real roots t0 <= t1 of the sphere's quadratic to a Hit under a rule.
// `touching` says the variant computed a zero discriminant (it believes the ray is tangent).
Hit sphere_hit_from_roots(const Ray& ray, const Sphere& s, double t0, double t1, bool touching,
                          HitRule rule) {
  if (rule == HitRule::enter_only) {
    // First tutorial: a root counts only where the ray enters, (p − m)·d < 0, evaluated in double.
    for (double t : {t0, t1}) {
      if (t > 0 && dot(ray.at(t) - s.center, ray.direction) < 0) return {HitClass::enter, t};
    }
    return Hit::miss();
  }
  if (touching) return t0 > 0 ? Hit{HitClass::tangent, t0} : Hit::miss();
  if (t0 > 0) return {HitClass::enter, t0};
  if (t1 > 0) return {HitClass::exit, t1};
  return Hit::miss();
}

// The sphere's quadratic a t² + b t + c = 0 with a = d·d, b = 2 d·(o−m), c = |o−m|² − r²
// (Rietmann 2020, Aufgabe 1), shared by the variants that start from it.
struct Quadratic {
  double a, b, c;
};
Quadratic sphere_quadratic(const Ray& ray, const Sphere& s) {
  const Vec3 oc = ray.origin - s.center;
  return {dot(ray.direction, ray.direction), 2 * dot(ray.direction, oc), dot(oc, oc) - s.radius * s.radius};
}

// The stable roots q = −½(b + sgn(b)√D), q/a and c/q with sgn(0) = +1, sorted.
std::pair<double, double> stable_roots(const Quadratic& k, double disc) {
  const double root = std::sqrt(disc);
  const double q = -0.5 * (k.b + (k.b >= 0 ? root : -root));
  const double x1 = q / k.a;
  const double x2 = q == 0 ? 0.0 : k.c / q;  // q = 0 only when b = D = 0, hence c = 0: both roots 0
  return {std::min(x1, x2), std::max(x1, x2)};
}

}  // namespace

// Textbook quadratic formula, t = (−b ± √(b² − 4ac)) / 2a (Rietmann, "Raytracing und
// Vektorgeometrie", 2020, Aufgabe 1). Cancels catastrophically in −b + √D when b² ≫ 4ac.
Hit sphere_textbook(const Ray& ray, const Sphere& s, HitRule rule) {
  const auto [a, b, c] = sphere_quadratic(ray, s);
  const double disc = b * b - 4 * a * c;
  if (disc < 0) return Hit::miss();
  const double root = std::sqrt(disc);
  const double t0 = (-b - root) / (2 * a);
  const double t1 = (-b + root) / (2 * a);
  return sphere_hit_from_roots(ray, s, t0, t1, disc == 0, rule);
}

// Stable quadratic roots q = −½(b + sgn(b)√D), t1 = q/a, t2 = c/q with sgn(0) = +1
// (DGL Wiki, "Tutorial Raytracing – Grundlagen I", 2012; Numerical Recipes §5.6).
Hit sphere_stable(const Ray& ray, const Sphere& s, HitRule rule) {
  const Quadratic k = sphere_quadratic(ray, s);
  const double disc = k.b * k.b - 4 * k.a * k.c;
  if (disc < 0) return Hit::miss();
  const auto [t0, t1] = stable_roots(k, disc);
  return sphere_hit_from_roots(ray, s, t0, t1, disc == 0, rule);
}

// As `stable`, but the discriminant b² − 4ac is computed with Kahan's FMA-compensated
// difference of products (Kahan, "On the Cost of Floating-Point Computation Without
// Extra-Precise Arithmetic", 2004): D is accurate to a few ulps even when b² ≈ 4ac.
Hit sphere_stable_fma(const Ray& ray, const Sphere& s, HitRule rule) {
  const Quadratic k = sphere_quadratic(ray, s);
  const double four_a = 4 * k.a;
  const double w = four_a * k.c;
  const double e = std::fma(-four_a, k.c, w);        // exact error of the product 4a·c
  const double disc = std::fma(k.b, k.b, -w) + e;    // b² − 4ac with one rounding in b²−w
  if (disc < 0) return Hit::miss();
  const auto [t0, t1] = stable_roots(k, disc);
  return sphere_hit_from_roots(ray, s, t0, t1, disc == 0, rule);
}

// Discriminant from the distance of the centre to the ray's line, Δ = r² − |f − (f·d/d·d) d|²
// with f = o − m, and the stable root choice q = b′ + sgn(b′)√(aΔ), b′ = −f·d, t0 = c/q,
// t1 = q/a (Haines, Günther, Akenine-Möller, Ray Tracing Gems ch. 7, eqs. 7–10, 2019).
Hit sphere_hearn_baker(const Ray& ray, const Sphere& s, HitRule rule) {
  const Vec3 f = ray.origin - s.center;
  const double a = dot(ray.direction, ray.direction);
  const double f_dot_d = dot(f, ray.direction);
  const double b_prime = -f_dot_d;
  const Vec3 l = f - (f_dot_d / a) * ray.direction;  // f minus its projection on d
  const double r2 = s.radius * s.radius;
  const double delta = r2 - dot(l, l);
  if (delta < 0) return Hit::miss();
  const double c = dot(f, f) - r2;
  const double root = std::sqrt(a * delta);
  const double q = b_prime + (b_prime >= 0 ? root : -root);
  const double t0 = q == 0 ? 0.0 : c / q;
  const double t1 = q / a;
  return sphere_hit_from_roots(ray, s, std::min(t0, t1), std::max(t0, t1), delta == 0, rule);
}

// Plane in normal form n·x = d: t = (d − n·o) / (n·dir) (DGL Wiki tutorial, "Ebenen").
Hit plane_direct(const Ray& ray, const Plane& p, HitRule rule) {
  const double denom = dot(p.normal, ray.direction);
  const double num = p.offset - dot(p.normal, ray.origin);
  if (denom == 0) {
    // Parallel: the ray lies in the plane (tangent, no single t) or never meets it.
    return (num == 0 && rule == HitRule::nearest_contact) ? Hit{HitClass::tangent} : Hit::miss();
  }
  const double t = num / denom;
  if (!(t > 0)) return Hit::miss();
  if (denom < 0) return {HitClass::enter, t};  // arrives from the side the normal points to
  return rule == HitRule::enter_only ? Hit::miss() : Hit{HitClass::exit, t};
}

namespace {
// Shared tail of the triangle variants: the hit is on the front face when `front`,
// on an edge or vertex when `on_edge`.
Hit triangle_hit(double t, bool front, bool on_edge, HitRule rule) {
  if (!(t > 0)) return Hit::miss();
  if (!front && rule == HitRule::enter_only) return Hit::miss();
  if (on_edge) return {HitClass::boundary, t};
  return {front ? HitClass::enter : HitClass::exit, t};
}
}  // namespace

// Möller & Trumbore, "Fast, Minimum Storage Ray/Triangle Intersection", JGT 1997.
// det = e1·(d × e2) = −d·n, so det > 0 means the ray meets the front face.
Hit triangle_moller_trumbore(const Ray& ray, const Triangle& tri, HitRule rule) {
  const Vec3 e1 = tri.v[1] - tri.v[0];
  const Vec3 e2 = tri.v[2] - tri.v[0];
  const Vec3 p = cross(ray.direction, e2);
  const double det = dot(e1, p);
  if (det == 0) return Hit::miss();  // parallel: MT cannot tell a coplanar ray
  const double inv_det = 1 / det;
  const Vec3 s = ray.origin - tri.v[0];
  const double u = dot(s, p) * inv_det;
  if (u < 0 || u > 1) return Hit::miss();
  const Vec3 q = cross(s, e1);
  const double v = dot(ray.direction, q) * inv_det;
  if (v < 0 || u + v > 1) return Hit::miss();
  const double t = dot(e2, q) * inv_det;
  return triangle_hit(t, det > 0, u == 0 || v == 0 || u + v == 1, rule);
}

// Woop, Benthin & Wald, "Watertight Ray/Triangle Intersection", JCGT 2(1), 2013: shear the
// vertices into the ray's frame, then 2D edge functions U, V, W; a zero edge function is
// recomputed in higher precision (here long double) as the paper does for float.
Hit triangle_watertight(const Ray& ray, const Triangle& tri, HitRule rule) {
  const Vec3& d = ray.direction;
  int kz = 0;
  if (std::abs(d.y()) > std::abs(d[kz])) kz = 1;
  if (std::abs(d.z()) > std::abs(d[kz])) kz = 2;
  int kx = (kz + 1) % 3;
  int ky = (kx + 1) % 3;
  if (d[kz] < 0) std::swap(kx, ky);  // keep the winding: det > 0 stays the front face
  const double sx = d[kx] / d[kz];
  const double sy = d[ky] / d[kz];
  const double sz = 1.0 / d[kz];
  const Vec3 a = tri.v[0] - ray.origin;
  const Vec3 b = tri.v[1] - ray.origin;
  const Vec3 c = tri.v[2] - ray.origin;
  const double ax = a[kx] - sx * a[kz], ay = a[ky] - sy * a[kz];
  const double bx = b[kx] - sx * b[kz], by = b[ky] - sy * b[kz];
  const double cx = c[kx] - sx * c[kz], cy = c[ky] - sy * c[kz];
  double u = cx * by - cy * bx;
  double v = ax * cy - ay * cx;
  double w = bx * ay - by * ax;
  if (u == 0 || v == 0 || w == 0) {
    using L = long double;
    u = static_cast<double>(L(cx) * L(by) - L(cy) * L(bx));
    v = static_cast<double>(L(ax) * L(cy) - L(ay) * L(cx));
    w = static_cast<double>(L(bx) * L(ay) - L(by) * L(ax));
  }
  if ((u < 0 || v < 0 || w < 0) && (u > 0 || v > 0 || w > 0)) return Hit::miss();
  const double det = u + v + w;
  if (det == 0) return Hit::miss();
  const double t_scaled = u * (sz * a[kz]) + v * (sz * b[kz]) + w * (sz * c[kz]);
  return triangle_hit(t_scaled / det, det > 0, u == 0 || v == 0 || w == 0, rule);
}

// watertight with a tie rule: a zero edge function counts as inside only on edges the triangle
// owns — in the sheared 2D frame, edges pointing up, or right when horizontal (the half-open
// half-plane rule rasterizers use, D3D's top-left rule in spirit). A shared edge is computed
// bit-identically, reversed, in both triangles (fl(x − y) = −fl(y − x)), so exactly one owns it;
// at a closed fan's centre exactly one triangle owns both its edges there. What DXR and Vulkan
// ray tracing promise: one hit per shared edge and vertex.
Hit triangle_watertight_top_left(const Ray& ray, const Triangle& tri, HitRule rule) {
  const Vec3& d = ray.direction;
  int kz = 0;
  if (std::abs(d.y()) > std::abs(d[kz])) kz = 1;
  if (std::abs(d.z()) > std::abs(d[kz])) kz = 2;
  int kx = (kz + 1) % 3;
  int ky = (kx + 1) % 3;
  if (d[kz] < 0) std::swap(kx, ky);
  const double sx = d[kx] / d[kz], sy = d[ky] / d[kz], sz = 1.0 / d[kz];
  const Vec3 a = tri.v[0] - ray.origin, b = tri.v[1] - ray.origin, c = tri.v[2] - ray.origin;
  const double ax = a[kx] - sx * a[kz], ay = a[ky] - sy * a[kz];
  const double bx = b[kx] - sx * b[kz], by = b[ky] - sy * b[kz];
  const double cx = c[kx] - sx * c[kz], cy = c[ky] - sy * c[kz];
  double u = cx * by - cy * bx, v = ax * cy - ay * cx, w = bx * ay - by * ax;
  if (u == 0 || v == 0 || w == 0) {
    using L = long double;
    u = static_cast<double>(L(cx) * L(by) - L(cy) * L(bx));
    v = static_cast<double>(L(ax) * L(cy) - L(ay) * L(cx));
    w = static_cast<double>(L(bx) * L(ay) - L(by) * L(ax));
  }
  if ((u < 0 || v < 0 || w < 0) && (u > 0 || v > 0 || w > 0)) return Hit::miss();
  const double det = u + v + w;
  if (det == 0) return Hit::miss();
  // u belongs to edge b→c, v to c→a, w to a→b.
  auto owns = [](double ex, double ey) { return ey > 0 || (ey == 0 && ex > 0); };
  if (u == 0 && !owns(cx - bx, cy - by)) return Hit::miss();
  if (v == 0 && !owns(ax - cx, ay - cy)) return Hit::miss();
  if (w == 0 && !owns(bx - ax, by - ay)) return Hit::miss();
  const double t_scaled = u * (sz * a[kz]) + v * (sz * b[kz]) + w * (sz * c[kz]);
  return triangle_hit(t_scaled / det, det > 0, u == 0 || v == 0 || w == 0, rule);
}

namespace {
// Shared tail of the box variants: the ray's parameter interval inside the closed box.
Hit box_hit(double t_min, double t_max, HitRule rule) {
  if (!(t_min <= t_max)) return Hit::miss();
  if (t_min > 0) {
    if (t_min == t_max) return rule == HitRule::enter_only ? Hit::miss() : Hit{HitClass::tangent, t_min};
    return {HitClass::enter, t_min};
  }
  if (t_max > 0 && rule == HitRule::nearest_contact) return {HitClass::exit, t_max};
  return Hit::miss();
}
}  // namespace

// Naive slab test as usually written (Kay & Kajiya 1986; Scratchapixel's ray–box lesson):
// per-axis division by d and plain comparisons, no care for zero or −0.0 components — 0/0 is
// NaN when the origin lies on a slab plane, and a NaN bound then poisons the interval.
Hit box_slab(const Ray& ray, const Box& b, HitRule rule) {
  double t_min = (b.min.x() - ray.origin.x()) / ray.direction.x();
  double t_max = (b.max.x() - ray.origin.x()) / ray.direction.x();
  if (t_min > t_max) std::swap(t_min, t_max);
  for (int i = 1; i < 3; ++i) {
    double t0 = (b.min[i] - ray.origin[i]) / ray.direction[i];
    double t1 = (b.max[i] - ray.origin[i]) / ray.direction[i];
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
// 1 + 2γ(3) (Ize, "Robust BVH Ray Traversal", JCGT 2013).
Hit box_robust_slab(const Ray& ray, const Box& b, HitRule rule) {
  double t_min = -kInf, t_max = kInf;
  for (int i = 0; i < 3; ++i) {
    const double inv = 1 / ray.direction[i];  // ±inf for ±0.0
    const bool negative = std::signbit(inv);
    const double near_plane = negative ? b.max[i] : b.min[i];
    const double far_plane = negative ? b.min[i] : b.max[i];
    const double t_near = (near_plane - ray.origin[i]) * inv;
    const double t_far = (far_plane - ray.origin[i]) * inv * (1 + 2 * gamma(3));
    // Written so that a NaN (0·inf: origin on the slab plane, zero direction) leaves the bound alone.
    t_min = t_near > t_min ? t_near : t_min;
    t_max = t_far < t_max ? t_far : t_max;
  }
  return box_hit(t_min, t_max, rule);
}

namespace {
template <class S, Hit (*F)(const Ray&, const S&, HitRule)>
Hit erase(const Ray& ray, const Shape& shape, HitRule rule) {
  return F(ray, std::get<S>(shape), rule);
}

constexpr Variant kVariants[] = {
    {"textbook", ShapeKind::sphere, "Rietmann 2020: (-b ± sqrt(b^2-4ac)) / 2a",
     erase<Sphere, sphere_textbook>},
    {"stable", ShapeKind::sphere, "DGL Wiki 2012 / Numerical Recipes: q = -(b + sgn(b) sqrt D)/2",
     erase<Sphere, sphere_stable>},
    {"stable-fma", ShapeKind::sphere, "stable roots, Kahan 2004 FMA discriminant",
     erase<Sphere, sphere_stable_fma>},
    {"hearn-baker", ShapeKind::sphere, "Ray Tracing Gems ch. 7 eqs. 7-10",
     erase<Sphere, sphere_hearn_baker>},
    {"direct", ShapeKind::plane, "t = (d - n.o) / n.dir", erase<Plane, plane_direct>},
    {"moller-trumbore", ShapeKind::triangle, "Moller & Trumbore, JGT 1997",
     erase<Triangle, triangle_moller_trumbore>},
    {"watertight", ShapeKind::triangle, "Woop, Benthin & Wald, JCGT 2013",
     erase<Triangle, triangle_watertight>},
    {"watertight-top-left", ShapeKind::triangle, "Woop, Benthin & Wald 2013 + a top-left tie rule on zero edge functions",
     erase<Triangle, triangle_watertight_top_left>},
    {"slab", ShapeKind::box, "naive slab test, Kay & Kajiya 1986", erase<Box, box_slab>},
    {"robust-slab", ShapeKind::box, "Williams et al. 2005 + Ize 2013",
     erase<Box, box_robust_slab>},
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

std::string_view to_string(Precision p) { return p == Precision::f32 ? "float" : "double"; }

Hit Variant::intersect(const Ray& ray, const Shape& shape, HitRule rule) const {
  if (kernel) return kernel(ray, shape, rule_for(rule));
  Hit out;
  const Query q{ray, shape, {}};
  external->answer_all(std::span(&q, 1), std::span(&out, 1));
  return out;
}

void Variant::intersect_all(std::span<const Query> qs, HitRule rule, std::span<Hit> out) const {
  if (!kernel) return external->answer_all(qs, out);
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
