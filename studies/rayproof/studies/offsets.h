// `rayproof offsets` (docs/spec/offsets.md): for each primitive of a scene and each variant, the
// proved bound on how far its computed hit point lies off the surface (verify/offset_bounds.h),
// the worst ray an adversarial search finds (its distance decided exactly), and each offset
// rule's verdict: safe (proved), unsafe (a re-hit, checked by the oracle, written as a case that
// `check` replays) or unproved.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "rayproof/core/json_fields.h"
#include "rayproof/core/scene.h"
#include "rayproof/core/scene_index.h"
#include "rayproof/verify/offset_bounds.h"

namespace rayproof::studies {

using nlohmann::ordered_json;

struct OffsetsOptions {
  std::vector<OffsetRule> rules = default_offset_rules();
  bool domain_all = false;     // --domain all: origins anywhere (bounds become infinite)
  std::uint64_t rays = 10000;  // witness rays per variant, spread over its primitives
  std::uint64_t seed = 1;
  int threads = 1;
  HitRule rule = HitRule::nearest_contact;
  std::function<void(std::size_t done, std::size_t total)> progress;  // from worker 0 only
};

enum class OffsetVerdict { safe, unsafe, unproved };
std::string_view to_string(OffsetVerdict v);

// A ray of the search and the point the variant computed for it.
struct OffsetWitness {
  Ray ray;  // as the variant saw it (rounded to float for a float variant)
  double t = 0;
  Vec3 point;           // o + t·d in the variant's precision
  double distance = 0;  // its exact signed distance to the surface, rounded: > 0 on the side the ray came from
  Vec3 normal;          // the unit normal toward that side
};

struct PrimitiveOffsets {
  std::int32_t primitive = 0;  // the scene's primitive id (SceneIndex)
  std::optional<OffsetProof> proof;
  double proved_offset = INFINITY;        // the smallest offset `proved` may use, along the normal
  double required_ulps = INFINITY;        // proved_offset in ulps of the point's largest coordinate, at its smallest
  std::optional<OffsetWitness> farthest;  // the largest |distance| found
  std::optional<OffsetWitness> deepest;   // the most negative distance (behind the surface)
  std::uint64_t rays = 0, hits = 0, outside_domain = 0;
  std::vector<OffsetVerdict> verdicts;  // per rule, in options' order
  // A witness farther than the proved bound, or a re-hit where a rule was proved safe: each a
  // bug in the derivation (the tests look for them).
  std::uint64_t beyond_bound = 0, rehit_where_safe = 0;
};

struct RuleSummary {
  OffsetRule rule;
  std::uint64_t safe = 0, unsafe = 0, unproved = 0;
  std::optional<json> witness;  // the first unsafe case
  OffsetVerdict verdict() const;
};

struct VariantOffsets {
  const Variant* variant = nullptr;
  Precision precision = Precision::f64;
  bool derived = false;  // offset_proof knows its formula
  std::vector<PrimitiveOffsets> primitives;
  std::vector<RuleSummary> rules;
  std::vector<json> unsafe_cases;  // every unsafe witness, as a case with found.rule
  std::uint64_t contradictions = 0;
  double seconds = 0;
  double needs_ulps_at_most() const;  // the largest required_ulps over proved primitives
};

struct OffsetsReport {
  std::string scene_name, domain;
  Bounds box;  // the domain's origins
  std::vector<VariantOffsets> variants;
};

// The scene's box (its bounded primitives, the camera's eye and the lights); throws when empty.
Bounds offsets_scene_box(const SceneIndex& index);

OffsetsReport run_offsets(const SceneIndex& index, const std::string& scene_name,
                          const std::vector<const Variant*>& variants, const OffsetsOptions& options);

// offsets.json (offsets.md), offsets-cases.jsonl's lines, report.html, and the stdout lines.
void write_offsets_json(const OffsetsReport& report, const SceneIndex& index, std::ostream& out);
std::string offsets_html(const OffsetsReport& report, const SceneIndex& index);
std::vector<std::string> offsets_summary_lines(const OffsetsReport& report);

// Where `proved` spawns from a hit at t of `ray` on `shape` (n: the unit normal toward the side
// the new ray leaves to): the variant's computed point moved by the primitive's proved offset;
// nullopt where the variant's formula has no derivation (`audit --offset proved`).
std::optional<Vec3> proved_spawn_origin(const Variant& v, const Shape& shape, const Bounds& scene_box, const Ray& ray,
                                        double t, const Vec3& n);
// The largest proved offset in ulps over the scene's primitives of v's shape (what `audit`
// reports), or nullopt where v's formula has no derivation.
std::optional<double> scene_needs_ulps(const SceneIndex& index, const Variant& v, const Bounds& scene_box);

// The bracket bound / |witness distance| of each primitive with both (how tight the proof is).
std::vector<double> offset_brackets(const VariantOffsets& v);

}  // namespace rayproof::studies
