// rayproof fuzz: every variant against the oracle on generated families; findings replayable.
#include <algorithm>
#include <iostream>
#include <mutex>
#include <sstream>
#include <thread>

#include "cli/commands.h"
#include "rayproof/atomic_file.h"
#include "rayproof/campaign.h"

namespace rayproof::cli {

void add_fuzz_command(CLI::App& app, int& exit_code) {
  struct Options {
    std::vector<std::string> families{"all"}, shapes{"all"};
    std::string shard = "0/1", output, rule = "nearest", summary;
    std::uint64_t count = 100000, seed = 1, max_findings = 1000, batch = 8192;
    int threads = 0;
    bool resume = false, no_shrink = false;
    long crash_after = -1;
  };
  auto opts = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("fuzz", "Hunt for disagreements between the variants and the exact oracle");
  cmd->add_option("--family", opts->families,
                  "families, comma separated: random, tangent, grazing, near-origin, exit-entry, extremes, all");
  cmd->add_option("--shape", opts->shapes, "shapes, comma separated: sphere, plane, triangle, box, all");
  cmd->add_option("--count", opts->count, "cases per family and shape (before sharding)")->check(CLI::Range(std::uint64_t(1), std::uint64_t(1) << 50));
  cmd->add_option("--seed", opts->seed, "campaign seed: the same seed, count and shard give the same cases anywhere");
  cmd->add_option("--shard", opts->shard, "this run's share, i/n (0-based)");
  cmd->add_option("--threads", opts->threads, "worker threads (default: all cores)")->check(CLI::Range(0, 256));
  cmd->add_option("-o,--output", opts->output, "findings (JSON Lines, replayable by rayproof check)")->required();
  cmd->add_flag("--resume", opts->resume, "continue from OUTPUT.checkpoint after the last completed batch");
  cmd->add_flag("--no-shrink", opts->no_shrink, "write findings as found, without shrinking");
  cmd->add_option("--max-findings", opts->max_findings, "findings written per family and shape (all are counted)");
  cmd->add_option("--batch", opts->batch, "cases per batch (the unit of checkpointing)")->check(CLI::Range(2, 1 << 24));
  cmd->add_option("--rule", opts->rule, "hit rule")->check(CLI::IsMember({"nearest", "enter-only"}));
  cmd->add_option("--summary", opts->summary, "also write the report as JSON");
  cmd->add_option("--crash-after-batches", opts->crash_after, "testing: exit abruptly after writing that many batches")
      ->group("");
  cmd->callback([opts, &exit_code] {
    fuzz::CampaignOptions o;
    for (const std::string& f : split_list(opts->families)) {
      if (f == "all") {
        o.families.assign(std::begin(fuzz::kAllFamilies), std::end(fuzz::kAllFamilies));
        continue;
      }
      const auto fam = fuzz::family_from_string(f);
      if (!fam) throw CLI::ValidationError("--family", "unknown family '" + f + "'");
      o.families.push_back(*fam);
    }
    for (const std::string& s : split_list(opts->shapes)) {
      if (s == "all") {
        o.shapes.assign(kAllShapeKinds.begin(), kAllShapeKinds.end());
        continue;
      }
      const auto k = shape_kind_from_string(s);
      if (!k) throw CLI::ValidationError("--shape", "unknown shape '" + s + "'");
      o.shapes.push_back(*k);
    }
    unsigned i = 0, n = 0;
    char slash = 0;
    std::stringstream ss(opts->shard);
    if (!(ss >> i >> slash >> n) || slash != '/' || n == 0 || i >= n || !ss.eof())
      throw CLI::ValidationError("--shard", "expected i/n with 0 <= i < n, got '" + opts->shard + "'");
    o.shard = i, o.shards = n;
    o.count = opts->count, o.seed = opts->seed, o.max_findings = opts->max_findings, o.batch = opts->batch;
    o.threads = opts->threads > 0 ? opts->threads : std::max(1u, std::thread::hardware_concurrency());
    o.rule = *hit_rule_from_string(opts->rule);
    o.output = opts->output, o.resume = opts->resume, o.shrink = !opts->no_shrink;
    o.crash_after_batches = opts->crash_after;
    Progress progress("fuzz");
    std::string current;
    o.progress = [&](const std::string& what, std::uint64_t done, std::uint64_t total) {
      if (what != current) progress.finish(), progress = Progress("fuzz " + what.substr(0, what.find('\t')) + "/" + what.substr(what.find('\t') + 1)), current = what;
      progress.update(static_cast<long>(done), static_cast<long>(total));
    };
    const fuzz::CampaignReport report = fuzz::run_campaign(o);
    progress.finish();
    fuzz::print_report(report, o.threads, std::cerr);
    std::cerr << "rayproof fuzz: " << report.findings_written << " findings in " << o.output << "\n";
    if (std::find(o.families.begin(), o.families.end(), fuzz::Family::near_origin) != o.families.end()) {
      // Near-origin hits raise the question users ask most: which t_min / offset? Answer it.
      std::vector<const Variant*> variants;
      for (ShapeKind s : o.shapes)
        for (const Variant* v : variants_for(s)) variants.push_back(v);
      std::vector<int> scales;
      for (int k = -40; k <= 40; k += 10) scales.push_back(k);
      run_spawn_report(variants, scales, std::min<std::uint64_t>(o.count, 20000), o.seed, o.threads,
                       o.output + ".spawn.csv");
    }
    if (!opts->summary.empty()) {
      AtomicFile s(opts->summary);
      s.stream() << report.to_json().dump(2) << "\n";
      s.commit();
    }
    exit_code = 0;
  });
}

}  // namespace rayproof::cli
