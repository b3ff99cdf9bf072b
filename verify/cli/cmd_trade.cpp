// rayproof trade: ns per test against accuracy per family, for every contender, in one run.
#include <iostream>
#include <sstream>
#include <thread>

#include "cli/commands.h"
#include "rayproof/atomic_file.h"
#include "rayproof/trade.h"
#ifdef RAYPROOF_HAVE_EMBREE
#include "peers/embree.h"
#endif
#include <algorithm>

namespace rayproof::cli {

void add_trade_command(CLI::App& app, int& exit_code) {
  struct Options {
    std::vector<std::string> shapes{"sphere,plane,triangle,box"};
    std::vector<std::string> families{"random,tangent,grazing,near-origin,extremes"};
    std::uint64_t count = 100000, seed = 1;
    int threads = 0;
    std::string output, plot;
  };
  auto opts = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("trade", "Speed against accuracy: every variant timed and judged on the same cases");
  cmd->add_option("--shapes", opts->shapes, "shapes, comma separated");
  cmd->add_option("--families", opts->families, "families, comma separated");
  cmd->add_option("--count", opts->count, "cases per shape and family")->check(CLI::Range(std::uint64_t(1), std::uint64_t(1) << 30));
  cmd->add_option("--seed", opts->seed, "seed");
  cmd->add_option("--threads", opts->threads, "threads for the oracle (timing is single-threaded)")->check(CLI::Range(0, 256));
  cmd->add_option("-o,--output", opts->output, "CSV: variant,shape,family,cases,ns_per_test,disagreements,disagreement_rate,ulp_p99,ulp_max")->required();
  cmd->add_option("--plot", opts->plot, "SVG scatter plot: ns per test against disagreement rate");
  cmd->callback([opts, &exit_code] {
    std::vector<ShapeKind> shapes;
    for (const std::string& s : split_list(opts->shapes)) {
      const auto k = shape_kind_from_string(s);
      if (!k) throw CLI::ValidationError("--shapes", "unknown shape '" + s + "'");
      shapes.push_back(*k);
    }
    std::vector<fuzz::Family> families;
    for (const std::string& f : split_list(opts->families)) {
      const auto fam = fuzz::family_from_string(f);
      if (!fam) throw CLI::ValidationError("--families", "unknown family '" + f + "'");
      families.push_back(*fam);
    }
    const int threads = opts->threads > 0 ? opts->threads : std::max(1u, std::thread::hardware_concurrency());
    const auto rows = fuzz::measure_trade(trade_contenders(), shapes, families, opts->count, opts->seed, threads);
    fuzz::print_trade_markdown(rows, std::cout);
    AtomicFile csv(opts->output);
    fuzz::write_trade_csv(rows, csv.stream());
    csv.commit();
    if (!opts->plot.empty()) {
      AtomicFile svg(opts->plot);
      fuzz::write_trade_svg(rows, svg.stream());
      svg.commit();
    }
#ifdef RAYPROOF_HAVE_EMBREE
    if (std::find(shapes.begin(), shapes.end(), ShapeKind::triangle) != shapes.end()) {
      // Embree's watertightness, judged by the oracle on the grazing family's shared-edge pairs.
      for (bool robust : {false, true}) {
        const auto holes = peers::embree_shared_edge_holes(opts->count / 2, opts->seed, robust);
        std::cout << "\n" << (robust ? "embree-robust" : "embree") << " shared-edge holes: "
                  << holes.holes - holes.holes_large << " of " << holes.crossing - holes.crossing_large
                  << " pairs whose exact ray crosses the shared edge, coordinates below 2^40; "
                  << holes.holes_large << " of " << holes.crossing_large << " at 2^40 and beyond\n";
      }
    }
#endif
    std::cerr << "rayproof trade: " << opts->output << (opts->plot.empty() ? "" : ", " + opts->plot) << "\n";
    exit_code = 0;
  });
}

}  // namespace rayproof::cli
