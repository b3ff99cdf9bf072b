// rayproof spawn: self-intersection (shadow acne) rates per variant × spawn strategy × scale.
#include <iostream>
#include <sstream>
#include <thread>

#include "cli/commands.h"
#include "rayproof/atomic_file.h"
#include "rayproof/spawn.h"

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
  std::vector<fuzz::SpawnStrategy> strategies(std::begin(fuzz::kAllSpawnStrategies), std::end(fuzz::kAllSpawnStrategies));
  const auto cells = fuzz::spawn_study(variants, strategies, scales, count, seed, threads);
  fuzz::print_spawn_table(cells, std::cerr);
  AtomicFile csv(csv_path);
  fuzz::write_spawn_csv(cells, csv.stream());
  csv.commit();
  std::cerr << "rayproof spawn: " << csv_path << "\n";
}

void add_spawn_command(CLI::App& app, int& exit_code) {
  struct Options {
    std::vector<std::string> variants;
    std::string scales = "-40:40:10", output;
    std::uint64_t count = 2000, seed = 1;
    int threads = 0;
  };
  auto opts = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("spawn", "Shadow-acne study: self-intersection rate per variant, spawn strategy and scale");
  cmd->add_option("--variants", opts->variants, "variants, comma separated (default: all)");
  cmd->add_option("--scales", opts->scales, "log2 scales, lo:hi:step or a comma list");
  cmd->add_option("--count", opts->count, "primary rays per variant and scale")->check(CLI::Range(std::uint64_t(1), std::uint64_t(1) << 40));
  cmd->add_option("--seed", opts->seed, "seed");
  cmd->add_option("--threads", opts->threads, "worker threads (default: all cores)")->check(CLI::Range(0, 256));
  cmd->add_option("-o,--output", opts->output, "CSV: variant,shape,strategy,log2_scale,rays,self_intersections,rate")->required();
  cmd->callback([opts, &exit_code] {
    const int threads = opts->threads > 0 ? opts->threads : std::max(1u, std::thread::hardware_concurrency());
    run_spawn_report(resolve_variants(opts->variants), parse_scales(opts->scales), opts->count, opts->seed, threads,
                     opts->output);
    exit_code = 0;
  });
}

}  // namespace rayproof::cli
