// ns per test of every variant, on rays that hit and rays that miss, prepared outside the loop.
#include <benchmark/benchmark.h>

#include <random>

#include "rayproof/variants.h"

namespace rayproof {
namespace {

struct Query {
  Ray ray;
  Shape shape;
};

Shape random_shape(ShapeKind kind, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  switch (kind) {
    case ShapeKind::sphere: return Sphere{Vec3(u(rng), u(rng), u(rng)), 0.5 + 0.4 * u(rng)};
    case ShapeKind::plane: return Plane{Vec3(u(rng), u(rng), 1), u(rng)};
    case ShapeKind::triangle:
      return Triangle{{Vec3(-1, -1, u(rng)), Vec3(1, -1, u(rng)), Vec3(u(rng), 1, u(rng))}};
    case ShapeKind::box: {
      const Vec3 c(u(rng) * 0.3, u(rng) * 0.3, u(rng) * 0.3);
      return Box{c - Vec3::Constant(0.5), c + Vec3::Constant(0.5)};
    }
  }
  return Sphere{};
}

// Rays from a shell of radius 5 toward a random point near the origin: most hit.
std::vector<Query> random_queries(ShapeKind kind, size_t n) {
  std::mt19937_64 rng(1234);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  std::vector<Query> qs;
  for (size_t i = 0; i < n; ++i) {
    Vec3 o(g(rng), g(rng), g(rng));
    o = 5 * normalized(o);
    const Vec3 target(u(rng), u(rng), u(rng));
    qs.push_back({Ray{o, target - o}, random_shape(kind, rng)});
  }
  return qs;
}

void BM_Variant(benchmark::State& state, const Variant* v) {
  const auto qs = random_queries(v->shape, 4096);
  size_t i = 0;
  for (auto _ : state) {
    const Query& q = qs[i++ & 4095];
    benchmark::DoNotOptimize(v->intersect(q.ray, q.shape, HitRule::nearest_contact));
  }
  state.counters["tests_per_s"] = benchmark::Counter(state.iterations(), benchmark::Counter::kIsRate);
}

const bool registered = [] {
  for (const Variant& v : all_variants())
    benchmark::RegisterBenchmark(("variant/" + std::string(v.name) + "/random").c_str(), BM_Variant, &v);
  return true;
}();

}  // namespace
}  // namespace rayproof

BENCHMARK_MAIN();
