// rayproof spawn: self-intersection (shadow acne) rates per variant × spawn strategy × scale.
#include <iostream>
#include <sstream>

#include "commands.h"
#include "rayproof/core/atomic_file.h"
#include "rayproof/studies/spawn.h"

namespace rayproof::cli {

std::vector<int> parse_scales(const std::string& spec) {
  // "lo:hi:step" or a comma list
  std::vector<int> out;
  int lo, hi, step;
  char c1, c2;
  std::stringstream ss(spec);
  if (spec.find(':') != std::string::npos) {
    if (!(ss >> lo >> c1 >> hi >> c2 >> step) || c1 != ':' || c2 != ':' || step <= 0 || lo > hi || hi - lo > 4000)
      throw CLI::ValidationError("--scales", "expected lo:hi:step, e.g. -40:40:10");
    for (int k = lo; k <= hi; k += step) out.push_back(k);
  } else {
    for (std::string x; std::getline(ss, x, ',');) {
      try {
        out.push_back(std::stoi(x));
      } catch (...) {
        throw CLI::ValidationError("--scales", "not an integer: '" + x + "'");
      }
    }
  }
  for (int k : out)
    if (k < -1000 || k > 1000) throw CLI::ValidationError("--scales", "log2 scales must lie in -1000..1000");
  return out;
}

void run_spawn_report(const std::vector<const Variant*>& variants, const std::vector<int>& scales, std::uint64_t count,
                      std::uint64_t seed, int threads, const std::string& csv_path) {
  using namespace studies;
  AtomicFile csv(csv_path);  // before the work: a path that cannot be written fails now
  const std::vector<SpawnStrategy> strategies(std::begin(kAllSpawnStrategies), std::end(kAllSpawnStrategies));
  const auto cells = spawn_study(variants, strategies, scales, count, seed, threads);
  print_spawn_table(cells, std::cerr);
  write_spawn_csv(cells, csv.stream());
  csv.commit();
  std::cerr << "rayproof spawn: " << csv_path << "\n";
}

void add_spawn_command(CLI::App& app, int& exit_code) {
  struct Options {
    std::vector<std::string> variants, shapes;
    std::string scales = "-40:40:10", output;
    std::uint64_t count = 2000, seed = 1;
    int threads = 0;
    ExternalFlags ext;
  };
  auto opts = std::make_shared<Options>();
  auto* cmd =
      app.add_subcommand("spawn", "Shadow-acne study: self-intersection rate per variant, spawn strategy and scale");
  add_variants_flag(cmd, opts->variants);
  add_external_flags(cmd, opts->ext);
  add_shapes_flag(cmd, opts->shapes);
  cmd->add_option("--scales", opts->scales, "log2 scales, lo:hi:step or a comma list");
  add_count_flag(cmd, opts->count, "primary rays per variant and scale", std::uint64_t(1) << 40);
  add_seed_flag(cmd, opts->seed);
  add_threads_flag(cmd, opts->threads);
  cmd->add_option("-o,--output", opts->output, "CSV: variant,shape,strategy,log2_scale,rays,self_intersections,rate")
      ->required();
  cmd->callback([opts, &exit_code] {
    load_externals(opts->ext);
    run_spawn_report(parse_variants(opts->variants, parse_shapes(opts->shapes)), parse_scales(opts->scales),
                     opts->count, opts->seed, thread_count(opts->threads), opts->output);
    exit_code = 0;
  });
}

}  // namespace rayproof::cli
