#include "rayproof/fuzz/campaign.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <cstring>

#include "rayproof/core/atomic_file.h"
#include "rayproof/core/casefile.h"
#include "rayproof/core/parallel.h"
#include "rayproof/core/timing.h"
#include "rayproof/fuzz/findings_file.h"
#include "rayproof/fuzz/shrink.h"
#include "rayproof/verify/compare.h"
#include "rayproof/verify/oracle.h"

namespace rayproof::fuzz {

// ----------------------------------------------------------------------------- the report
ReportKey ReportKey::parse(const std::string& joined) {
  const size_t tab = joined.find('\t');
  if (tab == std::string::npos) throw std::runtime_error("report key without a tab: '" + joined + "'");
  return {joined.substr(0, tab), joined.substr(tab + 1)};
}

namespace {
template <class Value, class ToJson>
json keyed_to_json(const std::map<ReportKey, Value>& m, ToJson to_json) {
  json j = json::object();
  for (const auto& [k, v] : m) j[k.to_string()] = to_json(v);
  return j;
}
// Errors name the entry: "tallies.tangent\tstable.agree".
template <class Value, class FromJson>
std::map<ReportKey, Value> keyed_from_json(const json& j, const std::string& field, FromJson from_json) {
  if (!j.is_object()) throw FieldError(field, "expected an object");
  std::map<ReportKey, Value> m;
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string where = field + "." + printable_prefix(it.key(), 60);
    try {
      m[ReportKey::parse(it.key())] = from_json(it.value(), where);
    } catch (const FieldError& e) {
      throw FieldError(where + (e.field.empty() ? "" : "." + e.field), e.what());
    } catch (const json::exception& e) {
      throw FieldError(where, e.what());
    } catch (const std::runtime_error& e) {
      throw FieldError(where, e.what());
    }
  }
  return m;
}
}  // namespace

std::string tally_name(const Variant& v, ShapeKind shape) {
  return v.all_shapes ? std::string(v.name) + "@" + std::string(to_string(shape)) : std::string(v.name);
}

std::pair<const Variant*, ShapeKind> variant_of_tally(const std::string& name) {
  const std::size_t at = name.find('@');
  const Variant* v = find_variant(name.substr(0, at));
  if (at != std::string::npos)
    if (const auto k = shape_kind_from_string(name.substr(at + 1))) return {v, *k};
  return {v, v ? v->shape : ShapeKind::sphere};
}

json CampaignReport::coverage() const {
  // Every kind a variant could get wrong on its shape: an exact class it can be (cases.md) and
  // another class it can answer. A kind no family found is where the next family should aim.
  std::map<std::string, std::map<std::string, json>> found;  // variant → kind → family → count
  for (const auto& [key, tally] : tallies)
    for (const auto& [kind, n] : tally.confusion) found[key.name][kind.to_string()][key.family] = n;
  json out = json::object();
  for (const auto& [key, tally] : tallies) {
    if (out.contains(key.name)) continue;
    const auto [v, shape] = variant_of_tally(key.name);
    std::vector<HitClass> exact = {HitClass::miss, HitClass::enter, HitClass::exit, HitClass::tangent};
    if (shape == ShapeKind::triangle) exact.push_back(HitClass::boundary);
    std::vector<HitClass> answers = exact;
    if (v && v->external) answers.push_back(HitClass::hit);
    json never = json::array();
    for (HitClass e : exact)
      for (HitClass a : answers) {
        if (agreement_of(e, a) == Agreement::agrees) continue;
        const std::string kind = std::string(rayproof::to_string(e)) + "->" + std::string(rayproof::to_string(a));
        if (!found[key.name].contains(kind)) never.push_back(kind);
      }
    json kinds = json::object();
    for (const auto& [kind, by_family] : found[key.name]) kinds[kind] = by_family;
    out[key.name] = {{"found", kinds}, {"never_found", never}};
  }
  return out;
}

json CampaignReport::to_json() const {
  auto plain = [](const auto& v) { return json(v); };
  json j = {{"tallies", keyed_to_json(tallies,
                                      [](const Tally& t) {
                                        json j = t.to_json();
                                        j["bits"] = bits_json(t);  // t error in bits beside the ULP histogram
                                        return j;
                                      })},
            {"seconds", keyed_to_json(seconds, plain)},
            {"shrink_seconds", keyed_to_json(shrink_seconds, plain)},
            {"cases", keyed_to_json(cases, plain)},
            {"findings_written", findings_written},
            {"findings_unshrunk", findings_unshrunk},
            {"coverage", coverage()}};
  shard_of.write_to(j);
  return j;
}

CampaignReport CampaignReport::from_json(const json& j) {
  CampaignReport r;
  r.tallies = keyed_from_json<Tally>(j.at("tallies"), "tallies",
                                     [](const json& v, const std::string&) { return Tally::from_json(v); });
  const auto seconds = [](const json& v, const std::string& field) {
    if (!v.is_number() || !(v.get<double>() >= 0)) throw FieldError(field, "expected seconds >= 0");
    return v.get<double>();
  };
  r.seconds = keyed_from_json<double>(j.at("seconds"), "seconds", seconds);
  // Summaries written before shrink times and unshrunk counts were kept have neither.
  if (j.contains("shrink_seconds"))
    r.shrink_seconds = keyed_from_json<double>(j.at("shrink_seconds"), "shrink_seconds", seconds);
  r.cases = keyed_from_json<std::uint64_t>(
      j.at("cases"), "cases", [](const json& v, const std::string& field) { return read_count(v, field); });
  r.findings_written = read_count(j.at("findings_written"), "findings_written");
  if (j.contains("findings_unshrunk")) r.findings_unshrunk = read_count(j.at("findings_unshrunk"), "findings_unshrunk");
  r.shard_of = ShardOf::read_from(j);
  return r;
}

namespace {
// The judged variants whose range is closed (--variant-range): they change the verdicts.
json closed_ranges(const CampaignOptions& o) {
  json closed = json::array();
  for (const Variant& x : all_variants())
    if (x.range == RangeRule::closed &&
        std::any_of(o.shapes.begin(), o.shapes.end(), [&](ShapeKind k) { return x.handles(k); }))
      closed.push_back(std::string(x.name));
  return closed;
}
}  // namespace

json campaign_identity(const CampaignOptions& o) {
  json f = json::array(), c = json::array(), s = json::array(), v = json::array();
  for (Family x : o.families) f.push_back(std::string(to_string(x)));
  for (Construction x : o.constructions) c.push_back(std::string(to_string(x)));
  for (ShapeKind x : o.shapes) s.push_back(std::string(to_string(x)));
  for (const Variant* x : o.variants) v.push_back(std::string(x->name));
  return {{"kind", "variants"},
          {"families", f},
          {"constructions", c},
          {"shapes", s},
          {"variants", v},
          {"count", o.count},
          {"seed", o.seed},
          {"rule", std::string(to_string(o.rule))},
          {"tolerance_ulps", o.tolerance_ulps},
          {"ranges", closed_ranges(o)},
          {"version", RAYPROOF_VERSION}};
}

namespace {

// ----------------------------------------------------------------------------- checkpoints
json fingerprint(const CampaignOptions& o) {
  json f = json::array(), s = json::array();
  for (Family x : o.families) f.push_back(std::string(to_string(x)));
  json c = json::array();
  for (Construction x : o.constructions) c.push_back(std::string(to_string(x)));
  for (ShapeKind x : o.shapes) s.push_back(std::string(to_string(x)));
  json v = json::array();
  for (const Variant* x : o.variants) v.push_back(std::string(x->name));
  // The variants judged, with where their code comes from: loading another plugin (or the same
  // name from another file) changes the findings as surely as an option does.
  json judged = json::array();
  for (const Variant& x : all_variants())
    if (std::any_of(o.shapes.begin(), o.shapes.end(), [&](ShapeKind k) { return x.handles(k); }) &&
        (o.variants.empty() ? !x.is_oracle : std::find(o.variants.begin(), o.variants.end(), &x) != o.variants.end()))
      judged.push_back(std::string(x.name) + " " + code_identity(std::string(x.origin)));
  return {{"families", f},
          {"constructions", c},
          {"shapes", s},
          {"variants", v},
          {"count", o.count},
          {"seed", o.seed},
          {"shard", o.shard},
          {"shards", o.shards},
          {"rule", std::string(to_string(o.rule))},
          {"tolerance_ulps", o.tolerance_ulps},
          {"closed_ranges", closed_ranges(o)},
          {"shrink", o.shrink},
          {"max_findings", o.max_findings},
          {"max_shrunk", o.max_shrunk},
          {"batch", o.batch},
          {"judged", judged}};
}

// Where the campaign stands after the last completed batch.
struct Checkpoint {
  size_t pair = 0;
  std::uint64_t next = 0;  // first case index not yet done in `pair`
  bool pair_started = false;
  std::uint64_t findings_in_pair = 0, rounding_findings_in_pair = 0;  // bug-level (and failures), rounding-level
  std::map<std::string, std::uint64_t> shrunk_in_pair;                // by finding kind
  std::uintmax_t findings_bytes = 0;
  FindingsHash findings_hash;  // of those bytes
  CampaignReport report;
};

void save(const std::string& path, const CampaignOptions& o, const Checkpoint& c) {
  write_checkpoint(path, fingerprint(o),
                   {{"pair", c.pair},
                    {"next", c.next},
                    {"pair_started", c.pair_started},
                    {"findings_in_pair", c.findings_in_pair},
                    {"rounding_findings_in_pair", c.rounding_findings_in_pair},
                    {"shrunk_in_pair", c.shrunk_in_pair},
                    {"findings_bytes", c.findings_bytes},
                    {"findings_hash", c.findings_hash.value},
                    {"report", c.report.to_json()}});
}

Checkpoint load(const std::string& path, const CampaignOptions& o) {
  return read_checkpoint(path, fingerprint(o), [](const json& j) {
    Checkpoint c;
    c.pair = j.at("pair"), c.next = j.at("next"), c.pair_started = j.at("pair_started");
    c.findings_in_pair = j.at("findings_in_pair"), c.findings_bytes = j.at("findings_bytes");
    c.rounding_findings_in_pair = j.at("rounding_findings_in_pair");
    c.shrunk_in_pair = j.at("shrunk_in_pair").get<std::map<std::string, std::uint64_t>>();
    c.findings_hash.value = j.at("findings_hash");
    c.report = CampaignReport::from_json(j.at("report"));
    return c;
  });
}

// The findings file opened for this campaign (findings_file.h, open_findings_file).
Checkpoint open_findings(const CampaignOptions& o, const std::string& checkpoint_path, std::ofstream& out) {
  return open_findings_file<Checkpoint>(
      o.output, checkpoint_path, o.resume, [&] { return load(checkpoint_path, o); },
      [&](const Checkpoint& cp) { save(checkpoint_path, o, cp); }, out);
}

// This shard's index range, with even bounds so grazing triangle pairs stay together.
std::pair<std::uint64_t, std::uint64_t> shard_range(const CampaignOptions& o) {
  auto bound = [&](unsigned s) -> std::uint64_t {
    if (s >= o.shards) return o.count;
    const std::uint64_t b = static_cast<std::uint64_t>((static_cast<unsigned __int128>(o.count) * s) / o.shards);
    return b & ~std::uint64_t(1);
  };
  return {bound(o.shard), bound(o.shard + 1)};
}

// ----------------------------------------------------------------------------- one batch
struct Batch {
  Family family;
  Construction construction;
  ShapeKind shape;
  std::uint64_t start, end;
  std::uint64_t size() const { return end - start; }
};

struct Finding {
  std::uint64_t index;
  GeneratedCase generated;
  const Variant* first_disagreeing;  // or the first that failed on it (plugin.md: crash, timeout, ...)
  AnswerFailure failure = AnswerFailure::none;
  std::string kind;          // "VARIANT exact->reported" or "VARIANT failure": what max_shrunk counts
  bool shrink = true;        // false: written as found (beyond max_shrunk)
  Level level = Level::bug;  // of the first disagreeing variant's answer (failures: bug)
};

// What hole counting needs of one case of a grazing-triangle batch.
struct EdgeEvidence {
  bool shared_edge = false;
  Verdict exact;
  std::vector<bool> variant_hit;  // by variant, in the order of `variants`
  // By variant: the verdict on what it saw where that differs from the case (float variants see
  // the case rounded to float: a hole is judged on those numbers, as every other answer is).
  std::vector<std::optional<Verdict>> own;
};

struct Worker {
  Oracle oracle;
  std::vector<Tally> tallies;  // by variant
  std::vector<Finding> findings;
  // A chunk's cases, verdicts and outcomes: kept from batch to batch, so their storage (hundreds
  // of kilobytes) is not returned to the system and faulted in again for every chunk.
  std::vector<GeneratedCase> cases;
  std::vector<Query> queries;
  std::vector<Verdict> exact;
  std::vector<VariantOutcome> outcomes;
  std::vector<Answer> answers;
  FloatView float_view;  // the chunk's float-rounded cases and their verdicts, for every f32 variant
};

struct Judged {
  std::vector<Finding> findings;    // in index order
  std::vector<EdgeEvidence> edges;  // by case, for grazing triangles only
};

// Step 1: generate and judge every case; tally per variant; keep the disagreeing cases and the
// cases external code failed on. Each thread asks each variant for a chunk of cases at once, so
// code behind a process boundary (plugins, --exec) answers in round trips of a chunk.
// Cases per chunk: small while every variant is built in (a chunk's cases, verdicts and
// outcomes stay in cache), large when external code answers (a round trip to a worker process
// costs tens of microseconds: spread over thousands of cases).
constexpr size_t kChunkBuiltIn = 64, kChunkExternal = 1024;
Judged judge_batch(const Batch& b, const std::vector<const Variant*>& variants, const CampaignOptions& o,
                   std::vector<Worker>& workers, CampaignReport& report) {
  const bool pairs_of_triangles = b.family == Family::grazing && b.shape == ShapeKind::triangle;
  Judged judged;
  judged.edges.resize(pairs_of_triangles ? b.size() : 0);
  const int threads = static_cast<int>(workers.size());
  const bool external = std::any_of(variants.begin(), variants.end(), [](const Variant* v) { return v->external; });
  // Queries are kept for every variant not judged case by case in the hot loop below (external
  // code, float variants: they are given the chunk, rounded where they compute in float).
  const bool keep_queries = std::any_of(variants.begin(), variants.end(), [](const Variant* v) {
    return !(v->kernel && v->precision == Precision::f64 && !v->fixed_rule);
  });
  const std::uint64_t chunk_size = external ? kChunkExternal : kChunkBuiltIn;
  run_workers(threads, [&](int w) {
    Worker& me = workers[w];
    me.tallies.assign(variants.size(), Tally{});
    me.findings.clear();
    const std::uint64_t lo = b.start + b.size() * w / threads, hi = b.start + b.size() * (w + 1) / threads;
    std::vector<GeneratedCase>& cases = me.cases;
    std::vector<Query>& queries = me.queries;
    std::vector<Verdict>& exact = me.exact;
    std::vector<VariantOutcome>& outcomes = me.outcomes;
    std::vector<const Variant*> first;  // by case in the chunk: the first variant that disagreed or failed
    std::vector<AnswerFailure> failure;
    std::vector<HitClass> reported;  // by case: the first disagreeing variant's class
    std::vector<Level> level;        // by case: the first disagreeing variant's level
    // The chunk's disagreements, each given its level (verdicts.md) once every variant answered.
    struct Disagreeing {
      size_t k, vi;
      VariantOutcome outcome;
    };
    std::vector<Disagreeing> disagreeing;
    for (Tally& t : me.tallies) t.tolerance_ulps = o.tolerance_ulps;
    for (std::uint64_t chunk = lo; chunk < hi; chunk += chunk_size) {
      const size_t n = static_cast<size_t>(std::min<std::uint64_t>(chunk_size, hi - chunk));
      cases.clear(), queries.clear(), exact.clear();
      for (size_t k = 0; k < n; ++k) {
        cases.push_back(generate(b.family, b.shape, o.seed, chunk + k, b.construction));
        if (keep_queries) queries.push_back(cases.back());
        exact.push_back(me.oracle.judge(cases.back().ray, cases.back().shape, o.rule));
      }
      me.float_view.clear(), first.assign(n, nullptr), failure.assign(n, AnswerFailure::none),
          reported.assign(n, HitClass::miss), level.assign(n, Level::bug), disagreeing.clear();
      auto disagrees = [&](size_t k, size_t vi, const Answer& a) {
        VariantOutcome d = judge_answer(exact[k], a);
        d.variant = variants[vi];
        disagreeing.push_back({k, vi, std::move(d)});
      };
      for (size_t k = 0; k < n && pairs_of_triangles; ++k) {
        EdgeEvidence& edge = judged.edges[chunk + k - b.start];
        edge.shared_edge = cases[k].shared_edge, edge.exact = exact[k], edge.variant_hit.resize(variants.size());
        edge.own.assign(variants.size(), std::nullopt);
      }
      // Variant vi's answer (its class, or its failure) to case k, counted in its tally already:
      // the case's first finding (a disagreement, or a failure that is one) and the shared-edge
      // evidence. (Class and failure by value: a built-in's Hit made into an Answer temporary
      // here was read back whole from narrow stores, a failed store forward per case and variant.)
      auto note = [&](size_t k, size_t vi, HitClass cls, AnswerFailure failed, bool finding) {
        if (finding && !first[k]) first[k] = variants[vi], failure[k] = failed, reported[k] = cls;
        if (pairs_of_triangles)
          judged.edges[chunk + k - b.start].variant_hit[vi] = failed == AnswerFailure::none && cls != HitClass::miss;
      };
      auto failure_is_finding = [](AnswerFailure f) { return stops_variant(f) || is_plugin_error(f); };
      for (size_t vi = 0; vi < variants.size(); ++vi) {
        // Built-in double code is judged case by case as it answers (nothing stored: the
        // campaign's hot loop); external code answers the chunk in one call first.
        const Variant& v = *variants[vi];
        Tally& tally = me.tallies[vi];
        const bool direct = v.kernel && v.precision == Precision::f64 && !v.fixed_rule;
        if (direct) {
          for (size_t k = 0; k < n; ++k) {
            const Hit h = v.kernel(cases[k].ray, cases[k].shape, o.rule);
            const bool wrong = tally.add_answer(exact[k], h) != Agreement::agrees;
            if (wrong) disagrees(k, vi, h);
            note(k, vi, h.cls, AnswerFailure::none, wrong);
          }
          continue;
        }
        if (v.precision == Precision::f64 && v.rule_for(o.rule) == o.rule) {
          // External double code on the case as given: its answers judged like a built-in's.
          me.answers.resize(n);
          v.intersect_all(queries, o.rule, me.answers);
          for (size_t k = 0; k < n; ++k) {
            const Answer& h = me.answers[k];
            if (h.failed()) tally.add(exact[k].cls, VariantOutcome{&v, h});
            const bool wrong = !h.failed() && tally.add_answer(exact[k], h) != Agreement::agrees;
            if (wrong) disagrees(k, vi, h);
            note(k, vi, h.cls, h.failure, h.failed() ? failure_is_finding(h.failure) : wrong);
          }
          continue;
        }
        judge_variant_all(me.oracle, v, queries, exact, o.rule, outcomes, &me.float_view);
        for (size_t k = 0; k < n; ++k) {
          const VariantOutcome& r = outcomes[k];
          tally.add(exact[k].cls, r);
          if (!r.answer.failed() && r.agreement != Agreement::agrees) disagreeing.push_back({k, vi, r});
          note(k, vi, r.answer.cls, r.answer.failure,
               r.answer.failed() ? failure_is_finding(r.answer.failure) : r.agreement != Agreement::agrees);
          if (pairs_of_triangles) {
            EdgeEvidence& edge = judged.edges[chunk + k - b.start];
            if (r.own_exact)
              edge.own[vi] = Verdict{r.own_exact->cls, r.own_exact->t, nullptr, r.own_exact->front};
            else if (r.answer.failure == AnswerFailure::not_representable)
              edge.own[vi] = Verdict{};  // not asked: no hole
          }
        }
      }
      // Levels: β checked up to K (beyond it a disagreement is a bug whatever a witness says).
      // Variants of one precision, rule and range that report the same class on a case share a
      // verdict (they saw the same numbers): judged once (disagreeing is in variant order, so a
      // case's earlier verdicts are looked up among the few kept for it).
      struct Shared {
        size_t k;
        Precision precision;
        HitRule rule;
        RangeRule range;
        HitClass reported;
        std::optional<OutcomeVerdict> verdict;
      };
      std::vector<Shared> shared;
      for (const Disagreeing& d : disagreeing) {
        const Variant& var = *variants[d.vi];
        const Shared key{d.k, var.precision, var.rule_for(o.rule), var.range, d.outcome.answer.cls, std::nullopt};
        auto same = std::find_if(shared.begin(), shared.end(), [&](const Shared& x) {
          return x.k == key.k && x.precision == key.precision && x.rule == key.rule && x.range == key.range &&
                 x.reported == key.reported;
        });
        if (same == shared.end()) {
          shared.push_back(key);
          // K = 0, the strict reading: every disagreement a bug, no β asked (none is "within" 0).
          shared.back().verdict =
              o.tolerance_ulps == 0
                  ? std::optional<OutcomeVerdict>(OutcomeVerdict{})
                  : outcome_verdict(cases[d.k], d.outcome, o.rule, o.tolerance_ulps, false, o.tolerance_ulps, false);
          same = shared.end() - 1;
        }
        const std::optional<OutcomeVerdict>& v = same->verdict;
        if (!v) continue;
        Tally& tally = me.tallies[d.vi];
        if (v->at_range_end)
          ++tally.at_range_end;
        else
          tally.add_level({d.outcome.own_exact ? d.outcome.own_exact->cls : exact[d.k].cls, d.outcome.answer.cls},
                          v->level == Level::bug, o.tolerance_ulps == 0 ? "unchecked" : beta_bucket(v->beta));
        if (first[d.k] == variants[d.vi] && failure[d.k] == AnswerFailure::none) level[d.k] = v->level;
      }
      for (size_t k = 0; k < n; ++k) {
        if (!first[k]) continue;
        std::string kind = std::string(first[k]->name) + " ";
        kind += failure[k] != AnswerFailure::none
                    ? std::string(to_string(failure[k]))
                    : std::string(to_string(exact[k].cls)) + "->" + std::string(to_string(reported[k]));
        me.findings.push_back({chunk + k, std::move(cases[k]), first[k], failure[k], std::move(kind), true, level[k]});
      }
    }
  });
  for (Worker& w : workers) {
    for (size_t vi = 0; vi < variants.size(); ++vi)
      report.tallies[{family_label(b.family, b.construction), tally_name(*variants[vi], b.shape)}].merge(w.tallies[vi]);
    for (Finding& f : w.findings) judged.findings.push_back(std::move(f));
  }
  std::sort(judged.findings.begin(), judged.findings.end(),
            [](const Finding& x, const Finding& y) { return x.index < y.index; });
  return judged;
}

// Step 2: shared-edge holes (verify/compare.h's rule) over the batch's pairs 2k, 2k + 1.
void count_shared_edge_holes(const Batch& b, const Judged& judged, const std::vector<const Variant*>& variants,
                             CampaignReport& report) {
  for (size_t i = 0; i + 1 < judged.edges.size(); i += 2) {
    const EdgeEvidence &first = judged.edges[i], &second = judged.edges[i + 1];
    if (!first.shared_edge) continue;
    for (size_t vi = 0; vi < variants.size(); ++vi) {
      const Verdict& a = first.own[vi] ? *first.own[vi] : first.exact;
      const Verdict& c = second.own[vi] ? *second.own[vi] : second.exact;
      if (crosses_shared_edge(a, c) && !first.variant_hit[vi] && !second.variant_hit[vi])
        ++report.tallies[{family_label(b.family, b.construction), tally_name(*variants[vi], b.shape)}]
              .shared_edge_holes;
    }
  }
}

// The disagreeing variants' answers on a (shrunk) finding, for its "found" object.
json disagreeing_answers(const std::vector<const Variant*>& variants, Oracle& oracle, const Case& c, HitRule rule,
                         double tolerance_ulps) {
  const Verdict exact = oracle.judge(c.ray, c.shape, rule);
  json out = json::object();
  // Variants of one precision, rule and range reporting one class share a verdict (judge_batch).
  std::map<std::tuple<Precision, HitRule, RangeRule, HitClass>, std::optional<OutcomeVerdict>> shared;
  for (const Variant* v : variants) {
    if (!v->handles(kind_of(c.shape))) continue;
    const VariantOutcome o = compare_variant(oracle, *v, exact, c, rule);
    if (o.answer.failed()) {
      if (o.answer.failure != AnswerFailure::not_representable && o.answer.failure != AnswerFailure::stopped)
        out[std::string(v->name)] = {{"error", std::string(to_string(o.answer.failure))}};
      continue;
    }
    if (o.agreement == Agreement::agrees) continue;
    json& entry = out[std::string(v->name)];
    entry = {{"class", std::string(to_string(o.answer.cls))},
             {"t", o.answer.has_t() ? json(hex_double(o.answer.t)) : json(nullptr)},
             {"ulp", o.ulp ? json(*o.ulp) : json(nullptr)}};
    const auto key = std::make_tuple(v->precision, v->rule_for(rule), v->range, o.answer.cls);
    if (!shared.contains(key)) shared[key] = outcome_verdict(c, o, rule, tolerance_ulps, false, tolerance_ulps);
    if (const std::optional<OutcomeVerdict>& verdict = shared.at(key)) {
      if (verdict->at_range_end)
        entry["at_range_end"] = true;
      else
        add_verdict_fields(entry, *verdict, to_string(v->range));
    }
  }
  return out;
}

// Findings that can be shrunk: disagreements, plugin errors and crashes (each crash probe a fresh
// process, kCrashProbes at most: a process start costs milliseconds, a Python one 25).
bool is_shrinkable_failure(AnswerFailure f) { return !stops_variant(f) || f == AnswerFailure::crash; }
constexpr int kCrashProbes = 100;

// One finding as a replayable case line: shrunk for the variant that first disagreed, its
// `expect` from the oracle, how it was found in "found".
std::string finding_line(const Batch& b, const Finding& f, const std::vector<const Variant*>& variants,
                         const CampaignOptions& o, Oracle& oracle) {
  Case c;
  c.id = family_label(b.family, b.construction) + "/" + std::string(to_string(b.shape)) + "/" + std::to_string(o.seed) +
         "/" + std::to_string(f.index);
  c.ray = f.generated.ray;
  c.shape = f.generated.shape;
  const Case original = c;
  // A crash shrinks while a fresh copy of the code still dies on the case (probe: a new process
  // each, so fewer steps); a hang would cost --case-timeout a step and a protocol error
  // stops the code for good: those cases stay as found.
  const bool shrinkable = o.shrink && f.shrink && is_shrinkable_failure(f.failure);
  if (shrinkable)
    c = shrink(c, *f.first_disagreeing, oracle, o.rule, f.failure == AnswerFailure::crash ? kCrashProbes : 3000,
               f.failure);
  // `expect` keeps the case format's meaning, the nearest contact, whatever rule found the case
  // (found.rule says which): the finding replays green under `check`.
  const Verdict exact = oracle.judge(c.ray, c.shape, HitRule::nearest_contact);
  c.expect = Expectation{exact.cls, exact.t};
  c.found = {
      {"family", std::string(to_string(b.family))},
      {"construction", std::string(to_string(has_full_construction(b.family) ? b.construction : Construction::full))},
      {"seed", o.seed},
      {"index", f.index},
      {"detail", f.generated.detail},
      {"rule", std::string(to_string(o.rule))},
      {"disagreeing", disagreeing_answers(variants, oracle, c, o.rule, o.tolerance_ulps)}};
  // The finding's level: its variant's on the written (shrunk) case, as found where it is gone.
  const json& own = c.found["disagreeing"].contains(std::string(f.first_disagreeing->name))
                        ? c.found["disagreeing"][std::string(f.first_disagreeing->name)]
                        : json::object();
  c.found["level"] = own.contains("level") ? own["level"] : json(std::string(to_string(f.level)));
  // Asked again, external code may answer otherwise (a plugin error that comes and goes): the
  // finding still names the variant it was found for, never an empty disagreeing.
  if (c.found["disagreeing"].empty())
    c.found["disagreeing"][std::string(f.first_disagreeing->name)] = {
        {"error", f.failure != AnswerFailure::none ? std::string(to_string(f.failure))
                                                   : std::string("not reproduced when asked again")}};
  if (f.failure != AnswerFailure::none) {
    c.found["kind"] = is_plugin_error(f.failure) ? "plugin_error" : std::string(to_string(f.failure));
    c.found["variant"] = std::string(f.first_disagreeing->name);
    if (f.first_disagreeing->external) c.found["reason"] = f.first_disagreeing->external->last_failure();
    if (is_plugin_error(f.failure)) c.found["reason"] = std::string(to_string(f.failure));
    if (stops_variant(f.failure))
      c.found["disagreeing"][std::string(f.first_disagreeing->name)] = {{"error", c.found["kind"]}};
  }
  if (o.shrink && !is_shrinkable_failure(f.failure))
    c.found["not_shrunk"] = f.failure == AnswerFailure::timeout ? "each step would wait --case-timeout"
                                                                : "code that stopped cannot be asked again";
  else if (o.shrink && !f.shrink && f.failure == AnswerFailure::crash)
    c.found["not_shrunk"] =
        "one crash of " + std::string(f.first_disagreeing->name) + " is shrunk in this family and shape";
  else if (o.shrink && !f.shrink)
    c.found["not_shrunk"] =
        "beyond the " + std::to_string(o.max_shrunk) + " shrunk for " + f.kind + " in this family and shape";
  if (shrinkable) {
    c.found["shrunk_for"] = std::string(f.first_disagreeing->name);
    const json now = case_to_json(c), before = case_to_json(original);
    if (now["ray"] != before["ray"]) c.found["shrunk_from"] = before["ray"];
    if (now["shape"] != before["shape"]) c.found["shrunk_from_shape"] = before["shape"];
  }
  return json_text(case_to_json(c)) + "\n";
}

// Step 3: shrink and format the findings in parallel, returned in index order.
std::vector<std::string> shrink_and_format(const Batch& b, const std::vector<Finding>& findings,
                                           const std::vector<const Variant*>& variants, const CampaignOptions& o,
                                           std::vector<Worker>& workers) {
  std::vector<std::string> lines(findings.size());
  const int threads = static_cast<int>(workers.size());
  std::atomic<std::uint64_t> done{0};
  const std::uint64_t to_shrink =
      o.shrink ? static_cast<std::uint64_t>(
                     std::count_if(findings.begin(), findings.end(), [](const Finding& f) { return f.shrink; }))
               : 0;
  run_workers(threads, [&](int w) {
    for (size_t k = w; k < findings.size(); k += threads) {
      lines[k] = finding_line(b, findings[k], variants, o, workers[w].oracle);
      const std::uint64_t d = done += findings[k].shrink;
      if (w == 0 && o.shrink_progress && to_shrink > 0) o.shrink_progress(d, to_shrink);
    }
  });
  return lines;
}

}  // namespace

CampaignReport run_campaign(const CampaignOptions& o) {
  if (o.families.empty() || o.shapes.empty()) throw std::runtime_error("no family or shape chosen");
  if (o.shards == 0 || o.shard >= o.shards)
    throw std::runtime_error("shard " + std::to_string(o.shard) + " of " + std::to_string(o.shards) +
                             ": the index must be below the count");
  const std::string checkpoint_path = o.output + ".checkpoint";
  struct Pair {
    Family family;
    Construction construction;
    ShapeKind shape;
  };
  std::vector<Pair> pairs;  // family × construction × shape; random and near-origin have one construction
  for (Family f : o.families)
    for (Construction c : o.constructions) {
      if (c == Construction::full && !has_full_construction(f) && o.constructions.size() > 1) continue;
      for (ShapeKind s : o.shapes) pairs.push_back({f, c, s});
    }
  const auto [lo, hi] = shard_range(o);
  const std::uint64_t batch = std::max<std::uint64_t>(2, o.batch & ~std::uint64_t(1));
  const FindingsLock lock(o.output);
  std::ofstream out;
  Checkpoint cp = open_findings(o, checkpoint_path, out);
  std::vector<Worker> workers(std::max(1, o.threads));
  long batches_done = 0;
  Stopwatch since_checkpoint;  // (checkpoint_seconds; open_findings_file cuts findings back to it on resume)
  for (; cp.pair < pairs.size(); ++cp.pair, cp.pair_started = false, cp.findings_in_pair = 0,
                                            cp.rounding_findings_in_pair = 0, cp.shrunk_in_pair.clear()) {
    const auto [family, construction, shape] = pairs[cp.pair];
    std::vector<const Variant*> variants = variants_for(shape);
    std::erase_if(variants, [&](const Variant* v) {
      return o.variants.empty() ? v->is_oracle : std::find(o.variants.begin(), o.variants.end(), v) == o.variants.end();
    });
    const ReportKey pair_key{family_label(family, construction), std::string(to_string(shape))};
    if (!cp.pair_started) cp.next = lo, cp.pair_started = true;
    for (std::uint64_t start = cp.next; start < hi; start += batch) {
      const Batch b{family, construction, shape, start, std::min(hi, start + batch)};
      // Throughput counts generating and checking; shrinking findings is reported apart.
      const Stopwatch checking;
      Judged judged = judge_batch(b, variants, o, workers, cp.report);
      const double check_seconds = checking.seconds();
      count_shared_edge_holes(b, judged, variants, cp.report);
      // The cap keeps the file short, but never drops the finding that stopped external code (a
      // crash, a hang, a protocol error): it is that variant's last word and its replay.
      // Bugs and rounding-level findings each have --max-findings (verdicts.md §4: rounding
      // never crowds out a bug).
      {
        std::uint64_t room[2] = {o.max_findings - std::min(o.max_findings, cp.findings_in_pair),
                                 o.max_findings - std::min(o.max_findings, cp.rounding_findings_in_pair)};
        std::vector<Finding> kept;
        for (Finding& f : judged.findings) {
          std::uint64_t& left = room[f.level == Level::rounding];
          if (left > 0 || stops_variant(f.failure)) {
            left -= left > 0;
            (f.level == Level::rounding ? cp.rounding_findings_in_pair : cp.findings_in_pair) += 1;
            kept.push_back(std::move(f));
          }
        }
        judged.findings = std::move(kept);
      }
      // Shrink the first max_shrunk of each kind in this family and shape (in index order, so
      // the choice does not depend on threads), of crashes the first (each probe starts a
      // process); the rest are written as found.
      for (Finding& f : judged.findings) {
        std::uint64_t& shrunk = cp.shrunk_in_pair[f.kind];
        const std::uint64_t cap =
            f.failure == AnswerFailure::crash ? std::min<std::uint64_t>(1, o.max_shrunk) : o.max_shrunk;
        f.shrink = shrunk < cap && is_shrinkable_failure(f.failure);
        shrunk += f.shrink;
        cp.report.findings_unshrunk += !f.shrink || !o.shrink;
      }
      // Step 4: append the findings whole, then checkpoint what they complete.
      const Stopwatch shrinking;
      for (const std::string& line : shrink_and_format(b, judged.findings, variants, o, workers)) {
        out << line;
        cp.findings_hash.add(line);
      }
      out.flush();
      if (!out) throw std::runtime_error(o.output + ": write failed");
      cp.report.findings_written += judged.findings.size();
      if (o.crash_after_batches >= 0 && ++batches_done > o.crash_after_batches) std::_Exit(3);  // testing hook
      cp.report.cases[pair_key] += b.size();
      cp.report.seconds[pair_key] += check_seconds;
      cp.report.shrink_seconds[pair_key] += shrinking.seconds();
      cp.next = b.end;
      cp.findings_bytes = std::filesystem::file_size(o.output);
      if (b.end == hi || since_checkpoint.seconds() >= o.checkpoint_seconds) {
        save(checkpoint_path, o, cp);
        since_checkpoint = Stopwatch();
      }
      if (o.progress) o.progress(family, shape, b.end - lo, hi - lo);
    }
  }
  // Bugs first (verdicts.md §4), whether or not the checkpoint is kept: a kept one then describes
  // the rewritten file (same bytes, another order).
  out.close();
  rewrite_bugs_first(o.output);
  if (o.keep_checkpoint) {
    cp.findings_hash = FindingsHash{};
    std::ifstream again(o.output, std::ios::binary);
    std::stringstream bytes;
    bytes << again.rdbuf();
    cp.findings_hash.add(bytes.str());
    save(checkpoint_path, o, cp);
  } else {
    std::filesystem::remove(checkpoint_path);  // complete: nothing to resume
  }
  cp.report.shard_of = {campaign_identity(o), o.shard, o.shards};
  return cp.report;
}

void print_report(const CampaignReport& r, int threads, TableFormat format, std::ostream& out) {
  std::vector<TallyRow> rows;
  for (const auto& [k, t] : r.tallies) {
    rows.push_back({k.family, k.name, variant_of_tally(k.name).second, t});
  }
  std::vector<std::string> families;  // table order: each family, its full construction after it
  for (Family f : kAllFamilies)
    for (Construction c : {Construction::exact, Construction::full})
      if (c == Construction::exact || has_full_construction(f)) families.push_back(family_label(f, c));
  write_tally_table(std::move(rows), format, out, families);
  if (format == TableFormat::json) return;
  const json coverage = r.coverage();
  for (const auto& [name, c] : coverage.items())  // what no family found, per variant
    if (!c["never_found"].empty()) {
      out << "coverage " << name << ": never found";
      for (const json& kind : c["never_found"]) out << " " << kind.get<std::string>();
      out << "\n";
    }
  for (const auto& [k, seconds] : r.seconds) {
    const std::uint64_t n = r.cases.at(k);
    const auto shrinking = r.shrink_seconds.find(k);
    const double shrink = shrinking != r.shrink_seconds.end() ? shrinking->second : 0;
    out << "throughput " << k.family << "/" << k.name << ": " << n << " cases checked in " << std::fixed
        << std::setprecision(2) << seconds << " s, " << std::setprecision(0)
        << (seconds > 0 ? n / seconds / threads : 0) << " cases/s per core (" << threads_text(threads)
        << "); findings shrunk and written in " << std::setprecision(2) << shrink << " s\n"
        << std::defaultfloat;
  }
  if (r.findings_unshrunk > 0)
    out << "findings: " << r.findings_unshrunk << " of " << r.findings_written
        << " written as found (beyond --max-shrunk per family, shape and kind, or from code that stopped)\n";
}

}  // namespace rayproof::fuzz
