// rayproof stability: where each formula breaks, as one heatmap per variant.
#include <filesystem>
#include <map>
#include <memory>
#include <iostream>

#include "commands.h"
#include "rayproof/core/atomic_file.h"
#include "rayproof/studies/stability.h"

namespace rayproof::cli {

namespace {
// stability.csv and one SVG per variant of one shape, in `dir`: opened before the study (a path
// that cannot be written fails first), written after it.
struct StabilityOutputs {
  std::unique_ptr<AtomicFile> csv;
  std::map<std::string, std::unique_ptr<AtomicFile>> svgs;
  StabilityOutputs(const std::string& dir, const std::vector<const Variant*>& variants) {
    std::filesystem::create_directories(dir);
    csv = std::make_unique<AtomicFile>(dir + "/stability.csv");
    for (const Variant* v : variants)
      svgs[std::string(v->name)] = std::make_unique<AtomicFile>(dir + "/" + std::string(v->name) + ".svg");
  }
  void write(ShapeKind shape, const std::string& rule,
             const std::map<std::string, std::vector<studies::StabilityCell>>& cells,
             const studies::StabilityGrid& grid) {
    studies::write_stability_csv(cells, csv->stream());
    csv->commit();
    for (const auto& [name, list] : cells) {
      AtomicFile& svg = *svgs.at(name);
      studies::write_stability_svg(
          name + " (" + std::string(to_string(shape)) + ", rule " + rule + "): bug-level disagreement rate", list, grid,
          svg.stream());
      svg.commit();
      std::cerr << "rayproof stability: " << svg.path() << "\n";
    }
    std::cerr << "rayproof stability: " << csv->path() << "\n";
  }
};
}  // namespace

void add_stability_command(CLI::App& app, int& exit_code) {
  struct Options {
    std::vector<std::string> shapes{"sphere"}, variants;
    std::string output, rule = "nearest";
    int lo = -200, hi = 200, step = 10, threads = 0;
    std::uint64_t cases = 200, seed = 1;
    double tolerance_ulps = kDefaultToleranceUlps;
  };
  auto opts = std::make_shared<Options>();
  auto ext = std::make_shared<ExternalFlags>();
  auto* cmd = app.add_subcommand("stability", "Stability maps: disagreement rate over position scale x size scale");
  cmd->add_option("--shapes,--shape", opts->shapes,
                  "shapes, comma separated, or all (default: sphere); several go to OUTPUT/SHAPE/");
  add_variants_flag(cmd, opts->variants);
  add_external_flags(cmd, *ext);
  add_rule_flag(cmd, opts->rule);
  cmd->add_option("--from", opts->lo, "smallest log2 scale")->check(CLI::Range(-1000, 1000));
  cmd->add_option("--to", opts->hi, "largest log2 scale")->check(CLI::Range(-1000, 1000));
  cmd->add_option("--step", opts->step, "log2 step")->check(CLI::Range(1, 1000));
  cmd->add_option("--count,--cases", opts->cases, "cases per cell")
      ->check(CLI::Range(std::uint64_t(1), std::uint64_t(1) << 24));
  add_seed_flag(cmd, opts->seed);
  add_threads_flag(cmd, opts->threads);
  add_tolerance_flag(cmd, opts->tolerance_ulps);
  cmd->add_option("-o,--output", opts->output, "directory for stability.csv and one SVG heatmap per variant")
      ->required();
  cmd->callback([opts, ext, &exit_code] {
    load_externals(*ext);
    if (opts->lo > opts->hi) throw CLI::ValidationError("--from", "must not exceed --to");
    const std::vector<ShapeKind> shapes = parse_shapes(opts->shapes);
    const std::vector<const Variant*> named = parse_variants(opts->variants);
    for (const Variant* v : opts->variants.empty() ? std::vector<const Variant*>{} : named)
      if (std::none_of(shapes.begin(), shapes.end(), [v](ShapeKind k) { return v->handles(k); }))
        throw CLI::ValidationError("--variants", std::string(v->name) + " is a " + std::string(to_string(v->shape)) +
                                                     " variant; add --shapes " + std::string(to_string(v->shape)));
    const studies::StabilityGrid grid{opts->lo, opts->hi, opts->step, opts->cases, opts->seed, opts->tolerance_ulps};
    const HitRule rule = parse_rule(opts->rule);
    for (ShapeKind shape : shapes) {
      const std::vector<const Variant*> variants = parse_variants(opts->variants, {shape});
      if (variants.empty()) continue;
      StabilityOutputs outputs(shapes.size() == 1 ? opts->output : opts->output + "/" + std::string(to_string(shape)),
                               variants);
      const auto cells = studies::stability_study(shape, variants, rule, grid, thread_count(opts->threads));
      outputs.write(shape, opts->rule, cells, grid);
    }
    exit_code = 0;
  });
}

}  // namespace rayproof::cli
