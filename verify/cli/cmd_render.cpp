// rayproof render SCENE -o OUT.png: the scene through the chosen variants.
#include <chrono>
#include <iostream>
#include <mutex>

#include "cli/commands.h"
#include "rayproof/render.h"

namespace rayproof::cli {

void add_render_command(CLI::App& app, int& exit_code) {
  struct Options {
    std::string scene, output, rule = "nearest";
    std::vector<std::string> variants;
    int threads = 0;
  };
  auto opts = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("render", "Render a scene file to PNG or PPM");
  cmd->add_option("scene", opts->scene, "scene file (shared/spec/scene.md)")->required();
  cmd->add_option("-o,--output", opts->output, "output image, .png or .ppm")->required();
  cmd->add_option("--variant", opts->variants, "variant to use for its shape (repeatable; default: stable, direct, watertight, robust-slab)");
  cmd->add_option("--rule", opts->rule, "hit rule")->check(CLI::IsMember({"nearest", "enter-only"}));
  cmd->add_option("--threads", opts->threads, "worker threads (default: all cores)")->check(CLI::Range(0, 256));
  cmd->callback([opts, &exit_code] {
    if (!is_image_path(opts->output))
      throw CLI::ValidationError("--output", "'" + opts->output + "': the image type comes from the extension, .png or .ppm");
    RenderOptions ro;
    if (!opts->variants.empty())
      for (const Variant* v : resolve_variants(opts->variants)) ro.intersectors.use(v->name);
    ro.intersectors.rule = *hit_rule_from_string(opts->rule);
    ro.threads = opts->threads;
    const Scene scene = load_scene(opts->scene);
    Progress progress("render " + opts->scene);
    std::mutex mutex;
    ro.progress = [&](int done, int total) {
      std::lock_guard lock(mutex);
      progress.update(done, total);
    };
    const auto start = std::chrono::steady_clock::now();
    const Image image = render(scene, ro);
    progress.finish();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    write_image(image, opts->output);
    std::cerr << "rayproof render: " << opts->output << " (" << image.width << "x" << image.height << ", "
              << seconds << " s)\n";
    exit_code = 0;
  });
}

}  // namespace rayproof::cli
