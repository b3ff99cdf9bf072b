// rayproof: is your ray intersection code right, how wrong is it, where, and at what cost.
#include <unistd.h>

#include <cstdio>
#include <iostream>
#include <sstream>

#include "cli/commands.h"
#include "rayproof/batch.h"
#ifdef RAYPROOF_HAVE_EMBREE
#include "peers/embree.h"
#endif

namespace rayproof::cli {

std::vector<std::string> split_list(const std::vector<std::string>& lists) {
  std::vector<std::string> out;
  for (const std::string& l : lists) {
    std::stringstream ss(l);
    for (std::string x; std::getline(ss, x, ',');)
      if (!x.empty()) out.push_back(x);
  }
  return out;
}

std::vector<const Variant*> resolve_variants(const std::vector<std::string>& names) {
  std::vector<const Variant*> out;
  for (const std::string& name : split_list(names)) {
    const Variant* v = find_variant(name);
    if (!v) {
      std::string known;
      for (const Variant& k : all_variants()) known += (known.empty() ? "" : ", ") + std::string(k.name);
      throw CLI::ValidationError("--variants", "unknown variant '" + name + "' (known: " + known + ")");
    }
    out.push_back(v);
  }
  if (out.empty())
    for (const Variant& v : all_variants()) out.push_back(&v);
  return out;
}

Progress::Progress(std::string label) : label_(std::move(label)), enabled_(isatty(2)) {}

void Progress::update(long done, long total) {
  if (!enabled_) return;
  if (total <= 0) {  // unknown total (a case file read as it streams): a count every 10,000
    if (done % 10000 == 0) std::fprintf(stderr, "\r%s: %ld done", label_.c_str(), done), last_percent_ = 0;
    return;
  }
  const long percent = done * 100 / total;
  if (percent == last_percent_) return;
  last_percent_ = percent;
  std::fprintf(stderr, "\r%s: %ld/%ld (%ld%%)", label_.c_str(), done, total, percent);
  std::fflush(stderr);
}

void Progress::finish() {
  if (enabled_ && last_percent_ >= 0) std::fprintf(stderr, "\n");
}

std::vector<fuzz::Contender> trade_contenders() {
  std::vector<fuzz::Contender> all = fuzz::variant_contenders();
  for (fuzz::Contender& c : fuzz::batched_contenders()) all.push_back(std::move(c));
#ifdef RAYPROOF_HAVE_EMBREE
  for (fuzz::Contender& c : peers::embree_contenders()) all.push_back(std::move(c));
#endif
  return all;
}

void add_variants_command(CLI::App& app, int& exit_code) {
  auto* cmd = app.add_subcommand("variants", "List every intersection variant, its shape and its source");
  cmd->callback([&exit_code] {
    for (const Variant& v : all_variants())
      std::cout << v.name << "\t" << to_string(v.shape) << "\t" << v.source << "\n";
    for (const BatchedVariant& b : batched_variants())
      std::cout << b.name << "\t" << to_string(b.shape) << "\tstructure-of-arrays form of " << b.scalar
                << ", bit-identical (nearest rule; used by trade and the benchmarks)\n";
    exit_code = 0;
  });
}

}  // namespace rayproof::cli

int main(int argc, char** argv) {
  CLI::App app{"rayproof: exact audits, fuzzing and benchmarks of ray intersection code"};
  app.require_subcommand(1);
  int exit_code = 0;
  rayproof::cli::add_variants_command(app, exit_code);
  rayproof::cli::add_intersect_command(app, exit_code);
  rayproof::cli::add_render_command(app, exit_code);
  rayproof::cli::add_check_command(app, exit_code);
  rayproof::cli::add_fuzz_command(app, exit_code);
  rayproof::cli::add_spawn_command(app, exit_code);
  rayproof::cli::add_trade_command(app, exit_code);
  rayproof::cli::add_stability_command(app, exit_code);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::cerr << "rayproof: " << e.what() << "\n";
    return 1;
  }
  return exit_code;
}
