// rayproof intersect FILE...: every chosen variant on every case, as JSON lines.
#include <iostream>

#include "commands.h"
#include "rayproof/core/casefile.h"

namespace rayproof::cli {

void add_intersect_command(CLI::App& app, int& exit_code) {
  struct Options {
    std::vector<std::string> files, variants, shapes;
    std::string rule = "nearest";
    ExternalFlags ext;
  };
  auto opts = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("intersect", "Run double-precision variants on case files (JSON lines on stdout)");
  cmd->add_option("files", opts->files, "case files (JSON Lines, docs/spec/cases.md)")->required();
  add_variants_flag(cmd, opts->variants);
  add_external_flags(cmd, opts->ext);
  add_shapes_flag(cmd, opts->shapes);
  add_rule_flag(cmd, opts->rule);
  cmd->callback([opts, &exit_code] {
    load_externals(opts->ext);
    const auto variants = parse_variants(opts->variants, parse_shapes(opts->shapes));
    const HitRule rule = parse_rule(opts->rule);
    long errors = 0, cases = 0, unopened = 0;
    for (const std::string& file : opts->files) {
      long in_file = 0, errors_before = errors;
      const bool opened = read_case_file(
          file,
          [&](const Case& c, long) {
            ++cases, ++in_file;
            json out = {{"id", c.id}, {"variants", json::object()}};
            for (const Variant* v : variants) {
              if (!v->handles(kind_of(c.shape))) continue;
              const Answer h = v->intersect(c.ray, c.shape, rule);
              if (h.failed()) {  // external code that gave no answer (docs/spec/plugin.md)
                out["variants"][std::string(v->name)] = {{"error", std::string(to_string(h.failure))}};
                continue;
              }
              out["variants"][std::string(v->name)] = {{"class", std::string(to_string(h.cls))},
                                                       {"t", h.has_t() ? json(hex_double(h.t)) : json(nullptr)}};
            }
            std::cout << json_text(out) << "\n";
          },
          [&](const CaseError& e) {
            ++errors;
            std::cerr << "rayproof: " << e.to_string() << "\n";
          });
      if (!opened) ++unopened;
      if (opened && in_file == 0 && errors == errors_before) {
        ++errors;
        std::cerr << "rayproof: " << printable(file) << ": no cases in file\n";
      }
    }
    std::cout.flush();
    std::cerr << "rayproof intersect: " << cases << " cases, " << errors << " unreadable\n";
    exit_code = unopened > 0 ? 2 : errors > 0 ? 1 : 0;
  });
}

}  // namespace rayproof::cli
