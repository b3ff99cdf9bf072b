#include "rayproof/studies/spawn.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ostream>

#include "rayproof/core/fp.h"
#include "rayproof/core/offset.h"
#include "rayproof/core/parallel.h"
#include "rayproof/fuzz/generators.h"

namespace rayproof::studies {

using fuzz::Family;
using fuzz::generate;
using fuzz::GeneratedCase;

std::string_view to_string(SpawnStrategy s) {
  switch (s) {
    case SpawnStrategy::none: return "none";
    case SpawnStrategy::epsilon: return "epsilon";
    case SpawnStrategy::ulp_offset: return "ulp-offset";
    case SpawnStrategy::error_bound: return "error-bound";
    case SpawnStrategy::ulp_offset_f32: return "ulp-offset-f32";
  }
  return "?";
}

std::optional<SpawnStrategy> spawn_strategy_from_string(std::string_view s) {
  for (SpawnStrategy x : kAllSpawnStrategies)
    if (to_string(x) == s) return x;
  return std::nullopt;
}

SpawnedRay spawn(SpawnStrategy s, const Ray& primary, double t, const Vec3& n, const Vec3& direction) {
  const Vec3 p = primary.at(t);
  switch (s) {
    case SpawnStrategy::none: return {Ray{p, direction}, 0};
    case SpawnStrategy::epsilon: return {Ray{p, direction}, 1e-3};  // the hobby tracer's fixed t_min
    case SpawnStrategy::ulp_offset: return {Ray{offset_by_ulps(p, n), direction}, 0};
    case SpawnStrategy::error_bound: return {Ray{offset_by_error_bound(primary, t, p, n), direction}, 0};
    case SpawnStrategy::ulp_offset_f32: return {Ray{spawn_origin(primary, t, p, n, Precision::f32), direction}, 0};
  }
  return {Ray{p, direction}, 0};
}

std::vector<SpawnCell> spawn_study(const std::vector<const Variant*>& variants,
                                   const std::vector<SpawnStrategy>& strategies, const std::vector<int>& log2_scales,
                                   std::uint64_t count, std::uint64_t seed, int threads) {
  std::vector<SpawnCell> cells;
  for (const Variant* v : variants)
    for (SpawnStrategy s : strategies)
      for (int k : log2_scales) cells.push_back({v, s, k});
  // One job per (variant, scale): the primary ray and its spawned direction are shared by all
  // strategies, so they are compared on the same hits.
  std::vector<std::pair<const Variant*, int>> jobs;
  for (const Variant* v : variants)
    for (int k : log2_scales) jobs.push_back({v, k});
  std::vector<std::vector<SpawnCell>> partial(jobs.size());
  run_workers(threads, [&](int first) {
    for (size_t j = first; j < jobs.size(); j += threads) {
      const auto [v, k] = jobs[j];
      std::vector<SpawnCell> out;
      for (SpawnStrategy s : strategies) out.push_back({v, s, k});
      // Every primary ray, then every spawned one, asked in one call each (Variant::intersect_all:
      // external code answers a batch per round trip, not a case).
      std::vector<Query> primaries(count);
      for (std::uint64_t i = 0; i < count; ++i) {
        const GeneratedCase g = generate(Family::random, v->shape, seed, i);
        const double f = std::ldexp(1.0, k);
        primaries[i] = Query{Ray{g.ray.origin * f, g.ray.direction * f}, scaled(g.shape, f), {}};
      }
      std::vector<Answer> first(count);
      v->intersect_all(primaries, HitRule::nearest_contact, first);
      std::vector<Query> spawned;
      std::vector<std::pair<size_t, double>> strategy_and_t_min;  // per spawned ray
      for (std::uint64_t i = 0; i < count; ++i) {
        const Hit& h = first[i];
        if (h.cls == HitClass::miss || !h.has_t()) continue;
        // From inside a sphere or box the far side is a genuine hit, not acne: only entries.
        const bool closed = v->shape == ShapeKind::sphere || v->shape == ShapeKind::box;
        if (closed && h.cls == HitClass::exit) continue;
        const Ray& primary = primaries[i].ray;
        const Shape& shape = primaries[i].shape;
        Vec3 n = outward_normal(shape, primary.at(h.t));
        if (dot(n, primary.direction) > 0) n = -n;
        // A direction in the hemisphere around n, from the case's own generator stream.
        Vec3 d = generate(Family::random, v->shape, seed ^ 0x5eed, i).ray.direction;
        d = normalized(d);
        if (dot(d, n) < 0) d = -d;
        d = normalized(d + 0.05 * n);  // away from grazing directions, which no strategy can save
        for (size_t si = 0; si < strategies.size(); ++si) {
          // Unit-length directions, as a renderer's secondary rays have: t is in world units.
          const SpawnedRay sr = spawn(strategies[si], primary, h.t, n, d);
          spawned.push_back(Query{sr.ray, shape, {}});
          strategy_and_t_min.emplace_back(si, sr.t_min);
        }
      }
      std::vector<Answer> again(spawned.size());
      v->intersect_all(spawned, HitRule::nearest_contact, again);
      for (size_t r = 0; r < spawned.size(); ++r) {
        const auto [si, t_min] = strategy_and_t_min[r];
        ++out[si].rays;
        if (again[r].cls != HitClass::miss && again[r].has_t() && again[r].t > t_min) ++out[si].self_intersections;
      }
      partial[j] = std::move(out);
    }
  });
  for (size_t j = 0; j < jobs.size(); ++j)
    for (const SpawnCell& c : partial[j])
      for (SpawnCell& cell : cells)
        if (cell.variant == c.variant && cell.strategy == c.strategy && cell.log2_scale == c.log2_scale)
          cell.rays = c.rays, cell.self_intersections = c.self_intersections;
  return cells;
}

}  // namespace rayproof::studies

namespace rayproof::studies {

void write_spawn_csv(const std::vector<SpawnCell>& cells, std::ostream& out) {
  out << "variant,shape,strategy,log2_scale,rays,self_intersections,rate\n";
  for (const SpawnCell& c : cells)
    out << c.variant->name << "," << to_string(c.variant->shape) << "," << to_string(c.strategy) << "," << c.log2_scale
        << "," << c.rays << "," << c.self_intersections << ","
        << (c.rays ? static_cast<double>(c.self_intersections) / c.rays : 0.0) << "\n";
}

void print_spawn_table(const std::vector<SpawnCell>& cells, std::ostream& out) {
  std::vector<int> scales;
  for (const SpawnCell& c : cells)
    if (std::find(scales.begin(), scales.end(), c.log2_scale) == scales.end()) scales.push_back(c.log2_scale);
  out << "self-intersection rate (%) of rays spawned from each variant's own hit point, by scale 2^k\n";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%-25s%-16s", "variant", "strategy");
  out << buf;
  for (int k : scales) {
    std::snprintf(buf, sizeof buf, "%8s", ("2^" + std::to_string(k)).c_str());
    out << buf;
  }
  out << "\n";
  for (size_t i = 0; i < cells.size(); i += scales.size()) {
    std::snprintf(buf, sizeof buf, "%-25s%-16s", std::string(cells[i].variant->name).c_str(),
                  std::string(to_string(cells[i].strategy)).c_str());
    out << buf;
    for (size_t j = 0; j < scales.size() && i + j < cells.size(); ++j) {
      const SpawnCell& c = cells[i + j];
      std::snprintf(buf, sizeof buf, "%8.2f", c.rays ? 100.0 * c.self_intersections / c.rays : 0.0);
      out << buf;
    }
    out << "\n";
  }
}

}  // namespace rayproof::studies
