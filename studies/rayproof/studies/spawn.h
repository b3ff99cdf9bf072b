// Spawn strategies against shadow acne: a secondary ray leaves a variant's own computed hit
// point, outward; does the same variant hit the surface it started on? For the convex and
// flat shapes here the true answer is always no, so every reported hit is a self-intersection.
#pragma once

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "rayproof/core/variants.h"

namespace rayproof::studies {

// ulp_offset_f32: the hit point computed in float (o + t·d, each rounded to float) and moved by
// Wächter & Binder's float offset, as a float renderer spawns.
enum class SpawnStrategy { none, epsilon, ulp_offset, error_bound, ulp_offset_f32 };
inline constexpr SpawnStrategy kAllSpawnStrategies[] = {SpawnStrategy::none, SpawnStrategy::epsilon,
                                                        SpawnStrategy::ulp_offset, SpawnStrategy::error_bound,
                                                        SpawnStrategy::ulp_offset_f32};
std::string_view to_string(SpawnStrategy s);
std::optional<SpawnStrategy> spawn_strategy_from_string(std::string_view s);

// The secondary ray from hit point p (computed as ray.at(t)) with the unit normal n on the side
// the primary ray came from, and the t below which the strategy ignores hits.
struct SpawnedRay {
  Ray ray;
  double t_min = 0;
};
SpawnedRay spawn(SpawnStrategy s, const Ray& primary, double t, const Vec3& n, const Vec3& direction);

struct SpawnCell {
  const Variant* variant;
  SpawnStrategy strategy;
  int log2_scale;
  std::uint64_t rays = 0, self_intersections = 0;
};

// `count` primary rays per variant and scale (the random family, scaled by 2^scale).
std::vector<SpawnCell> spawn_study(const std::vector<const Variant*>& variants,
                                   const std::vector<SpawnStrategy>& strategies, const std::vector<int>& log2_scales,
                                   std::uint64_t count, std::uint64_t seed, int threads);

// CSV: variant,shape,strategy,log2_scale,rays,self_intersections,rate — and a table of rates.
void write_spawn_csv(const std::vector<SpawnCell>& cells, std::ostream& out);
void print_spawn_table(const std::vector<SpawnCell>& cells, std::ostream& out);

}  // namespace rayproof::studies
