// rayproof render SCENE -o OUT.png: the scene through the chosen variants.
#include <chrono>
#include <iostream>
#include <mutex>

#include "commands.h"
#include "rayproof/core/render.h"
#include "rayproof/core/timing.h"

namespace rayproof::cli {

void add_render_command(CLI::App& app, int& exit_code) {
  struct Options {
    std::string scene, output, rule = "nearest";
    std::vector<std::string> variants;
    int threads = 0;
    ExternalFlags ext;
  };
  auto opts = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("render", "Render a scene file to PNG or PPM");
  cmd->add_option("scene", opts->scene, "scene file (docs/spec/scene.md)")->required();
  cmd->add_option("-o,--output", opts->output, "output image, .png or .ppm")->required();
  cmd->add_option(
      "--variants,--variant", opts->variants,
      "one variant per shape, comma separated or repeated (default: stable, direct, watertight, robust-slab)");
  add_rule_flag(cmd, opts->rule);
  add_external_flags(cmd, opts->ext);
  add_threads_flag(cmd, opts->threads);
  cmd->callback([opts, &exit_code] {
    load_externals(opts->ext);
    if (!is_image_path(opts->output))
      throw CLI::ValidationError("--output",
                                 "'" + opts->output + "': the image type comes from the extension, .png or .ppm");
    RenderOptions ro;
    std::array<const Variant*, 4> chosen{};
    if (!opts->variants.empty())
      for (const Variant* v : parse_variants(opts->variants)) {
        const Variant*& slot = chosen[static_cast<int>(v->shape)];
        if (slot)
          throw CLI::ValidationError("--variants", "two " + std::string(to_string(v->shape)) + " variants, " +
                                                       std::string(slot->name) + " and " + std::string(v->name) +
                                                       ": a render uses one per shape");
        slot = v;
        ro.intersectors.use(v->name);
      }
    ro.intersectors.rule = parse_rule(opts->rule);
    ro.threads = opts->threads;
    const Scene scene = load_scene(opts->scene);
    refuse_output_over_input(opts->output, {opts->scene});
    AtomicFile output(opts->output);  // before the work: a path that cannot be written fails now
    Progress progress("render " + opts->scene);
    std::mutex mutex;
    ro.progress = [&](int done, int total) {
      std::lock_guard lock(mutex);
      progress.update(done, total);
    };
    const Stopwatch watch;
    const Image image = render(scene, ro);
    progress.finish();
    const double seconds = watch.seconds();
    write_image(image, output);
    std::cerr << "rayproof render: " << opts->output << " (" << image.width << "x" << image.height << ", " << seconds
              << " s)\n";
    exit_code = 0;
    for (const Variant* v : ro.intersectors.by_shape)  // external code that stopped drew misses from then on
      if (v && v->external && !v->external->stop_reason().empty()) {
        std::cerr << "rayproof render: " << v->name << " stopped (" << v->external->stop_reason()
                  << "): pixels after that point show misses for it\n";
        exit_code = 1;
      }
  });
}

}  // namespace rayproof::cli
