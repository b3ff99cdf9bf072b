// Benchmark inputs, built once outside the timed loops from the fuzz families (so a benchmark
// and a campaign of the same family see the same kind of rays). `random` is split by the exact
// oracle into rays that hit and rays that miss.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "rayproof/fuzz/generators.h"
#include "rayproof/verify/oracle.h"
#include "rayproof/core/query.h"

namespace rayproof::bench {

inline constexpr size_t kRing = 4096;  // queries per input set: cache-resident, like a hot loop

inline const std::vector<std::string>& bench_families() {
  static const std::vector<std::string> names = {"random-hit", "random-miss", "tangent",
                                                 "grazing",    "near-origin", "extremes"};
  return names;
}

inline const std::vector<Query>& inputs(ShapeKind shape, const std::string& family) {
  static std::map<std::pair<int, std::string>, std::vector<Query>> cache;
  auto& qs = cache[{static_cast<int>(shape), family}];
  if (!qs.empty()) return qs;
  Oracle oracle;
  const bool split = family.rfind("random", 0) == 0;
  const fuzz::Family f = split ? fuzz::Family::random : *fuzz::family_from_string(family);
  for (std::uint64_t i = 0; qs.size() < kRing && i < 100 * kRing; ++i) {
    const fuzz::GeneratedCase g = fuzz::generate(f, shape, 7, i);
    if (split && (oracle.judge(g.ray, g.shape).cls == HitClass::miss) != (family == "random-miss")) continue;
    qs.push_back(g);
  }
  return qs;
}

}  // namespace rayproof::bench
