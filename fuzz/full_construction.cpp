// The full-precision construction (Construction::full): the tangent, grazing and exit-entry
// families built from numbers with random 53-bit mantissas, their features computed in double, so
// the cases are what real scenes hold rather than the exact construction's small integers.
#include <cmath>
#include <string>

#include "case_draws.h"

namespace rayproof::fuzz {

namespace {

struct FullConstruction {
  CaseRng& rng;

  // A number with a random 53-bit mantissa, sign and magnitude within [2^(k−1), 2^k).
  double full_number(int k) {
    const double m = 1 + rng.unit();  // [1, 2): every mantissa bit random
    return std::ldexp(rng.integer(0, 1) ? m : -m, k - 1);
  }
  Vec3 full_vec(int k) {
    return vec_z_first([&] { return full_number(k - static_cast<int>(rng.integer(0, 3))); });
  }
  Vec3 full_direction() {  // full mantissas, no component much smaller than the others
    Vec3 d;
    do d = full_vec(0);
    while (dot(d, d) < 0.1);
    return d;
  }
  // A unit-ish vector perpendicular to d, computed in double (so only nearly perpendicular).
  Vec3 full_perpendicular(const Vec3& d) {
    Vec3 p;
    do p = cross(d, full_direction());
    while (dot(p, p) < 1e-3 * dot(d, d));
    return p / std::sqrt(dot(p, p));
  }
  // A ray through `at` (computed in double) along d: o = at − s·d, s ∈ [1, 2^12) with a full
  // mantissa. A far origin makes every product the variant forms larger than the feature's own
  // rounding, which is where formulas differ.
  Ray full_ray_through(const Vec3& at, const Vec3& d) {
    const int e = static_cast<int>(rng.integer(0, 11));
    const double s = std::ldexp(1 + rng.unit(), e);
    return Ray{at - s * d, d};
  }

  GeneratedCase tangent_full(ShapeKind kind, int k) {
    const double s = std::ldexp(1.0, k);
    const Vec3 m = full_vec(k + static_cast<int>(rng.integer(0, 20)));  // centres up to 2^20 radii out
    const Vec3 d = full_direction() * s;
    switch (kind) {
      case ShapeKind::sphere: {  // touches P = m + r·n, n ⊥ d, all in double
        const double r = std::fabs(full_number(k));
        const Vec3 n = full_perpendicular(d);
        return {full_ray_through(m + r * n, d), Sphere{m, r}, "sphere-tangent-full/2^" + std::to_string(k)};
      }
      case ShapeKind::plane: {  // runs along n·x = n·p, d ⊥ n in double
        const Vec3 n = full_direction();
        const Vec3 along = full_perpendicular(n) * s;
        return {full_ray_through(m, along), Plane{n, dot(n, m)}, "in-plane-full/2^" + std::to_string(k)};
      }
      case ShapeKind::triangle: {  // in the triangle's plane through an inner, edge or outer point
        const Triangle t = full_triangle(m, k);
        const Vec3 e1 = t.v[1] - t.v[0], e2 = t.v[2] - t.v[0];
        const double a = rng.uniform(-0.25, 1.25), b = rng.uniform(-0.25, 1.25);
        const double along2 = rng.uniform(0.25, 1);
        const double along1 = rng.uniform(-1, 1);
        const Vec3 along = along1 * e1 + along2 * e2;
        return {full_ray_through(t.v[0] + a * e1 + b * e2, along), t, "coplanar-full/2^" + std::to_string(k)};
      }
      case ShapeKind::box: break;
    }
    const Box b = full_box(m, k);  // along a face, along an edge, touching an edge or a corner
    const long mode = rng.integer(0, 3);
    Vec3 at = point_in(b);
    Vec3 dir = full_direction() * s;
    at.x() = b.min.x();
    if (mode == 0) dir.x() = 0;                                                  // along the face x = min
    if (mode >= 1) at.y() = b.min.y();                                           // at the edge x = min, y = min
    if (mode == 1) dir.x() = 0, dir.y() = 0;                                     // along it
    if (mode == 2) dir.x() = std::fabs(dir.x()), dir.y() = -std::fabs(dir.y());  // touching it
    if (mode == 3) at.z() = b.min.z(), dir = Vec3(std::fabs(dir.x()), -std::fabs(dir.y()), -std::fabs(dir.z()));
    static const char* what[] = {"along-face-full", "along-edge-full", "touch-edge-full", "touch-corner-full"};
    return {full_ray_through(at, dir), b, std::string(what[mode]) + "/2^" + std::to_string(k)};
  }

  Triangle full_triangle(const Vec3& centre, int k) {
    Triangle t;
    do t = Triangle{{centre + full_vec(k), centre + full_vec(k), centre + full_vec(k)}};
    while (degenerate_reason(t));
    return t;
  }
  Box full_box(const Vec3& centre, int k) {
    const Vec3 lo = centre + full_vec(k);
    return Box{lo, lo + vec_z_first([&] { return std::fabs(full_number(k)); })};
  }
  Vec3 point_in(const Box& b) {
    const double z = rng.uniform(b.min.z(), b.max.z());
    const double y = rng.uniform(b.min.y(), b.max.y());
    const double x = rng.uniform(b.min.x(), b.max.x());
    return Vec3(x, y, z);
  }

  GeneratedCase grazing_full(ShapeKind kind, std::uint64_t index, std::uint64_t seed) {
    const int k = static_cast<int>(rng.integer(-40, 40));
    const double s = std::ldexp(1.0, k);
    const Vec3 m = full_vec(k + static_cast<int>(rng.integer(0, 20)));
    switch (kind) {
      case ShapeKind::triangle: return shared_edge_pair_full(index, seed);
      case ShapeKind::box: {  // across an edge or a corner from outside to outside: a clip or a miss within rounding
        const Box b = full_box(m, k);
        const bool corner = rng.integer(0, 1) == 1;
        Vec3 at(b.min.x(), b.min.y(), corner ? b.min.z() : rng.uniform(b.min.z(), b.max.z()));
        const double dz = corner ? -std::fabs(full_number(k)) : full_number(k);
        const double dy = -std::fabs(full_number(k));
        const double dx = std::fabs(full_number(k));
        const Vec3 d(dx, dy, dz);
        return {full_ray_through(at, d), b,
                std::string(corner ? "through-corner-full" : "through-edge-full") + "/2^" + std::to_string(k)};
      }
      case ShapeKind::sphere: {  // a chord at angle 2^-j to the tangent plane at P
        const double r = std::fabs(full_number(k));
        const Vec3 t = full_direction() * s, n = full_perpendicular(t);
        const int j = static_cast<int>(rng.integer(10, 40));
        const Vec3 d = t - std::ldexp(r, -j) * n;
        return {full_ray_through(m + r * n, d), Sphere{m, r},
                "chord-full-2^-" + std::to_string(j) + "/2^" + std::to_string(k)};
      }
      case ShapeKind::plane: break;
    }
    const Vec3 n = full_direction();
    const int j = static_cast<int>(rng.integer(10, 40));
    const Vec3 d = full_perpendicular(n) * s - std::ldexp(s, -j) * n;
    return {full_ray_through(m, d), Plane{n, dot(n, m)},
            "glancing-full-2^-" + std::to_string(j) + "/2^" + std::to_string(k)};
  }

  // Pair p = index/2: two triangles sharing the edge v0 v1 (full mantissas), the ray through a
  // point of it (or a vertex) computed in double.
  GeneratedCase shared_edge_pair_full(std::uint64_t index, std::uint64_t seed) {
    CaseRng pair_rng{seed ^ (0x5A5A5A5Aull + (index / 2) * 0x9E3779B97F4A7C15ull)};
    FullConstruction pair{pair_rng};
    const int k = static_cast<int>(pair.rng.integer(-40, 40));
    const Vec3 centre = pair.full_vec(k + static_cast<int>(pair.rng.integer(0, 20)));
    const Vec3 v0 = centre + pair.full_vec(k), v1 = centre + pair.full_vec(k);
    Vec3 v2, v3;
    do {
      v2 = centre + pair.full_vec(k);
      v3 = v0 + v1 - v2 + (pair.rng.integer(0, 1) ? Vec3(pair.full_vec(k - 4)) : Vec3::Zero());  // flat quad or fold
    } while (degenerate_reason(Triangle{{v0, v1, v2}}) || degenerate_reason(Triangle{{v1, v0, v3}}));
    const long w16 = pair.rng.integer(0, 16);  // 0 or 16: a vertex
    const Vec3 target = w16 == 16 ? v1 : v0 + pair.rng.unit() * (w16 == 0 ? 0.0 : 1.0) * (v1 - v0);
    const Vec3 n = cross(v1 - v0, v2 - v0);
    Vec3 d = pair.full_direction() * std::ldexp(1.0, k);
    if (dot(d, n) > 0) d = -d;  // towards the front of the first triangle
    const Triangle t = index % 2 == 0 ? Triangle{{v0, v1, v2}} : Triangle{{v1, v0, v3}};
    const bool at_vertex = w16 == 0 || w16 == 16;
    const std::string what = std::string(at_vertex ? "vertex" : "shared-edge") + (index % 2 ? "/B" : "/A");
    GeneratedCase c{pair.full_ray_through(target, d), t, what + "/full/2^" + std::to_string(k)};
    c.shared_edge = !at_vertex;
    return c;
  }

  GeneratedCase exit_entry_full(ShapeKind kind) {
    const int k = static_cast<int>(rng.integer(-40, 40));
    const Vec3 m = full_vec(k + static_cast<int>(rng.integer(0, 20)));
    const Vec3 d = full_direction() * std::ldexp(1.0, k);
    const std::string at = "/2^" + std::to_string(k);
    switch (kind) {
      case ShapeKind::sphere: {  // origin inside, or on the surface as double computes m + r·n
        const double r = std::fabs(full_number(k));
        const Vec3 n = full_direction();
        const bool inside = rng.integer(0, 2) == 0;
        const Vec3 o = m + (inside ? 0.5 : 1.0) * r * (n / std::sqrt(dot(n, n)));
        return {Ray{o, d}, Sphere{m, r}, (inside ? "inside-full" : "on-surface-full") + at};
      }
      case ShapeKind::box: {  // origin inside, on a face, an edge or a corner (exact copies of the bounds)
        const Box b = full_box(m, k);
        const long mode = rng.integer(0, 3);
        Vec3 o = point_in(b);
        if (mode >= 1) o.x() = b.min.x();
        if (mode >= 2) o.y() = b.min.y();
        if (mode == 3) o.z() = b.min.z();
        static const char* what[] = {"inside-full", "on-face-full", "on-edge-full", "on-corner-full"};
        return {Ray{o, d}, b, what[mode] + at};
      }
      case ShapeKind::triangle: {  // from just in front of an inner point, meeting the back face
        const Triangle t = full_triangle(m, k);
        const Vec3 n = cross(t.v[1] - t.v[0], t.v[2] - t.v[0]);
        const double a = rng.uniform(0.05, 0.9), b = rng.uniform(0.05, 0.95 - a);
        const Vec3 inner = t.v[0] + a * (t.v[1] - t.v[0]) + b * (t.v[2] - t.v[0]);
        const Vec3 dd = dot(d, n) > 0 ? d : Vec3(-d);
        return {full_ray_through(inner, dd), t, "back-face-full" + at};
      }
      case ShapeKind::plane: break;
    }
    const Vec3 n = full_direction();
    Vec3 dd = d;
    if (dot(dd, n) < 0) dd = -dd;
    return {full_ray_through(m, dd), Plane{n, dot(n, m)}, "back-side-full" + at};
  }
};

}  // namespace

GeneratedCase tangent_full(CaseRng& rng, ShapeKind kind, int k) { return FullConstruction{rng}.tangent_full(kind, k); }
GeneratedCase grazing_full(CaseRng& rng, ShapeKind kind, std::uint64_t index, std::uint64_t seed) {
  return FullConstruction{rng}.grazing_full(kind, index, seed);
}
GeneratedCase exit_entry_full(CaseRng& rng, ShapeKind kind) { return FullConstruction{rng}.exit_entry_full(kind); }

}  // namespace rayproof::fuzz
