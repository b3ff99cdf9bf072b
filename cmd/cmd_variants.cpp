// rayproof variants: every intersection variant, its shape and its source.
#include <iostream>

#include "commands.h"
#include "rayproof/core/batch.h"

namespace rayproof::cli {

void add_variants_command(CLI::App& app, int& exit_code) {
  auto shapes = std::make_shared<std::vector<std::string>>();
  auto ext = std::make_shared<ExternalFlags>();
  auto tracer_flags = std::make_shared<TracerFlags>();
  auto* cmd = app.add_subcommand("variants", "List every intersection variant, its shape and its source");
  cmd->add_option("--shapes,--shape", *shapes,
                  "shapes, comma separated: sphere, plane, triangle, box, mesh (the tracers), all");
  add_external_flags(cmd, *ext);
  add_tracer_flags(cmd, *tracer_flags);
  cmd->callback([shapes, ext, tracer_flags, &exit_code] {
    load_externals(*ext);
    load_tracers(*tracer_flags, ext->case_timeout);
    // `mesh` (the shape this list gives tracers) names the tracers; the other shapes, variants.
    std::vector<std::string> names = split_list(*shapes);
    const bool mesh = std::erase(names, "mesh") > 0;
    const bool all = shapes->empty() || std::find(names.begin(), names.end(), "all") != names.end();
    // (Without `mesh`, the list as given: an empty one is refused, as every command refuses it.)
    const std::vector<ShapeKind> chosen =
        mesh && names.empty() ? std::vector<ShapeKind>{} : parse_shapes(mesh ? names : *shapes);
    auto listed = [&](ShapeKind k) { return std::find(chosen.begin(), chosen.end(), k) != chosen.end(); };
    // NAME<TAB>SHAPE<TAB>PRECISION<TAB>SOURCE: double, float, or exact (the oracle's own).
    for (const Variant& v : all_variants()) {
      if (!std::any_of(chosen.begin(), chosen.end(), [&](ShapeKind k) { return v.handles(k); })) continue;
      std::cout << v.name << "\t" << shapes_answered(v) << "\t" << (v.is_oracle ? "exact" : to_string(v.precision))
                << "\t" << v.source;
      if (v.origin != "built-in")
        std::cout << " [" << v.origin << ", " << to_string(v.precision)
                  << (v.fixed_rule ? ", " + std::string(to_string(*v.fixed_rule)) : std::string()) << "]";
      std::cout << " (range: " << to_string(v.range) << ")\n";  // verdicts.md §1
    }
    for (const BatchedVariant& b : batched_variants())
      if (listed(b.shape))
        std::cout << b.name << "\t" << to_string(b.shape) << "\tdouble\tstructure-of-arrays form of " << b.scalar
                  << ", bit-identical (nearest rule; used by trade and the benchmarks)\n";
    // Whole tracers (tracer.md): NAME, "mesh", PRECISION, SOURCE; listed for `mesh`, `all` or no --shapes.
    if (all || mesh)
      for (const Tracer* t : all_tracers()) {
        std::cout << t->name << "\tmesh\t" << to_string(t->precision) << "\t" << t->source;
        if (t->origin != "built-in") std::cout << " [" << t->origin << "]";
        std::cout << " (range: " << to_string(t->range) << ")";  // verdicts.md §1
        std::cout << "\n";
      }
    exit_code = 0;
  });
}

}  // namespace rayproof::cli
