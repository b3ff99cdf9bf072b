#include "peers/embree.h"

#include <embree3/rtcore.h>

#include <cfloat>
#include <cmath>
#include <memory>
#include <stdexcept>

#include "rayproof/oracle.h"

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

struct Device {
  RTCDevice device = rtcNewDevice("threads=1");
  Device() {
    if (!device) throw std::runtime_error("embree: rtcNewDevice failed");
  }
  ~Device() { rtcReleaseDevice(device); }
};
Device& device() {
  static Device d;
  return d;
}

// A committed scene holding one primitive.
struct Scene {
  RTCScene scene = nullptr;
  Scene(const Shape& shape, bool robust) {
    RTCDevice dev = device().device;
    scene = rtcNewScene(dev);
    rtcSetSceneFlags(scene, robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
    RTCGeometry g;
    if (const auto* t = std::get_if<Triangle>(&shape)) {
      g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
      auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3));
      for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) v[3 * i + k] = static_cast<float>(t->v[i][k]);
      auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), 1));
      idx[0] = 0, idx[1] = 1, idx[2] = 2;
    } else {
      const Sphere& s = std::get<Sphere>(shape);
      g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_SPHERE_POINT);
      auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), 1));
      v[0] = static_cast<float>(s.center.x()), v[1] = static_cast<float>(s.center.y());
      v[2] = static_cast<float>(s.center.z()), v[3] = static_cast<float>(s.radius);
    }
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene);
  }
  ~Scene() { if (scene) rtcReleaseScene(scene); }
  Scene(const Scene&) = delete;

  // Embree's answer in the case format's classes: a hit, its t, and the side from the
  // geometric normal Ng — outward for a sphere, along the case format's front normal
  // (v1−v0)×(v2−v0) for a triangle (checked by tests/test_embree.cpp).
  Hit intersect(const Ray& r) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh{};
    rh.ray.org_x = static_cast<float>(r.origin.x()), rh.ray.org_y = static_cast<float>(r.origin.y());
    rh.ray.org_z = static_cast<float>(r.origin.z());
    rh.ray.dir_x = static_cast<float>(r.direction.x()), rh.ray.dir_y = static_cast<float>(r.direction.y());
    rh.ray.dir_z = static_cast<float>(r.direction.z());
    rh.ray.tnear = 0, rh.ray.tfar = INFINITY, rh.ray.mask = ~0u, rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID || !(rh.ray.tfar > 0)) return Hit::miss();
    const double ng_dot_d = double(rh.hit.Ng_x) * r.direction.x() + double(rh.hit.Ng_y) * r.direction.y() +
                            double(rh.hit.Ng_z) * r.direction.z();
    return {ng_dot_d < 0 ? HitClass::enter : HitClass::exit, static_cast<double>(rh.ray.tfar)};
  }
};

fuzz::Contender contender(ShapeKind shape, bool robust) {
  return {robust ? "embree-robust" : "embree", shape,
          [robust](const std::vector<fuzz::Query>& qs) {
            auto hits = std::make_shared<std::vector<Hit>>(qs.size());
            // Few queries (the timing set): keep a scene per query and time rtcIntersect1 alone.
            // Many (the accuracy set): build, ask and release one scene at a time.
            if (qs.size() <= 4096) {
              auto scenes = std::make_shared<std::vector<std::unique_ptr<Scene>>>();
              for (const fuzz::Query& q : qs) scenes->push_back(std::make_unique<Scene>(q.shape, robust));
              return fuzz::Prepared{[scenes, hits, &qs] {
                                      for (size_t i = 0; i < qs.size(); ++i) (*hits)[i] = (*scenes)[i]->intersect(qs[i].ray);
                                    },
                                    [hits](size_t i) { return (*hits)[i]; }};
            }
            return fuzz::Prepared{[hits, &qs, robust] {
                                    for (size_t i = 0; i < qs.size(); ++i) (*hits)[i] = Scene(qs[i].shape, robust).intersect(qs[i].ray);
                                  },
                                  [hits](size_t i) { return (*hits)[i]; }};
          },
          [](const fuzz::Query& q) { return as_float_query(q); }};
}

}  // namespace

std::optional<fuzz::Query> as_float_query(const fuzz::Query& q) {
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
  return fuzz::Query{Ray{*o, *d}, s};
}

HoleCount embree_shared_edge_holes(std::uint64_t pairs, std::uint64_t seed, bool robust) {
  HoleCount count;
  Oracle oracle;
  RTCDevice dev = device().device;
  for (std::uint64_t p = 0; p < pairs; ++p) {
    const fuzz::GeneratedCase a = fuzz::generate(fuzz::Family::grazing, ShapeKind::triangle, seed, 2 * p);
    const fuzz::GeneratedCase b = fuzz::generate(fuzz::Family::grazing, ShapeKind::triangle, seed, 2 * p + 1);
    if (a.detail.rfind("shared-edge", 0) != 0) continue;
    const auto fa = as_float_query({a.ray, a.shape}), fb = as_float_query({b.ray, b.shape});
    if (!fa || !fb) continue;
    ++count.pairs;
    const Verdict ea = oracle.judge(fa->ray, fa->shape), eb = oracle.judge(fb->ray, fb->shape);
    const bool hit_a = ea.cls != HitClass::miss, hit_b = eb.cls != HitClass::miss;
    if (!(hit_a || hit_b) || (hit_a && hit_b && ea.front != eb.front)) continue;
    ++count.crossing;
    double largest = max_abs(fa->ray.origin);
    for (const fuzz::Query* q : {&*fa, &*fb})
      for (const Vec3& v : std::get<Triangle>(q->shape).v) largest = std::max(largest, max_abs(v));
    const bool large = largest >= 0x1p40;
    count.crossing_large += large;
    RTCScene scene = rtcNewScene(dev);
    rtcSetSceneFlags(scene, robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
    for (const fuzz::Query* q : {&*fa, &*fb}) {
      const Triangle& t = std::get<Triangle>(q->shape);
      RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
      auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3));
      for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) v[3 * i + k] = static_cast<float>(t.v[i][k]);
      auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), 1));
      idx[0] = 0, idx[1] = 1, idx[2] = 2;
      rtcCommitGeometry(g);
      rtcAttachGeometry(scene, g);
      rtcReleaseGeometry(g);
    }
    rtcCommitScene(scene);
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh{};
    rh.ray.org_x = float(fa->ray.origin.x()), rh.ray.org_y = float(fa->ray.origin.y()), rh.ray.org_z = float(fa->ray.origin.z());
    rh.ray.dir_x = float(fa->ray.direction.x()), rh.ray.dir_y = float(fa->ray.direction.y()), rh.ray.dir_z = float(fa->ray.direction.z());
    rh.ray.tnear = 0, rh.ray.tfar = INFINITY, rh.ray.mask = ~0u;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) ++count.holes, count.holes_large += large;
    rtcReleaseScene(scene);
  }
  return count;
}

std::vector<fuzz::Contender> embree_contenders() {
  return {contender(ShapeKind::triangle, false), contender(ShapeKind::triangle, true),
          contender(ShapeKind::sphere, false), contender(ShapeKind::sphere, true)};
}

}  // namespace rayproof::peers
