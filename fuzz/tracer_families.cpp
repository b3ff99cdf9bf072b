#include "rayproof/fuzz/tracer_families.h"

#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>

#include "rayproof/core/mesh.h"
#include "rayproof/fuzz/generators.h"

namespace rayproof::fuzz {

std::string_view to_string(TracerFamily f) {
  switch (f) {
    case TracerFamily::shared_edges: return "shared-edges";
    case TracerFamily::fans: return "fans";
    case TracerFamily::axis_planes: return "axis-planes";
    case TracerFamily::needles: return "needles";
    case TracerFamily::spawned: return "spawned";
    case TracerFamily::shells: return "shells";
    case TracerFamily::far: return "far";
    case TracerFamily::random: return "random";
  }
  return "?";
}

std::optional<TracerFamily> tracer_family_from_string(std::string_view s) {
  for (TracerFamily f : kAllTracerFamilies)
    if (to_string(f) == s) return f;
  return std::nullopt;
}

namespace {

struct Rng {
  SplitMix64 g;
  Rng(std::uint64_t seed, std::uint64_t family, std::uint64_t mesh, std::uint64_t ray) {
    g.state = seed * 0x9E3779B97F4A7C15ull ^ (family + 1) * 0xD1B54A32D192ED03ull ^ mesh * 0xA24BAED4963EE407ull ^
              (ray + 1) * 0x9FB21C651E98DF25ull;
    g.next();
  }
  int between(int lo, int hi) { return lo + static_cast<int>(g.next() % static_cast<std::uint64_t>(hi - lo + 1)); }
  bool coin() { return g.next() & 1; }
  double unit() { return g.unit(); }
};

// A mesh under construction: vertices deduplicated by exact position (so neighbouring faces of a
// closed surface share their vertices and edges by index).
struct Builder {
  TriangleMesh mesh;
  std::map<std::array<double, 3>, std::uint32_t> index;
  std::uint32_t vertex(const Vec3& p) {
    const std::array<double, 3> key{p.x(), p.y(), p.z()};
    const auto [it, fresh] = index.try_emplace(key, static_cast<std::uint32_t>(mesh.vertex_count()));
    if (fresh) mesh.vertices.insert(mesh.vertices.end(), key.begin(), key.end());
    return it->second;
  }
  void triangle(std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    mesh.indices.insert(mesh.indices.end(), {a, b, c});
  }
  // Two triangles over the quad a b c d (counter-clockwise), split along either diagonal.
  void quad(std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d, bool other_diagonal) {
    if (other_diagonal)
      triangle(a, b, d), triangle(b, c, d);
    else
      triangle(a, b, c), triangle(a, c, d);
  }
};

Vec3 random_direction(Rng& r, int range) {
  Vec3 d;
  do d = vec_z_first([&] { return double(r.between(-range, range)); });
  while (d == Vec3::Zero());
  return d;
}

// A ray from o = P − 2^k·d through P (exact: P and d are small dyadics).
TracerRay through(const Vec3& p, const Vec3& d, Rng& r) {
  const double back = std::ldexp(1.0, r.between(0, 5));
  return {Ray{p - back * d, d}, 0, std::numeric_limits<double>::infinity()};
}

// A point of triangle t that is exact in dyadics: a vertex, an edge point at 1/2, 1/4 or 3/4
// (shared with the neighbour across that edge), or an interior point (1, 1, 2)/4.
Vec3 feature_point(const TriangleMesh& m, std::uint32_t t, Rng& r, std::string& detail) {
  const Triangle tri = m.triangle(t);
  const int k = r.between(0, 2), what = r.between(0, 5);
  if (what <= 1) return detail = "vertex", tri.v[k];
  if (what <= 4) {
    const double lambda[] = {0.5, 0.25, 0.75};
    const int l = r.between(0, 2);
    detail = l == 0 ? "edge 1/2" : l == 1 ? "edge 1/4" : "edge 3/4";
    return tri.v[k] + lambda[l] * (tri.v[(k + 1) % 3] - tri.v[k]);
  }
  detail = "interior";
  return (tri.v[0] + tri.v[1] + 2 * tri.v[2]) / 4;
}

Vec3 normal_of(const TriangleMesh& m, std::uint32_t t) {
  const Triangle tri = m.triangle(t);
  return cross(tri.v[1] - tri.v[0], tri.v[2] - tri.v[0]);
}

// A grid of n × n cells of side 4 with integer heights (0 everywhere when flat), consistently
// wound, diagonals chosen at random; `lift` offsets every height (shells).
void height_field(Builder& b, Rng& r, int n, bool flat, double lift = 0, std::uint64_t height_seed = 0) {
  Rng heights(height_seed, 99, 0, 0);
  std::vector<std::uint32_t> id((n + 1) * (n + 1));
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const double h = flat ? 0 : heights.between(-2, 2);
      id[j * (n + 1) + i] = b.vertex(Vec3(4.0 * i, 4.0 * j, h + lift));
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      b.quad(id[j * (n + 1) + i], id[j * (n + 1) + i + 1], id[(j + 1) * (n + 1) + i + 1], id[(j + 1) * (n + 1) + i],
             r.coin());
}

// The surface of the cube [0, 4n]^3, each face n × n cells, wound outward, sharing its edges.
void cube_surface(Builder& b, Rng& r, int n) {
  const double side = 4.0 * n;
  for (int axis = 0; axis < 3; ++axis)
    for (int positive = 0; positive < 2; ++positive) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;  // ∂u × ∂v points along +axis
      auto at = [&](int i, int j) {
        Vec3 p;
        p[axis] = positive ? side : 0, p[u] = 4.0 * i, p[v] = 4.0 * j;
        return b.vertex(p);
      };
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          const std::uint32_t a = at(i, j), c = at(i + 1, j), d = at(i + 1, j + 1), e = at(i, j + 1);
          if (positive)
            b.quad(a, c, d, e, r.coin());
          else
            b.quad(a, e, d, c, r.coin());
        }
    }
}

// Rays through exact feature points of random triangles, entering the front side where asked.
void aim_at_features(MeshWork& w, std::uint64_t seed, TracerFamily f, std::uint64_t m, std::uint64_t rays,
                     bool from_front) {
  for (std::uint64_t i = 0; i < rays; ++i) {
    Rng r(seed, static_cast<std::uint64_t>(f), m, i);
    const std::uint32_t t = static_cast<std::uint32_t>(r.g.next() % w.mesh->triangle_count());
    std::string detail;
    const Vec3 p = feature_point(*w.mesh, t, r, detail);
    Vec3 d = random_direction(r, 8);
    const double facing = dot(d, normal_of(*w.mesh, t));
    if (facing == 0)
      d = -normal_of(*w.mesh, t);
    else if (from_front && facing > 0)
      d = -d;
    w.rays.push_back(through(p, d, r));
    w.details.push_back(detail);
  }
}

// Triangles 2 … 65,536: n cells a side chosen log-uniformly, small ones more often.
int grid_size(Rng& r, int most) {
  const double u = r.unit();
  return std::max(1, std::min(most, static_cast<int>(std::exp2(u * u * std::log2(most)))));
}

MeshWork shared_edges(std::uint64_t seed, std::uint64_t m, std::uint64_t rays, TracerFamily f) {
  Rng r(seed, static_cast<std::uint64_t>(f), m, ~0ull);
  Builder b;
  const bool closed = r.between(0, 2) == 0;
  const bool full_precision = !closed && r.coin();
  if (closed)
    cube_surface(b, r, grid_size(r, 73));
  else {
    const bool flat = r.coin();
    height_field(b, r, grid_size(r, 181), flat, 0, seed ^ m);
  }
  if (full_precision) {
    // 53-bit scales per axis: every column of vertices still shares one x (and every row one y),
    // so node bounds of a BVH coincide with edges, but the arithmetic rounds everywhere.
    const Vec3 scale = vec_z_first([&] { return 1 + r.unit(); });
    for (std::size_t i = 0; i < b.mesh.vertices.size(); ++i) b.mesh.vertices[i] *= scale[i % 3];
  }
  MeshWork w{std::make_shared<TriangleMesh>(std::move(b.mesh)), {}, {}, 0};
  aim_at_features(w, seed, f, m, rays, closed || r.coin());
  if (full_precision)
    for (std::string& d : w.details) d += " (full precision)";
  return w;
}

MeshWork fans(std::uint64_t seed, std::uint64_t m, std::uint64_t rays, TracerFamily f) {
  Rng r(seed, static_cast<std::uint64_t>(f), m, ~0ull);
  Builder b;
  const int k = r.between(3, 16);
  const bool flat = r.coin();
  const double cz = r.between(-8, 8);
  const double cy = r.between(-64, 64);
  const Vec3 centre(r.between(-64, 64), cy, cz);
  const std::uint32_t c = b.vertex(centre);
  std::vector<std::uint32_t> ring;
  for (int i = 0; i < k; ++i) {
    const double angle = 2 * std::numbers::pi * (i + 0.25 * r.unit()) / k;
    ring.push_back(b.vertex(centre + Vec3(std::round(64 * std::cos(angle)), std::round(64 * std::sin(angle)),
                                          flat ? 0 : r.between(-16, 16))));
  }
  for (int i = 0; i < k; ++i) b.triangle(c, ring[i], ring[(i + 1) % k]);
  MeshWork w{std::make_shared<TriangleMesh>(std::move(b.mesh)), {}, {}, 0};
  for (std::uint64_t i = 0; i < rays; ++i) {
    Rng rr(seed, static_cast<std::uint64_t>(f), m, i);
    Vec3 d = random_direction(rr, 8);
    if (d.z() == 0) d.z() = rr.coin() ? 1 : -1;
    if (rr.between(0, 3) == 0) {  // a spoke, a quarter of the way out: a shared edge
      const int s = rr.between(0, k - 1);
      w.rays.push_back(through(centre + (w.mesh->vertex(ring[s]) - centre) / 4, d, rr));
      w.details.push_back("spoke 1/4");
    } else {
      w.rays.push_back(through(centre, d, rr));
      w.details.push_back(d.z() < 0 ? "centre from above" : "centre from below");
    }
  }
  return w;
}

MeshWork axis_planes(std::uint64_t seed, std::uint64_t m, std::uint64_t rays, TracerFamily f) {
  Rng r(seed, static_cast<std::uint64_t>(f), m, ~0ull);
  Builder b;
  const int boxes = r.between(1, 8);
  std::vector<double> planes[3];
  for (int i = 0; i < boxes; ++i) {
    Vec3 lo, hi;
    for (int k = 0; k < 3; ++k) {
      lo[k] = r.between(0, 12), hi[k] = lo[k] + r.between(1, 4);
      planes[k].push_back(lo[k]), planes[k].push_back(hi[k]);
    }
    // The box's six faces, wound outward (the cube construction on one cell per face).
    for (int axis = 0; axis < 3; ++axis)
      for (int positive = 0; positive < 2; ++positive) {
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        auto at = [&](int i2, int j2) {
          Vec3 p;
          p[axis] = positive ? hi[axis] : lo[axis], p[u] = i2 ? hi[u] : lo[u], p[v] = j2 ? hi[v] : lo[v];
          return b.vertex(p);
        };
        // Vertices are numbered as first met: the corners are met in a fixed order, the one GCC
        // gave the arguments of one call (right to left; see vec_z_first).
        const bool other_diagonal = r.coin();
        if (positive) {
          const std::uint32_t c01 = at(0, 1), c11 = at(1, 1), c10 = at(1, 0), c00 = at(0, 0);
          b.quad(c00, c10, c11, c01, other_diagonal);
        } else {
          const std::uint32_t c10 = at(1, 0), c11 = at(1, 1), c01 = at(0, 1), c00 = at(0, 0);
          b.quad(c00, c01, c11, c10, other_diagonal);
        }
      }
  }
  MeshWork w{std::make_shared<TriangleMesh>(std::move(b.mesh)), {}, {}, 0};
  for (std::uint64_t i = 0; i < rays; ++i) {
    Rng rr(seed, static_cast<std::uint64_t>(f), m, i);
    Vec3 o, d = Vec3::Zero();
    const int along = rr.between(0, 2);
    const bool diagonal = rr.between(0, 3) == 0;
    for (int k = 0; k < 3; ++k) {
      // Origins on box-face planes (and so on the BVH's split planes), half-integers between.
      const auto& ps = planes[k];
      if (rr.between(0, 2)) {
        o[k] = ps[rr.g.next() % ps.size()];
      } else {
        const double whole = rr.between(-2, 18);
        o[k] = whole + 0.5 * rr.coin();
      }
      d[k] = rr.coin() ? -0.0 : 0.0;  // exactly zero, either sign: 1/d is ±inf
    }
    d[along] = rr.coin() ? 1 : -1;
    if (diagonal) d[(along + 1) % 3] = rr.coin() ? 1 : -1;
    o[along] = rr.between(0, 16);
    o -= 32 * d;  // the chosen point is met at t = 32; the zero components keep it on its planes
    w.rays.push_back({Ray{o, d}, 0, std::numeric_limits<double>::infinity()});
    w.details.push_back(diagonal ? "diagonal in a face plane" : "axis-aligned");
  }
  return w;
}

MeshWork needles(std::uint64_t seed, std::uint64_t m, std::uint64_t rays, TracerFamily f) {
  Rng r(seed, static_cast<std::uint64_t>(f), m, ~0ull);
  Builder b;
  const int n = r.between(2, 64);
  const double length = std::ldexp(1.0, r.between(4, 24)), width = std::ldexp(1.0, -r.between(0, 20));
  const double tilt = r.coin() ? 0 : std::ldexp(1.0, -r.between(0, 20));
  std::vector<std::uint32_t> bottom, top;
  for (int i = 0; i <= n; ++i) {
    bottom.push_back(b.vertex(Vec3(i * length, 0, 0)));
    top.push_back(b.vertex(Vec3(i * length + length / 2, width, (i & 1) ? tilt : 0)));
  }
  for (int i = 0; i < n; ++i)
    b.triangle(bottom[i], bottom[i + 1], top[i]), b.triangle(top[i], bottom[i + 1], top[i + 1]);
  MeshWork w{std::make_shared<TriangleMesh>(std::move(b.mesh)), {}, {}, 0};
  for (std::uint64_t i = 0; i < rays; ++i) {
    Rng rr(seed, static_cast<std::uint64_t>(f), m, i);
    const std::uint32_t t = static_cast<std::uint32_t>(rr.g.next() % w.mesh->triangle_count());
    std::string detail;
    const Vec3 p = feature_point(*w.mesh, t, rr, detail);
    // Nearly along the needles (x), nearly in their plane: 2^-a off in y and z.
    const Vec3 d = vec_z_first([&, axis = 0]() mutable {
      const double sign = rr.coin() ? 1 : -1;
      return axis++ == 2 ? sign : sign * std::ldexp(1.0, -rr.between(4, 30));
    });
    w.rays.push_back(through(p, d, rr));
    w.details.push_back("needle " + detail);
  }
  return w;
}

MeshWork spawned(std::uint64_t seed, std::uint64_t m, std::uint64_t rays, TracerFamily f) {
  Rng r(seed, static_cast<std::uint64_t>(f), m, ~0ull);
  Builder b;
  if (r.coin())
    height_field(b, r, grid_size(r, 32), false, 0, seed ^ m);
  else
    cube_surface(b, r, grid_size(r, 16));
  // Scaled by 2^s (exact): a shadow ray far from the origin re-hits its surface more easily.
  const int s = r.between(-8, 16);
  for (double& x : b.mesh.vertices) x = std::ldexp(x, s);
  MeshWork w{std::make_shared<TriangleMesh>(std::move(b.mesh)), {}, {}, 0};
  for (std::uint64_t i = 0; i < rays; ++i) {
    Rng rr(seed, static_cast<std::uint64_t>(f), m, i);
    const std::uint32_t t = static_cast<std::uint32_t>(rr.g.next() % w.mesh->triangle_count());
    const Triangle tri = w.mesh->triangle(t);
    const Vec3 p = (tri.v[0] + tri.v[1] + 2 * tri.v[2]) / 4;  // exactly on the triangle
    const Vec3 n = normal_of(*w.mesh, t);
    Vec3 d = random_direction(rr, 8);
    if (dot(d, n) == 0) d = n;
    const int how = rr.between(0, 2);
    if (how == 0) {  // leaving the surface outward, tmin = 0
      if (dot(d, n) < 0) d = -d;
      w.rays.push_back({Ray{p, d}, 0, std::numeric_limits<double>::infinity()});
      w.details.push_back("spawned outward");
    } else if (how == 1) {  // leaving the surface inward (a refracted or inside-facing ray)
      if (dot(d, n) > 0) d = -d;
      w.rays.push_back({Ray{p, d}, 0, std::numeric_limits<double>::infinity()});
      w.details.push_back("spawned inward");
    } else {  // a shadow ray towards a point on the surface: it ends there (tmax), exclusive
      const double span = std::ldexp(1.0, rr.between(0, 4));
      w.rays.push_back({Ray{p - span * d, d}, 0, span});
      w.details.push_back("ends on the surface (tmax)");
    }
  }
  return w;
}

MeshWork shells(std::uint64_t seed, std::uint64_t m, std::uint64_t rays, TracerFamily f) {
  Rng r(seed, static_cast<std::uint64_t>(f), m, ~0ull);
  Builder b;
  const int n = grid_size(r, 24);
  const double gap = std::ldexp(1.0, -r.between(20, 48));  // 2^-20 down to a few ulps of the coordinates
  height_field(b, r, n, r.coin(), 0, seed ^ m);
  height_field(b, r, n, false, gap, seed ^ m);  // same heights when both have them; lifted by the gap
  MeshWork w{std::make_shared<TriangleMesh>(std::move(b.mesh)), {}, {}, 0};
  for (std::uint64_t i = 0; i < rays; ++i) {
    Rng rr(seed, static_cast<std::uint64_t>(f), m, i);
    auto grid_point = [&] {
      const double whole = rr.between(0, 8 * n) * 0.5;
      return whole + 0.25 * rr.coin();
    };
    const double ty = grid_point();
    const Vec3 target(grid_point(), ty, 0);
    const double dz = rr.coin() ? -8 : 8;
    const double dy = rr.between(-3, 3);
    Vec3 d(rr.between(-3, 3), dy, dz);
    w.rays.push_back(through(target, d, rr));
    w.details.push_back(d.z() < 0 ? "from above" : "from below");
  }
  return w;
}

// The bundled meshes (the terrain in scenes/audit/, the bunny CGAL's data gives the build), read
// once; those missing on this machine are left out.
const std::vector<std::shared_ptr<const TriangleMesh>>& bundled_meshes() {
  static const std::vector<std::shared_ptr<const TriangleMesh>> all = [] {
    std::vector<std::shared_ptr<const TriangleMesh>> out;
    for (const char* path : {RAYPROOF_BUNDLED_TERRAIN, RAYPROOF_BUNDLED_BUNNY}) {
      if (!std::filesystem::is_regular_file(path)) continue;
      try {
        out.push_back(std::make_shared<const TriangleMesh>(triangle_mesh_of(load_mesh(path))));
      } catch (const std::exception&) {  // unreadable: not bundled here
      }
    }
    return out;
  }();
  return all;
}

// Random rays at a bundled mesh: from outside its box, aimed at points inside it.
MeshWork random_at_bundled(std::shared_ptr<const TriangleMesh> mesh, std::uint64_t seed, std::uint64_t m,
                           std::uint64_t rays, TracerFamily f) {
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
  for (std::size_t i = 0; i < mesh->vertex_count(); ++i)
    lo = lo.cwiseMin(mesh->vertex(i)), hi = hi.cwiseMax(mesh->vertex(i));
  const Vec3 centre = (lo + hi) / 2, half = (hi - lo) / 2;
  MeshWork w{std::move(mesh), {}, {}, 0};
  for (std::uint64_t i = 0; i < rays; ++i) {
    Rng rr(seed, static_cast<std::uint64_t>(f), m, i);
    const Vec3 from = centre + 3 * half.norm() * vec_z_first([&] { return rr.unit() - 0.5; }).normalized();
    const Vec3 to = centre + vec_z_first([&] { return rr.unit() - 0.5; }).cwiseProduct(2 * half);
    Vec3 d = to - from;
    if (d == Vec3::Zero()) d = Vec3(1, 0, 0);
    w.rays.push_back({Ray{from, d}, 0, std::numeric_limits<double>::infinity()});
    w.details.push_back("random at a bundled mesh");
  }
  return w;
}

MeshWork random_rays(std::uint64_t seed, std::uint64_t m, std::uint64_t rays, TracerFamily f) {
  // Every fourth mesh is a bundled one (where this machine has them), the others UV spheres.
  const auto& bundled = bundled_meshes();
  if (m % 4 == 3 && !bundled.empty()) return random_at_bundled(bundled[(m / 4) % bundled.size()], seed, m, rays, f);
  Rng r(seed, static_cast<std::uint64_t>(f), m, ~0ull);
  Builder b;
  // A UV sphere (poles shared by their fans), in double from cos and sin: whatever they round to.
  const int stacks = r.between(3, 48), slices = r.between(3, 64);
  const int radius_exponent = r.between(-4, 12);
  const double radius = std::ldexp(1.0 + r.unit(), radius_exponent);
  const Vec3 centre = vec_z_first([&] { return r.unit() - 0.5; }) * radius * 4;
  auto at = [&](int i, int j) {
    if (i == 0) return b.vertex(centre + Vec3(0, 0, radius));
    if (i == stacks) return b.vertex(centre - Vec3(0, 0, radius));
    const double theta = std::numbers::pi * i / stacks, phi = 2 * std::numbers::pi * (j % slices) / slices;
    return b.vertex(centre +
                    radius * Vec3(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)));
  };
  for (int i = 0; i < stacks; ++i)
    for (int j = 0; j < slices; ++j) {
      const std::uint32_t a = at(i, j), c = at(i + 1, j), d = at(i + 1, j + 1), e = at(i, j + 1);
      if (i == 0)
        b.triangle(a, c, d);
      else if (i == stacks - 1)
        b.triangle(a, c, e);
      else
        b.quad(a, c, d, e, false);
    }
  MeshWork w{std::make_shared<TriangleMesh>(std::move(b.mesh)), {}, {}, 0};
  for (std::uint64_t i = 0; i < rays; ++i) {
    Rng rr(seed, static_cast<std::uint64_t>(f), m, i);
    const Vec3 from = centre + radius * 3 * vec_z_first([&] { return rr.unit() - 0.5; }).normalized();
    const Vec3 to = centre + radius * 1.2 * vec_z_first([&] { return rr.unit() - 0.5; });
    Vec3 d = to - from;
    if (d == Vec3::Zero()) d = Vec3(1, 0, 0);
    w.rays.push_back({Ray{from, d}, 0, std::numeric_limits<double>::infinity()});
    w.details.push_back("random at a UV sphere");
  }
  return w;
}

MeshWork generate_base(TracerFamily family, std::uint64_t seed, std::uint64_t m, std::uint64_t rays, TracerFamily as) {
  switch (family) {
    case TracerFamily::shared_edges: return shared_edges(seed, m, rays, as);
    case TracerFamily::fans: return fans(seed, m, rays, as);
    case TracerFamily::axis_planes: return axis_planes(seed, m, rays, as);
    case TracerFamily::needles: return needles(seed, m, rays, as);
    case TracerFamily::spawned: return spawned(seed, m, rays, as);
    case TracerFamily::shells: return shells(seed, m, rays, as);
    case TracerFamily::random: return random_rays(seed, m, rays, as);
    case TracerFamily::far: break;
  }
  return {};
}

}  // namespace

MeshWork generate_mesh_work(TracerFamily family, std::uint64_t seed, std::uint64_t m, std::uint64_t rays) {
  rays = std::min(rays, kRaysPerMesh);
  if (family != TracerFamily::far) return generate_base(family, seed, m, rays, family);
  // far: each of the others in turn, moved by 2^k along (1, 1, 1) — k from 4 to 60, the
  // vertices and origins rounded to doubles there (that rounded mesh is what is judged).
  constexpr TracerFamily kBases[] = {TracerFamily::shared_edges, TracerFamily::fans,    TracerFamily::axis_planes,
                                     TracerFamily::needles,      TracerFamily::spawned, TracerFamily::shells};
  Rng r(seed, static_cast<std::uint64_t>(family), m, ~1ull);
  MeshWork w = generate_base(kBases[m % 6], seed, m, rays, TracerFamily::far);
  const int k = r.between(4, 60);
  const double shift = std::ldexp(1.0, k);
  auto moved = std::make_shared<TriangleMesh>(*w.mesh);
  for (double& x : moved->vertices) x += shift;
  w.mesh = moved;
  for (TracerRay& ray : w.rays) ray.ray.origin += Vec3::Constant(shift);
  for (std::string& d : w.details) d = std::string(to_string(kBases[m % 6])) + " " + d;
  w.log2_translate = k;
  return w;
}

}  // namespace rayproof::fuzz
