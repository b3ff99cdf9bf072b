#include "rayproof/fuzz/audit.h"

#include <sstream>

#include "rayproof/fuzz/generators.h"
#include "rayproof/fuzz/shrink.h"
#include "rayproof/verify/compare.h"
#include "rayproof/verify/report.h"

namespace rayproof {

namespace {

// The user's function seen as external code: answered in this process, in order.
class InProcess final : public ExternalIntersector {
 public:
  explicit InProcess(const UserIntersector& fn) : fn_(fn) {}
  void answer_all(std::span<const Query> qs, std::span<Answer> out, AnswerTiming*) override {
    for (size_t i = 0; i < qs.size(); ++i) out[i] = fn_(qs[i].ray, qs[i].shape);
  }

 private:
  const UserIntersector& fn_;
};

struct Auditor {
  Auditor(const UserIntersector& fn, ShapeKind shape, const AuditOptions& o) : adapter(fn), options(o) {
    report.name = o.name, report.shape = shape;
    variant = Variant{report.name, shape, "the function under audit", nullptr};
    variant.precision = o.precision;
    variant.external = &adapter;
    variant.origin = "in-process";
  }

  // Judges a chunk of queries; keeps the first disagreements as findings.
  void judge(const std::string& group, std::vector<Case>& chunk) {
    std::vector<Verdict> exact;
    for (const Case& c : chunk) exact.push_back(oracle.judge(c.ray, c.shape, options.rule));
    const std::vector<Query> queries(chunk.begin(), chunk.end());
    const std::vector<VariantOutcome> outcomes = judge_variant_all(oracle, variant, queries, exact, options.rule);
    Tally& tally = report.by_family[group];
    for (size_t i = 0; i < chunk.size(); ++i) {
      tally.add(exact[i].cls, outcomes[i]);
      const bool finding = outcomes[i].answer.failed() ? is_plugin_error(outcomes[i].answer.failure)
                                                       : outcomes[i].agreement != Agreement::agrees;
      if (finding && report.findings.size() < options.keep && shrinks < 4 * options.keep)
        keep(chunk[i], group, outcomes[i]);
    }
    chunk.clear();
  }

  // Shrinks a disagreement and keeps it, unless it shrinks to a case already kept (many cases of
  // one family shrink to the same few numbers: the same finding is never reported twice). A
  // shrunk case is another query than the one generated: it gets its own id, "ID/shrunk", and
  // names the one it came from.
  void keep(const Case& generated, const std::string& group, const VariantOutcome& outcome) {
    ++shrinks;
    Case c = fuzz::shrink(generated, variant, oracle, options.rule, 3000, outcome.answer.failure);
    const json query = case_to_json(c);
    for (const Case& k : report.findings) {
      const json kept = case_to_json(k);
      if (kept["ray"] == query["ray"] && kept["shape"] == query["shape"]) return;
    }
    const Verdict v = oracle.judge(c.ray, c.shape, HitRule::nearest_contact);
    c.expect = Expectation{v.cls, v.t};
    const Hit h = variant.intersect(c.ray, c.shape, options.rule);
    c.found = {{"audit", report.name}, {"group", group}, {"answer", std::string(to_string(h.cls))}};
    if (h.has_t()) c.found["t"] = hex_double(h.t);
    const json original = case_to_json(generated);
    if (original["ray"] != query["ray"] || original["shape"] != query["shape"]) {
      c.id = generated.id + "/shrunk";
      c.found["shrunk_from"] = generated.id;
    }
    report.findings.push_back(std::move(c));
  }

  AuditReport finish() {
    for (const auto& [group, t] : report.by_family) report.total.merge(t);
    return std::move(report);
  }

  InProcess adapter;
  AuditOptions options;
  Variant variant;
  Oracle oracle;
  AuditReport report;
  std::size_t shrinks = 0;  // bounded: findings that all shrink to one case stop being shrunk
};

constexpr size_t kChunk = 1024;

}  // namespace

AuditReport audit_function(const UserIntersector& fn, ShapeKind shape, const AuditOptions& options) {
  Auditor a(fn, shape, options);
  std::vector<fuzz::Family> families;
  std::stringstream list(options.families);
  for (std::string name; std::getline(list, name, ',');) {
    if (name == "all")
      families.assign(std::begin(fuzz::kAllFamilies), std::end(fuzz::kAllFamilies));
    else if (auto f = fuzz::family_from_string(name))
      families.push_back(*f);
    else if (!name.empty())
      throw std::invalid_argument("rayproof::audit: unknown family '" + name + "'");
  }
  for (fuzz::Family family : families) {
    const std::string group(to_string(family));
    std::vector<Case> chunk;
    for (std::uint64_t i = 0; i < options.count; ++i) {
      Case c;
      static_cast<Query&>(c) = fuzz::generate(family, shape, options.seed, i);
      c.id = group + "/" + std::string(to_string(shape)) + "/" + std::to_string(options.seed) + "/" + std::to_string(i);
      chunk.push_back(std::move(c));
      if (chunk.size() == kChunk) a.judge(group, chunk);
    }
    a.judge(group, chunk);
  }
  return a.finish();
}

AuditReport audit_case_file(const UserIntersector& fn, ShapeKind shape, const std::string& path,
                            const AuditOptions& options) {
  Auditor a(fn, shape, options);
  std::vector<Case> chunk;
  std::string errors;
  const bool opened = read_case_file(
      path,
      [&](const Case& c, long) {
        if (kind_of(c.shape) != shape) return;
        chunk.push_back(c);
        if (chunk.size() == kChunk) a.judge(path, chunk);
      },
      [&](const CaseError& e) { errors += e.to_string() + "\n"; });
  if (!opened || !errors.empty()) throw std::runtime_error("rayproof::audit: " + errors);
  a.judge(path, chunk);
  return a.finish();
}

std::string AuditReport::summary() const {
  std::ostringstream out;
  std::vector<TallyRow> rows;
  for (const auto& [group, t] : by_family) rows.push_back({group, name, shape, t});
  write_tally_table(std::move(rows), TableFormat::table, out);
  for (const Case& c : findings) out << json_text(case_to_json(c)) << "\n";
  return out.str();
}

}  // namespace rayproof
