// A goal's ratio measured interleaved: each iteration times a chunk of the numerator's work, then
// the same chunk of the denominator's, so a machine whose speed drifts within a run (this 2-core
// machine swings by up to 1.5×, once between the variants' benchmarks and the oracle's of one
// `make bench`, which put the oracle's class "faster" than a plain double test) moves both sides
// alike. Each side disturbs the other's caches and branch predictor: chunks are long (many
// passes over the inputs) so each side runs warm most of its chunk, and where a side still
// suffers the other's presence (the bunny against Embree: Embree ~10% slower) the interleaved
// ratio is not used. Counters: numerator_ns and denominator_ns per item, and their ratio (what
// scripts/bench-goals.py reads for the oracle's goals).
#pragma once

#include <benchmark/benchmark.h>

#include <chrono>
#include <cstddef>

namespace rayproof::bench {

template <class Numerator, class Denominator>
void interleaved_ratio(benchmark::State& state, std::size_t items_per_chunk, Numerator&& numerator,
                       Denominator&& denominator) {
  using clock = std::chrono::steady_clock;
  double numerator_ns = 0, denominator_ns = 0;
  for (auto _ : state) {
    const auto t0 = clock::now();
    numerator();
    const auto t1 = clock::now();
    denominator();
    const auto t2 = clock::now();
    numerator_ns += std::chrono::duration<double, std::nano>(t1 - t0).count();
    denominator_ns += std::chrono::duration<double, std::nano>(t2 - t1).count();
  }
  const double items = double(state.iterations()) * double(items_per_chunk);
  state.counters["numerator_ns"] = numerator_ns / items;
  state.counters["denominator_ns"] = denominator_ns / items;
  state.counters["ratio"] = denominator_ns > 0 ? numerator_ns / denominator_ns : 0;
}

}  // namespace rayproof::bench
