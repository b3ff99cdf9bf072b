// The exact truth about a scene's rays (docs/spec/audit.md, "What is compared"): the nearest
// exact contact over a kind's primitives or the whole scene, exact shadow status, the exact hit
// point rounded to doubles. Every decision is the oracle's; doubles only prune the search, each
// with its bound beside it.
#pragma once

#include <cstdint>
#include <limits>

#include "rayproof/core/scene_index.h"
#include "rayproof/verify/oracle.h"

namespace rayproof {

// A contact: the primitive and its exact t rounded to nearest (primitive −1: none).
struct ExactContact {
  std::int32_t primitive = -1;
  double t = std::numeric_limits<double>::quiet_NaN();
  bool found() const { return primitive >= 0; }
};

// One per thread (it owns oracles, which count their stages).
class ExactTracer {
 public:
  explicit ExactTracer(const SceneIndex& index);

  // The nearest exact contact with t > 0 among primitives of `kind` (contacts without a t, a ray
  // lying in a plane, have no point and are passed over, as in the renderer). On an exact tie
  // the object listed first, then the lower primitive.
  ExactContact nearest(ShapeKind kind, const Ray& ray);
  ExactContact nearest(const Ray& ray);  // over every kind the scene uses
  // Whether contact a lies before b on the ray, exactly (t, then object order, then primitive);
  // a found contact is before none.
  bool before(const Ray& ray, const ExactContact& a, const ExactContact& b);

  // Whether a primitive of `kind` other than `self` meets the segment o + t·d, 0 < t < 1, exactly.
  bool blocks(ShapeKind kind, const Ray& segment, std::int32_t self);
  bool blocked(const Ray& segment, std::int32_t self);  // any kind

  // The point o + t·d at the contact's exact t, each coordinate correctly rounded.
  Vec3 hit_point(const Ray& ray, const ExactContact& contact);

  // Oracle calls that needed more than the static filter and intervals (expansions or rationals),
  // including the exact parameters asked for ties and hit points: per ray, the caller compares
  // this count before and after.
  std::uint64_t beyond_intervals() const;
  const Oracle& oracle() const { return filtered_; }

 private:
  ExactParameter exact_parameter(const Ray& ray, std::int32_t primitive);
  const SceneIndex* index_;
  Oracle filtered_;                                        // classes and rounded t
  Oracle with_parameter_{{.keep_exact_parameter = true}};  // exact t for ties and points
};

}  // namespace rayproof
