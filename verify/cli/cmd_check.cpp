// rayproof check FILE...: the exact verdict and every variant's class, t, ULP error and
// agreement, one JSON line per case; the per-variant summary on stderr.
#include <iostream>
#include <memory>

#include "cli/commands.h"
#include "rayproof/atomic_file.h"
#include "rayproof/compare.h"

namespace rayproof::cli {

void print_oracle_stats(std::ostream& out, const Oracle& oracle) {
  out << "oracle: ";
  bool first = true;
  for (ShapeKind k : kAllShapeKinds) {
    const OracleStats& s = oracle.stats(k);
    if (s.queries == 0) continue;
    out << (first ? "" : "\n        ") << to_string(k) << ": " << s.queries << " queries; class beyond the interval filter "
        << s.class_expansion + s.class_exact << " (rationals " << s.class_exact << "); t rounded " << s.rounding.rounded
        << " (rationals " << s.rounding.rational << ", exact midpoint test " << s.rounding.exact_fallbacks << ")";
    first = false;
  }
  out << "\n";
}

json oracle_stats_json(const Oracle& oracle) {
  json j = json::object();
  for (ShapeKind k : kAllShapeKinds) {
    const OracleStats& s = oracle.stats(k);
    j[std::string(to_string(k))] = {{"queries", s.queries},
                                    {"class_expansion", s.class_expansion},
                                    {"class_exact", s.class_exact},
                                    {"t_rounded", s.rounding.rounded},
                                    {"t_rational", s.rounding.rational},
                                    {"t_exact_fallbacks", s.rounding.exact_fallbacks}};
  }
  return j;
}

void add_check_command(CLI::App& app, int& exit_code) {
  struct Options {
    std::vector<std::string> files, variants;
    std::string rule = "nearest", summary, output;
    bool exact_only = false;
  };
  auto opts = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("check", "Judge variants against the exact oracle (JSON lines; summary on stderr)");
  cmd->add_option("files", opts->files, "case files (JSON Lines, shared/spec/cases.md)")->required();
  cmd->add_option("--variants", opts->variants, "variants to judge, comma separated (default: all)");
  cmd->add_option("--rule", opts->rule, "hit rule")->check(CLI::IsMember({"nearest", "enter-only"}));
  cmd->add_option("--summary", opts->summary, "also write the summary as JSON to this file");
  cmd->add_option("-o,--output", opts->output, "write the per-case lines here (atomically) instead of stdout");
  cmd->add_flag("--exact-only", opts->exact_only, "skip the interval filter (decide every class in rationals)");
  cmd->callback([opts, &exit_code] {
    const auto variants = resolve_variants(opts->variants);
    const HitRule rule = *hit_rule_from_string(opts->rule);
    Oracle oracle(Oracle::Options{!opts->exact_only});
    CheckSummary summary;
    std::unique_ptr<AtomicFile> file;
    if (!opts->output.empty()) file = std::make_unique<AtomicFile>(opts->output);
    std::ostream& out = file ? file->stream() : std::cout;
    long cases = 0, unreadable = 0, oracle_disagreements = 0;
    Progress progress("check");
    for (const std::string& path : opts->files) {
      long in_file = 0, errors_before = unreadable;
      read_case_file(
          path,
          [&](const Case& c, long line) {
            ++cases, ++in_file;
            const Verdict exact = oracle.judge(c.ray, c.shape, rule);
            std::vector<VariantOutcome> outcomes;
            for (const Variant* v : variants)
              if (v->shape == kind_of(c.shape)) outcomes.push_back(compare_variant(*v, exact, c.ray, c.shape, rule));
            summary.add(exact, outcomes);
            out << check_line(c.id, exact, outcomes).dump() << "\n";
            if (c.expect && rule == HitRule::nearest_contact) {
              const std::string why = expectation_mismatch(*c.expect, exact);
              if (!why.empty()) {
                ++oracle_disagreements;
                std::cerr << "rayproof: " << path << ":" << line << ": case '" << c.id << "': " << why << "\n";
              }
            }
            progress.update(cases, 0);
          },
          [&](const CaseError& e) {
            ++unreadable;
            std::cerr << "rayproof: " << e.to_string() << "\n";
          });
      if (in_file == 0 && unreadable == errors_before) {
        ++unreadable;
        std::cerr << "rayproof: " << path << ": no cases in file\n";
      }
    }
    progress.finish();
    if (file) file->commit();
    else std::cout.flush();
    summary.print_table(std::cerr);
    print_oracle_stats(std::cerr, oracle);
    std::cerr << "rayproof check: " << cases << " cases, " << unreadable << " unreadable, " << oracle_disagreements
              << " expectations contradicted by the exact oracle\n";
    if (!opts->summary.empty()) {
      AtomicFile s(opts->summary);
      s.stream() << json{{"cases", cases},
                         {"unreadable", unreadable},
                         {"expect_disagreements", oracle_disagreements},
                         {"rule", opts->rule},
                         {"variants", summary.to_json()},
                         {"oracle", oracle_stats_json(oracle)}}
                        .dump(2)
                 << "\n";
      s.commit();
    }
    exit_code = (unreadable > 0 || oracle_disagreements > 0) ? 1 : 0;
  });
}

}  // namespace rayproof::cli
