// rayproof audit SCENE -o DIR: which variant does this scene require (docs/spec/audit.md).
#include <unistd.h>

#include <chrono>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "commands.h"
#include "rayproof/core/atomic_file.h"
#include "rayproof/core/json_fields.h"
#include "rayproof/studies/scene_audit.h"
#include "rayproof/studies/markup.h"
#include "rayproof/studies/svg.h"

namespace rayproof::cli {

namespace {
// An audit keeps per pixel the exact hit, each contender's hit, shadows and images: measured at
// 115-133 bytes per pixel for 1-4 variants on a diffuse 1024x1024 scene, so 128 + 16 per
// contender, times the samples per pixel. A scene that needs more than the machine has free is
// refused with the number before anything is rendered, not ended by std::bad_alloc after.
void refuse_beyond_memory(const Scene& scene, std::size_t contenders) {
  const double pixels = double(scene.camera.width) * scene.camera.height * std::max(1, scene.samples);
  const double needed = pixels * (128.0 + 16.0 * double(contenders));
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  double available_kb = 0;
  for (double value; meminfo >> key >> value;) {
    if (key == "MemAvailable:") available_kb = value;
    meminfo.ignore(64, '\n');
  }
  if (available_kb > 0 && needed > available_kb * 1024) {
    char message[320];
    std::snprintf(message, sizeof message,
                  "an audit of %dx%d pixels (%d samples each) with %zu variants needs about %.1f GB, and this machine "
                  "has %.1f GB available: lower camera.width and camera.height, or audit fewer variants",
                  scene.camera.width, scene.camera.height, std::max(1, scene.samples), contenders, needed / 1e9,
                  available_kb * 1024 / 1e9);
    throw std::runtime_error(message);
  }
}
}  // namespace

void add_audit_command(CLI::App& app, int& exit_code) {
  struct Options {
    std::string scene, dir;
    std::vector<std::string> variants;
    bool headroom = false;
    std::string offset = "default";
    int threads = 0;
    ExternalFlags ext;
    TracerFlags tracer_flags;
  };
  auto opts = std::make_shared<Options>();
  auto* cmd = app.add_subcommand(
      "audit", "Render a scene exactly and with every variant of its shapes: which variant does it require?");
  cmd->add_option("scene", opts->scene, "scene file (docs/spec/scene.md, meshes as docs/spec/audit.md)")->required();
  cmd->add_option("-o,--output", opts->dir,
                  "output directory: audit.json, exact.png, VARIANT.png, VARIANT-diff.png, report.html")
      ->required();
  add_variants_flag(cmd, opts->variants);
  cmd->add_flag("--headroom", opts->headroom, "also translate the scene by 2^k·(1, 0.75, 0.5), k = 0, 2, …, 62");
  cmd->add_option("--offset", opts->offset,
                  "where shadow rays start: default (pbrt's error bound for double code, Waechter & Binder's "
                  "for float) or proved (the scene's proved offset, rayproof offsets)")
      ->check(CLI::IsMember({"default", "proved"}));
  add_external_flags(cmd, opts->ext);
  add_tracer_flags(cmd, opts->tracer_flags);
  add_threads_flag(cmd, opts->threads);
  cmd->callback([opts, &exit_code] {
    load_externals(opts->ext);
    load_tracers(opts->tracer_flags, opts->ext.case_timeout);
    // Audits count wrong pixels; they do not split bugs from rounding yet (verdicts.md, README).
    if (opts->tracer_flags.fail_on != "none")
      throw std::runtime_error(
          "--fail-on: audit does not split bugs from rounding-level disagreements yet; "
          "use fuzz or check on the tracer");
    const Scene scene = load_scene(opts->scene);
    for (const std::string& w : scene.warnings) std::cerr << "rayproof audit: warning: " << printable(w) << "\n";
    if (std::filesystem::exists(opts->dir) && !std::filesystem::is_directory(opts->dir))
      throw std::runtime_error(printable(opts->dir) + ": exists and is not a directory");
    std::filesystem::create_directories(opts->dir);
    {  // a directory that cannot be written fails now, not after the renders
      AtomicFile probe(opts->dir + "/.rayproof-write-test");
      probe.commit();
      std::filesystem::remove(opts->dir + "/.rayproof-write-test");
    }
    studies::SceneAuditOptions ao;
    ao.variants = parse_variants(opts->variants);
    if (opts->tracer_flags.given()) ao.tracers = parse_tracers(opts->tracer_flags.names);
    ao.headroom = opts->headroom;
    ao.spawn_proved = opts->offset == "proved";
    ao.threads = opts->threads;
    {  // what runs, before any wait (issue 41: 19 built-ins were re-rendered silently for minutes)
      const auto built_in = std::count_if(ao.variants.begin(), ao.variants.end(),
                                          [](const Variant* v) { return v->origin == "built-in"; });
      std::cerr << "rayproof audit: " << scene.camera.width << "x" << scene.camera.height << " pixels; "
                << ao.variants.size() << " variants (" << built_in << " built-in; --variants narrows), "
                << ao.tracers.size() << " tracers"
                << (ao.headroom ? "; --headroom: then the scene moved by 2^k, k = 0, 2, ..., 62, until all fail" : "")
                << "\n";
    }
    std::unique_ptr<Progress> progress;
    std::string stage;
    const auto started = std::chrono::steady_clock::now();
    auto last_said = started;
    ao.progress = [&](const std::string& s, long done, long total) {
      if (s != stage) {
        if (progress) progress->finish();
        stage = s;
        progress = std::make_unique<Progress>("audit: " + s);
        // Off a terminal each stage is short: say which one runs every 30 s, so no long audit is silent.
        const auto now = std::chrono::steady_clock::now();
        if (!isatty(2) && now - last_said > std::chrono::seconds(30)) {
          last_said = now;
          std::cerr << "rayproof audit: " << std::chrono::duration_cast<std::chrono::seconds>(now - started).count()
                    << " s: " << s << "\n";
        }
      }
      progress->update(done, total);
    };
    refuse_beyond_memory(scene, ao.variants.size() + ao.tracers.size());
    const studies::SceneAudit audit = studies::audit_scene(scene, ao);
    if (progress) progress->finish();
    studies::write_scene_audit(audit, opts->scene, opts->dir);

    std::cerr << "rayproof audit: " << printable(opts->scene) << ", " << audit.width << "x" << audit.height
              << ": exact render " << audit.exact_seconds << " s, " << audit.rays_beyond_intervals << " of "
              << audit.primary_rays << " pixels needed expansions or rationals\n";
    std::fprintf(stderr, "%-24s %-9s %9s %7s %7s %7s %7s %6s %s\n", "variant", "shape", "ns/ray", "wrong", "holes",
                 "false", "shadow", "acne", audit.headroom ? "exact  headroom k" : "exact");
    for (const studies::VariantAudit& va : audit.variants) {
      std::string headroom;
      if (audit.headroom)
        headroom = va.exact_up_to_log2_translate ? "  " + std::to_string(*va.exact_up_to_log2_translate) : "  none";
      const std::string cost = std::isnan(va.ns_per_ray) ? "-" : studies::markup::format("%.1f", va.ns_per_ray);
      std::fprintf(stderr, "%-24s %-9s %9s %7ld %7ld %7ld %7ld %6ld %s%s\n", va.label.c_str(),
                   std::string(to_string(va.shape)).c_str(), cost.c_str(), va.counts.wrong, va.counts.holes,
                   va.counts.false_hits, va.counts.shadow_wrong, va.counts.acne, va.exact_for_scene() ? "yes" : "no ",
                   headroom.c_str());
    }
    for (const studies::VariantAudit& va : audit.variants)
      if (va.counts.tracer_errors > 0)
        std::fprintf(stderr,
                     "%s: %ld pixels answered with a NaN or non-positive t or a triangle out of range (tracer "
                     "errors, not counted as holes)\n",
                     va.label.c_str(), va.counts.tracer_errors);
    for (const studies::VariantAudit& va : audit.variants)
      if (va.proved_offset_ulps)
        std::fprintf(stderr, "spawn offset: %s needs %.3g ulps for this scene, proved (rayproof offsets)%s\n",
                     va.label.c_str(), *va.proved_offset_ulps,
                     opts->offset == "proved" ? "; its shadow rays started there" : "; --offset proved spawns there");
    // With --headroom, each name carries its k: the cheapest exact code may be a float one that
    // stops being exact far sooner than the double ones beside it (issue 41).
    auto named = [&](const studies::VariantAudit& va) {
      if (!audit.headroom) return va.label;
      return va.label + " (k " +
             (va.exact_up_to_log2_translate ? std::to_string(*va.exact_up_to_log2_translate) : std::string("none")) +
             ")";
    };
    for (const auto& r : audit.recommendation) {
      std::cerr << "recommendation: " << to_string(r.shape) << ": "
                << (r.best ? named(*r.best)
                           : std::string(r.audited ? "none exact for this scene" : "no variant of this shape audited"));
      for (size_t i = 0; i < r.close.size(); ++i) std::cerr << (i == 0 ? "; within 10%: " : ", ") << named(*r.close[i]);
      std::cerr << "\n";
    }
    if (audit.headroom && !audit.recommendation.empty())
      std::cerr << "  (k: exact up to a translation of 2^k; the cheapest exact code first, whatever its k)\n";
    for (const std::string& v : studies::users_code_verdicts(audit)) std::cerr << "your code: " << printable(v) << "\n";
    const std::vector<std::string> stems = studies::audit_file_stems(audit);
    for (std::size_t i = 0; i < audit.variants.size(); ++i) {
      const studies::VariantAudit& va = audit.variants[i];
      const std::size_t written = va.cases.size() + va.mesh_cases.size();
      if (written == 0) continue;
      const std::string file = (std::filesystem::absolute(opts->dir) / (stems[i] + "-cases.jsonl")).string();
      std::cerr << "wrong pixels of " << printable(va.label) << (va.tracer ? " as mesh cases: " : " as cases: ")
                << written;
      if (va.cases_left_out > 0) std::cerr << " of " << written + va.cases_left_out;
      std::cerr << "; replay: " << printable(studies::cases_replay_command(va, file)) << "\n";
    }
    for (const std::string& w : audit.warnings)  // the scene's own were printed when it was loaded
      if (std::find(scene.warnings.begin(), scene.warnings.end(), w) == scene.warnings.end())
        std::cerr << "rayproof audit: warning: " << printable(w) << "\n";
    std::cerr << "rayproof audit: report " << (std::filesystem::absolute(opts->dir) / "report.html").string() << "\n";
    exit_code = 0;
    for (const studies::VariantAudit& va : audit.variants)
      if (!va.stopped.empty()) {
        std::cerr << "rayproof audit: " << va.label << " stopped (" << va.stopped << ")\n";
        exit_code = 1;
      }
  });
}

}  // namespace rayproof::cli
