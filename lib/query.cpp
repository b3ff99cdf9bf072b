#include "rayproof/core/query.h"

#include "rayproof/core/fp.h"

#include <cmath>

namespace rayproof {

namespace {
// x rounded to the nearest float (ties to even), or nullopt where that is ±inf: from
// FLT_MAX + ½ulp = 0x1.ffffffp+127 on, round-to-nearest overflows. (Converting an out-of-range
// double to float is undefined in C++, hence the test before the cast.)
std::optional<double> to_float(double x) {
  const float f = to_nearest_float(x);
  if (std::isinf(f)) return std::nullopt;
  return static_cast<double>(f);
}
}  // namespace

std::optional<Query> rounded_to_float(const Query& q) {
  Query out = q;
  for (Vec3* v : {&out.ray.origin, &out.ray.direction})
    for (int i = 0; i < 3; ++i) {
      const auto f = to_float((*v)[i]);
      if (!f) return std::nullopt;
      (*v)[i] = *f;
    }
  double numbers[kMaxShapeNumbers];
  const int n = shape_numbers(q.shape, numbers);
  for (int i = 0; i < n; ++i) {
    const auto f = to_float(numbers[i]);
    if (!f) return std::nullopt;
    numbers[i] = *f;
  }
  out.shape = shape_from_numbers(kind_of(q.shape), numbers);
  if (!is_valid_query(out.ray, out.shape)) return std::nullopt;
  return out;
}

}  // namespace rayproof
