// rayproof intersect FILE...: every chosen variant on every case, as JSON lines.
#include <iostream>

#include "cli/commands.h"
#include "rayproof/casefile.h"

namespace rayproof::cli {

void add_intersect_command(CLI::App& app, int& exit_code) {
  struct Options {
    std::vector<std::string> files, variants;
    std::string rule = "nearest";
  };
  auto opts = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("intersect", "Run double-precision variants on case files (JSON lines on stdout)");
  cmd->add_option("files", opts->files, "case files (JSON Lines, shared/spec/cases.md)")->required();
  cmd->add_option("--variants", opts->variants, "variants to run, comma separated (default: all)");
  cmd->add_option("--rule", opts->rule, "hit rule")->check(CLI::IsMember({"nearest", "enter-only"}));
  cmd->callback([opts, &exit_code] {
    const auto variants = resolve_variants(opts->variants);
    const HitRule rule = *hit_rule_from_string(opts->rule);
    long errors = 0, cases = 0;
    for (const std::string& file : opts->files) {
      long in_file = 0;
      read_case_file(
          file,
          [&](const Case& c, long) {
            ++cases, ++in_file;
            json out = {{"id", c.id}, {"variants", json::object()}};
            for (const Variant* v : variants) {
              if (v->shape != kind_of(c.shape)) continue;
              const Hit h = v->intersect(c.ray, c.shape, rule);
              out["variants"][std::string(v->name)] = {
                  {"class", std::string(to_string(h.cls))},
                  {"t", h.has_t() ? json(hex_double(h.t)) : json(nullptr)}};
            }
            std::cout << out.dump() << "\n";
          },
          [&](const CaseError& e) {
            ++errors;
            std::cerr << "rayproof: " << e.to_string() << "\n";
          });
      if (in_file == 0 && errors == 0) {
        ++errors;
        std::cerr << "rayproof: " << file << ": no cases in file\n";
      }
    }
    std::cout.flush();
    std::cerr << "rayproof intersect: " << cases << " cases, " << errors << " unreadable\n";
    exit_code = errors > 0 ? 1 : 0;
  });
}

}  // namespace rayproof::cli
