// One ray–shape query: the unit every layer works on. A case file's line (core/casefile.h), a
// generated fuzz case (fuzz/generators.h), a timed query of `trade` and a stability cell's sample
// are all Queries; `id` names it where a name exists (case files, findings), else stays empty.
#pragma once

#include <optional>
#include <string>

#include "rayproof/core/geometry.h"
#include "rayproof/core/shapes.h"

namespace rayproof {

struct Query {
  Ray ray;
  Shape shape;
  std::string id;
};

// Whether a query is one the case format accepts: finite numbers, a non-zero direction and a
// non-degenerate shape (core/shapes.h). Generators and shrinking keep to these.
inline bool is_valid_query(const Ray& ray, const Shape& shape) {
  return all_finite(ray.origin) && all_finite(ray.direction) && ray.direction != Vec3::Zero() &&
         !degenerate_reason(shape);
}

// The query as float code sees it (docs/spec/plugin.md): every number rounded to the nearest
// float, kept as the double of that float; nullopt where a number overflows float or the rounded
// query is no longer valid (a zero direction, a degenerate shape): "not_representable".
std::optional<Query> rounded_to_float(const Query& q);

}  // namespace rayproof
