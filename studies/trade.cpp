#include "rayproof/studies/trade.h"
#include "rayproof/studies/markup.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>

#include "rayproof/core/batch.h"
#include "rayproof/core/parallel.h"
#include "rayproof/core/variants.h"
#include "rayproof/core/timing.h"
#include "rayproof/studies/svg.h"
#include "rayproof/verify/compare.h"
#include "rayproof/verify/oracle.h"

namespace rayproof::studies {

std::vector<Contender> variant_contenders() {
  std::vector<Contender> out;
  for (const Variant& v : all_variants()) {
    const Variant* p = &v;
    Contender c{std::string(v.name),
                v.shape,
                [p](const std::vector<Query>& qs) {
                  auto hits = std::make_shared<std::vector<Answer>>(qs.size());
                  if (p->external)  // one round trip for the batch, run repeatedly where the code runs, timed there
                    return Prepared{[p, &qs, hits] { p->intersect_all(qs, HitRule::nearest_contact, *hits); },
                                    [hits](size_t i) { return (*hits)[i]; },
                                    [p, &qs, hits](int repeats) {
                                      AnswerTiming timing{repeats};
                                      p->intersect_all(qs, HitRule::nearest_contact, *hits, &timing);
                                      return timing.inner_seconds;
                                    }};
                  return Prepared{[p, &qs, hits] {
                                    for (size_t i = 0; i < qs.size(); ++i)
                                      (*hits)[i] = p->intersect(qs[i].ray, qs[i].shape, HitRule::nearest_contact);
                                  },
                                  [hits](size_t i) { return (*hits)[i]; }};
                },
                {}};
    if (v.precision == Precision::f32) c.effective_input = rounded_to_float;
    c.precision = v.is_oracle ? "exact" : std::string(to_string(v.precision));
    c.rule = v.rule_for(HitRule::nearest_contact);
    c.users_code = v.external != nullptr;
    out.push_back(std::move(c));
  }
  return out;
}

std::vector<Contender> batched_contenders() {
  std::vector<Contender> out;
  for (const BatchedVariant& b : batched_variants()) {
    // The queries laid out as structure of arrays once, in prepare; only the kernel is timed.
    const BatchedVariant* v = &b;
    out.push_back({std::string(b.name),
                   b.shape,
                   [v](const std::vector<Query>& qs) {
                     auto laid_out = std::make_shared<QueriesSoA>(qs);
                     auto hits = std::make_shared<HitsSoA>();
                     return Prepared{[v, laid_out, hits] { v->intersect_all(*laid_out, *hits); },
                                     [hits](size_t i) { return hits->at(i); }};
                   },
                   {}});
    const Variant* scalar = find_variant(b.scalar);
    if (scalar && scalar->precision == Precision::f32) out.back().effective_input = rounded_to_float;
    if (scalar) out.back().precision = std::string(to_string(scalar->precision));
  }
  return out;
}

namespace {

// Exact verdicts for a batch of queries, in parallel.
std::vector<Verdict> judge_all(const std::vector<Query>& qs, int threads, HitRule rule = HitRule::nearest_contact) {
  std::vector<Verdict> out(qs.size());
  run_workers(threads, [&](int w) {
    Oracle oracle;
    for (size_t i = w; i < qs.size(); i += threads) out[i] = oracle.judge(qs[i].ray, qs[i].shape, rule);
  });
  return out;
}

// Nanoseconds per query, single-threaded: the fastest of several passes over the first 4096
// queries (cache-resident, like a benchmark's prepared inputs; the whole set is still judged).
double time_per_query(const Contender& c, const std::vector<Query>& all) {
  const std::vector<Query> qs(all.begin(), all.begin() + std::min<size_t>(all.size(), 4096));
  const Prepared p = c.prepare(qs);
  const int repeats = static_cast<int>(std::max<size_t>(1, 200000 / qs.size()));
  if (p.time_where_it_runs) {  // external code repeats the batch where it runs: one round trip per pass
    // (exec cannot: -1)
    const double best = fastest_of(5, [&] { return p.time_where_it_runs(repeats); });
    if (best >= 0) return best * 1e9 / std::max<size_t>(1, qs.size());
  }
  const double best = fastest_of(5, [&] {
    const Stopwatch watch;
    for (int r = 0; r < repeats; ++r) p.run();
    return watch.seconds() / repeats;
  });
  for (size_t i = 0; i < qs.size(); ++i) keep_alive(p.answer(i).t);  // the passes cannot be optimised away
  return best * 1e9 / std::max<size_t>(1, qs.size());
}

}  // namespace

void mark_pareto(std::vector<TradeRow>& rows) {
  for (TradeRow& r : rows) {
    r.pareto = r.measured();
    for (const TradeRow& o : rows) {
      if (&o == &r || o.shape != r.shape || o.family != r.family || !o.measured()) continue;
      const double o_rate = o.bug_rate(), r_rate = r.bug_rate();
      const bool no_worse = o.ns_per_test <= r.ns_per_test && o_rate <= r_rate;
      const bool better = o.ns_per_test < r.ns_per_test || o_rate < r_rate;
      if (no_worse && better) r.pareto = false;
    }
  }
}

std::vector<TradeRow> measure_trade(const std::vector<Contender>& contenders, const std::vector<ShapeKind>& shapes,
                                    const std::vector<Family>& families, std::uint64_t count, std::uint64_t seed,
                                    int threads, double tolerance_ulps) {
  std::vector<TradeRow> rows;
  for (ShapeKind shape : shapes) {
    for (Family family : families) {
      std::vector<Query> generated(count);
      for (std::uint64_t i = 0; i < count; ++i) generated[i] = fuzz::generate(family, shape, seed, i);
      const std::vector<Verdict> exact = judge_all(generated, threads);
      for (const Contender& c : contenders) {
        if (c.shape != shape) continue;
        std::vector<Query> inputs = generated;
        std::vector<Verdict> truth;
        const bool own_truth = c.effective_input || c.rule != HitRule::nearest_contact;
        std::uint64_t not_representable = 0;
        if (c.effective_input) {
          inputs.clear();
          for (const Query& q : generated)
            if (auto e = c.effective_input(q)) inputs.push_back(*e);
          not_representable = generated.size() - inputs.size();
          if (inputs.empty()) continue;
        }
        if (own_truth) truth = judge_all(inputs, threads, c.rule);
        const std::vector<Verdict>& judge = own_truth ? truth : exact;
        const Prepared prepared = c.prepare(inputs);
        prepared.run();
        std::vector<Answer> answers(inputs.size());
        for (size_t i = 0; i < inputs.size(); ++i) answers[i] = prepared.answer(i);
        TradeRow row{c.name, shape, family, time_per_query(c, inputs)};
        row.users_code = c.users_code;
        row.precision = c.precision;
        row.tally.not_representable = not_representable;
        row.tally.tolerance_ulps = tolerance_ulps;
        const Precision precision = c.precision == "float" ? Precision::f32 : Precision::f64;
        for (size_t i = 0; i < inputs.size(); ++i) {
          VariantOutcome o = judge_answer(judge[i], answers[i]);
          if (c.precision == "float" && judge[i].t && answers[i].has_t() && o.agreement == Agreement::agrees)
            o.ulp_own =
                ulp_distance_f32(to_nearest_float(answers[i].t), exact_t_as_float(inputs[i], c.rule, *judge[i].t));
          row.tally.add(judge[i].cls, o);
          if (answers[i].failed() || o.agreement == Agreement::agrees) continue;
          // Its level (verdicts.md), on the inputs the contender saw (K = 0: every one a bug).
          const BackwardError b = tolerance_ulps == 0 ? BackwardError{}
                                                      : class_backward_error(inputs[i], c.rule, answers[i].cls,
                                                                             precision, tolerance_ulps, false);
          row.tally.add_level({judge[i].cls, answers[i].cls}, level_of(b, tolerance_ulps) == Level::bug,
                              tolerance_ulps == 0 ? "unchecked" : beta_bucket(b));
        }
        rows.push_back(std::move(row));
      }
    }
  }
  mark_pareto(rows);
  return rows;
}

void write_trade_csv(const std::vector<TradeRow>& rows, std::ostream& out) {
  // (bugs and bug_rate appended: readers of the earlier columns keep working.)
  out << "variant,shape,family,cases,ns_per_test,disagreements,disagreement_rate,ulp_p99,ulp_max,precision,bugs,"
         "bug_rate\n";
  char buf[64];
  for (const TradeRow& r : rows) {
    std::snprintf(buf, sizeof buf, "%.3f", r.ns_per_test);
    out << r.variant << "," << to_string(r.shape) << "," << to_string(r.family) << "," << r.tally.cases << "," << buf
        << "," << r.tally.disagreements() << ",";
    std::snprintf(buf, sizeof buf, "%.9g", r.tally.disagreement_rate());
    out << buf << "," << r.t_error().quantile(0.99) << "," << r.t_error().max() << "," << r.precision << ","
        << r.tally.bug_count() << ",";
    std::snprintf(buf, sizeof buf, "%.9g", r.bug_rate());
    out << buf << "\n";
  }
}

void write_trade_table(const std::vector<TradeRow>& rows, TableFormat format, std::ostream& out) {
  if (format == TableFormat::json) {
    json j = json::array();
    for (const TradeRow& r : rows)
      j.push_back({{"variant", r.variant},
                   {"shape", std::string(to_string(r.shape))},
                   {"family", std::string(to_string(r.family))},
                   {"ns_per_test", r.ns_per_test},
                   {"cases", r.tally.cases},
                   {"disagreements", r.tally.disagreements()},
                   {"disagreement_rate", r.tally.disagreement_rate()},
                   {"bugs", r.tally.bug_count()},
                   {"bug_rate", r.bug_rate()},
                   {"ulp_p99", r.t_error().quantile(0.99)},
                   {"ulp_max", r.t_error().max()},
                   {"bits", bits_json(r.t_error())},
                   {"pareto", r.pareto},
                   {"precision", r.precision}});
    out << json_text(j, 2) << "\n";
    return;
  }
  const bool md = format == TableFormat::markdown;
  const char* row_format = md ? "| %s | %s | %s | %.2f | %.3g%% | %.3g%% | %s | %llu | %llu | %s |\n"
                              : "%-9s %-12s %-22s %9.2f %10.3g%% %10.3g%% %9s %20llu %20llu  %s\n";
  if (md)
    out << "| shape | family | variant | ns/test | bug rate | disagreement rate | t error bits p99 | ULP p99 | ULP max "
           "| Pareto |\n"
        << "|---|---|---|---:|---:|---:|---:|---:|---:|:---:|\n";
  else
    out << markup::format("%-9s %-12s %-22s %9s %11s %11s %9s %20s %20s  %s\n", "shape", "family", "variant", "ns/test",
                          "bugs", "disagree", "bits-p99", "ulp-p99", "ulp-max", "pareto");
  for (const TradeRow& r : rows) {
    const std::string bits =
        r.t_error().count() ? markup::format("%.1f", bits_of_error(r.t_error().quantile(0.99))) : "-";
    out << markup::format(row_format, std::string(to_string(r.shape)).c_str(), std::string(to_string(r.family)).c_str(),
                          r.variant.c_str(), r.ns_per_test, 100 * r.bug_rate(), 100 * r.tally.disagreement_rate(),
                          bits.c_str(), static_cast<unsigned long long>(r.t_error().quantile(0.99)),
                          static_cast<unsigned long long>(r.t_error().max()), r.pareto ? "★" : "");
  }
  out << (md ? "\n" : "") << "Bug: a disagreement whose backward error exceeds --tolerance-ulps (verdicts.md); "
      << "disagreement: the class differs from the exact one; t error (ULPs, bits = log2(ulps + 1)) "
      << "over the cases whose class agrees, in the contender's own precision (float code: float ulps against the "
         "exact t "
      << "rounded to float); ★ Pareto-optimal on its shape and family (speed against the bug rate).\n";
}

namespace {

// The scatter's frame: log axes of ns per test and disagreement rate; zero rates sit on a floor
// line labelled "0", a decade below the smallest non-zero rate.
struct TradeFrame {
  static constexpr double W = 900, H = 480, left = 90, right = 230, bottom = 60;
  double top = 50;  // each shape's panel stacks below the last
  double lx0, lx1, ly_floor, ly0, ly1 = 0;
  std::string title;

  TradeFrame(const std::vector<TradeRow>& rows, double offset, std::string heading)
      : top(offset + 50), title(std::move(heading)) {
    double x_lo = INFINITY, x_hi = 0, y_min_nonzero = 1;
    for (const TradeRow& r : rows) {
      x_lo = std::min(x_lo, r.ns_per_test), x_hi = std::max(x_hi, r.ns_per_test);
      for (const double rate : {r.bug_rate(), r.tally.disagreement_rate()})  // both series
        if (rate > 0) y_min_nonzero = std::min(y_min_nonzero, rate);
    }
    if (rows.empty()) x_lo = 1, x_hi = 10;
    lx0 = std::floor(std::log10(std::max(x_lo, 1e-3))), lx1 = std::ceil(std::log10(std::max(x_hi, 1e-3)) + 1e-9);
    ly_floor = std::floor(std::log10(y_min_nonzero)) - 1, ly0 = ly_floor - 0.5;
  }
  double x(double ns) const {
    return left + (std::log10(std::max(ns, 1e-3)) - lx0) / std::max(1.0, lx1 - lx0) * (W - left - right);
  }
  double y(double rate) const {
    const double l = rate > 0 ? std::log10(rate) : ly_floor;
    return top + (ly1 - l) / (ly1 - ly0) * (H - 50 - bottom);
  }
  double bottom_y() const { return top + H - 50 - bottom; }

  void draw(std::ostream& out) const {
    out << svg::text(left, top - 22, title, "font-size='16'") << "\n";
    for (int e = static_cast<int>(lx0); e <= static_cast<int>(lx1); ++e) {  // x grid
      const double gx = x(std::pow(10, e));
      out << svg::line(gx, top, gx, bottom_y(), "stroke='#ddd'")
          << svg::text(gx, bottom_y() + 18, markup::format("%g", std::pow(10, e)), "text-anchor='middle'") << "\n";
    }
    for (int e = static_cast<int>(ly_floor) + 1; e <= 0; ++e) {  // y grid
      const double gy = y(std::pow(10, e));
      out << svg::line(left, gy, W - right, gy, "stroke='#ddd'")
          << svg::text(left - 6, gy + 4, markup::format("%g%%", 100 * std::pow(10, e)), "text-anchor='end'") << "\n";
    }
    out << svg::line(left, y(0), W - right, y(0), "stroke='#999' stroke-dasharray='4 3'")
        << svg::text(left - 6, y(0) + 4, "0", "text-anchor='end'") << "\n"
        << svg::text((left + W - right) / 2, bottom_y() + 38, "ns per test (log)", "text-anchor='middle'")
        << markup::format("<text transform='translate(22 %.1f) rotate(-90)' text-anchor='middle'>",
                          (top + bottom_y()) / 2)
        << "bug-level wrong answers, rate (log)</text>\n";
  }
};

// One marker shape per family (six shapes for the six families), filled with the contender's colour.
// The family's shape in the contender's colour; float contenders hollow (a white fill inside the
// colour), exact ones with a black dot in the middle, double ones solid.
std::string trade_marker(double x, double y, size_t family, const std::string& colour, const std::string& precision) {
  const char* c = colour.c_str();
  const std::string paint = precision == "float" ? markup::format("fill='#fff' stroke='%s' stroke-width='2'", c)
                                                 : markup::format("fill='%s'", c);
  std::string m;
  switch (family % 6) {
    case 0: m = markup::format("<circle cx='%.1f' cy='%.1f' r='5' %s/>", x, y, paint.c_str()); break;
    case 1:
      m = markup::format("<rect x='%.1f' y='%.1f' width='9' height='9' %s/>", x - 4.5, y - 4.5, paint.c_str());
      break;
    case 2: m = markup::format("<path d='M%.1f %.1f l5.5 9.5 l-11 0 z' %s/>", x, y - 6, paint.c_str()); break;
    case 3: m = markup::format("<path d='M%.1f %.1f l5.5 -9.5 l-11 0 z' %s/>", x, y + 6, paint.c_str()); break;
    case 4: m = markup::format("<path d='M%.1f %.1f l6 6 l-6 6 l-6 -6 z' %s/>", x, y - 6, paint.c_str()); break;
    default:
      m = markup::format("<path d='M%.1f %.1f h10 M%.1f %.1f v10' stroke='%s' stroke-width='%s'/>", x - 5, y, x, y - 5,
                         c, precision == "float" ? "1.5" : "3");
  }
  if (precision == "exact") m += markup::format("<circle cx='%.1f' cy='%.1f' r='1.8' fill='#000'/>", x, y);
  return m;
}

// A colour per contender, never repeated: Kelly's 22 colours of maximum contrast (white and
// black left out), then hues spaced by the golden angle.
std::string contender_colour(size_t i) {
  static const char* kelly[] = {"#f3c300", "#875692", "#f38400", "#a1caf1", "#be0032", "#c2b280", "#848482",
                                "#008856", "#e68fac", "#0067a5", "#f99379", "#604e97", "#f6a600", "#b3446c",
                                "#dcd300", "#882d17", "#8db600", "#654522", "#e25822", "#2b3d26"};
  if (i < std::size(kelly)) return kelly[i];
  return markup::format("hsl(%.0f, 65%%, 45%%)", std::fmod(i * 137.508, 360.0));
}

template <class T>
size_t index_in(std::vector<T>& seen, const T& value) {
  const auto it = std::find(seen.begin(), seen.end(), value);
  if (it != seen.end()) return static_cast<size_t>(it - seen.begin());
  seen.push_back(value);
  return seen.size() - 1;
}

}  // namespace

void write_trade_svg(const std::vector<TradeRow>& rows, std::ostream& out) {
  std::vector<std::string> contenders;  // colours and markers are the same in every panel
  std::vector<Family> families;
  std::vector<ShapeKind> shapes;
  for (const TradeRow& r : rows)
    index_in(contenders, r.variant), index_in(families, r.family), index_in(shapes, r.shape);
  std::sort(families.begin(), families.end());
  svg::begin(out, TradeFrame::W, std::max<size_t>(1, shapes.size()) * TradeFrame::H + 20, 12);
  for (size_t si = 0; si < shapes.size(); ++si) {
    std::vector<TradeRow> panel;
    for (const TradeRow& r : rows)
      if (r.shape == shapes[si] && r.measured()) panel.push_back(r);
    const TradeFrame frame(panel, si * TradeFrame::H,
                           std::string(to_string(shapes[si])) + ": speed against accuracy (lower left is better)");
    frame.draw(out);
    // The Pareto front of each family: its optimal contenders joined from fastest to slowest.
    for (size_t fi = 0; fi < families.size(); ++fi) {
      std::vector<const TradeRow*> front;
      for (const TradeRow& r : panel)
        if (r.family == families[fi] && r.pareto) front.push_back(&r);
      std::sort(front.begin(), front.end(),
                [](const TradeRow* a, const TradeRow* b) { return a->ns_per_test < b->ns_per_test; });
      std::string points;
      for (const TradeRow* r : front)
        points += markup::format("%.1f,%.1f ", frame.x(r->ns_per_test), frame.y(r->bug_rate()));
      if (front.size() > 1)
        out << "<polyline points='" << points << "' fill='none' stroke='#888' stroke-width='1.2'><title>"
            << markup::escape("Pareto front, " + std::string(to_string(families[fi]))) << "</title></polyline>\n";
    }
    for (const TradeRow& r : panel) {
      const size_t vi = index_in(contenders, r.variant), fi = index_in(families, r.family);
      const double x = frame.x(r.ns_per_test), y = frame.y(r.bug_rate());
      // The second series: every disagreement (rounding-level included), a small grey tick above
      // the mark, joined to it, where it differs.
      const double y_all = frame.y(r.tally.disagreement_rate());
      if (y_all < y - 0.5)
        out << svg::line(x, y, x, y_all, "stroke='#bbb' stroke-dasharray='2,2'")
            << markup::format("<circle cx='%.1f' cy='%.1f' r='2.5' fill='#999'/>", x, y_all) << "\n";
      out << "<g><title>"
          << markup::escape(r.variant + (r.users_code ? " (your code)" : "") + " / " +
                            std::string(to_string(r.family)) +
                            markup::format(": %g ns, bug rate %g, all disagreements %g", r.ns_per_test, r.bug_rate(),
                                           r.tally.disagreement_rate()))
          << "</title>" << trade_marker(x, y, fi, contender_colour(vi), r.precision);
      if (r.users_code)  // the user's own code: ringed (and named in bold in the legend), found at a glance
        out << markup::format("<circle cx='%.1f' cy='%.1f' r='10' fill='none' stroke='#000' stroke-width='2'/>", x, y);
      out << "</g>\n";
    }
    const double lx = TradeFrame::W - TradeFrame::right;
    double ly = frame.top + 10;
    for (size_t i = 0; i < contenders.size(); ++i) {
      if (std::none_of(panel.begin(), panel.end(), [&](const TradeRow& r) { return r.variant == contenders[i]; }))
        continue;
      const bool users = std::any_of(panel.begin(), panel.end(),
                                     [&](const TradeRow& r) { return r.variant == contenders[i] && r.users_code; });
      out << svg::rect(lx + 20, ly - 10, 12, 12, contender_colour(i))
          << svg::text(lx + 38, ly, contenders[i] + (users ? " (yours)" : ""), users ? "font-weight='bold'" : "")
          << "\n";
      ly += 16;
    }
    ly += 8;
    for (size_t i = 0; i < families.size(); ++i, ly += 16)
      out << trade_marker(lx + 26, ly - 4, i, "#444", "double") << svg::text(lx + 38, ly, to_string(families[i]))
          << "\n";
    for (const char* p : {"float (hollow)", "exact (dotted)"}) {  // how precision is drawn, on any family's mark
      out << trade_marker(lx + 26, ly - 4, 0, "#444", std::string(p).substr(0, 5)) << svg::text(lx + 38, ly, p) << "\n";
      ly += 16;
    }
    out << svg::line(lx + 20, ly, lx + 34, ly, "stroke='#888' stroke-width='1.2'")
        << svg::text(lx + 38, ly + 4, "Pareto front") << "\n";
    ly += 16;
    out << markup::format("<circle cx='%.1f' cy='%.1f' r='2.5' fill='#999'/>", lx + 27, ly)
        << svg::text(lx + 38, ly + 4, "all disagreements") << "\n";
  }
  svg::end(out);
}

}  // namespace rayproof::studies
