// rayproof check FILE...: the exact verdict and every variant's class, t, ULP error and
// agreement, one JSON line per case; the per-variant summary on stderr.
#include <algorithm>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <set>

#include "commands.h"
#include "rayproof/core/atomic_file.h"
#include "rayproof/peers/external.h"
#include "rayproof/core/mesh_case.h"
#include "rayproof/verify/tracer_judge.h"
#include "rayproof/verify/backward_error.h"
#include "rayproof/verify/compare.h"
#include "rayproof/verify/mesh_truth.h"
#include "rayproof/verify/report.h"
#include "rayproof/verify/tally.h"

namespace rayproof::cli {

namespace {

// Per variant (by name, with its shape): one Tally.
using CheckSummary = std::map<std::string, std::pair<ShapeKind, Tally>>;

void add_to_summary(CheckSummary& summary, const Verdict& exact, const std::vector<VariantOutcome>& outcomes) {
  for (const VariantOutcome& o : outcomes) {
    auto& [shape, tally] = summary[std::string(o.variant->name)];
    shape = o.variant->shape;
    tally.add(exact.cls, o);
  }
}

std::vector<TallyRow> summary_rows(const CheckSummary& summary) {
  std::vector<TallyRow> rows;
  for (const auto& [name, entry] : summary) rows.push_back({"", name, entry.first, entry.second});
  return rows;
}

json summary_json(const CheckSummary& summary) {
  json j = json::object();
  for (const auto& [name, entry] : summary) {
    j[name] = check_summary_json(entry.first, entry.second);
  }
  return j;
}

// Nothing when the oracle answered no query (a run of mesh cases only).
void print_oracle_stats(std::ostream& out, const Oracle& oracle) {
  bool first = true;
  for (ShapeKind k : kAllShapeKinds) {
    const OracleStats& s = oracle.stats(k);
    if (s.queries == 0) continue;
    out << (first ? "oracle: " : "\n        ") << to_string(k) << ": " << s.describe();
    first = false;
  }
  if (!first) out << "\n";
}

json oracle_stats_json(const Oracle& oracle) {
  json j = json::object();
  for (ShapeKind k : kAllShapeKinds) {
    j[std::string(to_string(k))] = oracle.stats(k).to_json();
  }
  return j;
}

struct CheckOptions {
  std::vector<std::string> files, variants, shapes;
  std::string rule = "nearest", summary, output, format = "table";
  bool exact_only = false;
  ExternalFlags ext;
  TracerFlags tracer_flags;
  std::vector<std::string> answers;  // NAME=FILE
  std::vector<std::string> ids;      // only these cases (--id)
};

struct CheckRun {
  std::vector<const Variant*> variants;
  HitRule rule;
  Oracle oracle;
  CheckSummary summary;
  long cases = 0, unreadable = 0, contradicted = 0;  // contradicted: an `expect` the oracle refutes
  long unopened = 0;                                 // files that could not be read at all
  long stopped = 0;                                  // external variants stopped by a crash, timeout or protocol error
  std::vector<const Tracer*> tracers;                // judged on mesh cases
  std::map<std::string, std::map<std::string, long>> tracer_kinds;  // tracer → kind → cases
  long mesh_cases = 0;
  double case_timeout = 10;  // --case-timeout: also the oracle's budget on one mesh case
  long oracle_timeouts = 0;  // mesh cases not judged: the oracle ran past the budget
  double tolerance_ulps = kDefaultToleranceUlps;
  std::string fail_on = "none";
  long failing = 0;                                                  // tracer outcomes --fail-on counts
  std::map<std::string, std::map<std::string, long>> tracer_levels;  // tracer → bug/rounding → disagreements
  std::vector<ShapeKind> shapes;  // --shapes: an --exec command (every shape) gets only these
  std::set<std::string> ids;      // --id: only these cases are judged
  std::set<std::string> ids_seen;
  std::vector<Disagreement> disagreements;  // for the examples and hints after the table (bounded)
  static constexpr std::size_t kMaxKept = 50000;
};

// A mesh case (docs/spec/tracer.md): every chosen tracer on it, as it sees it (float tracers: the
// case rounded to float), judged against the oracle's truth over the mesh. First everything is
// judged, within the oracle's budget (--case-timeout): a case the oracle cannot finish in it is
// not judged, and nothing of it is written or counted; then it is counted and written.
void judge_mesh_case(const std::string& path, long line, const MeshCase& c, CheckRun& run, std::ostream& out) {
  ++run.mesh_cases;
  json expect;
  std::vector<std::optional<TracerOutcome>> outcomes;  // nullopt: not representable for that tracer
  try {
    const ScopedOracleBudget budget(run.case_timeout);
    MeshOracle oracle(c.mesh);
    expect = expect_json(oracle, c.ray);
    for (const Tracer* t : run.tracers) {
      const auto seen = as_seen_by(*t, c);
      if (!seen) {
        outcomes.emplace_back();
        continue;
      }
      VerdictSettings settings{run.tolerance_ulps, std::nullopt};
      if (c.found.is_object() && c.found.contains("range"))  // replayed as found (checked when read)
        settings.range = range_rule_from_string(c.found.at("range").get<std::string>());
      outcomes.emplace_back(judge_tracer_on_case(*t, *seen, settings));
    }
  } catch (const OracleTimeout& e) {
    ++run.oracle_timeouts;
    std::cerr << "rayproof: " << printable(path) << ":" << line << ": case '" << printable(c.id)
              << "': not judged: " << e.what() << "\n";
    return;
  }
  nlohmann::ordered_json result;
  result["id"] = c.id;
  result["expect"] = expect;
  if (c.all) result["all"] = true;
  nlohmann::ordered_json tracers = nlohmann::ordered_json::object();
  for (std::size_t i = 0; i < run.tracers.size(); ++i) {
    const Tracer* t = run.tracers[i];
    if (!outcomes[i]) {
      tracers[t->name] = {{"skipped", "not_representable"}};
      ++run.tracer_kinds[t->name]["not_representable"];
      continue;
    }
    const TracerOutcome& o = *outcomes[i];
    if (is_disagreement(o.kind)) ++run.tracer_levels[t->name][std::string(to_string(o.level))];
    if (fails_on(run.fail_on, o.kind, o.level)) ++run.failing;
    tracers[t->name] = check_entry(o, c.all);
    ++run.tracer_kinds[t->name][std::string(to_string(o.kind))];
    if (o.kind == TraceKind::crash || o.kind == TraceKind::timeout || o.kind == TraceKind::out_of_memory) {
      ++run.stopped;
      std::cerr << "rayproof: " << printable(path) << ":" << line << ": case '" << printable(c.id) << "': tracer "
                << t->name << " stopped: " << to_string(o.kind) << " (" << o.reason << ")\n";
    }
  }
  result["tracers"] = tracers;
  out << json_text(result) << "\n";
  if (c.expect.is_null()) return;
  for (const char* key : {"touched", "nearest", "t"})
    if (c.expect.contains(key) && c.expect.at(key) != expect.at(key)) {
      ++run.contradicted;
      std::cerr << "rayproof: " << printable(path) << ":" << line << ": case '" << printable(c.id) << "': expect."
                << key << " is " << c.expect.at(key).dump() << ", the exact oracle says " << expect.at(key).dump()
                << "\n";
    }
}

// verdicts.md for each variant's answer on one case: the level and β of a disagreement (counted
// in the variant's tally, and by --fail-on), the β of a t that is not correctly rounded, each
// with its witness in the check line's entry.
void add_levels(const Case& c, const Verdict& exact, const std::vector<VariantOutcome>& outcomes, CheckRun& run,
                nlohmann::ordered_json& line) {
  for (const VariantOutcome& o : outcomes) {
    Tally& tally = run.summary[std::string(o.variant->name)].second;
    tally.tolerance_ulps = run.tolerance_ulps;
    const auto v = outcome_verdict(c, o, run.rule, run.tolerance_ulps, true);
    if (!v) continue;
    nlohmann::ordered_json& entry = line["variants"][std::string(o.variant->name)];
    if (v->at_range_end) {
      ++tally.at_range_end;
      entry["at_range_end"] = true;
      continue;
    }
    add_verdict_fields(entry, *v, to_string(o.variant->range));
    if (v->of_t) continue;
    const DisagreementKind kind{o.own_exact ? o.own_exact->cls : exact.cls, o.answer.cls};
    tally.add_level(kind, v->level == Level::bug, beta_bucket(v->beta));
    if (run.fail_on == "rounding" || (run.fail_on == "bug" && v->level == Level::bug)) ++run.failing;
  }
}

// A chunk of cases read but not yet judged: judged together, so each variant (external code
// behind a process boundary above all) is asked once per chunk instead of once per case.
struct PendingCase {
  Case c;
  long line;
};
constexpr size_t kCheckChunk = 1024;

void judge_chunk(const std::string& path, std::vector<PendingCase>& pending, CheckRun& run, std::ostream& out) {
  std::vector<Verdict> exact;
  for (const PendingCase& p : pending) exact.push_back(run.oracle.judge(p.c.ray, p.c.shape, run.rule));
  std::vector<std::vector<VariantOutcome>> outcomes(pending.size());
  for (const Variant* v : run.variants) {
    std::vector<Query> queries;  // this variant's shape only
    std::vector<Verdict> truth;
    std::vector<size_t> where;
    for (size_t i = 0; i < pending.size(); ++i)
      if (v->handles(kind_of(pending[i].c.shape)) &&
          (!v->all_shapes || std::count(run.shapes.begin(), run.shapes.end(), kind_of(pending[i].c.shape)) > 0))
        queries.push_back(pending[i].c), truth.push_back(exact[i]), where.push_back(i);
    if (queries.empty()) continue;
    std::vector<VariantOutcome> judged = judge_variant_all(run.oracle, *v, queries, truth, run.rule);
    for (size_t k = 0; k < judged.size(); ++k) {
      if (stops_variant(judged[k].answer.failure) && ++run.stopped)
        std::cerr << "rayproof: " << printable(path) << ":" << pending[where[k]].line << ": case '"
                  << printable(pending[where[k]].c.id) << "': variant " << v->name << ": "
                  << to_string(judged[k].answer.failure)
                  << (v->external ? " (" + v->external->last_failure() + ")" : std::string()) << "\n";
      outcomes[where[k]].push_back(std::move(judged[k]));
    }
  }
  for (size_t i = 0; i < pending.size(); ++i) {
    const Case& c = pending[i].c;
    for (const VariantOutcome& o : outcomes[i]) {  // kept for the examples and hints after the table
      if (run.disagreements.size() >= CheckRun::kMaxKept || !o.variant) break;
      const bool failed = o.answer.failed();
      if (failed ? (o.answer.failure == AnswerFailure::stopped || o.answer.failure == AnswerFailure::not_representable)
                 : o.agreement == Agreement::agrees)
        continue;
      Disagreement d;
      d.variant = std::string(o.variant->name), d.c = c, d.file = path;
      d.exact = o.own_exact ? o.own_exact->cls : exact[i].cls;
      d.exact_t = o.own_exact ? o.own_exact->t : exact[i].t;
      if (failed)
        d.failure = is_plugin_error(o.answer.failure) ? "plugin_error" : std::string(to_string(o.answer.failure));
      else
        d.answered = o.answer.cls, d.answered_t = o.answer.has_t() ? std::optional<double>(o.answer.t) : std::nullopt;
      run.disagreements.push_back(std::move(d));
    }
    add_to_summary(run.summary, exact[i], outcomes[i]);
    nlohmann::ordered_json line = check_line(c.id, exact[i], outcomes[i]);
    add_levels(c, exact[i], outcomes[i], run, line);
    out << json_text(line) << "\n";
    if (c.expect && run.rule == HitRule::nearest_contact) {
      const std::string why = expectation_mismatch(*c.expect, exact[i]);
      if (!why.empty()) {
        ++run.contradicted;
        std::cerr << "rayproof: " << printable(path) << ":" << pending[i].line << ": case '" << printable(c.id)
                  << "': " << why << "\n";
      }
    }
  }
  pending.clear();
}

// One file's cases: a result line each on `out`, tallied; bad lines and refuted expectations
// reported on stderr and counted.
void check_file(const std::string& path, CheckRun& run, std::ostream& out, Progress& progress) {
  long in_file = 0;
  const long errors_before = run.unreadable;
  std::vector<PendingCase> pending;
  const bool opened = read_case_file(
      path,
      [&](const Case& c, long line) {
        if (!run.ids.empty()) {  // --id: only those cases (nothing per case without it)
          if (!run.ids.count(c.id)) return;
          run.ids_seen.insert(c.id);
        }
        ++run.cases, ++in_file;
        pending.push_back({c, line});
        if (pending.size() == kCheckChunk) judge_chunk(path, pending, run, out);
        progress.update(run.cases, 0);
      },
      [&](const CaseError& e) {
        ++run.unreadable;
        std::cerr << "rayproof: " << e.to_string() << "\n";
      },
      [&](const MeshCase& c, long line) {
        if (!run.ids.empty()) {  // --id: only those cases (nothing per case without it)
          if (!run.ids.count(c.id)) return;
          run.ids_seen.insert(c.id);
        }
        // found.range (verdicts.md): a finding replays under the range it was found with.
        if (c.found.is_object() && c.found.contains("range") &&
            !(c.found.at("range").is_string() && range_rule_from_string(c.found.at("range").get<std::string>()))) {
          ++run.unreadable;
          std::cerr << "rayproof: "
                    << CaseError{path, line, "found.range", "expected \"open\" or \"closed\""}.to_string() << "\n";
          return;
        }
        ++run.cases, ++in_file;
        judge_mesh_case(path, line, c, run, out);
        progress.update(run.cases, 0);
      });
  judge_chunk(path, pending, run, out);
  if (!opened) ++run.unopened;
  if (opened && in_file == 0 && run.unreadable == errors_before && run.ids.empty()) {
    ++run.unreadable;
    std::cerr << "rayproof: " << printable(path) << ": no cases in file\n";
  }
}

int run_check(const CheckOptions& opts) {
  load_externals(opts.ext);
  load_tracers(opts.tracer_flags, opts.ext.case_timeout);
  std::vector<const Variant*> answers;
  for (const std::string& text : opts.answers) {
    const auto [name, path] = peers::split_assignment("--answers", text);
    answers.push_back(&peers::add_answers_variant(name, path));
  }
  CheckRun run{parse_variants(opts.variants, parse_shapes(opts.shapes)), parse_rule(opts.rule),
               Oracle(Oracle::Options{!opts.exact_only})};
  run.tracers = parse_tracers(opts.tracer_flags.names);
  run.tolerance_ulps = opts.tracer_flags.tolerance_ulps;
  run.case_timeout = opts.ext.case_timeout;
  run.fail_on = opts.tracer_flags.fail_on;
  run.ids.insert(opts.ids.begin(), opts.ids.end());
  run.shapes = parse_shapes(opts.shapes);
  refuse_output_over_input(opts.output, [&] {
    std::vector<std::string> inputs = opts.files;
    for (const std::string& a : opts.answers) inputs.push_back(peers::split_assignment("--answers", a).second);
    return inputs;
  }());
  refuse_output_over_input(opts.summary, opts.files);
  std::unique_ptr<AtomicFile> file, summary_file;  // opened before the work, so a bad path fails first
  if (!opts.output.empty()) file = std::make_unique<AtomicFile>(opts.output);
  if (!opts.summary.empty()) summary_file = std::make_unique<AtomicFile>(opts.summary);
  std::ostream& out = file ? file->stream() : std::cout;
  Progress progress("check");
  for (const std::string& path : opts.files) check_file(path, run, out, progress);
  progress.finish();
  if (file)
    file->commit();
  else
    std::cout.flush();
  if (opts.format == "json") {  // one JSON array and nothing else: the variants' rows, then the tracers'
    json all = tally_table_json(summary_rows(run.summary));
    for (const auto& [name, kinds] : run.tracer_kinds) {
      json row{{"tracer", name}, {"shape", "mesh"}, {"kinds", kinds}};
      if (run.tracer_levels.contains(name)) row["levels"] = run.tracer_levels.at(name);
      all.push_back(row);
    }
    std::cerr << json_text(all, 2) << "\n";
  } else {
    write_tally_table(summary_rows(run.summary), *table_format_from_string(opts.format), std::cerr);
    for (const auto& [name, kinds] : run.tracer_kinds) {  // mesh cases: one line per tracer
      std::cerr << "tracer " << name << ":";
      for (const auto& [kind, n] : kinds) std::cerr << " " << kind << " " << n;
      if (run.tracer_levels.contains(name))
        for (const auto& [level, n] : run.tracer_levels.at(name)) std::cerr << " (" << level << "-level " << n << ")";
      std::cerr << "\n";
    }
    print_digest(std::cerr, run.disagreements, run.variants);
    print_oracle_stats(std::cerr, run.oracle);
  }
  for (const std::string& id : run.ids)
    if (!run.ids_seen.count(id))
      ++run.unreadable, std::cerr << "rayproof: --id " << printable(id) << ": no case has this id\n";
  for (const Variant* v : run.variants)
    if (v->external && !v->external->stop_reason().empty())
      std::cerr << "rayproof check: variant " << v->name << " stopped (" << v->external->stop_reason()
                << "); its later cases say \"stopped\"\n";
  if (opts.format != "json")  // JSON readers get the counts from --summary
    std::cerr << "rayproof check: " << run.cases << " cases, " << run.unreadable << " unreadable, " << run.contradicted
              << " expectations contradicted by the exact oracle\n";
  if (summary_file) {
    AtomicFile& s = *summary_file;
    s.stream() << json_text(json{{"cases", run.cases},
                                 {"unreadable", run.unreadable},
                                 {"expect_disagreements", run.contradicted},
                                 {"rule", opts.rule},
                                 {"variants", summary_json(run.summary)},
                                 {"mesh_cases", run.mesh_cases},
                                 {"oracle_timeouts", run.oracle_timeouts},
                                 {"tracers", run.tracer_kinds},
                                 {"tracer_levels", run.tracer_levels},
                                 {"tolerance_ulps", run.tolerance_ulps},
                                 {"oracle", oracle_stats_json(run.oracle)}},
                            2)
               << "\n";
    s.commit();
  }
  long answer_problems = 0;  // after the summary, so they are the last thing a user reads
  for (const Variant* v : answers)
    for (const std::string& problem : peers::answers_problems(*v))
      ++answer_problems, std::cerr << "rayproof: " << problem << "\n";
  if (run.unopened > 0) return 2;
  if (run.failing > 0)
    std::cerr << "rayproof check: --fail-on " << run.fail_on << ": " << run.failing
              << " variant and tracer outcomes fail\n";
  return (run.unreadable > 0 || run.contradicted > 0 || answer_problems > 0 || run.stopped > 0 || run.failing > 0 ||
          run.oracle_timeouts > 0)
             ? 1
             : 0;
}

}  // namespace

void add_check_command(CLI::App& app, int& exit_code) {
  auto opts = std::make_shared<CheckOptions>();
  auto* cmd = app.add_subcommand("check", "Judge variants against the exact oracle (JSON lines; summary on stderr)");
  cmd->add_option("files", opts->files, "case files (JSON Lines, docs/spec/cases.md)")->required();
  add_variants_flag(cmd, opts->variants);
  add_shapes_flag(cmd, opts->shapes);
  add_rule_flag(cmd, opts->rule);
  add_external_flags(cmd, opts->ext);
  add_tracer_flags(cmd, opts->tracer_flags);
  cmd->add_option("--answers", opts->answers,
                  "NAME=FILE: answers your own program wrote for the cases (plugin.md); repeatable");
  cmd->add_option("--summary", opts->summary, "also write the summary as JSON to this file");
  cmd->add_option("-o,--output", opts->output, "write the per-case lines here (atomically) instead of stdout");
  add_format_flag(cmd, opts->format);
  cmd->add_flag("--exact-only", opts->exact_only, "skip the interval filter (decide every class in rationals)");
  cmd->add_option("--id", opts->ids,
                  "judge only the case with this id (repeatable): how fuzz and check replay one example");
  cmd->callback([opts, &exit_code] { exit_code = run_check(*opts); });
}

}  // namespace rayproof::cli
