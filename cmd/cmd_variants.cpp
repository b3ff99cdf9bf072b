// rayproof variants: every intersection variant, its shape and its source.
#include <iostream>

#include "commands.h"
#include "rayproof/core/batch.h"

namespace rayproof::cli {

void add_variants_command(CLI::App& app, int& exit_code) {
  auto shapes = std::make_shared<std::vector<std::string>>();
  auto* cmd = app.add_subcommand("variants", "List every intersection variant, its shape and its source");
  add_shapes_flag(cmd, *shapes);
  cmd->callback([shapes, &exit_code] {
    const std::vector<ShapeKind> chosen = parse_shapes(*shapes);
    auto listed = [&](ShapeKind k) { return std::find(chosen.begin(), chosen.end(), k) != chosen.end(); };
    for (const Variant& v : all_variants())
      if (listed(v.shape)) std::cout << v.name << "\t" << to_string(v.shape) << "\t" << v.source << "\n";
    for (const BatchedVariant& b : batched_variants())
      if (listed(b.shape))
        std::cout << b.name << "\t" << to_string(b.shape) << "\tstructure-of-arrays form of " << b.scalar
                  << ", bit-identical (nearest rule; used by trade and the benchmarks)\n";
    exit_code = 0;
  });
}

}  // namespace rayproof::cli
