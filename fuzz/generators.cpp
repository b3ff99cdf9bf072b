#include "rayproof/fuzz/generators.h"

#include <array>
#include <cmath>

#include "rayproof/core/variants.h"
#include "case_draws.h"

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

// Scaling by a power of two is exact while nothing under- or overflows.
GeneratedCase at_scale(GeneratedCase c, int k, int k_direction) {
  const double s = std::ldexp(1.0, k), s_direction = std::ldexp(1.0, k_direction);
  c.ray = Ray{c.ray.origin * s, c.ray.direction * s_direction};
  c.shape = scaled(c.shape, s);
  return c;
}
GeneratedCase at_scale(GeneratedCase c, int k) { return at_scale(std::move(c), k, k); }

namespace {

// One case under construction: exact geometry first, then `nudges` applied to the origin.
struct Builder {
  CaseRng rng;
  bool nudging = true;
  bool full = false;  // Construction::full

  // ±j ulps on one random origin component, j ∈ [−3, 3] (0 keeps the exact construction).
  std::string nudge_origin(Ray& ray) {
    const int j = static_cast<int>(rng.integer(-3, 3));
    const int axis = static_cast<int>(rng.integer(0, 2));
    if (!nudging || j == 0) return "exact";
    ray.origin[axis] = nudge(ray.origin[axis], j);
    std::string label = std::to_string(j) + "ulp";
    return j > 0 ? "+" + label : label;
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
    constexpr double kPowersOfTwo[7] = {0x1p-3, 0x1p-2, 0x1p-1, 1, 0x1p1, 0x1p2, 0x1p3};
    const double s = kPowersOfTwo[k + 3];  // 2^k (std::ldexp is a library call: 1.5% of a random case)
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

  // The exact construction c at scale 2^k; detail "what/2^k".
  static GeneratedCase scaled_by(GeneratedCase c, int k) {
    c = at_scale(std::move(c), k);
    c.detail += "/2^" + std::to_string(k);
    return c;
  }
  // The same, its origin then nudged; detail "what/2^k/nudge".
  GeneratedCase scaled_and_nudged(GeneratedCase c, int k) {
    c = scaled_by(std::move(c), k);
    const std::string nudged = nudge_origin(c.ray);
    c.detail += "/" + nudged;
    return c;
  }

  GeneratedCase tangent(ShapeKind kind) {
    const int k = static_cast<int>(rng.integer(-40, 40));
    if (full) return tangent_full(rng, kind, k);
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
    if (full) return grazing_full(rng, kind, index, seed);
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
    CaseRng pair_rng{seed ^ (0xA5A5A5A5ull + (index / 2) * 0x9E3779B97F4A7C15ull)};
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
  // index), leaving the surface outward, and rays from points exactly on the surface. Only the
  // compile-time built-ins spawn, never the registry: case i must be a pure function of (seed,
  // family, shape, i), whatever a program registers (issue 25: a plugin changed this family's
  // cases; issue 41: so did the certified variants `main` registers).
  GeneratedCase near_origin(ShapeKind kind, std::uint64_t index) {
    static const std::array<std::vector<const Variant*>, 4> by_kind = [] {  // fixed: built once
      std::array<std::vector<const Variant*>, 4> out;
      for (const Variant& v : builtin_variants()) out[static_cast<int>(v.shape)].push_back(&v);
      return out;
    }();
    const std::vector<const Variant*>& spawners = by_kind[static_cast<int>(kind)];
    const Variant& v = *spawners[index % spawners.size()];
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
    if (full) return exit_entry_full(rng, kind);
    const int k = static_cast<int>(rng.integer(-40, 40));
    switch (kind) {
      case ShapeKind::sphere: return origin_at_sphere(k);
      case ShapeKind::box: return origin_at_box(k);
      case ShapeKind::triangle: return scaled_by(back_face(), k);
      case ShapeKind::plane: break;
    }
    return scaled_by(back_side(), k);
  }

  GeneratedCase origin_at_sphere(int k) {
    Vec3 n;
    double r;
    quadruple(n, r);
    const Vec3 m = rng.ivec(1 << 20);
    const long mode = rng.integer(0, 2);
    Vec3 o = mode == 0 ? Vec3(m + 0.5 * n) : Vec3(m + n);
    const std::string what = mode == 0 ? "inside" : mode == 1 ? "on-surface" : "ulp-outside";
    const Vec3 d = rng.ivec(9) + Vec3(0.5, 0, 0);
    GeneratedCase c = scaled_by({Ray{o, d}, Sphere{m, r}, what}, k);
    if (mode == 2) {  // one ulp outward on the dominant normal axis
      int a = 0;
      for (int i = 1; i < 3; ++i)
        if (std::abs(n[i]) > std::abs(n[a])) a = i;
      c.ray.origin[a] = nudge(c.ray.origin[a], n[a] > 0 ? 1 : -1);
    }
    return c;
  }

  GeneratedCase origin_at_box(int k) {
    const Box b = integer_box(1 << 10);
    const long mode = rng.integer(0, 3);
    Vec3 o = 0.5 * (b.min + b.max);
    if (mode >= 1) o.x() = b.min.x();  // on a face
    if (mode >= 2) o.y() = b.min.y();  // on an edge
    if (mode == 3) o.z() = b.min.z();  // on a corner
    const std::string what = mode == 0 ? "inside" : mode == 1 ? "on-face" : mode == 2 ? "on-edge" : "on-corner";
    const Vec3 d = rng.ivec(5) + Vec3(0.5, 0, 0);
    const bool ulp_outside = rng.integer(0, 1) == 1;
    GeneratedCase c = scaled_by({Ray{o, d}, b, what + (ulp_outside ? "-ulp-outside" : "")}, k);
    if (ulp_outside) c.ray.origin.x() = nudge(c.ray.origin.x(), -1);
    return c;
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
  CaseRng r{seed * 0x9E3779B97F4A7C15ull + static_cast<std::uint64_t>(f) * 0x100000001B3ull +
            static_cast<std::uint64_t>(s) * 0xC2B2AE3D27D4EB4Full};
  r.state ^= index * 0xD6E8FEB86659FD93ull;
  return r.next();
}

GeneratedCase build(Family family, ShapeKind shape, std::uint64_t seed, std::uint64_t index, bool nudging,
                    Construction construction) {
  const bool full = construction == Construction::full && has_full_construction(family);
  // The full construction draws from its own stream: the exact family's cases stay what they were.
  Builder b{CaseRng{case_seed(family, shape, seed, index) ^ (full ? 0xF011F011F011F011ull : 0)}, nudging, full};
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
