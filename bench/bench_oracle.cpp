// What exactness costs: the oracle (class + correctly rounded t), filtered and forced-exact,
// against the double variants and CGAL's own exact predicate, on the same inputs in one run.
#include <benchmark/benchmark.h>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/intersections.h>

#include "inputs.h"
#include "interleaved.h"
#include "rayproof/verify/oracle.h"
#include "rayproof/core/variants.h"

namespace rayproof::bench {
namespace {

void BM_Oracle(benchmark::State& state, ShapeKind kind, std::string family, bool filter) {
  const auto& qs = inputs(kind, family);
  Oracle oracle(Oracle::Options{.filter = filter});
  size_t i = 0;
  for (auto _ : state) {
    const Query& q = qs[i++ % qs.size()];
    benchmark::DoNotOptimize(oracle.judge(q.ray, q.shape));
  }
  const OracleStats& s = oracle.stats(kind);
  const double queries = std::max<std::uint64_t>(1, s.queries);
  state.counters["per_test"] =
      benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["class_interval_pct"] = 100.0 * s.class_interval / queries;
  state.counters["class_expansion_pct"] = 100.0 * s.class_expansion / queries;
  state.counters["class_rational_pct"] = 100.0 * s.class_exact / queries;
  state.counters["t_expansion_pct"] = 100.0 * s.rounding.expansion / std::max<std::uint64_t>(1, s.rounding.rounded);
  state.counters["t_rational_pct"] = 100.0 * s.rounding.rational / std::max<std::uint64_t>(1, s.rounding.rounded);
}

// The exact class alone (a predicate, no t): the semi-static filter's cost.
void BM_OracleClass(benchmark::State& state, ShapeKind kind, std::string family) {
  const auto& qs = inputs(kind, family);
  Oracle oracle;
  size_t i = 0;
  for (auto _ : state) {
    const Query& q = qs[i++ % qs.size()];
    benchmark::DoNotOptimize(oracle.classify(q.ray, q.shape));
  }
  const OracleStats& s = oracle.stats(kind);
  const double queries = std::max<std::uint64_t>(1, s.queries);
  state.counters["per_test"] =
      benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["class_beyond_static_pct"] = 100.0 * (s.class_interval + s.class_expansion + s.class_exact) / queries;
}

// CGAL Epick's exact do_intersect(Ray_3, Triangle_3): a predicate only (no t), the yardstick a
// CGAL user would reach for. The ray's second point o + d is rounded to double here.
void BM_CgalEpickTriangle(benchmark::State& state, std::string family) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  std::vector<std::pair<K::Ray_3, K::Triangle_3>> cgal;
  auto P = [](const Vec3& v) { return K::Point_3(v.x(), v.y(), v.z()); };
  for (const Query& q : inputs(ShapeKind::triangle, family)) {
    const Triangle& t = std::get<Triangle>(q.shape);
    cgal.push_back(
        {K::Ray_3(P(q.ray.origin), K::Vector_3(q.ray.direction.x(), q.ray.direction.y(), q.ray.direction.z())),
         K::Triangle_3(P(t.v[0]), P(t.v[1]), P(t.v[2]))});
  }
  size_t i = 0;
  for (auto _ : state) {
    const auto& [r, t] = cgal[i++ % cgal.size()];
    benchmark::DoNotOptimize(CGAL::do_intersect(r, t));
  }
  state.counters["per_test"] =
      benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// The goals (issue 22): the oracle's class, and class + t, against the fastest double variant on
// the same random hits, timed interleaved (interleaved.h) in chunks of 16 passes over the ring (65,536 queries).
constexpr std::size_t kGoalChunk = 65536;
void BM_GoalOracle(benchmark::State& state, ShapeKind kind, const char* variant, bool with_t) {
  const auto& qs = inputs(kind, "random-hit");
  const Variant* v = find_variant(variant);
  if (!v) return state.SkipWithError("variant not found");
  Oracle oracle;
  std::size_t oracle_at = 0, variant_at = 0;
  interleaved_ratio(
      state, kGoalChunk,
      [&] {
        for (std::size_t k = 0; k < kGoalChunk; ++k) {
          const Query& q = qs[oracle_at++ % qs.size()];
          if (with_t)
            benchmark::DoNotOptimize(oracle.judge(q.ray, q.shape));
          else
            benchmark::DoNotOptimize(oracle.classify(q.ray, q.shape));
        }
      },
      [&] {
        for (std::size_t k = 0; k < kGoalChunk; ++k) {
          const Query& q = qs[variant_at++ % qs.size()];
          benchmark::DoNotOptimize(v->intersect(q.ray, q.shape, HitRule::nearest_contact));
        }
      });
}

const bool registered = [] {
  for (const auto& [kind, variant] :
       {std::pair{ShapeKind::sphere, "stable"}, std::pair{ShapeKind::plane, "direct"},
        std::pair{ShapeKind::triangle, "moller-trumbore"}, std::pair{ShapeKind::box, "robust-slab"}}) {
    const std::string shape(to_string(kind)), base(variant);
    benchmark::RegisterBenchmark(("goal/oracle-class/" + shape + "/" + base).c_str(), BM_GoalOracle, kind, variant,
                                 false);
    benchmark::RegisterBenchmark(("goal/oracle-class-and-t/" + shape + "/" + base).c_str(), BM_GoalOracle, kind,
                                 variant, true);
  }
  for (const std::string& family : bench_families()) {
    for (ShapeKind k : kAllShapeKinds) {
      const std::string base = "oracle/" + std::string(to_string(k)) + "/" + family;
      benchmark::RegisterBenchmark((base + "/filtered").c_str(), BM_Oracle, k, family, true);
      benchmark::RegisterBenchmark((base + "/exact").c_str(), BM_Oracle, k, family, false);
      benchmark::RegisterBenchmark((base + "/class").c_str(), BM_OracleClass, k, family);
    }
    benchmark::RegisterBenchmark(("cgal-epick-do-intersect/triangle/" + family).c_str(), BM_CgalEpickTriangle, family);
  }
  return true;
}();

}  // namespace
}  // namespace rayproof::bench
