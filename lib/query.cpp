#include "rayproof/core/query.h"

#include "rayproof/core/fp.h"

#include <cmath>
#include <type_traits>
#include <variant>

namespace rayproof {

// Rounded in place, number by number (the numbers shape_numbers lists), with one validity test at
// the end: the fuzzer rounds every case for the float variants, and a round trip through
// shape_numbers / shape_from_numbers with a test per number was a twentieth of its time.
std::optional<Query> rounded_to_float(const Query& q) {
  std::optional<Query> out(q);
  bool overflowed = false;  // ±inf: float cannot hold the number (NaN fails the validity test)
  auto round = [&](double& x) {
    const float f = to_nearest_float(x);
    overflowed |= std::isinf(f);
    x = f;
  };
  auto round_vec = [&](Vec3& v) { round(v.x()), round(v.y()), round(v.z()); };
  round_vec(out->ray.origin), round_vec(out->ray.direction);
  std::visit(
      [&](auto& s) {
        using S = std::decay_t<decltype(s)>;
        if constexpr (std::is_same_v<S, Sphere>) round_vec(s.center), round(s.radius);
        if constexpr (std::is_same_v<S, Plane>) round_vec(s.normal), round(s.offset);
        if constexpr (std::is_same_v<S, Triangle>) round_vec(s.v[0]), round_vec(s.v[1]), round_vec(s.v[2]);
        if constexpr (std::is_same_v<S, Box>) round_vec(s.min), round_vec(s.max);
      },
      out->shape);
  if (overflowed || !is_valid_query(out->ray, out->shape)) out.reset();
  return out;
}

}  // namespace rayproof
