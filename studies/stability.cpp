#include "rayproof/studies/stability.h"
#include "rayproof/studies/markup.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include "rayproof/core/parallel.h"
#include "rayproof/fuzz/generators.h"
#include "rayproof/studies/svg.h"
#include "rayproof/verify/compare.h"
#include "rayproof/verify/oracle.h"

namespace rayproof::studies {

namespace {
// A cell's rate of bug-level disagreements (verdicts.md): what its colour shows.
double bug_rate(const StabilityCell& c) {
  return c.tally.cases ? static_cast<double>(c.tally.bug_count()) / c.tally.cases : 0;
}

struct CellRng : fuzz::SplitMix64 {  // seeded per (seed, cell, case): independent of threads
  double sym() { return 2 * unit() - 1; }
  Vec3 direction() {
    Vec3 v;
    do v = fuzz::vec_z_first([&] { return sym(); });
    while (dot(v, v) > 1 || dot(v, v) < 1e-3);
    return normalized(v);
  }
};

// One query of cell (a, b): a shape of size 2^b at distance 2^a from the ray's origin (0,0,0),
// the ray aimed at a random point of the shape's extent, 10% beyond it so silhouettes and
// tangents are covered.
Query cell_query(ShapeKind kind, int a, int b, CellRng& rng) {
  const double pos = std::ldexp(1.0, a), size = std::ldexp(1.0, b);
  const Vec3 centre = pos * rng.direction();
  switch (kind) {
    case ShapeKind::sphere: {
      const double r = size * (1 + rng.unit());
      const Vec3 towards = rng.direction();
      const Vec3 target = centre + (1.1 * std::sqrt(rng.unit()) * r) * towards;
      return {Ray{Vec3::Zero(), target}, Sphere{centre, r}};
    }
    case ShapeKind::plane: {
      const Vec3 n = rng.direction();
      const Vec3 target = centre + size * rng.direction();
      return {Ray{Vec3::Zero(), target}, Plane{n, dot(n, centre)}};
    }
    case ShapeKind::triangle: {
      Triangle t{{centre + size * rng.direction(), centre + size * rng.direction(), centre + size * rng.direction()}};
      if (degenerate_reason(t)) t.v[2] = centre + size * Vec3(0.3, 0.7, -0.2);
      const double u = 1.2 * rng.unit() - 0.1, v = (1.2 - u) * rng.unit() - 0.1;
      const Vec3 target = t.v[0] + u * (t.v[1] - t.v[0]) + v * (t.v[2] - t.v[0]);
      return {Ray{Vec3::Zero(), target}, t};
    }
    case ShapeKind::box: {
      const Vec3 half = size * fuzz::vec_z_first([&] { return 0.5 + 0.5 * rng.unit(); });
      const Vec3 target = centre + fuzz::vec_z_first([&] { return 1.1 * rng.sym(); }).cwiseProduct(half);
      return {Ray{Vec3::Zero(), target}, Box{centre - half, centre + half}};
    }
  }
  return {};
}

}  // namespace

Query stability_query(ShapeKind shape, int log2_scale, int log2_size, std::uint64_t seed, std::uint64_t i) {
  CellRng rng{seed * 0x9E3779B97F4A7C15ull ^ (std::uint64_t(log2_scale + 4096) << 40) ^
              (std::uint64_t(log2_size + 4096) << 20) ^ i};
  return cell_query(shape, log2_scale, log2_size, rng);
}

std::map<std::string, std::vector<StabilityCell>> stability_study(ShapeKind shape,
                                                                  const std::vector<const Variant*>& variants,
                                                                  HitRule rule, const StabilityGrid& grid,
                                                                  int threads) {
  std::vector<std::pair<int, int>> coords;
  for (int b = grid.lo; b <= grid.hi; b += grid.step)
    for (int a = grid.lo; a <= grid.hi; a += grid.step) coords.push_back({a, b});
  std::map<std::string, std::vector<StabilityCell>> out;
  for (const Variant* v : variants) out[std::string(v->name)].resize(coords.size());
  run_workers(threads, [&](int w) {
    Oracle oracle;
    for (size_t c = w; c < coords.size(); c += threads) {
      const auto [a, b] = coords[c];
      std::vector<Tally> tallies(variants.size());
      std::vector<Query> queries;  // the cell's cases, so each variant answers them in one call
      std::vector<Verdict> exact;
      for (std::uint64_t i = 0; i < grid.cases_per_cell; ++i) {
        Query q = stability_query(shape, a, b, grid.seed, i);
        if (!is_valid_query(q.ray, q.shape)) continue;
        exact.push_back(oracle.judge(q.ray, q.shape, rule));
        queries.push_back(std::move(q));
      }
      for (size_t vi = 0; vi < variants.size(); ++vi) {
        const std::vector<VariantOutcome> outcomes = judge_variant_all(oracle, *variants[vi], queries, exact, rule);
        Tally& tally = tallies[vi];
        tally.tolerance_ulps = grid.tolerance_ulps;
        for (size_t k = 0; k < queries.size(); ++k) {
          const VariantOutcome& o = outcomes[k];
          tally.add(exact[k].cls, o);
          if (o.answer.failed() || o.agreement == Agreement::agrees) continue;
          // Its level (verdicts.md), as a campaign's tally gets it (K = 0: every one a bug).
          const auto v = grid.tolerance_ulps == 0 ? std::optional<OutcomeVerdict>(OutcomeVerdict{})
                                                  : outcome_verdict(queries[k], o, rule, grid.tolerance_ulps, false,
                                                                    grid.tolerance_ulps, false);
          if (!v) continue;
          if (v->at_range_end) {
            ++tally.at_range_end;
            continue;
          }
          tally.add_level({o.own_exact ? o.own_exact->cls : exact[k].cls, o.answer.cls}, v->level == Level::bug,
                          grid.tolerance_ulps == 0 ? "unchecked" : beta_bucket(v->beta));
        }
      }
      for (size_t vi = 0; vi < variants.size(); ++vi)
        out[std::string(variants[vi]->name)][c] = {a, b, std::move(tallies[vi])};
    }
  });
  return out;
}

void write_stability_csv(const std::map<std::string, std::vector<StabilityCell>>& cells, std::ostream& out) {
  out << "variant,log2_scale,log2_size,cases,disagreement_rate,ulp_p99,bugs,bug_rate\n";  // (levels appended)
  char buf[64];
  for (const auto& [name, list] : cells)
    for (const StabilityCell& c : list) {
      std::snprintf(buf, sizeof buf, "%.6g", c.tally.disagreement_rate());
      out << name << "," << c.log2_scale << "," << c.log2_size << "," << c.tally.cases << "," << buf << ","
          << c.tally.ulps.quantile(0.99) << "," << c.tally.bug_count() << ",";
      std::snprintf(buf, sizeof buf, "%.6g", bug_rate(c));
      out << buf << "\n";
    }
}

namespace {
// A perceptually ordered ramp (viridis-like) over t ∈ [0, 1].
std::string ramp(double t) {
  static const double stops[][3] = {{68, 1, 84}, {59, 82, 139}, {33, 145, 140}, {94, 201, 98}, {253, 231, 37}};
  t = std::clamp(t, 0.0, 1.0) * 4;
  const int i = std::min(3, static_cast<int>(t));
  const double f = t - i;
  char buf[16];
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", int(stops[i][0] + f * (stops[i + 1][0] - stops[i][0])),
                int(stops[i][1] + f * (stops[i + 1][1] - stops[i][1])),
                int(stops[i][2] + f * (stops[i + 1][2] - stops[i][2])));
  return buf;
}
// Colour of a disagreement rate: light grey for none, the ramp over log10(rate) ∈ [−4, 0].
std::string colour_of(double rate) { return rate <= 0 ? "#eeeeee" : ramp((std::log10(std::max(rate, 1e-4)) + 4) / 4); }
}  // namespace

void write_stability_svg(const std::string& title, const std::vector<StabilityCell>& cells, const StabilityGrid& grid,
                         std::ostream& out) {
  const int n = (grid.hi - grid.lo) / grid.step + 1;
  const double cell = std::max(12.0, 520.0 / n), left = 80, top = 50, plot = cell * n;
  svg::begin(out, left + plot + 170, top + plot + 70, 11);
  out << svg::text(left, 28, title, "font-size='15'") << "\n";
  for (const StabilityCell& c : cells) {
    const int col = (c.log2_scale - grid.lo) / grid.step, row = (c.log2_size - grid.lo) / grid.step;
    const std::string tip = markup::format(
        "distance 2^%d, size 2^%d: %llu of %llu disagree (%llu bug-level, %llu rounding-level), ULP p99 %llu",
        c.log2_scale, c.log2_size, (unsigned long long)c.tally.disagreements(), (unsigned long long)c.tally.cases,
        (unsigned long long)c.tally.bug_count(), (unsigned long long)c.tally.rounding_count(),
        (unsigned long long)c.tally.ulps.quantile(0.99));
    out << svg::rect(left + col * cell, top + (n - 1 - row) * cell, cell, cell, colour_of(bug_rate(c)), tip) << "\n";
  }
  const int label_every = std::max(1, n / 8);
  for (int i = 0; i < n; i += label_every) {
    const std::string k = std::to_string(grid.lo + i * grid.step);
    out << svg::text(left + (i + 0.5) * cell, top + plot + 16, k, "text-anchor='middle'")
        << svg::text(left - 6, top + (n - 1 - i + 0.5) * cell + 4, k, "text-anchor='end'") << "\n";
  }
  out << svg::text(left + plot / 2, top + plot + 40, "log2 of the distance from the ray origin", "text-anchor='middle'")
      << markup::format("<text transform='translate(24 %.1f) rotate(-90)' text-anchor='middle'>", top + plot / 2)
      << "log2 of the size (sphere radius, triangle or box extent)</text>\n";
  const double lx = left + plot + 30;  // legend
  out << svg::text(lx, top + 4, "bug-level rate") << "\n";
  const char* labels[] = {"100%", "10%", "1%", "0.1%", "0.01%"};
  for (int i = 0; i < 5; ++i)
    out << svg::rect(lx, top + 14 + i * 22.0, 18, 18, ramp(1 - i / 4.0))
        << svg::text(lx + 24, top + 27 + i * 22.0, labels[i]) << "\n";
  out << svg::rect(lx, top + 14 + 5 * 22.0, 18, 18, "#eeeeee") << svg::text(lx + 24, top + 27 + 5 * 22.0, "0") << "\n";
  svg::end(out);
}

}  // namespace rayproof::studies
