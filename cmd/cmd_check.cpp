// rayproof check FILE...: the exact verdict and every variant's class, t, ULP error and
// agreement, one JSON line per case; the per-variant summary on stderr.
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>

#include "commands.h"
#include "rayproof/core/atomic_file.h"
#include "rayproof/verify/compare.h"
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

void print_summary_table(const CheckSummary& summary, TableFormat format, std::ostream& out) {
  std::vector<TallyRow> rows;
  for (const auto& [name, entry] : summary) rows.push_back({"", name, entry.first, entry.second});
  write_tally_table(std::move(rows), format, out);
}

json summary_json(const CheckSummary& summary) {
  json j = json::object();
  for (const auto& [name, entry] : summary) {
    const auto& [shape, t] = entry;
    j[name] = {{"shape", std::string(to_string(shape))},
               {"cases", t.cases},
               {"agree", t.agree},
               {"wrong", t.wrong},
               {"cannot_tell", t.cannot_tell},
               {"disagreements", t.confusion},
               {"ulp", {{"count", t.ulps.count()},
                        {"median", t.ulps.quantile(0.5)},
                        {"p99", t.ulps.quantile(0.99)},
                        {"max", t.ulps.max()}}},
               {"bits", bits_json(t)}};
  }
  return j;
}

void print_oracle_stats(std::ostream& out, const Oracle& oracle) {
  out << "oracle: ";
  bool first = true;
  for (ShapeKind k : kAllShapeKinds) {
    const OracleStats& s = oracle.stats(k);
    if (s.queries == 0) continue;
    const std::uint64_t beyond_static = s.class_interval + s.class_expansion + s.class_exact;
    out << (first ? "" : "\n        ") << to_string(k) << ": " << s.queries << " queries; class beyond the static filter "
        << beyond_static << " (intervals " << s.class_interval << ", expansions " << s.class_expansion << ", rationals "
        << s.class_exact << "); t rounded " << s.rounding.rounded << " (expansions " << s.rounding.expansion
        << ", rationals " << s.rounding.rational << ", exact midpoint test " << s.rounding.exact_fallbacks << ")";
    first = false;
  }
  out << "\n";
}

json oracle_stats_json(const Oracle& oracle) {
  json j = json::object();
  for (ShapeKind k : kAllShapeKinds) {
    const OracleStats& s = oracle.stats(k);
    j[std::string(to_string(k))] = {{"queries", s.queries},
                                    {"class_interval", s.class_interval},
                                    {"class_expansion", s.class_expansion},
                                    {"class_exact", s.class_exact},
                                    {"t_rounded", s.rounding.rounded},
                                    {"t_expansion", s.rounding.expansion},
                                    {"t_rational", s.rounding.rational},
                                    {"t_exact_fallbacks", s.rounding.exact_fallbacks}};
  }
  return j;
}


struct CheckOptions {
  std::vector<std::string> files, variants, shapes;
  std::string rule = "nearest", summary, output, format = "table";
  bool exact_only = false;
};

struct CheckRun {
  std::vector<const Variant*> variants;
  HitRule rule;
  Oracle oracle;
  CheckSummary summary;
  long cases = 0, unreadable = 0, contradicted = 0;  // contradicted: an `expect` the oracle refutes
  long unopened = 0;                                 // files that could not be read at all
};

// One file's cases: a result line each on `out`, tallied; bad lines and refuted expectations
// reported on stderr and counted.
void check_file(const std::string& path, CheckRun& run, std::ostream& out, Progress& progress) {
  long in_file = 0;
  const long errors_before = run.unreadable;
  const bool opened = read_case_file(
      path,
      [&](const Case& c, long line) {
        ++run.cases, ++in_file;
        const Verdict exact = run.oracle.judge(c.ray, c.shape, run.rule);
        std::vector<VariantOutcome> outcomes;
        for (const Variant* v : run.variants)
          if (v->shape == kind_of(c.shape)) outcomes.push_back(compare_variant(*v, exact, c.ray, c.shape, run.rule));
        add_to_summary(run.summary, exact, outcomes);
        out << check_line(c.id, exact, outcomes).dump() << "\n";
        if (c.expect && run.rule == HitRule::nearest_contact) {
          const std::string why = expectation_mismatch(*c.expect, exact);
          if (!why.empty()) {
            ++run.contradicted;
            std::cerr << "rayproof: " << printable(path) << ":" << line << ": case '" << printable(c.id) << "': " << why << "\n";
          }
        }
        progress.update(run.cases, 0);
      },
      [&](const CaseError& e) {
        ++run.unreadable;
        std::cerr << "rayproof: " << e.to_string() << "\n";
      });
  if (!opened) ++run.unopened;
  if (opened && in_file == 0 && run.unreadable == errors_before) {
    ++run.unreadable;
    std::cerr << "rayproof: " << printable(path) << ": no cases in file\n";
  }
}

int run_check(const CheckOptions& opts) {
  CheckRun run{parse_variants(opts.variants, parse_shapes(opts.shapes)), parse_rule(opts.rule),
               Oracle(Oracle::Options{!opts.exact_only})};
  refuse_output_over_input(opts.output, opts.files);
  refuse_output_over_input(opts.summary, opts.files);
  std::unique_ptr<AtomicFile> file, summary_file;  // opened before the work, so a bad path fails first
  if (!opts.output.empty()) file = std::make_unique<AtomicFile>(opts.output);
  if (!opts.summary.empty()) summary_file = std::make_unique<AtomicFile>(opts.summary);
  std::ostream& out = file ? file->stream() : std::cout;
  Progress progress("check");
  for (const std::string& path : opts.files) check_file(path, run, out, progress);
  progress.finish();
  if (file) file->commit();
  else std::cout.flush();
  print_summary_table(run.summary, *table_format_from_string(opts.format), std::cerr);
  print_oracle_stats(std::cerr, run.oracle);
  std::cerr << "rayproof check: " << run.cases << " cases, " << run.unreadable << " unreadable, " << run.contradicted
            << " expectations contradicted by the exact oracle\n";
  if (summary_file) {
    AtomicFile& s = *summary_file;
    s.stream() << json{{"cases", run.cases},
                       {"unreadable", run.unreadable},
                       {"expect_disagreements", run.contradicted},
                       {"rule", opts.rule},
                       {"variants", summary_json(run.summary)},
                       {"oracle", oracle_stats_json(run.oracle)}}
                      .dump(2)
               << "\n";
    s.commit();
  }
  if (run.unopened > 0) return 2;
  return (run.unreadable > 0 || run.contradicted > 0) ? 1 : 0;
}

}  // namespace

void add_check_command(CLI::App& app, int& exit_code) {
  auto opts = std::make_shared<CheckOptions>();
  auto* cmd = app.add_subcommand("check", "Judge variants against the exact oracle (JSON lines; summary on stderr)");
  cmd->add_option("files", opts->files, "case files (JSON Lines, docs/spec/cases.md)")->required();
  add_variants_flag(cmd, opts->variants);
  add_shapes_flag(cmd, opts->shapes);
  add_rule_flag(cmd, opts->rule);
  cmd->add_option("--summary", opts->summary, "also write the summary as JSON to this file");
  cmd->add_option("-o,--output", opts->output, "write the per-case lines here (atomically) instead of stdout");
  add_format_flag(cmd, opts->format);
  cmd->add_flag("--exact-only", opts->exact_only, "skip the interval filter (decide every class in rationals)");
  cmd->callback([opts, &exit_code] { exit_code = run_check(*opts); });
}

}  // namespace rayproof::cli
