// rayproof offsets SCENE|MESH -o DIR: the spawn offset a scene requires, proved (docs/spec/offsets.md).
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <memory>
#include <stdexcept>

#include "commands.h"
#include "rayproof/core/atomic_file.h"
#include "rayproof/core/geometry.h"
#include "rayproof/core/json_fields.h"
#include "rayproof/core/mesh.h"
#include "rayproof/studies/offsets.h"

namespace rayproof::cli {

namespace {
bool is_mesh_path(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".off" || ext == ".obj" || ext == ".ply" || ext == ".stl";
}
// A mesh file alone: a scene of that mesh, seen from a diagonal (for the picture), a light at the eye.
Scene scene_of_mesh(const std::string& path) {
  const Mesh mesh = load_mesh(path);
  Bounds box;
  for (const Triangle& t : mesh.triangles)
    for (const Vec3& v : t.v) box.grow(v);
  const Vec3 centre = (box.lo + box.hi) / 2;
  const double size = (box.hi - box.lo).stableNorm();  // no overflow for coordinates near the largest double
  const Vec3 eye = centre + 1.6 * size * Vec3(0.35, 0.45, 1).normalized();
  if (!all_finite(eye))
    throw std::runtime_error(path + ": the mesh is too large to place a camera and light beside it (" +
                             "its bounding box's diagonal exceeds the largest double)");
  const json scene = {
      {"camera",
       {{"eye", {eye.x(), eye.y(), eye.z()}},
        {"look_at", {centre.x(), centre.y(), centre.z()}},
        {"up", {0, 1, 0}},
        {"fov_deg", 40},
        {"width", 320},
        {"height", 240}}},
      {"lights", json::array({{{"type", "point"}, {"position", {eye.x(), eye.y(), eye.z()}}, {"intensity", 1}}})},
      // The scene's files are resolved from its own directory: the mesh's, here.
      {"objects",
       json::array({{{"type", "mesh"}, {"file", std::filesystem::path(path).filename().string()}, {"id", "mesh"}}})}};
  return parse_scene(json_text(scene), path);
}
}  // namespace

void add_offsets_command(CLI::App& app, int& exit_code) {
  struct Options {
    std::string scene, dir, domain = "scene", rule = "nearest";
    std::vector<std::string> variants, rules;
    std::uint64_t rays = 10000, seed = 1;
    int threads = 0, log2_scale = 0;
    ExternalFlags ext;
  };
  auto opts = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("offsets", "The spawn offset a scene requires, proved: bounds, witnesses, rules");
  cmd->add_option("scene", opts->scene, "scene file (docs/spec/scene.md) or a mesh (.off, .obj, .ply, .stl)")
      ->required();
  cmd->add_option("-o,--output", opts->dir, "output directory: offsets.json, offsets-cases.jsonl, report.html")
      ->required();
  add_variants_flag(cmd, opts->variants);
  cmd->add_option("--rules", opts->rules,
                  "offset rules, comma separated: fixed:EPS, ulps:N, pbrt, waechter-binder, proved "
                  "(default fixed:1e-4,ulps:32,pbrt,waechter-binder,proved)");
  cmd->add_option("--domain", opts->domain, "scene: origins in the scene's box (default); all: anywhere")
      ->check(CLI::IsMember({"scene", "all"}));
  add_count_flag(cmd, opts->rays, "witness rays per variant, spread over its primitives", std::uint64_t(1) << 34);
  cmd->add_option("--log2-scale", opts->log2_scale, "scale the scene by 2^K about the origin first (exact)")
      ->check(CLI::Range(-200, 200));
  add_rule_flag(cmd, opts->rule);
  add_seed_flag(cmd, opts->seed);
  add_threads_flag(cmd, opts->threads);
  add_external_flags(cmd, opts->ext);
  cmd->callback([opts, &exit_code] {
    load_externals(opts->ext);
    studies::OffsetsOptions options;
    if (!opts->rules.empty()) {
      options.rules.clear();
      for (const std::string& r : split_list(opts->rules)) {
        try {
          options.rules.push_back(parse_offset_rule(r));
        } catch (const std::invalid_argument& e) {
          throw CLI::ValidationError("--rules", e.what());
        }
      }
    }
    options.domain_all = opts->domain == "all";
    options.rays = opts->rays;
    options.seed = opts->seed;
    options.threads = thread_count(opts->threads);
    options.rule = parse_rule(opts->rule);

    Scene scene = is_mesh_path(opts->scene) ? scene_of_mesh(opts->scene) : load_scene(opts->scene);
    if (opts->log2_scale != 0) scene = scaled(scene, opts->log2_scale);
    for (const std::string& w : scene.warnings) std::cerr << "rayproof offsets: warning: " << printable(w) << "\n";
    const SceneIndex index(scene);
    std::vector<ShapeKind> shapes = index.shapes_used();
    std::vector<const Variant*> variants = parse_variants(opts->variants, shapes);
    if (opts->variants.empty())  // by default the built-in formulas, not the oracle nor the batched twins
      std::erase_if(variants,
                    [](const Variant* v) { return v->is_oracle || std::string_view(v->name).ends_with("-batch"); });
    if (variants.empty()) throw std::runtime_error("no variant for the scene's shapes");

    if (std::filesystem::exists(opts->dir) && !std::filesystem::is_directory(opts->dir))
      throw std::runtime_error(printable(opts->dir) + ": exists and is not a directory");
    std::filesystem::create_directories(opts->dir);
    const std::filesystem::path dir(opts->dir);
    AtomicFile json_out((dir / "offsets.json").string()), cases_out((dir / "offsets-cases.jsonl").string()),
        html_out((dir / "report.html").string());  // opened first: an unwritable directory fails now

    Progress progress("rayproof offsets");
    options.progress = [&progress](std::size_t done, std::size_t total) { progress.update(long(done), long(total)); };
    const auto started = std::chrono::steady_clock::now();
    const studies::OffsetsReport report = studies::run_offsets(index, opts->scene, variants, options);
    progress.finish();

    studies::write_offsets_json(report, index, json_out.stream());
    std::uint64_t unsafe_cases = 0, contradictions = 0;
    for (const studies::VariantOffsets& v : report.variants) {
      for (const json& c : v.unsafe_cases) cases_out.stream() << json_text(c) << "\n";
      unsafe_cases += v.unsafe_cases.size();
      contradictions += v.contradictions;
    }
    html_out.stream() << studies::offsets_html(report, index);
    json_out.commit();
    cases_out.commit();
    html_out.commit();
    for (const std::string& line : studies::offsets_summary_lines(report)) std::cout << line << "\n";
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    std::cerr << "rayproof offsets: " << report.variants.size() << " variants in " << seconds << " s; " << unsafe_cases
              << " unsafe witnesses; results in " << printable(opts->dir)
              << "/ (offsets.json, offsets-cases.jsonl, report.html)\n";
    if (contradictions > 0) {
      std::cerr << "rayproof offsets: " << contradictions
                << " witnesses contradict a proved bound: a bug in rayproof's derivation (please report it)\n";
      exit_code = 1;
      return;
    }
    exit_code = 0;
  });
}

}  // namespace rayproof::cli
