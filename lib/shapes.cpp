#include "rayproof/core/shapes.h"

#include <gmpxx.h>

#include <cmath>
#include <limits>

#include "rayproof/core/fp.h"

namespace rayproof {

std::string_view to_string(ShapeKind k) {
  switch (k) {
    case ShapeKind::sphere: return "sphere";
    case ShapeKind::plane: return "plane";
    case ShapeKind::triangle: return "triangle";
    case ShapeKind::box: return "box";
  }
  return "?";
}

std::optional<ShapeKind> shape_kind_from_string(std::string_view s) {
  for (ShapeKind k : kAllShapeKinds)
    if (to_string(k) == s) return k;
  return std::nullopt;
}

namespace {
bool exactly_collinear_rational(const Vec3& a, const Vec3& b, const Vec3& c);

// Exactly whether (b−a)×(c−a) = 0. A double filter answers "not collinear" when some component
// of the computed cross product exceeds its rounding-error bound (each difference and product
// rounds once: γ(6) of the magnitudes covers them inside fp.h's safe range); only
// the rest is decided in GMP rationals (a double converts to mpq exactly).
bool exactly_collinear(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 e1 = b - a, e2 = c - a;
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    const double p = e1[j] * e2[k], q = e1[k] * e2[j];
    const double magnitude = std::abs(p) + std::abs(q);
    if (std::isfinite(magnitude) && magnitude > kSafeMagnitudeMin && std::abs(p - q) > 2 * gamma(6) * magnitude)
      return false;
  }
  return exactly_collinear_rational(a, b, c);
}

bool exactly_collinear_rational(const Vec3& a, const Vec3& b, const Vec3& c) {
  mpq_class e1[3], e2[3];
  for (int i = 0; i < 3; ++i) {
    e1[i] = mpq_class(b[i]) - mpq_class(a[i]);
    e2[i] = mpq_class(c[i]) - mpq_class(a[i]);
  }
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    if (e1[j] * e2[k] != e1[k] * e2[j]) return false;
  }
  return true;
}

bool finite(double x) { return std::isfinite(x); }
}  // namespace

namespace {
struct Check {
  const char* operator()(const Sphere& s) const {
    if (!all_finite(s.center) || !finite(s.radius)) return "non-finite sphere";
    if (!(s.radius > 0)) return "radius must be > 0";
    return nullptr;
  }
  const char* operator()(const Plane& p) const {
    if (!all_finite(p.normal) || !finite(p.offset)) return "non-finite plane";
    if (p.normal.x() == 0 && p.normal.y() == 0 && p.normal.z() == 0) return "zero plane normal";
    return nullptr;
  }
  const char* operator()(const Triangle& t) const {
    for (const Vec3& v : t.v)
      if (!all_finite(v)) return "non-finite triangle vertex";
    if (exactly_collinear(t.v[0], t.v[1], t.v[2])) return "triangle vertices are collinear";
    return nullptr;
  }
  const char* operator()(const Box& b) const {
    if (!all_finite(b.min) || !all_finite(b.max)) return "non-finite box";
    for (int i = 0; i < 3; ++i)
      if (!(b.min[i] < b.max[i])) return "box min must be < max on every axis";
    return nullptr;
  }
};
}  // namespace

const char* degenerate_reason(const Shape& shape) { return std::visit(Check{}, shape); }
const char* degenerate_reason(const Triangle& t) { return Check{}(t); }

Shape scaled(const Shape& shape, double f) {
  return std::visit(
      [f](const auto& x) -> Shape {
        using S = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<S, Sphere>) return Sphere{x.center * f, x.radius * f};
        if constexpr (std::is_same_v<S, Plane>) return Plane{x.normal, x.offset * f};
        if constexpr (std::is_same_v<S, Triangle>) return Triangle{{x.v[0] * f, x.v[1] * f, x.v[2] * f}};
        if constexpr (std::is_same_v<S, Box>) return Box{x.min * f, x.max * f};
      },
      shape);
}

Vec3 outward_normal(const Shape& shape, const Vec3& p) {
  struct Normal {
    const Vec3& p;
    Vec3 operator()(const Sphere& s) const { return normalized(p - s.center); }
    Vec3 operator()(const Plane& pl) const { return normalized(pl.normal); }
    Vec3 operator()(const Triangle& t) const { return normalized(cross(t.v[1] - t.v[0], t.v[2] - t.v[0])); }
    Vec3 operator()(const Box& b) const {
      // The face whose plane is nearest to p, relative to the box's extent on that axis.
      int best_axis = 0;
      double best = std::numeric_limits<double>::infinity(), sign = -1;
      for (int i = 0; i < 3; ++i) {
        const double extent = b.max[i] - b.min[i];
        const double to_min = std::abs(p[i] - b.min[i]) / extent;
        const double to_max = std::abs(b.max[i] - p[i]) / extent;
        if (to_min < best) best = to_min, best_axis = i, sign = -1;
        if (to_max < best) best = to_max, best_axis = i, sign = 1;
      }
      Vec3 n = Vec3::Zero();
      n[best_axis] = sign;
      return n;
    }
  };
  return std::visit(Normal{p}, shape);
}

int shape_number_count(ShapeKind k) {
  constexpr int counts[] = {4, 4, 9, 6};
  return counts[static_cast<int>(k)];
}

int shape_numbers(const Shape& s, double out[kMaxShapeNumbers]) {
  auto put = [&](int at, const Vec3& v) { out[at] = v.x(), out[at + 1] = v.y(), out[at + 2] = v.z(); };
  return std::visit(
      [&](const auto& x) {
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<T, Sphere>)
          put(0, x.center), out[3] = x.radius;
        else if constexpr (std::is_same_v<T, Plane>)
          put(0, x.normal), out[3] = x.offset;
        else if constexpr (std::is_same_v<T, Triangle>)
          put(0, x.v[0]), put(3, x.v[1]), put(6, x.v[2]);
        else
          put(0, x.min), put(3, x.max);
        return shape_number_count(kind_of(Shape(x)));
      },
      s);
}

std::span<const ShapeField> shape_fields(ShapeKind k) {
  static constexpr ShapeField sphere[] = {{"center", 1}, {"radius", 0}};
  static constexpr ShapeField plane[] = {{"normal", 1}, {"offset", 0}};
  static constexpr ShapeField triangle[] = {{"vertices", 3}};
  static constexpr ShapeField box[] = {{"min", 1}, {"max", 1}};
  switch (k) {
    case ShapeKind::sphere: return sphere;
    case ShapeKind::plane: return plane;
    case ShapeKind::triangle: return triangle;
    case ShapeKind::box: break;
  }
  return box;
}

Shape shape_from_numbers(ShapeKind k, const double* n) {
  auto at = [&](int i) { return Vec3(n[i], n[i + 1], n[i + 2]); };
  switch (k) {
    case ShapeKind::sphere: return Sphere{at(0), n[3]};
    case ShapeKind::plane: return Plane{at(0), n[3]};
    case ShapeKind::triangle: return Triangle{{at(0), at(3), at(6)}};
    case ShapeKind::box: break;
  }
  return Box{at(0), at(3)};
}

}  // namespace rayproof
