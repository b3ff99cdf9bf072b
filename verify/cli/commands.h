// Subcommands of the `rayproof` executable; each registers itself on the CLI11 app.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "rayproof/hit.h"
#include "rayproof/variants.h"

namespace rayproof::cli {

void add_intersect_command(CLI::App& app, int& exit_code);
void add_render_command(CLI::App& app, int& exit_code);
void add_variants_command(CLI::App& app, int& exit_code);
void add_check_command(CLI::App& app, int& exit_code);
void add_fuzz_command(CLI::App& app, int& exit_code);

// Resolves --variants names (comma lists allowed); an empty list means every variant.
// Throws CLI::ValidationError naming an unknown variant.
std::vector<const Variant*> resolve_variants(const std::vector<std::string>& names);

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
