#include "rayproof/fuzz/generators.h"

#include <cmath>

#include "rayproof/core/variants.h"

namespace rayproof::fuzz {

std::string_view to_string(Family f) {
  switch (f) {
    case Family::random: return "random";
    case Family::tangent: return "tangent";
    case Family::grazing: return "grazing";
    case Family::near_origin: return "near-origin";
    case Family::exit_entry: return "exit-entry";
    case Family::extremes: return "extremes";
  }
  return "?";
}

std::optional<Family> family_from_string(std::string_view s) {
  for (Family f : kAllFamilies)
    if (to_string(f) == s) return f;
  return std::nullopt;
}

std::string_view to_string(Construction c) { return c == Construction::full ? "full" : "exact"; }

bool has_full_construction(Family f) { return f != Family::random && f != Family::near_origin; }

std::string family_label(Family f, Construction c) {
  return std::string(to_string(f)) + (c == Construction::full && has_full_construction(f) ? "-full" : "");
}

namespace {

struct Rng : SplitMix64 {
  double uniform(double lo, double hi) { return lo + (hi - lo) * unit(); }
  long integer(long lo, long hi) { return lo + static_cast<long>(next() % std::uint64_t(hi - lo + 1)); }
  Vec3 ivec(long r) {
    return vec_z_first([&] { return double(integer(-r, r)); });
  }
  Vec3 uvec(double r) {
    return vec_z_first([&] { return uniform(-r, r); });
  }
  Vec3 direction() {  // a random unit-ish vector (not exactly unit; any non-zero vector will do)
    Vec3 v;
    do v = uvec(1);
    while (dot(v, v) > 1 || dot(v, v) < 1e-4);
    return v;
  }
};

Vec3 scaled(const Vec3& v, int k) { return v * std::ldexp(1.0, k); }
Shape scaled(const Shape& s, int k) { return rayproof::scaled(s, std::ldexp(1.0, k)); }
// The case with its shape and ray origin moved to scale 2^k and its direction to 2^k_direction
// (exact: powers of two, while nothing under- or overflows); its detail is the caller's to extend.
GeneratedCase at_scale(GeneratedCase c, int k, int k_direction) {
  c.ray = Ray{scaled(c.ray.origin, k), scaled(c.ray.direction, k_direction)};
  c.shape = scaled(c.shape, k);
  return c;
}
GeneratedCase at_scale(GeneratedCase c, int k) { return at_scale(std::move(c), k, k); }

// One case under construction: exact geometry first, then `nudges` applied to the origin.
struct Builder {
  Rng rng;
  bool nudging = true;
  bool full = false;  // Construction::full

  // ---------------------------------------------------------- the full-precision construction
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
    Builder pair{Rng{seed ^ (0x5A5A5A5Aull + (index / 2) * 0x9E3779B97F4A7C15ull)}, nudging, true};
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

  // ±j ulps on one random origin component, j ∈ [−3, 3] (0 keeps the exact construction).
  std::string nudge_origin(Ray& ray) {
    const int j = static_cast<int>(rng.integer(-3, 3));
    const int axis = static_cast<int>(rng.integer(0, 2));
    if (!nudging || j == 0) return "exact";
    ray.origin[axis] = nudge(ray.origin[axis], j);
    return (j > 0 ? "+" : "") + std::to_string(j) + "ulp";
  }

  // A Pythagorean quadruple x² + y² + z² = r² with r > 0 (Lebesgue's parametrisation).
  void quadruple(Vec3& n, double& r) {
    long a, b, c, d;
    do {
      a = rng.integer(0, 12), b = rng.integer(0, 12), c = rng.integer(0, 12), d = rng.integer(0, 12);
    } while (a * a + b * b + c * c + d * d == 0);
    n = Vec3(a * a + b * b - c * c - d * d, 2 * (a * d + b * c), 2 * (b * d - a * c));
    r = static_cast<double>(a * a + b * b + c * c + d * d);
  }

  // A non-zero integer vector perpendicular to n.
  Vec3 perpendicular(const Vec3& n) {
    Vec3 t;
    do t = cross(n, rng.ivec(5));
    while (t == Vec3::Zero());
    return t;
  }

  Triangle integer_triangle(long r) {
    Triangle t;
    do t = Triangle{{rng.ivec(r), rng.ivec(r), rng.ivec(r)}};
    while (degenerate_reason(t));
    return t;
  }

  Box integer_box(long r) {
    const Vec3 lo = rng.ivec(r);
    return Box{lo, lo + vec_z_first([&] { return double(rng.integer(1, r)); })};
  }

  // ------------------------------------------------------------------------------- families
  GeneratedCase random(ShapeKind kind) {
    const int k = static_cast<int>(rng.integer(-3, 3));
    const double s = std::ldexp(1.0, k);
    Shape shape;
    switch (kind) {
      case ShapeKind::sphere: shape = Sphere{rng.uvec(s), s * rng.uniform(0.1, 1)}; break;
      case ShapeKind::plane: shape = Plane{rng.direction(), rng.uniform(-s, s)}; break;
      case ShapeKind::triangle: {
        Triangle t;
        do t = Triangle{{rng.uvec(s), rng.uvec(s), rng.uvec(s)}};
        while (degenerate_reason(t));
        shape = t;
        break;
      }
      case ShapeKind::box: {
        const Vec3 c = rng.uvec(s), h = vec_z_first([&] { return rng.uniform(0.1, 1) * s; });
        shape = Box{c - h, c + h};
        break;
      }
    }
    const Vec3 o = 5 * s * rng.direction();
    return {Ray{o, rng.uvec(1.5 * s) - o}, shape, "random"};
  }

  // The exact construction c at scale 2^k, its origin then nudged; detail "what/2^k/nudge".
  GeneratedCase scaled_and_nudged(GeneratedCase c, int k) {
    c = at_scale(std::move(c), k);
    const std::string n = nudge_origin(c.ray);
    c.detail += "/2^" + std::to_string(k) + "/" + n;
    return c;
  }

  GeneratedCase tangent(ShapeKind kind) {
    const int k = static_cast<int>(rng.integer(-40, 40));
    if (full) return tangent_full(kind, k);
    switch (kind) {
      case ShapeKind::sphere: return scaled_and_nudged(tangent_sphere(), k);
      case ShapeKind::plane: return scaled_and_nudged(in_plane(), k);
      case ShapeKind::triangle: return scaled_and_nudged(coplanar(), k);
      case ShapeKind::box: break;
    }
    return scaled_and_nudged(along_box(), k);
  }

  GeneratedCase tangent_sphere() {  // touches the Pythagorean point P = m + n of |n| = r
    Vec3 n;
    double r;
    quadruple(n, r);
    const Vec3 m = rng.ivec(1 << 20), t = perpendicular(n);
    return {Ray{m + n - double(rng.integer(1, 8)) * t, t}, Sphere{m, r}, "sphere-tangent"};
  }

  GeneratedCase in_plane() {  // lies in the plane n·x = n·p
    const Vec3 n = rng.ivec(9), p = rng.ivec(1 << 20);
    const Vec3 nn = n == Vec3::Zero() ? Vec3(0, 0, 1) : n;
    const Vec3 t = perpendicular(nn);
    return {Ray{p - double(rng.integer(1, 8)) * t, t}, Plane{nn, dot(nn, p)}, "in-plane"};
  }

  GeneratedCase coplanar() {  // in the triangle's plane, through a dyadic point of it
    const Triangle tri = integer_triangle(1 << 10);
    const Vec3 e1 = tri.v[1] - tri.v[0], e2 = tri.v[2] - tri.v[0];
    const double a = rng.integer(-4, 8) / 4.0, b = rng.integer(-4, 8) / 4.0;
    const Vec3 through = tri.v[0] + a * e1 + b * e2;
    const double along2 = double(rng.integer(1, 3));
    const double along1 = double(rng.integer(-3, 3));
    const Vec3 d = along1 * e1 + along2 * e2;
    return {Ray{through - double(rng.integer(1, 4)) * d, d}, tri, "coplanar"};
  }

  GeneratedCase along_box() {  // along a face, along an edge, or touching an edge or a corner
    const Box b = integer_box(1 << 10);
    const Vec3 mid = 0.5 * (b.min + b.max);
    const long mode = rng.integer(0, 3);
    Vec3 at = mid, d;
    std::string what;
    if (mode == 0) {  // along the face x = min
      at.x() = b.min.x();
      const double dz = double(rng.integer(-3, 3));
      d = Vec3(0, double(rng.integer(1, 3)), dz);
      what = "along-face";
    } else if (mode == 1) {  // along the edge x = min, y = min
      at.x() = b.min.x(), at.y() = b.min.y();
      d = Vec3(0, 0, 1);
      what = "along-edge";
    } else if (mode == 2) {  // touches the edge x = min, y = min at one point
      at.x() = b.min.x(), at.y() = b.min.y();
      const double dz = double(rng.integer(-3, 3));
      const double dy = -double(rng.integer(1, 3));
      d = Vec3(double(rng.integer(1, 3)), dy, dz);
      what = "touch-edge";
    } else {  // touches the corner min
      at = b.min;
      d = vec_z_first([&] { return double(rng.integer(1, 3)); });
      d.y() = -d.y(), d.z() = -d.z();
      what = "touch-corner";
    }
    return {Ray{at - double(rng.integer(1, 4)) * d, d}, b, what};
  }

  // Rays through triangle edges and vertices (in pairs sharing an edge), box edges and
  // corners, and near-tangent chords of spheres and planes.
  GeneratedCase grazing(ShapeKind kind, std::uint64_t index, std::uint64_t seed) {
    if (full) return grazing_full(kind, index, seed);
    const int k = static_cast<int>(rng.integer(-40, 40));
    switch (kind) {
      case ShapeKind::triangle: return shared_edge_pair(index, seed);
      case ShapeKind::box: return scaled_and_nudged(through_box_edge(), k);
      case ShapeKind::sphere: return scaled_and_nudged(sphere_chord(), k);
      case ShapeKind::plane: break;
    }
    return scaled_and_nudged(glancing_plane(), k);
  }

  // Pair p = index/2 shares ray, edge and scale (its own generator); its two cases are the
  // triangles on either side of the edge.
  GeneratedCase shared_edge_pair(std::uint64_t index, std::uint64_t seed) {
    Rng pair_rng{seed ^ (0xA5A5A5A5ull + (index / 2) * 0x9E3779B97F4A7C15ull)};
    Builder pair{pair_rng, nudging};
    const Vec3 v0 = pair.rng.ivec(1 << 10), v1 = pair.rng.ivec(1 << 10);
    Vec3 v2, v3;
    do {
      v2 = pair.rng.ivec(1 << 10);
      v3 = v0 + v1 - v2 +
           (pair.rng.integer(0, 1) ? Vec3(pair.rng.ivec(64)) : Vec3::Zero());  // opposite v2: a flat quad or a fold
    } while (degenerate_reason(Triangle{{v0, v1, v2}}) || degenerate_reason(Triangle{{v1, v0, v3}}));
    const double w = pair.rng.integer(0, 16) / 16.0;  // 0 or 1: a vertex
    const Vec3 target = 16 * v0 + w * 16 * (v1 - v0);
    const Vec3 d = pair.rng.ivec(7) + Vec3(0, 0, 8);
    const Ray ray{target - double(pair.rng.integer(1, 4)) * d, d};
    const Triangle t = index % 2 == 0 ? Triangle{{16 * v0, 16 * v1, 16 * v2}} : Triangle{{16 * v1, 16 * v0, 16 * v3}};
    const bool at_vertex = w == 0 || w == 1;
    const std::string what = std::string(at_vertex ? "vertex" : "shared-edge") + (index % 2 ? "/B" : "/A");
    const int pair_k = static_cast<int>(pair.rng.integer(-40, 40));  // shared by both triangles
    GeneratedCase c = pair.scaled_and_nudged({ray, t, what}, pair_k);
    c.shared_edge = !at_vertex;
    return c;
  }

  GeneratedCase through_box_edge() {
    const Box b = integer_box(1 << 10);
    const bool corner = rng.integer(0, 1) == 1;
    Vec3 at = 0.5 * (b.min + b.max);
    at.x() = b.min.x(), at.y() = b.min.y();
    if (corner) at.z() = b.min.z();
    const double dz = double(corner ? rng.integer(1, 5) : rng.integer(-5, 5));
    const double dy = double(rng.integer(1, 5));
    const Vec3 d(double(rng.integer(1, 5)), dy, dz);
    return {Ray{at - double(rng.integer(1, 4)) * d, d}, b, corner ? "through-corner" : "through-edge"};
  }

  GeneratedCase sphere_chord() {  // a chord at angle 2^-j to the tangent plane at P
    Vec3 n;
    double r;
    quadruple(n, r);
    const Vec3 m = rng.ivec(1 << 20), t = perpendicular(n);
    const int j = static_cast<int>(rng.integer(10, 40));
    const Vec3 d = t - std::ldexp(1.0, -j) * n;
    return {Ray{m + n - d, d}, Sphere{m, r}, "chord-2^-" + std::to_string(j)};
  }

  GeneratedCase glancing_plane() {
    const Vec3 n = rng.ivec(9), p = rng.ivec(1 << 20);
    const Vec3 nn = n == Vec3::Zero() ? Vec3(0, 0, 1) : n;
    const int j = static_cast<int>(rng.integer(10, 40));
    const Vec3 d = perpendicular(nn) - std::ldexp(1.0, -j) * nn;
    return {Ray{p - d, d}, Plane{nn, dot(nn, p)}, "glancing-2^-" + std::to_string(j)};
  }

  // Secondary rays from a variant's own computed hit point (the built-in variants take turns by
  // index), leaving the surface outward, and rays from points exactly on the surface. Only
  // built-in code spawns: case i must be a pure function of (seed, family, shape, i), whatever
  // plugins or exec commands are loaded (issue 25: an extra plugin changed this family's cases).
  GeneratedCase near_origin(ShapeKind kind, std::uint64_t index) {
    auto variants = variants_for(kind);
    std::erase_if(variants, [](const Variant* v) { return v->kernel == nullptr || v->external != nullptr; });
    const Variant& v = *variants[index % variants.size()];
    for (int attempt = 0; attempt < 64; ++attempt) {
      const int k = static_cast<int>(rng.integer(-40, 40));
      const GeneratedCase primary = at_scale(random(kind), k);
      const Hit h = v.intersect(primary.ray, primary.shape, HitRule::nearest_contact);
      if (h.cls == HitClass::miss || !h.has_t()) continue;
      const Vec3 p = primary.ray.at(h.t);
      Vec3 n = outward_normal(primary.shape, p);
      if (dot(n, primary.ray.direction) > 0) n = -n;  // the side the ray came from
      Vec3 d = rng.direction();
      if (dot(d, n) < 0) d = -d;
      if (!all_finite(p) || !all_finite(d)) continue;
      return {Ray{p, d}, primary.shape, "spawned-from-" + std::string(v.name) + "/2^" + std::to_string(k)};
    }
    return random(kind);
  }

  // Origins inside, exactly on, and one ulp outside spheres and boxes; back faces of
  // triangles and planes.
  GeneratedCase exit_entry(ShapeKind kind) {
    if (full) return exit_entry_full(kind);
    const int k = static_cast<int>(rng.integer(-40, 40));
    switch (kind) {
      case ShapeKind::sphere: return origin_at_sphere(k);
      case ShapeKind::box: return origin_at_box(k);
      case ShapeKind::triangle: return scaled_by(back_face(), k);
      case ShapeKind::plane: break;
    }
    return scaled_by(back_side(), k);
  }

  static GeneratedCase scaled_by(GeneratedCase c, int k) {
    c = at_scale(std::move(c), k);
    c.detail += "/2^" + std::to_string(k);
    return c;
  }

  GeneratedCase origin_at_sphere(int k) {
    Vec3 n;
    double r;
    quadruple(n, r);
    const Vec3 m = rng.ivec(1 << 20);
    const long mode = rng.integer(0, 2);
    Vec3 o = mode == 0 ? Vec3(m + 0.5 * n) : Vec3(m + n);
    const std::string what = mode == 0 ? "inside" : mode == 1 ? "on-surface" : "ulp-outside";
    Ray ray{scaled(o, k), scaled(Vec3(rng.ivec(9) + Vec3(0.5, 0, 0)), k)};
    if (mode == 2) {  // one ulp outward on the dominant normal axis
      int a = 0;
      for (int i = 1; i < 3; ++i)
        if (std::abs(n[i]) > std::abs(n[a])) a = i;
      ray.origin[a] = nudge(ray.origin[a], n[a] > 0 ? 1 : -1);
    }
    return {ray, scaled(Shape(Sphere{m, r}), k), what + "/2^" + std::to_string(k)};
  }

  GeneratedCase origin_at_box(int k) {
    const Box b = integer_box(1 << 10);
    const long mode = rng.integer(0, 3);
    Vec3 o = 0.5 * (b.min + b.max);
    if (mode >= 1) o.x() = b.min.x();  // on a face
    if (mode >= 2) o.y() = b.min.y();  // on an edge
    if (mode == 3) o.z() = b.min.z();  // on a corner
    std::string what = mode == 0 ? "inside" : mode == 1 ? "on-face" : mode == 2 ? "on-edge" : "on-corner";
    Ray ray{scaled(o, k), scaled(Vec3(rng.ivec(5) + Vec3(0.5, 0, 0)), k)};
    if (rng.integer(0, 1) == 1) {
      ray.origin.x() = nudge(ray.origin.x(), -1);
      what += "-ulp-outside";
    }
    return {ray, scaled(Shape(b), k), what + "/2^" + std::to_string(k)};
  }

  GeneratedCase back_face() {
    const Triangle t = integer_triangle(1 << 10);
    const Vec3 n = cross(t.v[1] - t.v[0], t.v[2] - t.v[0]);
    const Vec3 inner = 0.25 * (2 * t.v[0] + t.v[1] + t.v[2]);
    const Vec3 d = rng.direction();
    const Vec3 dd = dot(d, n) > 0 ? d : Vec3(-d);  // travels along n: meets the back face
    return {Ray{inner - dd, dd}, t, "back-face"};
  }

  GeneratedCase back_side() {
    const Vec3 n = rng.direction();
    const double off = rng.uniform(-4, 4);
    Vec3 d = rng.direction();
    if (dot(d, n) < 0) d = -d;
    return {Ray{Vec3(rng.uvec(4) - 8 * n), d}, Plane{n, off}, "back-side"};
  }

  GeneratedCase extremes(ShapeKind kind) {
    const long mode = rng.integer(0, 4);
    if (mode == 0) {  // the tangent family at 2^±500
      GeneratedCase c = tangent(kind);
      const int k = static_cast<int>(rng.integer(-460, 460));
      c = at_scale(std::move(c), k);
      c.detail += "/x2^" + std::to_string(k);
      return c;
    }
    if (mode == 1) {  // the random family at 2^±500
      GeneratedCase c = random(kind);
      const int k = static_cast<int>(rng.integer(-500, 500));
      c = at_scale(std::move(c), k);
      c.detail = "random/2^" + std::to_string(k);
      return c;
    }
    if (mode == 2) {  // subnormal and −0.0 direction components
      GeneratedCase c = random(kind);
      for (int i = 0; i < 3; ++i) {
        const long pick = rng.integer(0, 3);
        if (pick == 0) c.ray.direction[i] = -0.0;
        if (pick == 1) c.ray.direction[i] = std::ldexp(rng.uniform(-1, 1), -1060);
      }
      if (c.ray.direction == Vec3::Zero()) c.ray.direction.x() = 1;
      return {c.ray, c.shape, "subnormal-or-negative-zero"};
    }
    if (mode == 3 && kind == ShapeKind::sphere) {
      if (rng.integer(0, 1) == 0) {  // a tiny sphere far away (Ray Tracing Gems ch. 7)
        const double dist = std::ldexp(1.0, static_cast<int>(rng.integer(20, 60)));
        const double r = std::ldexp(1.0, static_cast<int>(rng.integer(-4, 4)));
        const double mz = rng.uniform(-1.5, 1.5) * r;
        const Vec3 m(dist, rng.uniform(-1.5, 1.5) * r, mz);
        return {Ray{Vec3::Zero(), Vec3(1, 0, 0)}, Sphere{m, r}, "tiny-far-sphere"};
      }
      // a huge sphere used as a ground plane
      // radius 2^20…2^40 (1e6…1e12); no libm call, so every machine builds the same case
      const int big_exponent = static_cast<int>(rng.integer(20, 39));
      const double big = std::ldexp(rng.uniform(1, 2), big_exponent);
      const double oz = rng.uniform(-10, 10);
      const double oy = rng.uniform(0.5, 10);
      const Vec3 o(rng.uniform(-10, 10), oy, oz);
      const double dz = rng.uniform(-1, 1);
      const double dy = -rng.uniform(0.01, 1);
      const Vec3 d(rng.uniform(-1, 1), dy, dz);
      return {Ray{o, d}, Sphere{Vec3(0, -big, 0), big}, "huge-ground-sphere"};
    }
    // b² and |o − m|² beyond the double range
    GeneratedCase c = random(kind);
    const int k = static_cast<int>(rng.integer(560, 1000));
    c = at_scale(std::move(c), k, k - 200);
    c.detail = "overflow/2^" + std::to_string(k);
    return c;
  }
};

std::uint64_t case_seed(Family f, ShapeKind s, std::uint64_t seed, std::uint64_t index) {
  Rng r{seed * 0x9E3779B97F4A7C15ull + static_cast<std::uint64_t>(f) * 0x100000001B3ull +
        static_cast<std::uint64_t>(s) * 0xC2B2AE3D27D4EB4Full};
  r.state ^= index * 0xD6E8FEB86659FD93ull;
  return r.next();
}

GeneratedCase build(Family family, ShapeKind shape, std::uint64_t seed, std::uint64_t index, bool nudging,
                    Construction construction) {
  const bool full = construction == Construction::full && has_full_construction(family);
  // The full construction draws from its own stream: the exact family's cases stay what they were.
  Builder b{Rng{case_seed(family, shape, seed, index) ^ (full ? 0xF011F011F011F011ull : 0)}, nudging, full};
  switch (family) {
    case Family::random: return b.random(shape);
    case Family::tangent: return b.tangent(shape);
    case Family::grazing: return b.grazing(shape, index, seed);
    case Family::near_origin: return b.near_origin(shape, index);
    case Family::exit_entry: return b.exit_entry(shape);
    case Family::extremes: return b.extremes(shape);
  }
  return b.random(shape);
}

}  // namespace

GeneratedCase generate(Family family, ShapeKind shape, std::uint64_t seed, std::uint64_t index,
                       Construction construction) {
  GeneratedCase c = build(family, shape, seed, index, true, construction);
  // Rounding can, rarely, make a full-precision construction degenerate: draw again, deterministically.
  for (std::uint64_t retry = 1; !is_valid_query(c.ray, c.shape) && retry < 16; ++retry)
    c = build(family, shape, seed ^ (retry * 0x9E3779B97F4A7C15ull), index, true, construction);
  return c;
}

GeneratedCase generate_unnudged(Family family, ShapeKind shape, std::uint64_t seed, std::uint64_t index) {
  return build(family, shape, seed, index, false, Construction::exact);
}

}  // namespace rayproof::fuzz
