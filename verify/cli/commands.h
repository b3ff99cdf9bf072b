// Subcommands of the `rayproof` executable; each registers itself on the CLI11 app.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "rayproof/hit.h"
#include "rayproof/trade.h"
#include "rayproof/variants.h"

namespace rayproof::cli {

void add_intersect_command(CLI::App& app, int& exit_code);
void add_render_command(CLI::App& app, int& exit_code);
void add_variants_command(CLI::App& app, int& exit_code);
void add_check_command(CLI::App& app, int& exit_code);
void add_fuzz_command(CLI::App& app, int& exit_code);
void add_spawn_command(CLI::App& app, int& exit_code);
void add_trade_command(CLI::App& app, int& exit_code);
void add_stability_command(CLI::App& app, int& exit_code);
// The spawn study's table on stderr and its CSV (shared by `spawn` and `fuzz --family near-origin`).
void run_spawn_report(const std::vector<const Variant*>& variants, const std::vector<int>& scales, std::uint64_t count,
                      std::uint64_t seed, int threads, const std::string& csv_path);

// Comma-separated option values, flattened ("a,b" "c" → a, b, c); empty items dropped.
std::vector<std::string> split_list(const std::vector<std::string>& lists);

// Resolves --variants names (comma lists allowed); an empty list means every variant.
// Throws CLI::ValidationError naming an unknown variant.
std::vector<const Variant*> resolve_variants(const std::vector<std::string>& names);

// Everything `trade` and the benchmarks measure: the registered variants, their batched forms
// and, when built, peer libraries.
std::vector<fuzz::Contender> trade_contenders();

// A progress line on stderr, only when stderr is a terminal.
class Progress {
 public:
  explicit Progress(std::string label);
  void update(long done, long total);
  void finish();
 private:
  std::string label_;
  bool enabled_;
  long last_percent_ = -1;
};

}  // namespace rayproof::cli
