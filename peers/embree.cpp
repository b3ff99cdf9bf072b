#include "rayproof/peers/embree.h"

#include <cfloat>
#include <cmath>
#include <memory>
#include <stdexcept>

#include "rayproof/fuzz/generators.h"
#include "rayproof/verify/compare.h"
#include "rayproof/verify/oracle.h"

namespace rayproof::peers {

namespace {

// Embree asserts that ray components stay within ±FLT_LARGE = 1.844e18 (rtcore_ray.h's valid());
// queries beyond it are not Embree's to answer.
constexpr double kEmbreeLargest = 1.844e18;

std::optional<double> to_float(double x) {
  if (!(std::abs(x) <= kEmbreeLargest)) return std::nullopt;
  const float f = static_cast<float>(x);
  if (std::isinf(f)) return std::nullopt;
  return static_cast<double>(f);
}

std::optional<Vec3> to_float(const Vec3& v) {
  const auto x = to_float(v.x()), y = to_float(v.y()), z = to_float(v.z());
  if (!x || !y || !z) return std::nullopt;
  return Vec3(*x, *y, *z);
}

// A committed scene, released with its owner.
struct Scene {
  RTCScene scene;
  Scene(std::span<const Shape> shapes, bool robust) : scene(build_embree_scene(shapes, robust)) {}
  ~Scene() { rtcReleaseScene(scene); }
  Scene(const Scene&) = delete;

  // Whether Embree reports any hit at all (t ≥ tnear = 0).
  bool hits(const Ray& r) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh = embree_ray(r);
    rtcIntersect1(scene, &ctx, &rh);
    return rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
  }

  // Embree's answer in the case format's classes: a hit, its t, and the side from the
  // geometric normal Ng — outward for a sphere, along the case format's front normal
  // (v1−v0)×(v2−v0) for a triangle (checked by tests/test_embree.cpp).
  Hit intersect(const Ray& r) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh = embree_ray(r);
    rtcIntersect1(scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID || !(rh.ray.tfar > 0)) return Hit::miss();
    const double ng_dot_d = double(rh.hit.Ng_x) * r.direction.x() + double(rh.hit.Ng_y) * r.direction.y() +
                            double(rh.hit.Ng_z) * r.direction.z();
    return {ng_dot_d < 0 ? HitClass::enter : HitClass::exit, static_cast<double>(rh.ray.tfar)};
  }
};

studies::Contender contender(ShapeKind shape, bool robust) {
  return {robust ? "embree-robust" : "embree", shape,
          [robust](const std::vector<Query>& qs) {
            auto hits = std::make_shared<std::vector<Hit>>(qs.size());
            // Few queries (the timing set): keep a scene per query and time rtcIntersect1 alone.
            // Many (the accuracy set): build, ask and release one scene at a time.
            if (qs.size() <= 4096) {
              auto scenes = std::make_shared<std::vector<std::unique_ptr<Scene>>>();
              for (const Query& q : qs) scenes->push_back(std::make_unique<Scene>(std::span(&q.shape, 1), robust));
              return studies::Prepared{[scenes, hits, &qs] {
                                         for (size_t i = 0; i < qs.size(); ++i)
                                           (*hits)[i] = (*scenes)[i]->intersect(qs[i].ray);
                                       },
                                       [hits](size_t i) { return (*hits)[i]; }};
            }
            return studies::Prepared{[hits, &qs, robust] {
                                       for (size_t i = 0; i < qs.size(); ++i)
                                         (*hits)[i] = Scene(std::span(&qs[i].shape, 1), robust).intersect(qs[i].ray);
                                     },
                                     [hits](size_t i) { return (*hits)[i]; }};
          },
          [](const Query& q) { return as_float_query(q); }};
}

}  // namespace

RTCDevice embree_device() {
  static const RTCDevice device = [] {
    RTCDevice d = rtcNewDevice("threads=1");
    if (!d) throw std::runtime_error("embree: rtcNewDevice failed");
    return d;
  }();
  return device;
}

RTCScene build_embree_scene(std::span<const Shape> shapes, bool robust) {
  RTCDevice dev = embree_device();
  RTCScene scene = rtcNewScene(dev);
  rtcSetSceneFlags(scene, robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
  std::vector<const Triangle*> triangles;
  for (const Shape& s : shapes) {
    if (const auto* t = std::get_if<Triangle>(&s)) triangles.push_back(t);
    if (const auto* sp = std::get_if<Sphere>(&s)) {
      RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_SPHERE_POINT);
      auto* v = static_cast<float*>(
          rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), 1));
      v[0] = float(sp->center.x()), v[1] = float(sp->center.y()), v[2] = float(sp->center.z()),
      v[3] = float(sp->radius);
      rtcCommitGeometry(g);
      rtcAttachGeometry(scene, g);
      rtcReleaseGeometry(g);
    }
  }
  if (!triangles.empty()) {
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    const size_t n = triangles.size();
    auto* v = static_cast<float*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3 * n));
    auto* idx = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), n));
    for (size_t t = 0; t < n; ++t)
      for (int i = 0; i < 3; ++i) {
        for (int k = 0; k < 3; ++k) v[9 * t + 3 * i + k] = static_cast<float>(triangles[t]->v[i][k]);
        idx[3 * t + i] = static_cast<unsigned>(3 * t + i);
      }
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
  }
  rtcCommitScene(scene);
  return scene;
}

RTCRayHit embree_ray(const Ray& r) {
  RTCRayHit rh{};
  rh.ray.org_x = float(r.origin.x()), rh.ray.org_y = float(r.origin.y()), rh.ray.org_z = float(r.origin.z());
  rh.ray.dir_x = float(r.direction.x()), rh.ray.dir_y = float(r.direction.y()), rh.ray.dir_z = float(r.direction.z());
  rh.ray.tnear = 0, rh.ray.tfar = INFINITY, rh.ray.mask = ~0u, rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  return rh;
}

std::optional<Query> as_float_query(const Query& q) {
  const auto o = to_float(q.ray.origin), d = to_float(q.ray.direction);
  if (!o || !d || *d == Vec3::Zero()) return std::nullopt;
  Shape s;
  if (const auto* t = std::get_if<Triangle>(&q.shape)) {
    const auto a = to_float(t->v[0]), b = to_float(t->v[1]), c = to_float(t->v[2]);
    if (!a || !b || !c) return std::nullopt;
    s = Triangle{{*a, *b, *c}};
  } else if (const auto* sp = std::get_if<Sphere>(&q.shape)) {
    const auto c = to_float(sp->center);
    const auto r = to_float(sp->radius);
    if (!c || !r) return std::nullopt;
    s = Sphere{*c, *r};
  } else {
    return std::nullopt;
  }
  if (degenerate_reason(s)) return std::nullopt;
  return Query{Ray{*o, *d}, s, q.id};
}

HoleCount embree_shared_edge_holes(std::uint64_t pairs, std::uint64_t seed, bool robust) {
  HoleCount count;
  Oracle oracle;
  for (std::uint64_t p = 0; p < pairs; ++p) {
    const fuzz::GeneratedCase a = fuzz::generate(fuzz::Family::grazing, ShapeKind::triangle, seed, 2 * p);
    const fuzz::GeneratedCase b = fuzz::generate(fuzz::Family::grazing, ShapeKind::triangle, seed, 2 * p + 1);
    if (!a.shared_edge) continue;
    const auto fa = as_float_query(a), fb = as_float_query(b);
    if (!fa || !fb) continue;
    ++count.pairs;
    if (!crosses_shared_edge(oracle.judge(fa->ray, fa->shape), oracle.judge(fb->ray, fb->shape))) continue;
    ++count.crossing;
    double largest = max_abs(fa->ray.origin);
    for (const Query* q : {&*fa, &*fb})
      for (const Vec3& v : std::get<Triangle>(q->shape).v) largest = std::max(largest, max_abs(v));
    const bool large = largest >= 0x1p40;
    count.crossing_large += large;
    const Shape both[] = {fa->shape, fb->shape};
    if (!Scene(both, robust).hits(fa->ray)) ++count.holes, count.holes_large += large;
  }
  return count;
}

std::vector<studies::Contender> embree_contenders() {
  std::vector<studies::Contender> all = {contender(ShapeKind::triangle, false), contender(ShapeKind::triangle, true),
                                         contender(ShapeKind::sphere, false), contender(ShapeKind::sphere, true)};
  for (studies::Contender& c : all) c.precision = "float";
  return all;
}

}  // namespace rayproof::peers
