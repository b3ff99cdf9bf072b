// Whole tracers (issue 20's speed goals), each question its own benchmark, inputs built outside
// the timed loops, on the bunny's primary rays (its scene's camera):
//  - ground truth: the exact nearest crossing over the mesh per ray (goal >= 10^6 rays/s/core);
//  - a tracer plugin's nearest called in this process, against the same calls made through
//    rayproof's worker process in batches (goal: through the worker <= 1.5x direct), and the
//    whole judgement (truth + worker + kinds) per ray beside them;
//  - what verdicts cost (issue 39's goal: <= 1.2x on every family): a tracer campaign per family,
//    every built-in tracer (bvh-*), both modes, run without backward errors and with them
//    (the default K, witnesses checked) in the same iteration; the counter beta_cost is the ratio.
#include <benchmark/benchmark.h>
#include <dlfcn.h>

#include <cerrno>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <memory>
#include <optional>
#include <vector>

#include "rayproof/core/mesh.h"
#include "rayproof/core/scene.h"
#include "rayproof/fuzz/tracer_campaign.h"
#include "rayproof/peers/tracers.h"
#include "rayproof/tracer.h"
#include "rayproof/verify/mesh_truth.h"

namespace rayproof::bench {
namespace {

struct BunnyMesh {
  std::shared_ptr<TriangleMesh> mesh;
  std::vector<TracerRay> rays;
};

const BunnyMesh* bunny_mesh() {
  static const BunnyMesh* b = []() -> const BunnyMesh* {
    const std::string path = RAYPROOF_BENCH_SCENES "/bunny.json";
    if (!std::filesystem::exists(path)) return nullptr;
    const Scene scene = load_scene(path);
    auto* out = new BunnyMesh{std::make_shared<TriangleMesh>(), {}};
    for (const SceneObject& o : scene.objects)
      if (o.mesh) append_mesh(*out->mesh, triangle_mesh_of(*o.mesh));
    const Camera& cam = scene.camera;
    for (int y = 0; y < cam.height; ++y)
      for (int x = 0; x < cam.width; ++x) out->rays.push_back({cam.ray_through(x + 0.5, y + 0.5), 0, INFINITY});
    return out;
  }();
  return b;
}

void BM_GroundTruthBunnyPrimary(benchmark::State& state) {
  const BunnyMesh* b = bunny_mesh();
  if (!b) return state.SkipWithError("no bunny scene (Debian libcgal-demo)");
  MeshOracle oracle(b->mesh);
  std::size_t i = 0, crossings = 0;
  for (auto _ : state) {
    const MeshTruth t = oracle.truth(b->rays[i], false);
    crossings += !t.points.empty();
    benchmark::DoNotOptimize(t);
    if (++i == b->rays.size()) i = 0;
  }
  state.counters["rays_per_s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["crossing_fraction"] = double(crossings) / double(state.iterations());
}
BENCHMARK(BM_GroundTruthBunnyPrimary)->Name("tracers/ground-truth/bunny-primary")->MinTime(0.5);

// The example tracer library, loaded into this process for the direct calls.
const rayproof_tracer* example_tracer() {
  static const rayproof_tracer* t = []() -> const rayproof_tracer* {
    void* lib = ::dlopen(RAYPROOF_BENCH_TRACER, RTLD_NOW | RTLD_LOCAL);
    if (!lib) return nullptr;
    auto entry = reinterpret_cast<decltype(&rayproof_tracers)>(::dlsym(lib, "rayproof_tracers"));
    int n = 0;
    const rayproof_tracer* table = entry ? entry(RAYPROOF_TRACER_ABI, &n) : nullptr;
    for (int i = 0; table && i < n; ++i)
      if (std::string(table[i].name) == "float-bvh-careful-slab") return &table[i];
    return nullptr;
  }();
  return t;
}

constexpr std::size_t kBatch = 4096;

std::vector<rayproof_ray> wire_rays(const std::vector<TracerRay>& rays) {
  std::vector<rayproof_ray> out;
  for (const TracerRay& r : rays) {
    rayproof_ray w;
    for (int k = 0; k < 3; ++k) w.origin[k] = float(r.ray.origin[k]), w.direction[k] = float(r.ray.direction[k]);
    w.tmin = r.tmin, w.tmax = r.tmax;
    out.push_back(w);
  }
  return out;
}

void BM_TracerNearestDirect(benchmark::State& state) {
  const BunnyMesh* b = bunny_mesh();
  const rayproof_tracer* t = example_tracer();
  if (!b || !t) return state.SkipWithError("no bunny scene or example tracer");
  const auto mesh = *mesh_rounded_to_float(*b->mesh);
  const rayproof_mesh m{mesh.vertices.data(), uint32_t(mesh.vertex_count()), mesh.indices.data(),
                        uint32_t(mesh.triangle_count())};
  void* scene = t->build(&m);
  const std::vector<rayproof_ray> rays = wire_rays(b->rays);
  std::vector<rayproof_trace> out(kBatch);
  std::size_t at = 0;
  for (auto _ : state) {
    const std::size_t n = std::min(kBatch, rays.size() - at);
    t->nearest(scene, rays.data() + at, n, out.data());
    benchmark::DoNotOptimize(out.data());
    at = at + n == rays.size() ? 0 : at + n;
    state.SetItemsProcessed(state.items_processed() + std::int64_t(n));
  }
  t->release(scene);
}
BENCHMARK(BM_TracerNearestDirect)->Name("tracers/plugin-nearest/direct")->MinTime(0.5)->UseRealTime();

const Tracer* loaded_example() {
  static const Tracer* t = []() -> const Tracer* {
    if (!std::filesystem::exists(RAYPROOF_BENCH_TRACER)) return nullptr;
    peers::ExternalOptions o;
    peers::load_tracer_plugin(RAYPROOF_BENCH_TRACER, o);
    return find_tracer("float-bvh-careful-slab");
  }();
  return t;
}

void BM_TracerNearestThroughWorker(benchmark::State& state) {
  const BunnyMesh* b = bunny_mesh();
  const Tracer* t = loaded_example();
  if (!b || !t) return state.SkipWithError("no bunny scene or example tracer");
  const auto mesh = *mesh_rounded_to_float(*b->mesh);
  BuiltScene built = t->build(mesh);
  std::vector<TracerRay> rays;
  for (const TracerRay& r : b->rays) rays.push_back(*ray_rounded_to_float(r));
  std::vector<TraceAnswer> out(kBatch);
  std::size_t at = 0;
  for (auto _ : state) {
    const std::size_t n = std::min(kBatch, rays.size() - at);
    built.scene->nearest(std::span(rays).subspan(at, n), std::span(out).subspan(0, n));
    benchmark::DoNotOptimize(out.data());
    at = at + n == rays.size() ? 0 : at + n;
    state.SetItemsProcessed(state.items_processed() + std::int64_t(n));
  }
}
BENCHMARK(BM_TracerNearestThroughWorker)
    ->Name("tracers/plugin-nearest/worker")
    ->MinTime(0.5)
    ->UseRealTime();  // the work is in another process

// Through the worker and judged: truth over the float mesh plus the kind of each answer.
void BM_TracerJudged(benchmark::State& state) {
  const BunnyMesh* b = bunny_mesh();
  const Tracer* t = loaded_example();
  if (!b || !t) return state.SkipWithError("no bunny scene or example tracer");
  auto mesh = std::make_shared<TriangleMesh>(*mesh_rounded_to_float(*b->mesh));
  BuiltScene built = t->build(*mesh);
  MeshOracle oracle(mesh);
  std::vector<TracerRay> rays;
  for (const TracerRay& r : b->rays) rays.push_back(*ray_rounded_to_float(r));
  std::vector<TraceAnswer> out(kBatch);
  std::size_t at = 0, right = 0;
  for (auto _ : state) {
    const std::size_t n = std::min(kBatch, rays.size() - at);
    built.scene->nearest(std::span(rays).subspan(at, n), std::span(out).subspan(0, n));
    for (std::size_t i = 0; i < n; ++i)
      right += oracle.judge_nearest(rays[at + i], oracle.truth(rays[at + i], false), out[i], Precision::f32).kind ==
               TraceKind::right;
    at = at + n == rays.size() ? 0 : at + n;
    state.SetItemsProcessed(state.items_processed() + std::int64_t(n));
  }
  state.counters["right_fraction"] = double(right) / double(state.items_processed());
}
BENCHMARK(BM_TracerJudged)->Name("tracers/plugin-nearest/judged")->MinTime(0.5)->UseRealTime();

// One family's campaign without β and with it, back to back on one thread (far: fewer rays, each
// far slower to judge exactly).
void BM_VerdictCost(benchmark::State& state) {
  const auto family = fuzz::kAllTracerFamilies[state.range(0)];
  state.SetLabel(std::string(fuzz::to_string(family)));
  const std::filesystem::path out = std::filesystem::temp_directory_path() / "rayproof-bench-verdict-cost.jsonl";
  // RAYPROOF_VERDICT_COST_RAYS=N: every family at N rays (issue 39's figure is at 10^5, where the
  // findings written, capped, no longer weigh).
  std::optional<std::uint64_t> rays;
  if (const char* n = std::getenv("RAYPROOF_VERDICT_COST_RAYS")) {
    char* end = nullptr;
    errno = 0;
    const unsigned long long parsed = std::strtoull(n, &end, 10);
    if (end == n || *end != '\0' || errno != 0 || parsed == 0 || n[0] == '-')
      return state.SkipWithError("RAYPROOF_VERDICT_COST_RAYS: expected a whole number of rays above 0");
    rays = parsed;
  }
  auto seconds = [&](bool beta) {
    fuzz::TracerCampaignOptions o;
    o.families = {family};
    o.tracers = all_tracers();
    o.count = family == fuzz::TracerFamily::far ? 500 : 4000;
    if (rays) o.count = *rays;
    o.output = out.string();
    o.shrink = false;
    o.verdicts.backward_error = beta;
    const std::clock_t start = std::clock();  // processor time: one thread, the tracers in process
    benchmark::DoNotOptimize(fuzz::run_tracer_campaign(o));
    return double(std::clock() - start) / CLOCKS_PER_SEC;
  };
  double without = 0, with = 0;
  for (auto _ : state) without += seconds(false), with += seconds(true);
  std::filesystem::remove(out);
  state.counters["beta_cost"] = with / without;
}
BENCHMARK(BM_VerdictCost)->Name("tracers/verdict-cost")->DenseRange(0, 7)->Iterations(2)->Unit(benchmark::kSecond);

}  // namespace
}  // namespace rayproof::bench
