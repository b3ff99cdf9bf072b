// rayproof audit (docs/spec/audit.md): a scene rendered with the exact oracle and with every
// variant of every shape it uses, each variant's shape by that variant and the other shapes
// judged exactly, so every count belongs to that variant alone; the cheapest variant exact for
// the scene per shape; and, with headroom, how far the scene may move from the origin.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "rayproof/core/mesh_case.h"
#include "rayproof/core/render.h"
#include "rayproof/core/scene.h"
#include "rayproof/core/tracer.h"
#include "rayproof/core/variants.h"

namespace rayproof::studies {

// The headroom translations: 2^k·(1, 0.75, 0.5) for k = 0, 2, …, 62.
std::vector<int> headroom_exponents();
Vec3 headroom_offset(int k);

struct SceneAuditOptions {
  std::vector<const Variant*> variants;  // those of shapes the scene does not use are left out
  // Whole tracers (docs/spec/tracer.md): each draws every triangle of the scene (its meshes, with
  // their vertices shared as in their files, and lone triangles), the other shapes exact.
  std::vector<const Tracer*> tracers;
  bool headroom = false;
  // Shadow rays of the built-in variants start from the proved offset (offsets.md, `--offset
  // proved`) instead of pbrt's error bound (double) or Wächter & Binder's (float).
  bool spawn_proved = false;
  int threads = 0;  // 0: every hardware thread
  // Called from the calling thread between and within stages (for a progress line).
  std::function<void(const std::string& stage, long done, long total)> progress;
};

// The pixel counts of one variant (audit.md, "What is compared"). Each wrong pixel is a hole or a
// false hit (the variant's nearest t at or beyond the exact one, or the background: hole; nearer,
// or where the exact ray meets nothing: false hit). Shadows are compared on pixels whose visible
// object is right, for each light the exact hit point faces; acne is the part of shadow_wrong
// where the variant's ray is blocked by the primitive it left or a neighbour and the exact one
// is not blocked.
struct PixelCounts {
  long wrong = 0, holes = 0, false_hits = 0, shadow_wrong = 0, acne = 0;
  // shadow_wrong by direction (a pixel with two lights may be both): the variant's shadow ray
  // blocked where the exact one reaches the light, and the reverse.
  long wrongly_shadowed = 0, wrongly_lit = 0;
  // A whole tracer's pixels whose answer no ray can have (NaN or non-positive t, a triangle out of
  // range): its errors, never counted as holes (issue 42).
  long tracer_errors = 0;
  PixelCounts& operator+=(const PixelCounts& o);
  // Pixels with anything wrong (wrong, shadow_wrong and tracer_errors never count the same pixel).
  long any_wrong() const { return wrong + shadow_wrong + tracer_errors; }
};

// A wrong pixel as a case (docs/spec/cases.md), so `rayproof check` replays what decided it: the
// pixel's primary ray and the primitive it should have hit (a hole) or wrongly hit (a false hit),
// or its shadow ray and the primitive that wrongly blocked it or should have; a shadow error with
// no such primitive of the variant's shape is the primary ray and the primitive it hit (the hit
// point, and so the shadow ray's start, is where the variant went wrong). One per pixel and light.
struct WrongPixelCase {
  int x = 0, y = 0;
  std::string kind;         // "hole", "false_hit", "acne", "wrongly_shadowed", "wrongly_lit"
  int light = -1;           // the light of a shadow error (scene.md's lights, from 0), else −1
  bool shadow_ray = false;  // `ray` is the shadow ray, else the pixel's primary ray
  Ray ray;
  std::int32_t primitive = -1;  // the scene's primitive (audit's index) and its shape
  Shape shape;
};
// At most this many cases per variant, in pixel order (the rest are counted).
inline constexpr std::size_t kMaxCasesPerVariant = 256;
// At most this many mesh cases per tracer (each costs the tracer's rebuilds while it is shrunk),
// spread evenly over its wrong primary pixels.
inline constexpr std::size_t kMaxMeshCasesPerTracer = 8;

struct VariantAudit {
  const Variant* variant = nullptr;     // or
  const Tracer* tracer = nullptr;       // a whole tracer, drawing the triangles
  std::string name, precision, origin;  // the variant's or tracer's
  ShapeKind shape = ShapeKind::sphere;  // the shape it drew (an --exec command answers several)
  // The row's name: the variant's, with "@shape" for an --exec command audited on several
  // shapes; file names and headroom keys use it.
  std::string label;
  PixelCounts counts;
  // Primary rays against the scene's primitives of its shape, one thread; NaN (null in
  // audit.json) for external code that stopped.
  double ns_per_ray = 0;
  // External code: ns_per_ray is rayproof's traversal plus the time the code spent in its worker
  // (timed_in_worker; an --exec command cannot be timed there and is charged its round trips);
  // round_trip_ns_per_ray is the same frame's wall time, the pipe included.
  double round_trip_ns_per_ray = 0;
  bool timed_in_worker = false;
  bool users_code() const { return origin != "built-in"; }
  Image render, diff;                 // the variant's render; wrong pixels over the dimmed exact render
  std::vector<WrongPixelCase> cases;  // a variant's wrong pixels
  // A whole tracer's wrong primary pixels as mesh cases (tracer.md, "Mesh findings"), judged on
  // the scene's triangles as one mesh, each shrunk to the fewest triangles that still show its kind
  // and level; `check --tracers NAME` replays them. Shadow errors are counted, not written: a
  // shadow ray starts at a computed hit point, and what it meets there is `rayproof offsets`' question.
  std::vector<MeshCase> mesh_cases;
  long cases_left_out = 0;              // wrong pixels not written (past the cap)
  long pixels_right_as_mesh_cases = 0;  // a tracer's wrong pixels whose mesh case the judge calls right
  std::string stopped;                  // external code that stopped: why (its later answers are misses)
  // A variant that stopped (crash, hang, protocol error) left pixels unjudged: never exact.
  bool exact_for_scene() const { return counts.any_wrong() == 0 && stopped.empty(); }
  // Headroom: pixels wrong or shadow wrong (what exact_for_scene counts) per exponent of
  // headroom_exponents() (−1: not rendered, because an earlier exponent already had some, or
  // the scene collapsed). exact_up_to is set only for a variant exact for the scene itself.
  std::vector<long> headroom_wrong;
  std::optional<int> exact_up_to_log2_translate, first_wrong_log2_translate;
  // The scene's proved spawn offset for this variant (`rayproof offsets`): the largest over its
  // primitives, in ulps of the point's largest coordinate; nullopt without a derivation.
  std::optional<double> proved_offset_ulps;
};

struct SceneAudit {
  int width = 0, height = 0;
  std::vector<ShapeKind> shapes;
  long primary_rays = 0, shadow_rays = 0;
  double exact_seconds = 0;
  // Exact rays whose decisions needed more than the static filter and intervals (expansions or
  // rationals), primary and shadow; hit points for shading are always computed in rationals.
  long rays_beyond_intervals = 0;
  Image exact;
  std::vector<VariantAudit> variants;
  // Per shape: the cheapest exact row; nullptr where none is (or none of that shape was audited,
  // which `audited` tells).
  struct Recommendation {
    ShapeKind shape;
    const VariantAudit* best = nullptr;
    bool audited = false;
    // Other exact rows within 10% of best's cost: timing noise can order these either way.
    std::vector<const VariantAudit*> close;
  };
  std::vector<Recommendation> recommendation;
  bool headroom = false;
  // Per headroom exponent rendered: pixels whose exact visible object differs from the scene's
  // own (untranslated) exact render. Where this grows, rounding to doubles has changed the scene
  // itself, and a variant's headroom beyond that point says little.
  std::vector<long> headroom_scene_changed;
  // The first exponent at which translating dropped triangles as degenerate: the scene is no
  // longer itself, so no exponent from there on is rendered (their warnings say how many).
  std::optional<int> headroom_collapsed_at;
  std::vector<std::string> warnings;
};

// Per shape: the cheapest row exact for the scene, and the other exact rows within 10% of its
// cost (pointers into `rows`).
std::vector<SceneAudit::Recommendation> recommend(const std::vector<VariantAudit>& rows,
                                                  const std::vector<ShapeKind>& shapes);

// Throws std::runtime_error for a scene the audit cannot take (more than 64 lights).
SceneAudit audit_scene(const Scene& scene, const SceneAuditOptions& options);

// DIR/audit.json, DIR/exact.png, DIR/VARIANT.png, DIR/VARIANT-diff.png, DIR/VARIANT-cases.jsonl
// (variants with wrong pixels), DIR/report.html and (with headroom) DIR/headroom.svg, each written
// atomically. `scene_path` is what audit.json's "scene" says.
void write_scene_audit(const SceneAudit& audit, const std::string& scene_path, const std::string& dir);

// The marks of the diff images (distinct from any dimmed pixel: each has a channel of 255,
// the dimmed exact render stays below 80).
inline constexpr std::array<std::uint8_t, 3> kHoleColour{255, 0, 0}, kFalseHitColour{0, 160, 255},
    kShadowColour{255, 255, 0}, kAcneColour{255, 128, 0};
inline constexpr double kDiffDimming = 0.3;

// Each row's file stem (STEM.png, STEM-diff.png, STEM-cases.jsonl): its label made a file name,
// made unique against the other rows and the audit's own files.
std::vector<std::string> audit_file_stems(const SceneAudit& audit);
// The command that replays a variant's wrong pixels from `cases_path`.
std::string cases_replay_command(const VariantAudit& va, const std::string& cases_path);
// Per row of users' code (plugins, exec commands, tracers), one sentence: exact for the scene or
// not, and what it costs, saying where it was timed.
std::vector<std::string> users_code_verdicts(const SceneAudit& audit);

// The report page alone (self-contained HTML, images inline as data: URIs).
std::string scene_audit_html(const SceneAudit& audit, const std::string& scene_path);

}  // namespace rayproof::studies
