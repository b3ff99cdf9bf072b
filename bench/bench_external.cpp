// The cost of judging code rayproof did not write: a plugin in a worker process against the same
// formula built in, and the exec protocol against a responder that does nothing. Inputs are built
// outside the timed loop; one batch per iteration, as the campaigns and `trade` send them.
#include <benchmark/benchmark.h>

#include "rayproof/core/variants.h"
#include "rayproof/fuzz/generators.h"
#include "rayproof/peers/external.h"

namespace rayproof {
namespace {

std::vector<Query> random_spheres(size_t n) {
  std::vector<Query> qs;
  for (size_t i = 0; i < n; ++i) qs.push_back(fuzz::generate(fuzz::Family::random, ShapeKind::sphere, 1, i));
  return qs;
}

const Variant& same_as_builtin() {
  static const Variant* v = peers::load_plugin(RAYPROOF_BENCH_PLUGIN, {})[0];
  return *v;
}

// One batch of state.range(0) random sphere queries per iteration through v.intersect_all.
void answer_batches(benchmark::State& state, const Variant& v) {
  const std::vector<Query> qs = random_spheres(state.range(0));
  std::vector<Answer> out(qs.size());
  for (auto _ : state) {
    v.intersect_all(qs, HitRule::nearest_contact, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * qs.size());
  state.counters["per_test"] =
      benchmark::Counter(qs.size(), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

// The built-in textbook formula, the loop `trade` and the campaigns run for a built-in.
void BM_builtin_textbook_batch(benchmark::State& state) { answer_batches(state, *find_variant("textbook")); }
BENCHMARK(BM_builtin_textbook_batch)->Name("external/builtin-textbook/batch")->Arg(512)->Arg(4096);

// The same formula as a plugin: one round trip to its worker process per batch (isolation included).
void BM_plugin_textbook_batch(benchmark::State& state) { answer_batches(state, same_as_builtin()); }
BENCHMARK(BM_plugin_textbook_batch)->Name("external/plugin-textbook/batch")->Arg(512)->Arg(4096)->UseRealTime();

// The exec protocol: cases written as hex-float JSON lines, answers parsed, ids checked.
void BM_exec_responder(benchmark::State& state) {
  static const Variant& v = peers::add_exec_variant("bench-responder", RAYPROOF_BENCH_RESPONDER, {});
  answer_batches(state, v);
}
BENCHMARK(BM_exec_responder)->Name("external/exec-responder/batch")->Arg(512)->Arg(8192)->UseRealTime();

}  // namespace
}  // namespace rayproof
