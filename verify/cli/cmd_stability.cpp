// rayproof stability: where each formula breaks, as one heatmap per variant.
#include <filesystem>
#include <iostream>
#include <thread>

#include "cli/commands.h"
#include "rayproof/atomic_file.h"
#include "rayproof/stability.h"

namespace rayproof::cli {

void add_stability_command(CLI::App& app, int& exit_code) {
  struct Options {
    std::string shape = "sphere", output, rule = "nearest";
    std::vector<std::string> variants;
    int lo = -200, hi = 200, step = 10, threads = 0;
    std::uint64_t cases = 200, seed = 1;
  };
  auto opts = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("stability", "Stability maps: disagreement rate over position scale x size scale");
  cmd->add_option("--shape", opts->shape, "sphere, plane, triangle or box")->check(CLI::IsMember({"sphere", "plane", "triangle", "box"}));
  cmd->add_option("--variant", opts->variants, "variants (repeatable or comma separated; default: all of the shape)");
  cmd->add_option("--rule", opts->rule, "hit rule")->check(CLI::IsMember({"nearest", "enter-only"}));
  cmd->add_option("--from", opts->lo, "smallest log2 scale")->check(CLI::Range(-1000, 1000));
  cmd->add_option("--to", opts->hi, "largest log2 scale")->check(CLI::Range(-1000, 1000));
  cmd->add_option("--step", opts->step, "log2 step")->check(CLI::Range(1, 1000));
  cmd->add_option("--cases", opts->cases, "cases per cell")->check(CLI::Range(std::uint64_t(1), std::uint64_t(1) << 24));
  cmd->add_option("--seed", opts->seed, "seed");
  cmd->add_option("--threads", opts->threads, "threads (default: all cores)")->check(CLI::Range(0, 256));
  cmd->add_option("-o,--output", opts->output, "directory for stability.csv and one SVG heatmap per variant")->required();
  cmd->callback([opts, &exit_code] {
    if (opts->lo > opts->hi) throw CLI::ValidationError("--from", "must not exceed --to");
    const ShapeKind shape = *shape_kind_from_string(opts->shape);
    std::vector<const Variant*> variants;
    for (const Variant* v : opts->variants.empty() ? variants_for(shape) : resolve_variants(opts->variants)) {
      if (v->shape != shape)
        throw CLI::ValidationError("--variant", std::string(v->name) + " is a " + std::string(to_string(v->shape)) + " variant");
      variants.push_back(v);
    }
    fuzz::StabilityGrid grid{opts->lo, opts->hi, opts->step, opts->cases, opts->seed};
    const int threads = opts->threads > 0 ? opts->threads : std::max(1u, std::thread::hardware_concurrency());
    const HitRule rule = *hit_rule_from_string(opts->rule);
    const auto cells = fuzz::stability_study(shape, variants, rule, grid, threads);
    std::filesystem::create_directories(opts->output);
    AtomicFile csv(opts->output + "/stability.csv");
    fuzz::write_stability_csv(cells, csv.stream());
    csv.commit();
    for (const auto& [name, list] : cells) {
      const std::string path = opts->output + "/" + name + ".svg";
      AtomicFile svg(path);
      fuzz::write_stability_svg(name + " (" + opts->shape + ", rule " + opts->rule + "): class disagreement rate", list,
                                grid, svg.stream());
      svg.commit();
      std::cerr << "rayproof stability: " << path << "\n";
    }
    std::cerr << "rayproof stability: " << opts->output << "/stability.csv\n";
    exit_code = 0;
  });
}

}  // namespace rayproof::cli
