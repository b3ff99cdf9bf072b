// `rayproof offsets`: the proof side (verify/offset_bounds.h) per primitive, the witness side (an
// adversarial search, each distance decided exactly in floating-point expansions), and each
// offset rule judged on both (docs/spec/offsets.md).
#include "rayproof/studies/offsets.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cctype>
#include <cmath>
#include <cstring>
#include <mutex>
#include <numeric>
#include <tuple>

#include "rayproof/core/casefile.h"
#include "rayproof/core/fp.h"
#include "rayproof/core/parallel.h"
#include "rayproof/core/render.h"
#include "rayproof/fuzz/generators.h"
#include "rayproof/studies/markup.h"
#include "rayproof/verify/certified.h"
// GCC takes Expansion's c_[i] (read only for i < n_) for uninitialized when it inlines the merge.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include "rayproof/verify/expansion.h"
#pragma GCC diagnostic pop

namespace rayproof::studies {

std::string_view to_string(OffsetVerdict v) {
  switch (v) {
    case OffsetVerdict::safe: return "safe";
    case OffsetVerdict::unsafe: return "unsafe";
    case OffsetVerdict::unproved: return "unproved";
  }
  return "unproved";
}

OffsetVerdict RuleSummary::verdict() const {
  if (unsafe > 0) return OffsetVerdict::unsafe;
  if (unproved == 0 && safe > 0) return OffsetVerdict::safe;
  return OffsetVerdict::unproved;
}

double VariantOffsets::needs_ulps_at_most() const {
  double most = 0;
  for (const PrimitiveOffsets& p : primitives)
    if (p.proof) most = std::max(most, p.required_ulps);
  return most;
}

namespace {

// One seeded stream per ray (fuzz's SplitMix64), and a draw below n.
using Stream = fuzz::SplitMix64;
int below(Stream& s, int n) { return int(s.next() % std::uint64_t(n)); }

double to_precision(Precision p, double x) { return p == Precision::f32 ? double(to_nearest_float(x)) : x; }
Vec3 to_precision(Precision p, const Vec3& v) {
  return {to_precision(p, v.x()), to_precision(p, v.y()), to_precision(p, v.z())};
}
Shape to_precision(Precision p, const Shape& s) {
  if (p == Precision::f64) return s;
  return std::visit(
      [&](const auto& x) -> Shape {
        using S = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<S, Sphere>)
          return Sphere{to_precision(p, x.center), to_precision(p, x.radius)};
        else if constexpr (std::is_same_v<S, Plane>)
          return Plane{to_precision(p, x.normal), to_precision(p, x.offset)};
        else if constexpr (std::is_same_v<S, Triangle>)
          return Triangle{{to_precision(p, x.v[0]), to_precision(p, x.v[1]), to_precision(p, x.v[2])}};
        else
          return Box{to_precision(p, x.min), to_precision(p, x.max)};
      },
      s);
}
// o + t·d as the variant's precision computes it.
Vec3 computed_point(Precision p, const Ray& r, double t) {
  if (p == Precision::f64)
    return {r.origin.x() + t * r.direction.x(), r.origin.y() + t * r.direction.y(), r.origin.z() + t * r.direction.z()};
  const float tf = float(t);
  Vec3 out;
  for (int i = 0; i < 3; ++i) out[i] = double(float(r.origin[i]) + tf * float(r.direction[i]));
  return out;
}
bool inside(const Bounds& b, const Vec3& p) {
  for (int i = 0; i < 3; ++i)
    if (!(p[i] >= b.lo[i] && p[i] <= b.hi[i])) return false;
  return true;
}
bool reports_hit(const Hit& h) { return h.cls != HitClass::miss && h.has_t() && h.t > 0 && std::isfinite(h.t); }
Vec3 unit(const Vec3& v) { return v / v.norm(); }
// Any unit vector perpendicular to n.
Vec3 perpendicular(const Vec3& n) {
  const Vec3 a = std::abs(n.x()) < 0.6 ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
  return unit(cross(n, a));
}

// The exact side and distance of a computed point, per shape: `value` is a signed quantity whose
// sign is exact (n·(p − v0), n·p − off, |p − m|² − r², p_i − plane), `scale` turns its estimate
// into a distance, `side` is +1 on the side the ray came from.
struct SurfaceCheck {
  Expansion value;
  double scale = 1;  // distance ≈ value / scale
  int side = 1;      // the incoming side's sign of `value`
  Vec3 normal;       // unit, toward the incoming side
  // Exactly whether |distance| > bound (the proof's claim broken).
  std::function<bool(double)> exceeds;
};

struct ExactTriangle {
  std::array<Expansion, 3> n;
  Expansion nn;
  double length = 0;
  Vec3 unit_normal;
};
ExactTriangle exact_triangle(const Triangle& t) {
  std::array<Expansion, 3> e1, e2;
  for (int i = 0; i < 3; ++i) {
    e1[i] = Expansion(t.v[1][i]) - Expansion(t.v[0][i]);
    e2[i] = Expansion(t.v[2][i]) - Expansion(t.v[0][i]);
  }
  ExactTriangle x;
  x.n = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
  x.nn = x.n[0] * x.n[0] + x.n[1] * x.n[1] + x.n[2] * x.n[2];
  x.length = std::sqrt(x.nn.estimate());
  x.unit_normal = Vec3(x.n[0].estimate(), x.n[1].estimate(), x.n[2].estimate()) / x.length;
  return x;
}
Expansion dot_exact(const std::array<Expansion, 3>& n, const Vec3& p, const Vec3& base) {
  return n[0] * (Expansion(p.x()) - Expansion(base.x())) + n[1] * (Expansion(p.y()) - Expansion(base.y())) +
         n[2] * (Expansion(p.z()) - Expansion(base.z()));
}
// |value| > bound·√nn, exactly: value² > bound²·nn.
bool exceeds_scaled(const Expansion& value, const Expansion& nn, double bound) {
  if (!std::isfinite(bound)) return false;
  const Expansion b(bound);
  const Expansion diff = value * value - b * b * nn;
  return diff.valid() && diff.sign() > 0;
}

std::optional<SurfaceCheck> surface_check(const Shape& shape, const ExactTriangle* tri, const Ray& ray, const Vec3& p) {
  SurfaceCheck c;
  if (const auto* t = std::get_if<Triangle>(&shape)) {
    c.value = dot_exact(tri->n, p, t->v[0]);
    const Expansion origin_side = dot_exact(tri->n, ray.origin, t->v[0]);
    if (!c.value.valid() || !origin_side.valid() || origin_side.sign() == 0) return std::nullopt;
    c.side = origin_side.sign();
    c.scale = tri->length;
    c.normal = tri->unit_normal * c.side;
    const Expansion value = c.value, nn = tri->nn;
    c.exceeds = [value, nn](double bound) { return exceeds_scaled(value, nn, bound); };
  } else if (const auto* pl = std::get_if<Plane>(&shape)) {
    const std::array<Expansion, 3> n = {Expansion(pl->normal.x()), Expansion(pl->normal.y()),
                                        Expansion(pl->normal.z())};
    c.value = n[0] * p.x() + n[1] * p.y() + n[2] * p.z() - Expansion(pl->offset);
    const Expansion origin_side =
        n[0] * ray.origin.x() + n[1] * ray.origin.y() + n[2] * ray.origin.z() - Expansion(pl->offset);
    if (!c.value.valid() || !origin_side.valid() || origin_side.sign() == 0) return std::nullopt;
    c.side = origin_side.sign();
    c.scale = pl->normal.norm();
    c.normal = pl->normal / c.scale * c.side;
    const Expansion value = c.value, nn = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
    c.exceeds = [value, nn](double bound) { return exceeds_scaled(value, nn, bound); };
  } else if (const auto* s = std::get_if<Sphere>(&shape)) {
    auto power = [&](const Vec3& x) {
      Expansion sum = -(Expansion(s->radius) * Expansion(s->radius));
      for (int i = 0; i < 3; ++i) {
        const Expansion d = Expansion(x[i]) - Expansion(s->center[i]);
        sum = sum + d * d;
      }
      return sum;
    };
    c.value = power(p);
    const Expansion origin_side = power(ray.origin);
    if (!c.value.valid() || !origin_side.valid() || origin_side.sign() == 0) return std::nullopt;
    c.side = origin_side.sign();
    c.scale = (p - s->center).norm() + s->radius;  // |p−m|² − r² = (|p−m| − r)(|p−m| + r)
    c.normal = unit(p - s->center) * c.side;
    // |p − m| − R > b (outside) or R − |p − m| > b (inside), squared: value ∓ 2Rb − b² against 0.
    const Expansion value = c.value, radius(s->radius);
    c.exceeds = [value, radius](double bound) {
      if (!std::isfinite(bound)) return false;
      const Expansion b(bound), two_rb = radius * b + radius * b, bb = b * b;
      if (value.sign() > 0) {
        const Expansion over = value - two_rb - bb;
        return over.valid() && over.sign() > 0;
      }
      const Expansion past_centre = b - radius;  // b ≥ R: no point inside lies that deep
      if (!past_centre.valid() || past_centre.sign() >= 0) return false;
      const Expansion under = value + two_rb - bb;
      return under.valid() && under.sign() < 0;
    };
  } else {
    const Box& b = std::get<Box>(shape);
    // The face the ray crosses: the last entry plane from outside, the first exit plane from inside.
    bool outside = false;
    for (int i = 0; i < 3; ++i) outside |= ray.origin[i] < b.min[i] || ray.origin[i] > b.max[i];
    int axis = -1;
    double best = outside ? -INFINITY : INFINITY, plane = 0;
    for (int i = 0; i < 3; ++i) {
      const double di = ray.direction[i];
      if (di == 0) continue;
      const double face = outside ? (di > 0 ? b.min[i] : b.max[i]) : (di > 0 ? b.max[i] : b.min[i]);
      const double ti = (face - ray.origin[i]) / di;
      if (outside ? ti > best : ti < best) {
        best = ti;
        axis = i;
        plane = face;
      }
    }
    if (axis < 0) return std::nullopt;
    const double outward = plane == b.max[axis] ? 1 : -1;
    c.value = (Expansion(p[axis]) - Expansion(plane)) * Expansion(outward);
    c.side = outside ? 1 : -1;
    c.scale = 1;
    c.normal = Vec3::Zero();
    c.normal[axis] = outward * c.side;
    const Expansion value = c.value;
    c.exceeds = [value](double bound) {
      if (!std::isfinite(bound)) return false;
      const Expansion over = (value.sign() >= 0 ? value : -value) - Expansion(bound);
      return over.valid() && over.sign() > 0;
    };
  }
  return c;
}

// The search's rays for one primitive (offsets.md: the scene's camera and lights first, box
// corners, then grazing rays, points near vertices and edges, random points).
struct SearchRay {
  Ray ray;
  bool ok = false;
};
Vec3 random_in(const Bounds& b, Stream& s) {
  return {b.lo.x() + s.unit() * (b.hi.x() - b.lo.x()), b.lo.y() + s.unit() * (b.hi.y() - b.lo.y()),
          b.lo.z() + s.unit() * (b.hi.z() - b.lo.z())};
}
// A point on the shape, and its unit normal there (for grazing origins).
std::pair<Vec3, Vec3> target_on(const Shape& shape, const Bounds& box, int pattern, Stream& s) {
  if (const auto* t = std::get_if<Triangle>(&shape)) {
    double b[3];
    if (pattern == 1) {  // near a vertex
      const int a = below(s, 3);
      const double eps = std::ldexp(1.0, -1 - below(s, 40));
      for (int i = 0; i < 3; ++i) b[i] = i == a ? 1 - eps : eps / 2;
    } else if (pattern == 2) {  // near an edge
      const int c = below(s, 3);
      const double eps = std::ldexp(1.0, -1 - below(s, 40)), x = s.unit();
      b[c] = eps;
      b[(c + 1) % 3] = (1 - eps) * x;
      b[(c + 2) % 3] = (1 - eps) * (1 - x);
    } else {
      double x = s.unit(), y = s.unit();
      if (x + y > 1) x = 1 - x, y = 1 - y;
      b[0] = 1 - x - y, b[1] = x, b[2] = y;
    }
    const Vec3 p = b[0] * t->v[0] + b[1] * t->v[1] + b[2] * t->v[2];
    return {p, unit(cross(t->v[1] - t->v[0], t->v[2] - t->v[0]))};
  }
  if (const auto* pl = std::get_if<Plane>(&shape)) {
    const Vec3 x = random_in(box, s);
    const double nn = pl->normal.squaredNorm();
    return {x - ((pl->normal.dot(x) - pl->offset) / nn) * pl->normal, pl->normal / std::sqrt(nn)};
  }
  if (const auto* sp = std::get_if<Sphere>(&shape)) {
    Vec3 u;
    do u = Vec3(2 * s.unit() - 1, 2 * s.unit() - 1, 2 * s.unit() - 1);
    while (u.squaredNorm() > 1 || u.squaredNorm() < 1e-6);
    u = unit(u);
    return {sp->center + sp->radius * u, u};
  }
  const Box& b = std::get<Box>(shape);
  const int axis = below(s, 3), hi = below(s, 2);
  Vec3 p = random_in({b.min, b.max}, s);
  p[axis] = hi ? b.max[axis] : b.min[axis];
  Vec3 n = Vec3::Zero();
  n[axis] = hi ? 1 : -1;
  return {p, n};
}
SearchRay search_ray(const Shape& shape, const Bounds& box, const std::vector<Vec3>& listed, std::uint64_t local,
                     Stream& s) {
  // Grazing rays (pattern 3) one in eight: they set the bound only where a corner of the domain
  // does (a terrain); steep rays carry the largest travel along the normal.
  const int pick = int(s.next() % 8), pattern = pick == 7 ? 3 : pick % 3;
  const auto [target, n] = target_on(shape, box, pattern == 3 ? 0 : pattern, s);
  const auto* sphere = std::get_if<Sphere>(&shape);
  if (sphere && pick == 1 && local >= listed.size()) {  // one ray in eight
    // Leaving the surface tangentially, from within an ulp or two inside or outside, tilted 2^-30
    // to 2^-80 either way: the discriminant is rounding alone there, the formulas' hardest case.
    const double below_or_above = std::ldexp(s.next() & 1 ? 1.0 : -1.0, -52 - below(s, 8)) * sphere->radius;
    const Vec3 along = perpendicular(n), side = cross(along, n);
    const double angle = 2 * M_PI * s.unit();
    const double tilt = std::ldexp(s.next() & 1 ? 1.0 : -1.0, -30 - below(s, 51));
    SearchRay r;
    r.ray = Ray{target + below_or_above * n, std::cos(angle) * along + std::sin(angle) * side + tilt * n};
    r.ok = all_finite(r.ray.direction) && inside(box, r.ray.origin);
    return r;
  }
  // After the listed origins, three rays in four from the box corner farthest from the target's
  // tangent plane: the proof's error terms grow with the travel along the normal, |n·t̃d| (the
  // corner farthest in each coordinate may lie much nearer the plane). A sphere's grow with the
  // origin's distance to its centre (c = |o − m|² − R² cancels): the corner farthest from it.
  Vec3 origin;
  if (local < listed.size()) {
    origin = listed[local];
  } else if (local % 4 == 3) {
    origin = random_in(box, s);
  } else if (sphere != nullptr) {
    for (int i = 0; i < 3; ++i) {
      const double m = sphere->center[i];
      origin[i] = std::abs(box.lo[i] - m) > std::abs(box.hi[i] - m) ? box.lo[i] : box.hi[i];
    }
  } else {
    double farthest = -1;
    for (const double side : {1.0, -1.0}) {
      Vec3 corner;
      for (int i = 0; i < 3; ++i) corner[i] = side * n[i] > 0 ? box.hi[i] : box.lo[i];
      const double along = std::abs(n.dot(corner - target));
      if (along > farthest) farthest = along, origin = corner;
    }
  }
  if (pattern == 3) {  // grazing: from far along the surface's tangent plane, lifted a little
    const Vec3 along = perpendicular(n);
    const Vec3 side = cross(along, n);
    const double angle = 2 * M_PI * s.unit();
    const Vec3 dir = std::cos(angle) * along + std::sin(angle) * side;
    double reach = (box.hi - box.lo).norm() * (0.05 + s.unit());
    const double lift = std::ldexp(s.next() & 1 ? 1.0 : -1.0, -8 - below(s, 40));
    for (int tries = 0; tries < 60; ++tries, reach /= 2) {
      const Vec3 o = target + reach * (dir + lift * n);
      if (inside(box, o)) {
        origin = o;
        break;
      }
    }
  }
  SearchRay r;
  // A unit direction, as renderers use: a long one would overflow float's products (b² of a far
  // sphere at 2^30), outside the proofs' domain. Three rays in four shorten it (by at most 2×) so
  // that t lands just above a power of two: a rounding errs by at most half an ulp of its binade,
  // u·2^⌊log2 |y|⌋, so only there does the quotient's rounding reach u·|t| (and the watertight
  // test's depths z_i ≈ t theirs). The bound allows any length; on the bunny's triangles the
  // roundings a witness lines up, in units of u·|n̂·t̃d|, averaged 0.53 for the quotient.
  Vec3 direction = normalized(target - origin);
  const double reach = (target - origin).norm();
  if (s.next() % 4 != 0 && reach > 0 && std::isfinite(reach)) {
    const double above = 1 + std::ldexp(1 + s.unit(), -12 + below(s, 8));  // 1 + [2^-12, 2^-4)
    direction *= reach / (std::ldexp(1.0, std::ilogb(reach)) * above);
  }
  r.ray = Ray{origin, direction};
  r.ok = all_finite(r.ray.direction) && r.ray.direction != Vec3::Zero() && inside(box, origin);
  return r;
}

// A primitive's rays: the first spread over the search's patterns (the listed origins first), the
// rest climbing from the farthest point found. Few rays all spread.
std::uint64_t spread_rays(std::uint64_t rays, std::size_t listed) {
  return rays <= 2 * listed ? rays : std::max<std::uint64_t>(2 * listed, rays / 4);
}
// The climb tries kClimbTries moves of one of the ray's numbers, then goes to the best if it beats
// where it stands; each move is 1 to 2^20 ulps of the variant's precision, either way.
constexpr int kClimbTries = 5;
std::int64_t random_ulps(Stream& s) {
  const std::int64_t size = std::int64_t(1) << below(s, 21);
  const std::int64_t k = 1 + std::int64_t(s.next() % std::uint64_t(size));
  return s.next() & 1 ? k : -k;
}
// x moved k ulps in the precision's bits (away from or towards zero); x itself where the move
// would change its sign or leave the finite numbers.
double moved_ulps(Precision p, double x, std::int64_t k) {
  double moved;
  if (p == Precision::f32) {  // unsigned: the bits wrap instead of overflowing
    const float f = float(x);
    std::uint32_t bits;
    std::memcpy(&bits, &f, sizeof bits);
    bits += std::uint32_t(k);
    float g;
    std::memcpy(&g, &bits, sizeof g);
    moved = g;
  } else {
    std::uint64_t bits;
    std::memcpy(&bits, &x, sizeof bits);
    bits += std::uint64_t(k);
    std::memcpy(&moved, &bits, sizeof moved);
  }
  return std::isfinite(moved) && std::signbit(moved) == std::signbit(x) ? moved : x;
}

// Whether a ray starts inside a solid (box, sphere): its hit is an exit, and a new ray leaving to
// that side is inside the solid, which it meets again by definition.
bool starts_inside_solid(const Shape& shape, const Vec3& o) {
  if (const auto* b = std::get_if<Box>(&shape)) return inside({b->min, b->max}, o);
  if (const auto* s = std::get_if<Sphere>(&shape)) return (o - s->center).squaredNorm() < s->radius * s->radius;
  return false;
}

// The outgoing directions a re-hit is looked for along: straight out, mirrored, grazing out.
std::array<Vec3, 3> outgoing_directions(const Vec3& incoming, const Vec3& n) {
  const Vec3 mirrored = incoming - 2 * incoming.dot(n) * n;
  const Vec3 grazing = perpendicular(n) + 0x1p-20 * n;
  return {n, mirrored.dot(n) > 0 ? mirrored : Vec3(n), grazing};
}

Precision computing_precision(const Variant& v) {  // batched float twins report double
  return std::string_view(v.name).find("-f32") != std::string_view::npos ? Precision::f32 : v.precision;
}
// The primitive's proved offset and the ulps it takes at the point's smallest magnitude.
std::pair<double, double> proved_offset_and_ulps(const OffsetProof& proof, Precision prec, const Shape& shape) {
  Vec3 n(1, 0, 0);
  if (const auto* t = std::get_if<Triangle>(&shape)) n = unit(cross(t->v[1] - t->v[0], t->v[2] - t->v[0]));
  if (const auto* pl = std::get_if<Plane>(&shape)) n = unit(pl->normal);
  double worst = proved_offset(proof, prec, n);
  if (std::holds_alternative<Box>(shape))  // the offset along any face's normal: the largest
    for (int i = 1; i < 3; ++i) {
      Vec3 e = Vec3::Zero();
      e[i] = 1;
      worst = std::max(worst, proved_offset(proof, prec, e));
    }
  double smallest_max = 0;
  for (int i = 0; i < 3; ++i) {
    const double lo = proof.point_box.lo[i], hi = proof.point_box.hi[i];
    smallest_max = std::max(smallest_max, lo <= 0 && hi >= 0 ? 0.0 : std::min(std::abs(lo), std::abs(hi)));
  }
  if (const auto* sp = std::get_if<Sphere>(&shape)) {  // a box round the origin: |p| ≥ ||m| − R| − point
    const double apart = std::abs(sp->center.norm() - sp->radius) * (1 - 0x1p-50) - proof.point;
    smallest_max = std::max(smallest_max, apart / std::sqrt(3.0) * (1 - 0x1p-50));
  }
  return std::pair{worst, smallest_max > 0 ? worst / ulp_in(prec, smallest_max) : INFINITY};
}
}  // namespace

Bounds offsets_scene_box(const SceneIndex& index) {
  Bounds box;
  for (const Primitive& p : index.primitives())
    if (!std::holds_alternative<Plane>(p.shape)) box.grow(bounds_of(p.shape));
  const Scene& scene = index.scene();
  if (scene.camera.width > 0) box.grow(scene.camera.eye);
  for (const PointLight& l : scene.lights) box.grow(l.position);
  if (box.empty())
    throw std::runtime_error("the scene has no bounded primitive, camera or light: no domain for offsets");
  return box;
}

OffsetsReport run_offsets(const SceneIndex& index, const std::string& scene_name,
                          const std::vector<const Variant*>& variants, const OffsetsOptions& options) {
  OffsetsReport report;
  report.scene_name = scene_name;
  report.domain = options.domain_all ? "all" : "scene";
  report.box = offsets_scene_box(index);
  const Scene& scene = index.scene();
  std::vector<Vec3> listed;  // the scene's own origins first
  if (scene.camera.width > 0) listed.push_back(scene.camera.eye);
  for (const PointLight& l : scene.lights) listed.push_back(l.position);
  for (int c = 0; c < 8; ++c)
    listed.emplace_back(c & 1 ? report.box.hi.x() : report.box.lo.x(), c & 2 ? report.box.hi.y() : report.box.lo.y(),
                        c & 4 ? report.box.hi.z() : report.box.lo.z());
  Bounds proof_box = report.box;
  if (options.domain_all) {
    proof_box.lo = Vec3::Constant(-std::numeric_limits<double>::max());
    proof_box.hi = Vec3::Constant(std::numeric_limits<double>::max());
  }

  for (const Variant* v : variants) {
    const auto started = std::chrono::steady_clock::now();
    VariantOffsets out;
    out.variant = v;
    out.precision = computing_precision(*v);
    const Precision prec = out.precision;
    std::vector<std::int32_t> ids;
    for (std::int32_t i = 0; i < std::int32_t(index.primitives().size()); ++i)
      if (v->handles(kind_of(index.primitive(i).shape))) ids.push_back(i);
    out.primitives.resize(ids.size());
    for (const OffsetRule& r : options.rules) out.rules.push_back(RuleSummary{r});
    // Rays per primitive: spread evenly, the remainder to primitives in a seeded order.
    const std::uint64_t P = ids.size(), base = P ? options.rays / P : 0, extra = P ? options.rays % P : 0;
    std::vector<std::uint32_t> order(P);
    std::iota(order.begin(), order.end(), 0u);
    {
      Stream s{options.seed ^ 0x5eedull};
      for (std::size_t i = P; i > 1; --i) std::swap(order[i - 1], order[s.next() % i]);
    }
    std::vector<std::uint64_t> ray_count(P, base);
    for (std::uint64_t k = 0; k < extra; ++k) ++ray_count[order[k]];
    const Bounds origin_box{to_precision(prec, report.box.lo), to_precision(prec, report.box.hi)};

    std::mutex merge;
    std::atomic<std::size_t> next{0}, done{0};
    run_workers(options.threads, [&](int worker) {
      for (std::size_t j; (j = next.fetch_add(1)) < P;) {
        PrimitiveOffsets& po = out.primitives[j];
        po.primitive = ids[j];
        const Shape shape = to_precision(prec, index.primitive(ids[j]).shape);
        po.proof = offset_proof(*v, index.primitive(ids[j]).shape, proof_box);
        std::optional<ExactTriangle> tri;
        if (std::holds_alternative<Triangle>(shape)) tri = exact_triangle(std::get<Triangle>(shape));
        // The domain's points: the proof's, else (no proof) the primitive's box widened by its size.
        Bounds domain;
        if (po.proof) {
          domain = po.proof->point_box;
        } else if (std::holds_alternative<Plane>(shape)) {
          domain = report.box;
        } else {
          domain = bounds_of(shape);
          const double size = (domain.hi - domain.lo).maxCoeff();
          domain.lo -= Vec3::Constant(size);
          domain.hi += Vec3::Constant(size);
        }
        // The witness search. One ray: its computed point's distance off the surface, decided
        // exactly; nullopt for a miss or a point outside the domain.
        auto try_ray = [&](const Ray& ray) -> std::optional<double> {
          if (ray.direction == Vec3::Zero() || !all_finite(ray.direction)) return std::nullopt;
          ++po.rays;
          const Answer a = v->intersect(ray, shape, options.rule);
          if (a.failed() || !reports_hit(a)) return std::nullopt;
          ++po.hits;
          const Vec3 p = computed_point(prec, ray, a.t);
          if (!inside(domain, p)) {
            ++po.outside_domain;
            return std::nullopt;
          }
          const auto check = surface_check(shape, tri ? &*tri : nullptr, ray, p);
          if (!check) return std::nullopt;
          const double distance = check->side * check->value.estimate() / check->scale;
          if (po.proof && check->exceeds(po.proof->point)) ++po.beyond_bound;
          const OffsetWitness w{ray, a.t, p, distance, check->normal};
          if (!po.farthest || std::abs(distance) > std::abs(po.farthest->distance)) po.farthest = w;
          if (distance < 0 && (!po.deepest || distance < po.deepest->distance)) po.deepest = w;
          return std::abs(distance);
        };
        const std::uint64_t spread = spread_rays(ray_count[j], listed.size());
        const std::uint64_t stream_base =
            options.seed * 0x9e3779b97f4a7c15ull + std::uint64_t(ids[j]) * 0x100000001b3ull;
        for (std::uint64_t k = 0; k < spread; ++k) {
          Stream s{stream_base + k};
          SearchRay sr = search_ray(shape, report.box, listed, k, s);
          if (sr.ok) try_ray(Ray{to_precision(prec, sr.ray.origin), to_precision(prec, sr.ray.direction)});
        }
        // Then climb from the farthest point found: the error is a sum of roundings, each set by
        // the low bits of a few of the ray's six numbers, so moving one number re-draws only its
        // own roundings and keeps what the others gained. Random rays reach a few standard
        // deviations of that sum; the climb lines the roundings up (on the bunny's triangles, 133
        // rays each, the bracket's median fell from 8.4x to 5.9x with the bound unchanged).
        if (po.farthest && spread < ray_count[j]) {
          Ray at = po.farthest->ray;
          double from = std::abs(po.farthest->distance);
          Stream s{stream_base + spread};
          for (std::uint64_t k = spread, round = 0; k < ray_count[j]; ++round) {
            const int coordinate = int(round % 6);
            std::optional<Ray> best;
            for (int tries = 0; tries < kClimbTries && k < ray_count[j]; ++tries, ++k) {
              Ray next = at;
              double& x = coordinate < 3 ? next.origin[coordinate] : next.direction[coordinate - 3];
              const double was = x;
              const std::int64_t move = random_ulps(s);
              x = moved_ulps(prec, was, move);
              // From a corner of the box (where the search starts most), half the moves leave it.
              if (coordinate < 3 && !inside(origin_box, next.origin)) x = moved_ulps(prec, was, -move);
              if (coordinate < 3 && !inside(origin_box, next.origin)) continue;
              const auto distance = try_ray(next);
              if (distance && *distance > from) from = *distance, best = next;
            }
            if (best) at = *best;
          }
        }
        // The rules.
        if (po.proof) std::tie(po.proved_offset, po.required_ulps) = proved_offset_and_ulps(*po.proof, prec, shape);
        po.verdicts.assign(options.rules.size(), OffsetVerdict::unproved);
        std::vector<json> cases;
        for (std::size_t r = 0; r < options.rules.size(); ++r) {
          const OffsetRule& rule = options.rules[r];
          bool safe = false;
          if (po.proof && std::isfinite(po.proved_offset)) {
            // Every normal the proof's primitive may be left by: a box's six faces, else ±n.
            std::vector<Vec3> normals;
            if (std::holds_alternative<Box>(shape)) {
              for (int i = 0; i < 6; ++i) {
                Vec3 e = Vec3::Zero();
                e[i % 3] = i < 3 ? 1 : -1;
                normals.push_back(e);
              }
            } else {
              Vec3 n = tri ? tri->unit_normal : Vec3(1, 0, 0);
              if (const auto* pl = std::get_if<Plane>(&shape)) n = pl->normal / pl->normal.norm();
              normals = {n, -n};
            }
            safe = true;
            for (const Vec3& n : normals)
              safe = safe && rule_proved_safe(*po.proof,
                                              rule_displacement(rule, prec, po.proof->point_box, n, po.proved_offset));
          }
          if (safe) po.verdicts[r] = OffsetVerdict::safe;
          if (rule.kind == OffsetRule::Kind::proved && !po.proof) continue;
          // The witness: spawn from the deepest point found (else the farthest), look for a re-hit.
          const std::optional<OffsetWitness>& from = po.deepest ? po.deepest : po.farthest;
          if (!from) continue;
          // A solid (box, sphere) is left to its outside: a ray into it meets it again by definition.
          if (starts_inside_solid(shape, from->ray.origin)) continue;
          const Vec3 o2 = apply_offset_rule(rule, prec, from->point, from->normal,
                                            std::isfinite(po.proved_offset) ? po.proved_offset : 0);
          if (!all_finite(o2)) continue;
          for (const Vec3& d2 : outgoing_directions(from->ray.direction, from->normal)) {
            const Ray spawned{o2, to_precision(prec, d2)};
            if (spawned.direction == Vec3::Zero()) continue;
            const Answer again = v->intersect(spawned, shape, options.rule);
            if (again.failed() || !reports_hit(again)) continue;
            const Vec3 p2 = computed_point(prec, spawned, again.t);
            if (safe && inside(domain, p2)) ++po.rehit_where_safe;
            if (safe) continue;  // outside the domain: a wrong answer of the variant, not this rule's
            po.verdicts[r] = OffsetVerdict::unsafe;
            const Hit exact = certified_intersect(spawned, shape, options.rule);
            Case c;
            c.ray = spawned;
            c.shape = shape;
            c.id = "offsets-" + std::string(v->name) + "-" + rule.name + "-" + std::to_string(ids[j]);
            c.found = {{"rule", rule.name},
                       {"variant", std::string(v->name)},
                       {"primitive", ids[j]},
                       {"spawned_from",
                        {exact_json_number(from->point.x()), exact_json_number(from->point.y()),
                         exact_json_number(from->point.z())}},
                       {"point_distance", from->distance},
                       {"reported", {{"class", std::string(to_string(again.cls))}, {"t", exact_json_number(again.t)}}},
                       {"exact", {{"class", std::string(to_string(exact.cls))}}}};
            if (exact.has_t()) c.found["exact"]["t"] = exact_json_number(exact.t);
            cases.push_back(case_to_json(c));
            break;
          }
        }
        {
          std::lock_guard<std::mutex> lock(merge);
          for (json& c : cases) out.unsafe_cases.push_back(std::move(c));
        }
        const std::size_t finished = done.fetch_add(1) + 1;
        if (worker == 0 && options.progress) options.progress(finished, P);
      }
    });
    // Deterministic order of the cases whatever the threads did.
    std::sort(out.unsafe_cases.begin(), out.unsafe_cases.end(),
              [](const json& a, const json& b) { return a["id"].get<std::string>() < b["id"].get<std::string>(); });
    for (const PrimitiveOffsets& po : out.primitives) {
      out.derived = out.derived || po.proof.has_value();
      out.contradictions += po.beyond_bound + po.rehit_where_safe;
      for (std::size_t r = 0; r < options.rules.size(); ++r) {
        RuleSummary& sum = out.rules[r];
        switch (po.verdicts[r]) {
          case OffsetVerdict::safe: ++sum.safe; break;
          case OffsetVerdict::unsafe: ++sum.unsafe; break;
          case OffsetVerdict::unproved: ++sum.unproved; break;
        }
      }
    }
    for (RuleSummary& sum : out.rules) {
      const std::string prefix = "offsets-" + std::string(v->name) + "-" + sum.rule.name + "-";
      for (const json& c : out.unsafe_cases)
        if (c["id"].get<std::string>().rfind(prefix, 0) == 0) {
          sum.witness = c;
          break;
        }
    }
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    report.variants.push_back(std::move(out));
  }
  return report;
}

std::optional<Vec3> proved_spawn_origin(const Variant& v, const Shape& shape, const Bounds& scene_box, const Ray& ray,
                                        double t, const Vec3& n) {
  const Precision prec = computing_precision(v);
  const auto proof = offset_proof(v, shape, scene_box);
  if (!proof) return std::nullopt;
  const auto offset = proved_offset_and_ulps(*proof, prec, shape);
  if (!std::isfinite(offset.first)) return std::nullopt;
  const Ray seen{to_precision(prec, ray.origin), to_precision(prec, ray.direction)};
  return apply_offset_rule(OffsetRule{OffsetRule::Kind::proved, 0, "proved"}, prec, computed_point(prec, seen, t), n,
                           offset.first);
}

std::optional<double> scene_needs_ulps(const SceneIndex& index, const Variant& v, const Bounds& scene_box) {
  std::optional<double> most;
  for (const Primitive& p : index.primitives()) {
    if (!v.handles(kind_of(p.shape))) continue;
    const auto proof = offset_proof(v, p.shape, scene_box);
    if (!proof) return std::nullopt;
    most = std::max(most.value_or(0.0), proved_offset_and_ulps(*proof, computing_precision(v), p.shape).second);
  }
  return most;
}

std::vector<double> offset_brackets(const VariantOffsets& v) {
  std::vector<double> out;
  for (const PrimitiveOffsets& p : v.primitives)
    if (p.proof && p.farthest && p.farthest->distance != 0)
      out.push_back(p.proof->point / std::abs(p.farthest->distance));
  return out;
}

namespace {
json number_or_null(double x) { return std::isfinite(x) ? json(x) : json(nullptr); }
json witness_json(const std::optional<OffsetWitness>& w) {
  if (!w) return nullptr;
  auto vec = [](const Vec3& v) {
    return json::array({exact_json_number(v.x()), exact_json_number(v.y()), exact_json_number(v.z())});
  };
  return {{"ray", {{"origin", vec(w->ray.origin)}, {"direction", vec(w->ray.direction)}}},
          {"t", exact_json_number(w->t)},
          {"point", vec(w->point)},
          {"distance", w->distance}};
}
std::string shape_name(const Shape& s) { return std::string(to_string(kind_of(s))); }
}  // namespace

void write_offsets_json(const OffsetsReport& report, const SceneIndex& index, std::ostream& out) {
  // Streamed, one primitive a line: a mesh of 10^5 triangles times a dozen variants would not fit
  // in memory as one JSON tree.
  ordered_json head;
  head["scene"] = report.scene_name;
  head["domain"] = report.domain;
  head["box"] = {{"lo", {report.box.lo.x(), report.box.lo.y(), report.box.lo.z()}},
                 {"hi", {report.box.hi.x(), report.box.hi.y(), report.box.hi.z()}}};
  std::string text = json_text(head);
  text.pop_back();  // the closing brace: the variants follow
  out << text << ",\n\"variants\": [";
  for (std::size_t vi = 0; vi < report.variants.size(); ++vi) {
    const VariantOffsets& v = report.variants[vi];
    ordered_json jv;
    jv["name"] = std::string(v.variant->name);
    jv["precision"] = v.precision == Precision::f32 ? "float" : "double";
    jv["hit_point"] = "o+td";
    jv["derived"] = v.derived;
    jv["contradictions"] = v.contradictions;
    jv["seconds"] = v.seconds;
    jv["rules"] = ordered_json::array();
    for (const RuleSummary& r : v.rules) {
      ordered_json jr;
      jr["rule"] = r.rule.name;
      jr["verdict"] = to_string(r.verdict());
      jr["safe"] = r.safe;
      jr["unsafe"] = r.unsafe;
      jr["unproved"] = r.unproved;
      jr["witness"] = r.witness ? *r.witness : json(nullptr);
      jv["rules"].push_back(jr);
    }
    text = json_text(jv);
    text.pop_back();
    out << (vi ? ",\n" : "\n") << text << ",\n\"primitives\": [";
    for (std::size_t k = 0; k < v.primitives.size(); ++k) {
      const PrimitiveOffsets& p = v.primitives[k];
      const Primitive& prim = index.primitive(p.primitive);
      const SceneObject& obj = index.scene().objects[prim.object];
      ordered_json jp;
      jp["mesh"] = obj.mesh ? json(obj.file) : json(nullptr);
      jp["index"] = obj.mesh ? prim.element : p.primitive;
      jp["shape"] = shape_name(prim.shape);
      jp["bound"] = p.proof ? number_or_null(p.proof->point) : json(nullptr);
      jp["witness"] = witness_json(p.farthest);
      jp["bracket"] = p.proof && p.farthest && p.farthest->distance != 0
                          ? json(p.proof->point / std::abs(p.farthest->distance))
                          : json(nullptr);
      jp["required_ulps"] = number_or_null(p.required_ulps);
      out << (k ? ",\n" : "\n") << json_text(jp);
    }
    out << "]}";
  }
  out << "]}\n";
}

namespace {
std::string with_commas(std::uint64_t n) {
  std::string s = std::to_string(n);
  for (int i = int(s.size()) - 3; i > 0; i -= 3) s.insert(std::size_t(i), ",");
  return s;
}
std::string kind_plural(const VariantOffsets& v) {
  return std::string(to_string(v.variant->shape)) + (v.variant->shape == ShapeKind::box ? "es" : "s");
}
// Why a variant has no bound: no derivation for its formula (users' code), or one whose bound is
// not finite on this scene (beyond the precision's proved range: products that overflow).
const char* why_unproved(const VariantOffsets& v) {
  const std::vector<std::string_view> derived = variants_with_offset_proofs();
  return std::find(derived.begin(), derived.end(), std::string_view(v.variant->name)) != derived.end()
             ? "derived, but no finite bound on this scene (beyond the proved range): witnesses only"
             : "no derivation for this variant: witnesses only";
}
}  // namespace

std::vector<std::string> offsets_summary_lines(const OffsetsReport& report) {
  std::vector<std::string> lines;
  for (const VariantOffsets& v : report.variants) {
    const std::uint64_t total = v.primitives.size();
    for (const RuleSummary& r : v.rules) {
      std::string line = std::string(v.variant->name) + ": " + r.rule.name + " ";
      if (r.verdict() == OffsetVerdict::unsafe)
        line += "unsafe: re-hits on " + with_commas(r.unsafe) + " of " + with_commas(total) + " " + kind_plural(v) +
                " (offsets-cases.jsonl)";
      else if (r.verdict() == OffsetVerdict::safe)
        line += "safe on " + with_commas(r.safe) + " of " + with_commas(total) + " " + kind_plural(v);
      else
        line += "unproved: safe on " + with_commas(r.safe) + " of " + with_commas(total) + " " + kind_plural(v);
      if (v.derived)
        line += markup::format(" (needs %.3g ulps at most)", v.needs_ulps_at_most());
      else
        line += std::string(" (") + why_unproved(v) + ")";
      lines.push_back(line);
    }
  }
  return lines;
}

std::string offsets_html(const OffsetsReport& report, const SceneIndex& index) {
  using markup::escape;
  using markup::format;
  std::string html =
      "<!doctype html><meta charset=utf-8><title>rayproof offsets: " + escape(report.scene_name) +
      "</title><style>body{font:14px system-ui,sans-serif;margin:2em;max-width:70em}"
      "table{border-collapse:collapse}td,th{padding:2px 8px;border-bottom:1px solid #ddd;text-align:left}"
      ".safe{color:#060}.unsafe{color:#b00;font-weight:bold}.unproved{color:#666}</style>";
  html += "<h1>Spawn offsets: " + escape(report.scene_name) + "</h1><p>Domain <b>" + escape(report.domain) +
          "</b>: origins in the box " +
          format("[%g, %g, %g] – [%g, %g, %g]", report.box.lo.x(), report.box.lo.y(), report.box.lo.z(),
                 report.box.hi.x(), report.box.hi.y(), report.box.hi.z()) +
          ", any direction. <i>safe</i>: proved for every such ray; <i>unsafe</i>: a ray re-hits its own surface "
          "(offsets-cases.jsonl, replay with <code>rayproof check</code>); <i>unproved</i>: neither.</p>";
  const Scene& scene = index.scene();
  for (const VariantOffsets& v : report.variants) {
    html += "<h2>" + escape(v.variant->name) + " (" + (v.precision == Precision::f32 ? "float" : "double") + ")</h2>";
    html += "<table><tr><th>rule<th>verdict<th>safe<th>unsafe<th>unproved</tr>";
    for (const RuleSummary& r : v.rules)
      html += "<tr><td>" + escape(r.rule.name) + "<td class=" + std::string(to_string(r.verdict())) + ">" +
              std::string(to_string(r.verdict())) +
              format("<td>%llu<td>%llu<td>%llu</tr>", (unsigned long long)r.safe, (unsigned long long)r.unsafe,
                     (unsigned long long)r.unproved);
    html += "</table>";
    const std::vector<double> brackets = offset_brackets(v);
    if (!brackets.empty()) {
      std::vector<double> b = brackets;
      std::sort(b.begin(), b.end());
      const auto within4 = std::count_if(b.begin(), b.end(), [](double x) { return x <= 4; });
      html += format(
          "<p>Bracket bound / witness over %zu primitives with a witness: median %.3g, 95th percentile "
          "%.3g, %.1f%% within 4×. Needs %.3g ulps at most.</p>",
          b.size(), b[b.size() / 2], b[std::min(b.size() - 1, b.size() * 95 / 100)],
          100.0 * double(within4) / double(b.size()), v.needs_ulps_at_most());
    }
    if (!v.derived) {
      std::string why = why_unproved(v);
      why[0] = char(std::toupper(static_cast<unsigned char>(why[0])));
      html += "<p class=unproved>" + why + ".</p>";
      continue;
    }
    // The picture: the camera's view, each pixel coloured by its primitive's required offset in
    // ulps (log scale, blue 1 → red 2^12), shaded by the angle to the eye; grey where another kind.
    if (scene.camera.width <= 0) continue;
    std::vector<double> ulps(index.primitives().size(), -1);
    for (const PrimitiveOffsets& p : v.primitives) ulps[p.primitive] = p.required_ulps;
    Image img;
    img.width = std::min(scene.camera.width, 480);
    img.height = int(std::lround(double(scene.camera.height) * img.width / scene.camera.width));
    img.rgb.assign(std::size_t(img.width) * img.height * 3, 0);
    const Intersectors isect = Intersectors::defaults();
    double most = 0;
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x) {
        const double sx = (x + 0.5) * scene.camera.width / img.width, sy = (y + 0.5) * scene.camera.height / img.height;
        const Ray ray = scene.camera.ray_through(sx, sy);
        const SceneHit h = trace(index, isect, ray);
        std::array<double, 3> c{0.08, 0.08, 0.12};
        if (h.primitive >= 0) {
          const double u = ulps[h.primitive];
          if (u < 0) {
            c = {0.55, 0.55, 0.55};
          } else if (!std::isfinite(u)) {
            c = {0.8, 0.0, 0.8};
          } else {
            most = std::max(most, u);
            const double k = std::clamp(std::log2(std::max(u, 1.0)) / 12, 0.0, 1.0);
            c = {std::clamp(2 * k, 0.0, 1.0), std::clamp(k < 0.5 ? 2 * k : 2 - 2 * k, 0.0, 1.0),
                 std::clamp(1 - 2 * k, 0.0, 1.0)};
          }
          const Shape& s = index.primitive(h.primitive).shape;
          const Vec3 p = ray.at(h.hit.t);
          Vec3 n(0, 1, 0);
          if (const auto* t = std::get_if<Triangle>(&s)) n = unit(cross(t->v[1] - t->v[0], t->v[2] - t->v[0]));
          if (const auto* sp = std::get_if<Sphere>(&s)) n = unit(p - sp->center);
          if (const auto* pl = std::get_if<Plane>(&s)) n = unit(pl->normal);
          const double shade = 0.35 + 0.65 * std::abs(n.dot(unit(ray.direction)));
          for (double& ch : c) ch *= shade;
        }
        for (int ch = 0; ch < 3; ++ch)
          img.rgb[3 * (std::size_t(y) * img.width + x) + ch] =
              std::uint8_t(std::lround(255 * std::clamp(c[ch], 0.0, 1.0)));
      }
    const std::string b64 = markup::base64(encode_png(img));
    html += "<p><img alt='required offset per primitive' src='data:image/png;base64," + b64 +
            "'><br>Required offset in ulps of the hit point's largest coordinate: blue 1, green 64, red 4096 or "
            "more (magenta: no finite proof, grey: another shape's primitive). A primitive needs more where its "
            "points are small beside the rays' reach (near the origin, or small and far from the camera) and "
            "where it is large. Most here: " +
            format("%.3g ulps.", most) + "</p>";
  }
  return html;
}

}  // namespace rayproof::studies
