// ns per test of every variant (scalar and batched) of every shape on every family.
#include <benchmark/benchmark.h>

#include "inputs.h"
#include "rayproof/core/variants.h"
#include "rayproof/verify/certified.h"
#include "rayproof/studies/trade.h"

namespace rayproof::bench {
namespace {

// One query per iteration, cycling through the prepared ring.
void BM_Variant(benchmark::State& state, const Variant* v, std::string family) {
  const auto& qs = inputs(v->shape, family);
  size_t i = 0;
  for (auto _ : state) {
    const Query& q = qs[i++ % qs.size()];
    benchmark::DoNotOptimize(v->intersect(q.ray, q.shape, HitRule::nearest_contact));
  }
  state.counters["tests_per_s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["per_test"] =
      benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// The whole ring per iteration, in the contender's own layout (structure of arrays).
void BM_Batched(benchmark::State& state, const studies::Contender* c, std::string family) {
  const auto& qs = inputs(c->shape, family);
  const studies::Prepared p = c->prepare(qs);
  for (auto _ : state) {
    p.run();
    benchmark::ClobberMemory();
  }
  benchmark::DoNotOptimize(p.answer(0));
  const double tests = double(state.iterations()) * qs.size();
  state.counters["tests_per_s"] = benchmark::Counter(tests, benchmark::Counter::kIsRate);
  state.counters["per_test"] = benchmark::Counter(tests, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

const bool registered = [] {
  register_certified_variants();
  static const std::vector<studies::Contender> batched = studies::batched_contenders();
  for (const std::string& family : bench_families()) {
    for (const Variant& v : all_variants())
      benchmark::RegisterBenchmark(("variant/" + std::string(v.name) + "/" + family).c_str(), BM_Variant, &v, family);
    for (const studies::Contender& c : batched)
      benchmark::RegisterBenchmark(("batched/" + c.name + "/" + family).c_str(), BM_Batched, &c, family);
  }
  return true;
}();

}  // namespace
}  // namespace rayproof::bench
