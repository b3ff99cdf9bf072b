// Embree 3, the speed a user would pick instead, in the same run: a one-triangle and a
// one-sphere scene (single rays and 8-ray packets) against rayproof's variants on the same
// rays, and a 10,000-triangle scene.
#include <benchmark/benchmark.h>
#include <embree3/rtcore.h>

#include <cmath>
#include <random>
#include <vector>

#include "rayproof/variants.h"

namespace rayproof::bench {
namespace {

RTCDevice device() {
  static RTCDevice d = rtcNewDevice("threads=1");
  return d;
}

RTCScene triangle_scene(const std::vector<Triangle>& tris, bool robust) {
  RTCScene scene = rtcNewScene(device());
  rtcSetSceneFlags(scene, robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
  RTCGeometry g = rtcNewGeometry(device(), RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3 * tris.size()));
  auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), tris.size()));
  for (size_t t = 0; t < tris.size(); ++t)
    for (int i = 0; i < 3; ++i) {
      for (int k = 0; k < 3; ++k) v[9 * t + 3 * i + k] = static_cast<float>(tris[t].v[i][k]);
      idx[3 * t + i] = static_cast<unsigned>(3 * t + i);
    }
  rtcCommitGeometry(g);
  rtcAttachGeometry(scene, g);
  rtcReleaseGeometry(g);
  rtcCommitScene(scene);
  return scene;
}

RTCScene sphere_scene(const Sphere& s, bool robust) {
  RTCScene scene = rtcNewScene(device());
  rtcSetSceneFlags(scene, robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
  RTCGeometry g = rtcNewGeometry(device(), RTC_GEOMETRY_TYPE_SPHERE_POINT);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), 1));
  v[0] = float(s.center.x()), v[1] = float(s.center.y()), v[2] = float(s.center.z()), v[3] = float(s.radius);
  rtcCommitGeometry(g);
  rtcAttachGeometry(scene, g);
  rtcReleaseGeometry(g);
  rtcCommitScene(scene);
  return scene;
}

const Triangle kTriangle{{Vec3(-1, -1, 0.1), Vec3(1, -1, -0.2), Vec3(0, 1, 0.05)}};
const Sphere kSphere{Vec3(0.1, -0.2, 0.05), 1};

// Rays from a shell of radius 5 toward points of [-1, 1]³ (float-exact, so both sides agree).
std::vector<Ray> rays(size_t n) {
  std::mt19937_64 rng(99);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Ray> out;
  for (size_t i = 0; i < n; ++i) {
    Vec3 o(g(rng), g(rng), g(rng));
    o = 5 * normalized(o);
    const Vec3 target(u(rng), u(rng), u(rng));
    Vec3 d = target - o;
    for (int k = 0; k < 3; ++k) o[k] = float(o[k]), d[k] = float(d[k]);
    out.push_back({o, d});
  }
  return out;
}

void set(RTCRayHit& rh, const Ray& r) {
  rh.ray.org_x = float(r.origin.x()), rh.ray.org_y = float(r.origin.y()), rh.ray.org_z = float(r.origin.z());
  rh.ray.dir_x = float(r.direction.x()), rh.ray.dir_y = float(r.direction.y()), rh.ray.dir_z = float(r.direction.z());
  rh.ray.tnear = 0, rh.ray.tfar = INFINITY, rh.ray.mask = ~0u, rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
}

void counters(benchmark::State& state, double tests) {
  state.counters["tests_per_s"] = benchmark::Counter(tests, benchmark::Counter::kIsRate);
  state.counters["per_test"] = benchmark::Counter(tests, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_EmbreeSingle(benchmark::State& state, RTCScene scene) {
  const auto rs = rays(4096);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  size_t i = 0;
  for (auto _ : state) {
    RTCRayHit rh;
    set(rh, rs[i++ % rs.size()]);
    rtcIntersect1(scene, &ctx, &rh);
    benchmark::DoNotOptimize(rh.ray.tfar);
  }
  counters(state, double(state.iterations()));
}

void BM_EmbreePacket8(benchmark::State& state, RTCScene scene) {
  const auto rs = rays(4096);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  alignas(32) int valid[8];
  for (int& v : valid) v = -1;
  size_t i = 0;
  for (auto _ : state) {
    alignas(32) RTCRayHit8 p;
    for (int k = 0; k < 8; ++k) {
      const Ray& r = rs[i++ % rs.size()];
      p.ray.org_x[k] = float(r.origin.x()), p.ray.org_y[k] = float(r.origin.y()), p.ray.org_z[k] = float(r.origin.z());
      p.ray.dir_x[k] = float(r.direction.x()), p.ray.dir_y[k] = float(r.direction.y()), p.ray.dir_z[k] = float(r.direction.z());
      p.ray.tnear[k] = 0, p.ray.tfar[k] = INFINITY, p.ray.mask[k] = ~0u, p.ray.flags[k] = 0;
      p.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
    }
    rtcIntersect8(valid, scene, &ctx, &p);
    benchmark::DoNotOptimize(p.ray.tfar[0]);
  }
  counters(state, 8.0 * state.iterations());
}

// rayproof's variant on the same primitive and the same rays: the ratio's denominator.
void BM_VariantOnSameRays(benchmark::State& state, const Variant* v, Shape shape) {
  const auto rs = rays(4096);
  size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(v->intersect(rs[i++ % rs.size()], shape, HitRule::nearest_contact));
  counters(state, double(state.iterations()));
}

const bool registered = [] {
  for (bool robust : {false, true}) {
    const std::string flag = robust ? "-robust" : "";
    RTCScene tri = triangle_scene({kTriangle}, robust), sph = sphere_scene(kSphere, robust);
    benchmark::RegisterBenchmark(("peer/embree" + flag + "/one-triangle/single").c_str(), BM_EmbreeSingle, tri);
    benchmark::RegisterBenchmark(("peer/embree" + flag + "/one-triangle/packet8").c_str(), BM_EmbreePacket8, tri);
    benchmark::RegisterBenchmark(("peer/embree" + flag + "/one-sphere/single").c_str(), BM_EmbreeSingle, sph);
    benchmark::RegisterBenchmark(("peer/embree" + flag + "/one-sphere/packet8").c_str(), BM_EmbreePacket8, sph);
  }
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1), small(-0.02, 0.02);
  std::vector<Triangle> many;
  while (many.size() < 10000) {
    const Vec3 c(u(rng), u(rng), u(rng));
    const Triangle t{{c + Vec3(small(rng), small(rng), small(rng)), c + Vec3(small(rng), small(rng), small(rng)),
                      c + Vec3(small(rng), small(rng), small(rng))}};
    if (!degenerate_reason(t)) many.push_back(t);
  }
  RTCScene big = triangle_scene(many, false);
  benchmark::RegisterBenchmark("peer/embree/10000-triangles/single", BM_EmbreeSingle, big);
  benchmark::RegisterBenchmark("peer/embree/10000-triangles/packet8", BM_EmbreePacket8, big);
  for (const char* name : {"moller-trumbore", "watertight"})
    benchmark::RegisterBenchmark(("variant/" + std::string(name) + "/one-triangle").c_str(), BM_VariantOnSameRays,
                                 find_variant(name), Shape(kTriangle));
  for (const char* name : {"textbook", "stable", "hearn-baker"})
    benchmark::RegisterBenchmark(("variant/" + std::string(name) + "/one-sphere").c_str(), BM_VariantOnSameRays,
                                 find_variant(name), Shape(kSphere));
  return true;
}();

}  // namespace
}  // namespace rayproof::bench
