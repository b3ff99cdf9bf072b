// Embree 3, the speed a user would pick instead, in the same run: a one-triangle and a
// one-sphere scene (single rays and 8-ray packets) against rayproof's variants on the same
// rays, and a 10,000-triangle scene.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "rayproof/core/variants.h"
#include "rayproof/peers/embree.h"

namespace rayproof::bench {
namespace {

RTCScene triangle_scene(const std::vector<Triangle>& tris, bool robust) {
  const std::vector<Shape> shapes(tris.begin(), tris.end());
  return peers::build_embree_scene(shapes, robust);
}

RTCScene sphere_scene(const Sphere& s, bool robust) {
  const Shape shape = s;
  return peers::build_embree_scene(std::span(&shape, 1), robust);
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
    RTCRayHit rh = peers::embree_ray(rs[i++ % rs.size()]);
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
      p.ray.dir_x[k] = float(r.direction.x()), p.ray.dir_y[k] = float(r.direction.y()),
      p.ray.dir_z[k] = float(r.direction.z());
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
