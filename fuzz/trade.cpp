#include "rayproof/trade.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <set>
#include <thread>

#include "rayproof/batch.h"
#include "rayproof/compare.h"
#include "rayproof/oracle.h"
#include "rayproof/variants.h"

namespace rayproof::fuzz {

std::vector<Contender> variant_contenders() {
  std::vector<Contender> out;
  for (const Variant& v : all_variants()) {
    const Variant* p = &v;
    out.push_back({std::string(v.name), v.shape,
                   [p](const std::vector<Query>& qs) {
                     auto hits = std::make_shared<std::vector<Hit>>(qs.size());
                     return Prepared{[p, &qs, hits] {
                                       for (size_t i = 0; i < qs.size(); ++i)
                                         (*hits)[i] = p->intersect(qs[i].ray, qs[i].shape, HitRule::nearest_contact);
                                     },
                                     [hits](size_t i) { return (*hits)[i]; }};
                   },
                   {}});
  }
  return out;
}

namespace {
// A batched variant as a contender: the queries laid out as structure of arrays once, in
// prepare; only the kernel is timed.
template <class S, class ShapesSoA, void (*Kernel)(const RaysSoA&, const ShapesSoA&, HitsSoA&)>
Contender batched_contender(const BatchedVariant& b) {
  return {std::string(b.name), b.shape, [](const std::vector<Query>& qs) {
            auto rays = std::make_shared<RaysSoA>();
            auto shapes = std::make_shared<ShapesSoA>();
            for (const Query& q : qs) rays->push(q.ray), shapes->push(std::get<S>(q.shape));
            auto hits = std::make_shared<HitsSoA>();
            return Prepared{[rays, shapes, hits] { Kernel(*rays, *shapes, *hits); },
                            [hits](size_t i) { return hits->at(i); }};
          }, {}};
}
}  // namespace

std::vector<Contender> batched_contenders() {
  std::vector<Contender> out;
  for (const BatchedVariant& b : batched_variants()) {
    if (b.shape == ShapeKind::sphere) out.push_back(batched_contender<Sphere, SpheresSoA, sphere_stable_batch>(b));
    if (b.shape == ShapeKind::triangle)
      out.push_back(batched_contender<Triangle, TrianglesSoA, triangle_moller_trumbore_batch>(b));
  }
  return out;
}

namespace {

// Exact verdicts for a batch of queries, in parallel.
std::vector<Verdict> judge_all(const std::vector<Query>& qs, int threads) {
  std::vector<Verdict> out(qs.size());
  auto work = [&](int w) {
    Oracle oracle;
    for (size_t i = w; i < qs.size(); i += threads) out[i] = oracle.judge(qs[i].ray, qs[i].shape);
  };
  std::vector<std::thread> pool;
  for (int w = 1; w < threads; ++w) pool.emplace_back(work, w);
  work(0);
  for (auto& t : pool) t.join();
  return out;
}

// Nanoseconds per query, single-threaded: the fastest of several passes over the first 4096
// queries (cache-resident, like a benchmark's prepared inputs; the whole set is still judged).
double time_per_query(const Contender& c, const std::vector<Query>& all) {
  const std::vector<Query> qs(all.begin(), all.begin() + std::min<size_t>(all.size(), 4096));
  const Prepared p = c.prepare(qs);
  const int repeats = static_cast<int>(std::max<size_t>(1, 200000 / qs.size()));
  double best = INFINITY;
  for (int pass = 0; pass < 5; ++pass) {
    const auto t0 = std::chrono::steady_clock::now();
    for (int r = 0; r < repeats; ++r) p.run();
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / repeats;
    best = std::min(best, s);
  }
  // Keep the answers observable so the passes cannot be optimised away.
  volatile double sink = 0;
  for (size_t i = 0; i < qs.size(); ++i) sink = sink + (p.answer(i).has_t() ? p.answer(i).t : 0);
  return best * 1e9 / std::max<size_t>(1, qs.size());
}

void mark_pareto(std::vector<TradeRow>& rows) {
  for (TradeRow& r : rows) {
    r.pareto = true;
    for (const TradeRow& o : rows) {
      if (&o == &r || o.shape != r.shape || o.family != r.family) continue;
      const bool no_worse = o.ns_per_test <= r.ns_per_test && o.disagreement_rate <= r.disagreement_rate;
      const bool better = o.ns_per_test < r.ns_per_test || o.disagreement_rate < r.disagreement_rate;
      if (no_worse && better) r.pareto = false;
    }
  }
}

}  // namespace

std::vector<TradeRow> measure_trade(const std::vector<Contender>& contenders, const std::vector<ShapeKind>& shapes,
                                    const std::vector<Family>& families, std::uint64_t count, std::uint64_t seed,
                                    int threads) {
  std::vector<TradeRow> rows;
  for (ShapeKind shape : shapes) {
    for (Family family : families) {
      std::vector<Query> generated(count);
      for (std::uint64_t i = 0; i < count; ++i) {
        GeneratedCase g = generate(family, shape, seed, i);
        generated[i] = {g.ray, g.shape};
      }
      const std::vector<Verdict> exact = judge_all(generated, threads);
      for (const Contender& c : contenders) {
        if (c.shape != shape) continue;
        std::vector<Query> inputs = generated;
        std::vector<Verdict> truth;
        if (c.effective_input) {
          inputs.clear();
          for (const Query& q : generated)
            if (auto e = c.effective_input(q)) inputs.push_back(*e);
          truth = judge_all(inputs, threads);
          if (inputs.empty()) continue;
        }
        const std::vector<Verdict>& judge = c.effective_input ? truth : exact;
        const Prepared prepared = c.prepare(inputs);
        prepared.run();
        std::vector<Hit> hits(inputs.size());
        for (size_t i = 0; i < inputs.size(); ++i) hits[i] = prepared.answer(i);
        TradeRow row{c.name, shape, family, inputs.size()};
        row.ns_per_test = time_per_query(c, inputs);
        std::vector<std::uint64_t> ulps;
        for (size_t i = 0; i < inputs.size(); ++i) {
          if (hits[i].cls != judge[i].cls) ++row.disagreements;
          if (judge[i].t && hits[i].has_t()) ulps.push_back(*ulp_distance(hits[i].t, *judge[i].t));
        }
        row.disagreement_rate = static_cast<double>(row.disagreements) / inputs.size();
        row.ulp_p99 = quantile(ulps, 0.99);
        row.ulp_max = quantile(ulps, 1.0);
        rows.push_back(row);
      }
    }
  }
  mark_pareto(rows);
  return rows;
}

void write_trade_csv(const std::vector<TradeRow>& rows, std::ostream& out) {
  out << "variant,shape,family,cases,ns_per_test,disagreements,disagreement_rate,ulp_p99,ulp_max\n";
  char buf[64];
  for (const TradeRow& r : rows) {
    std::snprintf(buf, sizeof buf, "%.3f", r.ns_per_test);
    out << r.variant << "," << to_string(r.shape) << "," << to_string(r.family) << "," << r.cases << "," << buf << ","
        << r.disagreements << ",";
    std::snprintf(buf, sizeof buf, "%.9g", r.disagreement_rate);
    out << buf << "," << r.ulp_p99 << "," << r.ulp_max << "\n";
  }
}

void print_trade_markdown(const std::vector<TradeRow>& rows, std::ostream& out) {
  out << "| shape | family | variant | ns/test | disagreement rate | ULP p99 | ULP max | Pareto |\n"
      << "|---|---|---|---:|---:|---:|---:|:---:|\n";
  char buf[256];
  for (const TradeRow& r : rows) {
    std::snprintf(buf, sizeof buf, "| %s | %s | %s | %.2f | %.3g%% | %llu | %llu | %s |\n",
                  std::string(to_string(r.shape)).c_str(), std::string(to_string(r.family)).c_str(), r.variant.c_str(),
                  r.ns_per_test, 100 * r.disagreement_rate, static_cast<unsigned long long>(r.ulp_p99),
                  static_cast<unsigned long long>(r.ulp_max), r.pareto ? "★" : "");
    out << buf;
  }
}

void write_trade_svg(const std::vector<TradeRow>& rows, std::ostream& out) {
  // Layout: plot area with log axes; zero rates sit on a floor line labelled "0".
  const double W = 900, H = 600, left = 90, right = 230, top = 50, bottom = 70;
  double x_lo = INFINITY, x_hi = 0, y_min_nonzero = 1;
  for (const TradeRow& r : rows) {
    x_lo = std::min(x_lo, r.ns_per_test), x_hi = std::max(x_hi, r.ns_per_test);
    if (r.disagreement_rate > 0) y_min_nonzero = std::min(y_min_nonzero, r.disagreement_rate);
  }
  if (rows.empty()) x_lo = 1, x_hi = 10;
  const double lx0 = std::floor(std::log10(std::max(x_lo, 1e-3))), lx1 = std::ceil(std::log10(std::max(x_hi, 1e-3)) + 1e-9);
  const double ly1 = 0, ly_floor = std::floor(std::log10(y_min_nonzero)) - 1, ly0 = ly_floor - 0.5;
  auto px = [&](double ns) { return left + (std::log10(std::max(ns, 1e-3)) - lx0) / std::max(1.0, lx1 - lx0) * (W - left - right); };
  auto py = [&](double rate) {
    const double l = rate > 0 ? std::log10(rate) : ly_floor;
    return top + (ly1 - l) / (ly1 - ly0) * (H - top - bottom);
  };
  char buf[512];
  out << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='" << H
      << "' font-family='sans-serif' font-size='12'>\n<rect width='100%' height='100%' fill='white'/>\n";
  out << "<text x='" << left << "' y='28' font-size='16'>Speed against accuracy: every variant on every family "
         "(lower left is better)</text>\n";
  for (int e = static_cast<int>(lx0); e <= static_cast<int>(lx1); ++e) {  // x grid
    std::snprintf(buf, sizeof buf,
                  "<line x1='%.1f' y1='%.1f' x2='%.1f' y2='%.1f' stroke='#ddd'/><text x='%.1f' y='%.1f' "
                  "text-anchor='middle'>%g</text>\n",
                  px(std::pow(10, e)), top, px(std::pow(10, e)), H - bottom, px(std::pow(10, e)), H - bottom + 18,
                  std::pow(10, e));
    out << buf;
  }
  for (int e = static_cast<int>(ly_floor) + 1; e <= 0; ++e) {  // y grid
    std::snprintf(buf, sizeof buf,
                  "<line x1='%.1f' y1='%.1f' x2='%.1f' y2='%.1f' stroke='#ddd'/><text x='%.1f' y='%.1f' "
                  "text-anchor='end'>%g%%</text>\n",
                  left, py(std::pow(10, e)), W - right, py(std::pow(10, e)), left - 6, py(std::pow(10, e)) + 4,
                  100 * std::pow(10, e));
    out << buf;
  }
  std::snprintf(buf, sizeof buf,
                "<line x1='%.1f' y1='%.1f' x2='%.1f' y2='%.1f' stroke='#999' stroke-dasharray='4 3'/><text x='%.1f' "
                "y='%.1f' text-anchor='end'>0</text>\n",
                left, py(0), W - right, py(0), left - 6, py(0) + 4);
  out << buf;
  std::snprintf(buf, sizeof buf,
                "<text x='%.1f' y='%.1f' text-anchor='middle'>ns per test (log)</text><text transform='translate(22 "
                "%.1f) rotate(-90)' text-anchor='middle'>class disagreement rate (log)</text>\n",
                (left + W - right) / 2, H - 25, (top + H - bottom) / 2);
  out << buf;
  // One colour per variant, one marker per family.
  static const char* colours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e",
                                  "#8c564b", "#e377c2", "#17becf", "#7f7f7f", "#bcbd22"};
  std::vector<std::string> variants;
  std::vector<Family> families;
  for (const TradeRow& r : rows) {
    if (std::find(variants.begin(), variants.end(), r.variant) == variants.end()) variants.push_back(r.variant);
    if (std::find(families.begin(), families.end(), r.family) == families.end()) families.push_back(r.family);
  }
  auto marker = [&](double x, double y, size_t family, const char* colour) {
    switch (family % 4) {
      case 0: std::snprintf(buf, sizeof buf, "<circle cx='%.1f' cy='%.1f' r='5' fill='%s'/>", x, y, colour); break;
      case 1: std::snprintf(buf, sizeof buf, "<rect x='%.1f' y='%.1f' width='9' height='9' fill='%s'/>", x - 4.5, y - 4.5, colour); break;
      case 2: std::snprintf(buf, sizeof buf, "<path d='M%.1f %.1f l5 9 l-10 0 z' fill='%s'/>", x, y - 5.5, colour); break;
      default: std::snprintf(buf, sizeof buf, "<path d='M%.1f %.1f l5 5 l-5 5 l-5 -5 z' fill='none' stroke='%s' stroke-width='2'/>", x, y - 5, colour);
    }
    return std::string(buf);
  };
  for (const TradeRow& r : rows) {
    const size_t vi = std::find(variants.begin(), variants.end(), r.variant) - variants.begin();
    const size_t fi = std::find(families.begin(), families.end(), r.family) - families.begin();
    out << "<g><title>" << r.variant << " / " << to_string(r.shape) << " / " << to_string(r.family) << ": "
        << r.ns_per_test << " ns, rate " << r.disagreement_rate << "</title>"
        << marker(px(r.ns_per_test), py(r.disagreement_rate), fi, colours[vi % 10]) << "</g>\n";
  }
  double ly = top + 10;
  for (size_t i = 0; i < variants.size(); ++i, ly += 18) {
    std::snprintf(buf, sizeof buf, "<rect x='%.1f' y='%.1f' width='12' height='12' fill='%s'/><text x='%.1f' y='%.1f'>%s</text>\n",
                  W - right + 20, ly - 10, colours[i % 10], W - right + 38, ly, variants[i].c_str());
    out << buf;
  }
  ly += 10;
  for (size_t i = 0; i < families.size(); ++i, ly += 18)
    out << marker(W - right + 26, ly - 4, i, "#444") << "<text x='" << W - right + 38 << "' y='" << ly << "'>"
        << to_string(families[i]) << "</text>\n";
  out << "</svg>\n";
}

}  // namespace rayproof::fuzz
