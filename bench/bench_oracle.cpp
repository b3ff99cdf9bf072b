// What exactness costs: the oracle (class + correctly rounded t), filtered and forced-exact,
// against the double variants and CGAL's own exact predicate, on the same inputs in one run.
#include <benchmark/benchmark.h>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/intersections.h>

#include "queries.h"
#include "rayproof/oracle.h"
#include "rayproof/variants.h"

namespace rayproof::bench {
namespace {

constexpr size_t kQueries = 4096;

const char* family_name(Family f) { return f == Family::random ? "random" : "grazing"; }

void BM_Oracle(benchmark::State& state, ShapeKind kind, Family family, bool filter) {
  const auto qs = make_queries(kind, family, kQueries);
  Oracle oracle(Oracle::Options{filter});
  size_t i = 0;
  for (auto _ : state) {
    const Query& q = qs[i++ % kQueries];
    benchmark::DoNotOptimize(oracle.judge(q.ray, q.shape));
  }
  const OracleStats& s = oracle.stats(kind);
  state.SetItemsProcessed(state.iterations());
  const double queries = std::max<std::uint64_t>(1, s.queries);
  state.counters["class_expansion_pct"] = 100.0 * s.class_expansion / queries;
  state.counters["class_rational_pct"] = 100.0 * s.class_exact / queries;
  state.counters["t_rational_pct"] = 100.0 * s.rounding.rational / std::max<std::uint64_t>(1, s.rounding.rounded);
}

void BM_Variant(benchmark::State& state, const Variant* v, Family family) {
  const auto qs = make_queries(v->shape, family, kQueries);
  size_t i = 0;
  for (auto _ : state) {
    const Query& q = qs[i++ % kQueries];
    benchmark::DoNotOptimize(v->intersect(q.ray, q.shape, HitRule::nearest_contact));
  }
  state.SetItemsProcessed(state.iterations());
}

// CGAL Epick's exact do_intersect(Ray_3, Triangle_3): a predicate only (no t), the yardstick a
// CGAL user would reach for. The ray's second point o + d is rounded to double here.
void BM_CgalEpickTriangle(benchmark::State& state, Family family) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  const auto qs = make_queries(ShapeKind::triangle, family, kQueries);
  std::vector<std::pair<K::Ray_3, K::Triangle_3>> cgal;
  auto P = [](const Vec3& v) { return K::Point_3(v.x(), v.y(), v.z()); };
  for (const Query& q : qs) {
    const Triangle& t = std::get<Triangle>(q.shape);
    cgal.push_back({K::Ray_3(P(q.ray.origin), K::Vector_3(q.ray.direction.x(), q.ray.direction.y(), q.ray.direction.z())),
                    K::Triangle_3(P(t.v[0]), P(t.v[1]), P(t.v[2]))});
  }
  size_t i = 0;
  for (auto _ : state) {
    const auto& [r, t] = cgal[i++ % kQueries];
    benchmark::DoNotOptimize(CGAL::do_intersect(r, t));
  }
  state.SetItemsProcessed(state.iterations());
}

const bool registered = [] {
  for (Family f : {Family::random, Family::grazing}) {
    for (ShapeKind k : kAllShapeKinds) {
      const std::string base = std::string(to_string(k)) + "/" + family_name(f);
      for (const Variant* v : variants_for(k))
        benchmark::RegisterBenchmark(("variant/" + std::string(v->name) + "/" + family_name(f)).c_str(), BM_Variant, v, f);
      benchmark::RegisterBenchmark(("oracle/" + base + "/filtered").c_str(), BM_Oracle, k, f, true);
      benchmark::RegisterBenchmark(("oracle/" + base + "/exact").c_str(), BM_Oracle, k, f, false);
    }
    benchmark::RegisterBenchmark((std::string("cgal-epick-do-intersect/triangle/") + family_name(f)).c_str(),
                                 BM_CgalEpickTriangle, f);
  }
  return true;
}();

}  // namespace
}  // namespace rayproof::bench

BENCHMARK_MAIN();
