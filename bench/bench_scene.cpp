// Scenes with meshes: primary rays through the BVH with a variant at the leaves (what `render`
// and `audit` do per ray), against Embree 3's single-ray rtcIntersect1 on the same mesh and the
// same rays in the same run; and a 10-triangle scene's rays per second per core.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <random>
#include <vector>

#include "rayproof/core/render.h"
#include "rayproof/core/scene_index.h"
#include "rayproof/core/scene_rays.h"
#ifdef RAYPROOF_BENCH_EMBREE
#include "rayproof/peers/embree.h"
#endif

namespace rayproof::bench {
namespace {

// The bunny's primary rays (its scene's camera), built outside the timed loops.
struct MeshScene {
  Scene scene;
  std::unique_ptr<SceneIndex> index;
  std::vector<Ray> rays;
};

std::vector<Ray> primary_rays(const Camera& cam) {
  std::vector<Ray> rays;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) rays.push_back(cam.ray_through(x + 0.5, y + 0.5));
  return rays;
}

const MeshScene* bunny() {
  static const MeshScene* s = []() -> const MeshScene* {
    const std::string path = RAYPROOF_BENCH_SCENES "/bunny.json";
    if (!std::filesystem::exists(path)) return nullptr;
    auto* m = new MeshScene{load_scene(path), nullptr, {}};
    m->index = std::make_unique<SceneIndex>(m->scene);
    m->rays = primary_rays(m->scene.camera);
    return m;
  }();
  return s;
}

// Ten triangles in front of a camera (a small scene: traversal overhead dominates).
const MeshScene* ten_triangles() {
  static const MeshScene* s = [] {
    auto* m = new MeshScene;
    m->scene.camera.eye = Vec3(0, 0, -3);
    m->scene.camera.forward = Vec3(0, 0, 1), m->scene.camera.right = Vec3(1, 0, 0), m->scene.camera.up = Vec3(0, 1, 0);
    m->scene.camera.width = 160, m->scene.camera.height = 120;
    m->scene.camera.window_left = -0.5, m->scene.camera.window_right = 0.5;
    m->scene.camera.window_top = 0.375, m->scene.camera.window_bottom = -0.375;
    std::mt19937_64 rng(10);
    std::uniform_real_distribution<double> u(-1, 1), s_(-0.5, 0.5);
    while (m->scene.objects.size() < 10) {
      const Vec3 c(u(rng), u(rng), u(rng));
      SceneObject obj;
      obj.shape = Triangle{{c + Vec3(s_(rng), s_(rng), s_(rng)), c + Vec3(s_(rng), s_(rng), s_(rng)),
                            c + Vec3(s_(rng), s_(rng), s_(rng))}};
      if (!degenerate_reason(obj.shape)) m->scene.objects.push_back(obj);
    }
    m->index = std::make_unique<SceneIndex>(m->scene);
    m->rays = primary_rays(m->scene.camera);
    return m;
  }();
  return s;
}

void rays_counter(benchmark::State& state) {
  state.counters["rays_per_s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["per_test"] =
      benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_BvhPrimary(benchmark::State& state, const MeshScene* (*scene)(), const char* variant) {
  const MeshScene* s = scene();
  if (!s) return state.SkipWithError("bunny scene not built (libcgal-demo missing)");
  const Variant& v = *find_variant(variant);
  const KindIndex& triangles = s->index->of_kind(ShapeKind::triangle);
  std::vector<SceneRay> rays(s->rays.begin(), s->rays.end());
  size_t i = 0;
  for (auto _ : state) {  // one ray a call, as rtcIntersect1: the nearest primitive and its t
    SceneRayAnswer a;
    trace_scene_rays(v, triangles, HitRule::nearest_contact, std::span(&rays[i++ % rays.size()], 1), std::span(&a, 1));
    benchmark::DoNotOptimize(a.primitive);
  }
  rays_counter(state);
}

#ifdef RAYPROOF_BENCH_EMBREE
void BM_EmbreePrimary(benchmark::State& state, const MeshScene* (*scene)()) {
  const MeshScene* s = scene();
  if (!s) return state.SkipWithError("bunny scene not built (libcgal-demo missing)");
  std::vector<Shape> tris;
  for (const Primitive& p : s->index->primitives())
    if (p.shape.index() == static_cast<int>(ShapeKind::triangle)) tris.push_back(p.shape);
  RTCScene es = peers::build_embree_scene(tris, false);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  size_t i = 0;
  for (auto _ : state) {
    RTCRayHit rh = peers::embree_ray(s->rays[i++ % s->rays.size()]);
    rtcIntersect1(es, &ctx, &rh);
    benchmark::DoNotOptimize(rh.hit.primID);
  }
  rays_counter(state);
  rtcReleaseScene(es);
}
#endif

// At least half a second each, whatever --benchmark_min_time says: the ratio to Embree is a goal,
// and 50 ms runs on a shared machine swing it by ±10%.
constexpr double kSceneMinSeconds = 0.5;

const bool registered = [] {
  for (const char* v : {"moller-trumbore", "watertight"}) {
    benchmark::RegisterBenchmark(("scene/bunny/bvh/" + std::string(v)).c_str(), BM_BvhPrimary, bunny, v)
        ->MinTime(kSceneMinSeconds);
    benchmark::RegisterBenchmark(("scene/ten-triangles/bvh/" + std::string(v)).c_str(), BM_BvhPrimary, ten_triangles, v)
        ->MinTime(kSceneMinSeconds);
  }
#ifdef RAYPROOF_BENCH_EMBREE
  benchmark::RegisterBenchmark("scene/bunny/embree/single", BM_EmbreePrimary, bunny)->MinTime(kSceneMinSeconds);
  benchmark::RegisterBenchmark("scene/ten-triangles/embree/single", BM_EmbreePrimary, ten_triangles)
      ->MinTime(kSceneMinSeconds);
#endif
  return true;
}();

}  // namespace
}  // namespace rayproof::bench
