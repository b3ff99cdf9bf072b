// rayproof trade: ns per test against accuracy per family, for every contender, in one run.
#include <algorithm>
#include <memory>
#include <iostream>

#include "commands.h"
#include "rayproof/core/atomic_file.h"
#include "rayproof/studies/trade.h"
#ifdef RAYPROOF_HAVE_EMBREE
#include "rayproof/peers/embree.h"
#endif

namespace rayproof::cli {

void add_trade_command(CLI::App& app, int& exit_code) {
  struct Options {
    std::vector<std::string> shapes{"all"}, variants;
    std::vector<std::string> families{"random,tangent,grazing,near-origin,extremes"};
    std::uint64_t count = 100000, seed = 1;
    int threads = 0;
    std::string output, plot, format = "markdown";
    ExternalFlags ext;
    double tolerance_ulps = kDefaultToleranceUlps;
  };
  auto opts = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("trade", "Speed against accuracy: every variant timed and judged on the same cases");
  add_shapes_flag(cmd, opts->shapes);
  add_families_flag(cmd, opts->families);
  cmd->add_option("--variants,--variant", opts->variants,
                  "contenders by name: variants, batched variants, peers (default: all)");
  add_external_flags(cmd, opts->ext);
  add_count_flag(cmd, opts->count, "cases per shape and family", std::uint64_t(1) << 30);
  add_seed_flag(cmd, opts->seed);
  cmd->add_option("--threads", opts->threads, "threads for the oracle (timing is single-threaded)")
      ->check(CLI::Range(0, 256));
  cmd->add_option("-o,--output", opts->output,
                  "CSV: variant,shape,family,cases,ns_per_test,disagreements,disagreement_rate,ulp_p99,ulp_max,"
                  "precision,bugs,bug_rate")
      ->required();
  cmd->add_option("--plot", opts->plot,
                  "SVG scatter plot: ns per test against the rate of bug-level wrong answers (all disagreements "
                  "beside them)");
  add_tolerance_flag(cmd, opts->tolerance_ulps);
  cmd->add_option("--format", opts->format, "stdout table: markdown (default, paste-ready), table or json")
      ->check(CLI::IsMember({"table", "markdown", "json"}));
  cmd->callback([opts, &exit_code] {
    exit_code = 0;
    load_externals(opts->ext);
    const std::vector<ShapeKind> shapes = parse_shapes(opts->shapes);
    const std::vector<fuzz::Family> families = parse_families(opts->families);
    std::vector<studies::Contender> contenders = trade_contenders();
    const std::vector<std::string> names = split_list(opts->variants);
    if (!names.empty() && std::find(names.begin(), names.end(), "all") == names.end()) {
      for (const std::string& n : names)
        if (std::none_of(contenders.begin(), contenders.end(), [&](const auto& c) { return c.name == n; }))
          throw CLI::ValidationError("--variants", "unknown contender '" + n + "' (see rayproof variants)");
      std::erase_if(contenders,
                    [&](const auto& c) { return std::find(names.begin(), names.end(), c.name) == names.end(); });
    }
    AtomicFile csv(opts->output);  // before the work: a path that cannot be written fails now
    std::unique_ptr<AtomicFile> svg;
    if (!opts->plot.empty()) svg = std::make_unique<AtomicFile>(opts->plot);
    const auto rows = studies::measure_trade(contenders, shapes, families, opts->count, opts->seed,
                                             thread_count(opts->threads), opts->tolerance_ulps);
    studies::write_trade_table(rows, *table_format_from_string(opts->format), std::cout);
    for (const studies::TradeRow& r : rows)  // external code that stopped: its row times nothing
      if (r.tally.crashes + r.tally.timeouts + r.tally.protocol_errors > 0) {
        const Variant* v = find_variant(r.variant);
        std::cerr << "rayproof trade: " << r.variant << " stopped on " << to_string(r.shape) << "/"
                  << to_string(r.family) << (v && v->external ? ": " + v->external->stop_reason() : std::string())
                  << "; its later rows are left out of the plot and the Pareto front\n";
        exit_code = 1;
      }
    studies::write_trade_csv(rows, csv.stream());
    csv.commit();
    if (svg) {
      studies::write_trade_svg(rows, svg->stream());
      svg->commit();
    }
#ifdef RAYPROOF_HAVE_EMBREE
    const bool embree_chosen = names.empty() || std::find(names.begin(), names.end(), "all") != names.end() ||
                               std::find(names.begin(), names.end(), "embree") != names.end();
    if (embree_chosen && std::find(shapes.begin(), shapes.end(), ShapeKind::triangle) != shapes.end()) {
      // Embree's watertightness, judged by the oracle on the grazing family's shared-edge pairs.
      for (bool robust : {false, true}) {
        const auto holes = peers::embree_shared_edge_holes(opts->count / 2, opts->seed, robust);
        std::cout << "\n"
                  << (robust ? "embree-robust" : "embree") << " shared-edge holes: " << holes.holes - holes.holes_large
                  << " of " << holes.crossing - holes.crossing_large
                  << " pairs whose exact ray crosses the shared edge, coordinates below 2^40; " << holes.holes_large
                  << " of " << holes.crossing_large << " at 2^40 and beyond\n";
      }
    }
#endif
    std::cerr << "rayproof trade: " << opts->output << (opts->plot.empty() ? "" : ", " + opts->plot) << "\n";
  });
}

}  // namespace rayproof::cli
