// Intersection variants: each is one small named function (sources in variants.cpp) and all
// are reachable by name through one registry, which the command line, the tests and the
// benchmarks enumerate. Adding a variant = one function + one registry row.
#pragma once

#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "rayproof/core/answer.h"
#include "rayproof/core/geometry.h"
#include "rayproof/core/hit.h"
#include "rayproof/core/query.h"
#include "rayproof/core/shapes.h"

namespace rayproof {

// Sphere: roots of a t² + b t + c = 0, a = d·d, b = 2 d·(o−m), c = |o−m|² − r².
Hit sphere_textbook(const Ray& ray, const Sphere& s, HitRule rule);
Hit sphere_stable(const Ray& ray, const Sphere& s, HitRule rule);
Hit sphere_stable_fma(const Ray& ray, const Sphere& s, HitRule rule);
Hit sphere_hearn_baker(const Ray& ray, const Sphere& s, HitRule rule);
Hit plane_direct(const Ray& ray, const Plane& p, HitRule rule);
Hit triangle_moller_trumbore(const Ray& ray, const Triangle& tri, HitRule rule);
Hit triangle_watertight(const Ray& ray, const Triangle& tri, HitRule rule);
Hit triangle_watertight_top_left(const Ray& ray, const Triangle& tri, HitRule rule);
Hit box_slab(const Ray& ray, const Box& b, HitRule rule);
Hit box_robust_slab(const Ray& ray, const Box& b, HitRule rule);

// The numbers an intersector computes in. An f32 variant sees each number of a query rounded
// to the nearest float (docs/spec/plugin.md); verify/ judges exactly those numbers.
enum class Precision { f64, f32 };
std::string_view to_string(Precision p);

// Code rayproof did not write (a plugin in a worker process, an --exec command): it answers
// queries in batches, because each call crosses a process boundary, and it may fail (an Answer's
// `failure`). After a failure that stops it, it answers every later query with `stopped`.
// How one call of external code is timed where the code runs (`trade`, `audit`): it runs each
// batch `repeats` times there, on inputs then in its cache, and `inner_seconds` gets the time of
// one pass measured there (no transport), or stays negative where only the round trip can be
// timed (an --exec command, a batch with a crash). Per call, so threads never share it.
struct AnswerTiming {
  int repeats = 1;
  double inner_seconds = -1;
};

class KindIndex;  // scene_index.h

// A ray traced through one kind's primitives of a scene by one variant (render, audit, spawn):
// the nearest contact at t ≥ 0, or (`any_hit`) whether any primitive but `skip` is met at
// 0 ≤ t < 1 — a shadow segment from a hit point to a light. The leaf rules are scene_rays.h's.
struct SceneRay {
  Ray ray;
  std::int32_t skip = -1;  // a primitive never counted (the one the segment starts on)
  bool any_hit = false;
};
struct SceneRayAnswer {
  std::int32_t primitive = -1;  // the nearest (or the blocking) primitive, -1 for none
  Answer answer;                // its hit; failed(): the code died or hung on this ray (nothing is known)
};

class ExternalIntersector {
 public:
  virtual ~ExternalIntersector() = default;
  // out[i] = the answer to qs[i], in the variant's own rule. Thread-safe. `timing`: may be null.
  virtual void answer_all(std::span<const Query> qs, std::span<Answer> out, AnswerTiming* timing) = 0;
  // Traces every ray through `scene` where the code runs, rayproof's own traversal calling the
  // code at the leaves (asked as far off the ray as `reach` says, scene_rays.h): one round trip
  // per batch instead of one per leaf test. Returns false where the code cannot (can_trace()
  // false: an --exec command, an answers file): callers then ask leaf by leaf.
  // `timing`: as for answer_all, the time of the whole traversal where it ran.
  virtual bool trace_all(const KindIndex& /*scene*/, HitRule /*rule*/, std::span<const SceneRay> /*rays*/,
                         std::span<SceneRayAnswer> /*out*/, AnswerTiming* /*timing*/, double /*reach*/) {
    return false;
  }
  virtual bool can_trace() const { return false; }
  // One query asked of a fresh copy of the code (a new worker or command) that nothing else uses,
  // outside the crash budget: how a crash is shrunk, each probe free to die. Code that keeps no
  // process (an answers file) answers as answer_all does.
  virtual Answer probe(const Query& q) {
    Answer a;
    answer_all(std::span(&q, 1), std::span(&a, 1), nullptr);
    return a;
  }
  // One line: why it stopped (signal, exit status, the unreadable line), empty while it runs.
  virtual std::string stop_reason() const { return {}; }
  // Why the last crash, hang or protocol error happened, also when a fresh worker went on after it.
  virtual std::string last_failure() const { return stop_reason(); }
};

struct Variant {
  std::string_view name;  // unique over all shapes, e.g. "stable"
  ShapeKind shape;
  std::string_view source;                                     // paper or formula it follows
  Hit (*kernel)(const Ray&, const Shape&, HitRule) = nullptr;  // built-in code: the type-erased entry point
  bool is_oracle = false;  // the exact oracle's own answer (certified-*): campaigns skip it unless named
  Precision precision = Precision::f64;
  std::optional<HitRule> fixed_rule;        // external code reports one rule, whatever --rule asks
  ExternalIntersector* external = nullptr;  // set instead of kernel for plugins and --exec
  std::string_view origin = "built-in";     // where the code comes from: "built-in", a plugin path, "exec: CMD"
  bool all_shapes = false;  // an --exec command or answers file answers several shapes (`shape` is then nominal)
  unsigned shape_mask = 0;  // with all_shapes: bit k set for each ShapeKind it declared (0: every shape)
  // t = 0 admitted (`closed`) or not (`open`, the case format's t > 0): verdicts.md §1, declared
  // by --variant-range (built-ins compute t > 0: open).
  RangeRule range = RangeRule::open;

  bool handles(ShapeKind k) const {
    return all_shapes ? shape_mask == 0 || (shape_mask >> static_cast<unsigned>(k) & 1u) : shape == k;
  }

  // The rule this variant's answers follow when `asked` is requested.
  HitRule rule_for(HitRule asked) const { return fixed_rule.value_or(asked); }
  // One query (external code: a batch of one, so prefer intersect_all in loops). `timing`: for
  // external code, see AnswerTiming; built-in code ignores it.
  Answer intersect(const Ray& ray, const Shape& shape, HitRule rule, AnswerTiming* timing = nullptr) const;
  // Every query, in order; external code answers in one round trip.
  void intersect_all(std::span<const Query> qs, HitRule rule, std::span<Answer> out,
                     AnswerTiming* timing = nullptr) const;
};

// The shapes a variant answers as `rayproof variants` lists them: "sphere", "sphere,box" (an
// --exec command that declared them) or "any".
std::string shapes_answered(const Variant& v);

// Every variant: the built-ins above, then those registered at run time.
std::span<const Variant> all_variants();
// The built-in variants alone, fixed at compile time: what registration cannot change (the
// near-origin family spawns from these, so its cases do not depend on what a program registers).
std::span<const Variant> builtin_variants();
// Adds a variant from a higher layer (the oracle's certified front ends, plugins) before any
// command starts; `name`, `source` must outlive the process. Throws on a duplicate name.
const Variant& register_variant(const Variant& v);
const Variant* find_variant(std::string_view name);
// --variant-range NAME=open|closed: declares a loaded variant's range; false when no variant has
// that name. (Before any work starts: variants are shared read-only after.)
bool set_variant_range(std::string_view name, RangeRule range);
std::vector<const Variant*> variants_for(ShapeKind shape);
// The variant the renderer uses for a shape unless told otherwise.
const Variant& default_variant(ShapeKind shape);

}  // namespace rayproof
