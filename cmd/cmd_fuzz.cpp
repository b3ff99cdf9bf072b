// rayproof fuzz: every variant against the oracle on generated families; findings replayable.
#include <unistd.h>
#include <algorithm>
#include <charconv>
#include <iomanip>
#include <set>
#include <limits>
#include <cstdlib>
#include <memory>
#include <iostream>
#include <sstream>

#include "commands.h"
#include "rayproof/core/atomic_file.h"
#include "rayproof/core/casefile.h"
#include "rayproof/core/json_fields.h"
#include "rayproof/fuzz/campaign.h"
#include "rayproof/fuzz/tracer_campaign.h"
#include "rayproof/core/parallel.h"

namespace rayproof::cli {

namespace {
// i/n; or `auto`, from the array index and count the batch system sets: Slurm job arrays
// (SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_COUNT), Kubernetes Indexed Jobs (JOB_COMPLETION_INDEX,
// with the completion count given as auto/N since Kubernetes does not export it).
std::pair<unsigned, unsigned> parse_shard(const std::string& text) {
  // Whole numbers only, as written (no sign, no spaces), and at most 2^32 − 1: a value that a
  // wider or signed reader would wrap is an error naming where it came from, never a shard.
  auto number = [](const char* value, const std::string& what) -> std::uint64_t {
    if (!value || !*value) throw CLI::ValidationError("--shard", what + " is not set");
    const std::string_view v(value);
    std::uint64_t n = 0;
    const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), n);
    if (ec == std::errc::result_out_of_range || (ec == std::errc() && end == v.data() + v.size() && n > 0xffffffffu))
      throw CLI::ValidationError("--shard", what + " is out of range (at most 4294967295): '" + printable(v) + "'");
    if (ec != std::errc() || end != v.data() + v.size())
      throw CLI::ValidationError("--shard", what + " is not a whole number >= 0: '" + printable(v) + "'");
    return n;
  };
  std::uint64_t i = 0, n = 0;
  if (text == "auto" || text.rfind("auto/", 0) == 0) {
    if (text == "auto" && std::getenv("SLURM_ARRAY_TASK_ID")) {
      i = number(std::getenv("SLURM_ARRAY_TASK_ID"), "SLURM_ARRAY_TASK_ID");
      n = number(std::getenv("SLURM_ARRAY_TASK_COUNT"), "SLURM_ARRAY_TASK_COUNT");
      // Slurm arrays may start at 1 (--array=1-4): shift by SLURM_ARRAY_TASK_MIN when set.
      if (const char* min_text = std::getenv("SLURM_ARRAY_TASK_MIN")) {
        const std::uint64_t min = number(min_text, "SLURM_ARRAY_TASK_MIN");
        if (i < min)
          throw CLI::ValidationError("--shard", "SLURM_ARRAY_TASK_ID " + std::to_string(i) +
                                                    " is below SLURM_ARRAY_TASK_MIN " + std::to_string(min));
        i -= min;
      }
    } else if (std::getenv("JOB_COMPLETION_INDEX")) {
      i = number(std::getenv("JOB_COMPLETION_INDEX"), "JOB_COMPLETION_INDEX");
      if (text == "auto")
        throw CLI::ValidationError("--shard", "on Kubernetes give the completion count: --shard auto/N");
      n = number(text.c_str() + 5, "the count in auto/N");
    } else {
      throw CLI::ValidationError("--shard", "auto: neither SLURM_ARRAY_TASK_ID nor JOB_COMPLETION_INDEX is set");
    }
  } else {
    const std::size_t slash = text.find('/');
    if (slash == std::string::npos)
      throw CLI::ValidationError("--shard", "expected i/n with 0 <= i < n, or auto, got '" + printable(text) + "'");
    i = number(text.substr(0, slash).c_str(), "the shard index i in i/n");
    n = number(text.substr(slash + 1).c_str(), "the shard count n in i/n");
  }
  if (n == 0 || i >= n)
    throw CLI::ValidationError("--shard",
                               "shard " + std::to_string(i) + " of " + std::to_string(n) + ": need 0 <= i < n");
  return {static_cast<unsigned>(i), static_cast<unsigned>(n)};
}

struct FuzzOptions {
  ExternalFlags ext;
  TracerFlags tracers;
  std::vector<std::string> families{"all"}, shapes{"all"}, variants;
  std::string shard = "0/1", output, rule = "nearest", summary, format = "table", spawn_csv, construction = "both";
  static constexpr std::uint64_t kModeDefault = std::numeric_limits<std::uint64_t>::max();
  std::uint64_t count = 100000, seed = 1, max_findings = kModeDefault,
                batch = 8192;  // findings: 1000 (variants) or 20 (tracers)
  std::uint64_t max_shrunk = fuzz::CampaignOptions{}.max_shrunk;
  int threads = 0;
  bool resume = false, no_shrink = false, keep_checkpoint = false;
  long crash_after = -1;
  double checkpoint_every = fuzz::CampaignOptions{}.checkpoint_seconds;
};

// Counts given on the command line: digits only ("-1" would otherwise wrap to 2^64 − 1).
const CLI::Validator kWholeNumber(
    [](std::string& text) {
      return text.empty() || text.find_first_not_of("0123456789") != std::string::npos
                 ? "expected a whole number >= 0, got '" + text + "'"
                 : std::string();
    },
    "N");

fuzz::CampaignOptions campaign_options(const FuzzOptions& opts) {
  fuzz::CampaignOptions o;
  o.families = parse_families(opts.families);
  if (opts.construction == "exact") o.constructions = {fuzz::Construction::exact};
  if (opts.construction == "full") o.constructions = {fuzz::Construction::full};
  o.shapes = parse_shapes(opts.shapes);
  if (!opts.variants.empty()) o.variants = parse_variants(opts.variants, o.shapes);
  std::tie(o.shard, o.shards) = parse_shard(opts.shard);
  o.count = opts.count, o.seed = opts.seed,
  o.max_findings = opts.max_findings == FuzzOptions::kModeDefault ? 1000 : opts.max_findings, o.batch = opts.batch;
  o.threads = thread_count(opts.threads);
  o.rule = parse_rule(opts.rule);
  o.tolerance_ulps = opts.tracers.tolerance_ulps;
  o.output = opts.output, o.resume = opts.resume, o.shrink = !opts.no_shrink, o.keep_checkpoint = opts.keep_checkpoint;
  o.crash_after_batches = opts.crash_after;
  o.checkpoint_seconds = opts.checkpoint_every;
  o.max_shrunk = opts.max_shrunk;
  return o;
}

// `fuzz --tracer ...`: whole tracers on the tracer families (docs/spec/tracer.md).
int run_tracer_fuzz(const FuzzOptions& opts) {
  fuzz::TracerCampaignOptions o;
  o.verdicts.tolerance_ulps = opts.tracers.tolerance_ulps;
  o.families = parse_tracer_families(opts.families);
  o.tracers = parse_tracers(opts.tracers.names);
  std::tie(o.shard, o.shards) = parse_shard(opts.shard);
  o.count = opts.count, o.seed = opts.seed,
  o.max_findings = opts.max_findings == FuzzOptions::kModeDefault ? 20 : opts.max_findings;
  o.threads = thread_count(opts.threads);
  o.output = opts.output, o.resume = opts.resume, o.shrink = !opts.no_shrink, o.keep_checkpoint = opts.keep_checkpoint;
  o.crash_after_batches = opts.crash_after;
  std::unique_ptr<AtomicFile> summary;
  if (!opts.summary.empty()) summary = std::make_unique<AtomicFile>(opts.summary);
  if (opts.format != "json") {  // what runs, defaults included, before any wait
    std::string families, tracers;
    for (fuzz::TracerFamily f : o.families) families += (families.empty() ? "" : ",") + std::string(to_string(f));
    for (const Tracer* t : o.tracers) tracers += (tracers.empty() ? "" : ",") + t->name;
    std::cerr << "rayproof fuzz: " << o.count << " rays per family and tracer (--count), seed " << o.seed << ", "
              << threads_text(o.threads) << "\n  families " << families << "\n  tracers " << tracers << "\n";
  }
  const bool logged = opts.format != "json";  // JSON on standard error: nothing else there off a terminal
  Progress progress("fuzz", logged);
  std::optional<fuzz::TracerFamily> current;
  o.progress = [&](fuzz::TracerFamily family, std::uint64_t done, std::uint64_t total) {
    if (current != family) {
      progress.finish();
      progress = Progress("fuzz " + std::string(to_string(family)) + " (meshes)", logged);
      current = family;
    }
    progress.update(static_cast<long>(done), static_cast<long>(total));
  };
  const fuzz::TracerCampaignReport report = fuzz::run_tracer_campaign(o);
  progress.finish();
  fuzz::print_tracer_report(report, *table_format_from_string(opts.format), std::cout);  // the report is the output
  for (const Tracer* t : o.tracers)  // why external code stopped, on screen (not only in the findings)
    if (const std::string why = t->stop_reason(); !why.empty() && opts.format != "json")
      std::cerr << "rayproof fuzz: tracer " << t->name << " stopped: " << printable(why)
                << " (its later rays are counted as failed)\n";
  double seconds = 0;
  std::uint64_t rays = 0;
  for (const auto& [family, s] : report.seconds) seconds += s, rays += report.rays.at(family);
  std::cerr << "rayproof fuzz: " << rays << " rays per tracer in " << std::fixed << std::setprecision(1) << seconds
            << " s (" << threads_text(o.threads) << "), " << report.findings_written << " findings in " << o.output
            << "\n"
            << std::defaultfloat;
  if (summary) {
    summary->stream() << json_text(report.to_json(), 2) << "\n";
    summary->commit();
  }
  // --fail-on (verdicts.md): bug-level disagreements and failures, or every disagreement.
  std::uint64_t failing = 0;
  for (const auto& [key, t] : report.tallies) {
    if (opts.tracers.fail_on == "none") break;
    for (const TraceKindInfo& k : kTraceKinds) {
      if (!k.disagreement) continue;
      if (!k.verdict || opts.tracers.fail_on == "rounding")
        failing += t.count(k.kind);  // failures to answer fail at every level
      else
        failing += t.level(std::string(k.name) + "_bugs");
    }
  }
  if (failing == 0) return 0;
  std::cerr << "rayproof fuzz: --fail-on " << opts.tracers.fail_on << ": " << failing << " tracer outcomes fail\n";
  return 1;
}

int run_fuzz(const FuzzOptions& opts) {
  fuzz::CampaignOptions o = campaign_options(opts);
  std::unique_ptr<AtomicFile> summary;  // before the work: a path that cannot be written fails now
  if (!opts.summary.empty()) summary = std::make_unique<AtomicFile>(opts.summary);
  if (opts.format != "json") {  // what runs, defaults included, before any wait
    std::string families, shapes;
    for (fuzz::Family f : o.families) families += (families.empty() ? "" : ",") + std::string(to_string(f));
    for (ShapeKind k : o.shapes) shapes += (shapes.empty() ? "" : ",") + std::string(to_string(k));
    std::cerr << "rayproof fuzz: " << o.count << " cases per family and shape (--count), seed " << o.seed << ", "
              << threads_text(o.threads) << ", construction " << opts.construction << "\n  families " << families
              << "; shapes " << shapes << "; variants "
              << (o.variants.empty() ? "all but certified-*" : std::to_string(o.variants.size()) + " chosen") << "\n";
  }
  const bool logged = opts.format != "json";  // JSON on standard error: nothing else there off a terminal
  Progress progress("fuzz", logged);
  std::optional<std::pair<fuzz::Family, ShapeKind>> current;
  o.progress = [&](fuzz::Family family, ShapeKind shape, std::uint64_t done, std::uint64_t total) {
    if (current != std::pair{family, shape}) {
      progress.finish();
      progress = Progress("fuzz " + std::string(to_string(family)) + "/" + std::string(to_string(shape)), logged);
      current = {family, shape};
    }
    progress.update(static_cast<long>(done), static_cast<long>(total));
  };
  o.shrink_progress = [&](std::uint64_t done, std::uint64_t total) {
    if (isatty(2) && current)  // on the pair's line, cleared to its end; the next batch writes over it
      std::fprintf(stderr, "\rfuzz %s/%s: shrinking findings %llu/%llu\033[K",
                   std::string(to_string(current->first)).c_str(), std::string(to_string(current->second)).c_str(),
                   static_cast<unsigned long long>(done), static_cast<unsigned long long>(total));
  };
  const fuzz::CampaignReport report = fuzz::run_campaign(o);
  progress.finish();
  fuzz::print_report(report, o.threads, *table_format_from_string(opts.format), std::cerr);
  if (opts.format != "json") {  // a few lines a user reads: one case per kind, its replay, the hints
    std::vector<Case> findings;
    read_case_file(
        o.output, [&](const Case& c, long) { findings.push_back(c); }, [](const CaseError&) {},
        [](const MeshCase&, long) {});
    std::vector<const Variant*> judged;
    for (const auto& [key, tally] : report.tallies)
      if (const Variant* v = fuzz::variant_of_tally(key.name).first;
          v && std::find(judged.begin(), judged.end(), v) == judged.end())
        judged.push_back(v);
    print_digest(std::cerr, disagreements_in_findings(findings, o.output), judged, [&](const std::string& name) {
      std::uint64_t holes = 0;
      for (const auto& [key, tally] : report.tallies)
        if (const Variant* v = fuzz::variant_of_tally(key.name).first; v && v->name == name)
          holes += tally.shared_edge_holes;
      return holes;
    });
  }
  if (opts.format != "json") {
    std::set<const Variant*> told;  // why external code stopped, on screen (not only in the findings)
    for (const auto& [key, tally] : report.tallies)
      if (const Variant* v = fuzz::variant_of_tally(key.name).first; v && v->external && told.insert(v).second)
        if (const std::string why = v->external->stop_reason(); !why.empty())
          std::cerr << "rayproof fuzz: variant " << v->name << " stopped: " << printable(why) << "\n";
    std::cerr << "rayproof fuzz: " << report.findings_written << " findings in " << o.output << "\n";
  }
  if (!opts.spawn_csv.empty()) {
    // Near-origin hits raise the question users ask most: which t_min / offset? Answer it.
    std::vector<int> scales;
    for (int k = -40; k <= 40; k += 10) scales.push_back(k);
    run_spawn_report(parse_variants({}, o.shapes), scales, std::min<std::uint64_t>(o.count, 20000), o.seed, o.threads,
                     opts.spawn_csv);
  }
  if (summary) {
    summary->stream() << json_text(report.to_json(), 2) << "\n";
    summary->commit();
  }
  // --fail-on (verdicts.md): bug-level disagreements and failures of external code, or every
  // disagreement; by default a variant campaign exits 0 whatever it found.
  std::uint64_t failing = 0;
  for (const auto& [key, t] : report.tallies)
    if (opts.tracers.fail_on != "none")
      failing += t.failures() + (opts.tracers.fail_on == "rounding" ? t.disagreements() : t.bug_count());
  if (failing == 0) return 0;
  std::cerr << "rayproof fuzz: --fail-on " << opts.tracers.fail_on << ": " << failing << " variant outcomes fail\n";
  return 1;
}

}  // namespace

void add_fuzz_command(CLI::App& app, int& exit_code) {
  auto opts = std::make_shared<FuzzOptions>();
  auto* cmd = app.add_subcommand("fuzz", "Hunt for disagreements between the variants and the exact oracle");
  add_families_flag(cmd, opts->families);
  add_shapes_flag(cmd, opts->shapes);
  cmd->add_option("--variants,--variant", opts->variants,
                  "variants to judge (default: all but the oracle's own certified-*, which always agree)");
  add_external_flags(cmd, opts->ext);
  add_tracer_flags(cmd, opts->tracers);
  cmd->add_option("--construction", opts->construction,
                  "exact (small integers, nudged), full (53-bit mantissas, features computed in double) or both "
                  "(default; tallied apart as FAMILY and FAMILY-full)")
      ->check(CLI::IsMember({"exact", "full", "both"}));
  add_count_flag(cmd, opts->count, "cases per family and shape, or rays per tracer family, before sharding",
                 std::uint64_t(1) << 50);
  add_seed_flag(cmd, opts->seed);
  cmd->add_option("--shard", opts->shard,
                  "this run's share: i/n (0-based), auto (Slurm job arrays) or auto/N (Kubernetes Indexed Jobs)");
  add_threads_flag(cmd, opts->threads);
  add_rule_flag(cmd, opts->rule);
  cmd->add_option("-o,--output", opts->output, "findings (JSON Lines, replayable by rayproof check)")->required();
  cmd->add_flag("--resume", opts->resume, "continue from OUTPUT.checkpoint after the last completed batch");
  cmd->add_flag("--keep-checkpoint", opts->keep_checkpoint, "keep OUTPUT.checkpoint after the campaign completes");
  cmd->add_flag("--no-shrink", opts->no_shrink, "write findings as found, without shrinking");
  cmd->add_option("--max-shrunk", opts->max_shrunk,
                  "findings shrunk per family, shape and kind (default " + std::to_string(opts->max_shrunk) +
                      "); the rest are written as found")
      ->check(kWholeNumber);
  cmd->add_option("--spawn-csv", opts->spawn_csv,
                  "also run the spawn (shadow-acne) study on the chosen shapes and write its CSV here");
  add_format_flag(cmd, opts->format);
  cmd->add_option("--max-findings", opts->max_findings,
                  "findings written per family and shape (default 1000), or per family, tracer and mode (default 20); "
                  "all are counted")
      ->check(kWholeNumber);
  cmd->add_option("--batch", opts->batch, "cases per batch (the unit of work between checkpoints)")
      ->check(CLI::Range(2, 1 << 24));
  cmd->add_option("--checkpoint-every", opts->checkpoint_every,
                  "seconds of work between checkpoints (default 1; 0: after every batch); a family and shape's "
                  "last batch is always checkpointed")
      ->check(seconds_from(0, 86400));
  cmd->add_option("--summary", opts->summary, "also write the report as JSON");
  cmd->add_option("--crash-after-batches", opts->crash_after, "testing: exit abruptly after writing that many batches")
      ->group("");
  cmd->callback([opts, &exit_code] {
    load_externals(opts->ext);
    load_tracers(opts->tracers, opts->ext.case_timeout);
    if (opts->tracers.given()) {
      exit_code = run_tracer_fuzz(*opts);
      return;
    }
    exit_code = run_fuzz(*opts);
  });
}

}  // namespace rayproof::cli
