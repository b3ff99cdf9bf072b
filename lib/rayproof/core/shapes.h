// The four shapes of the case format (docs/spec/cases.md), with outward normals.
#pragma once

#include <array>
#include <span>
#include <optional>
#include <string>
#include <string_view>
#include <variant>

#include "rayproof/core/geometry.h"

namespace rayproof {

struct Sphere {
  Vec3 center;
  double radius;
};

// Points x with dot(normal, x) = offset; the front is the side the normal points to.
struct Plane {
  Vec3 normal;
  double offset;
};

// Front face is the side (v1-v0)×(v2-v0) points to.
struct Triangle {
  std::array<Vec3, 3> v;
};

// Axis-aligned and closed.
struct Box {
  Vec3 min;
  Vec3 max;
};

using Shape = std::variant<Sphere, Plane, Triangle, Box>;

enum class ShapeKind { sphere = 0, plane = 1, triangle = 2, box = 3 };
inline constexpr std::array<ShapeKind, 4> kAllShapeKinds = {ShapeKind::sphere, ShapeKind::plane, ShapeKind::triangle,
                                                            ShapeKind::box};

inline ShapeKind kind_of(const Shape& s) { return static_cast<ShapeKind>(s.index()); }
std::string_view to_string(ShapeKind k);
std::optional<ShapeKind> shape_kind_from_string(std::string_view s);

// A shape's numbers in the case format's order (cases.md): sphere center[3], radius; plane
// normal[3], offset; triangle v0[3], v1[3], v2[3]; box min[3], max[3]. Returns how many.
inline constexpr int kMaxShapeNumbers = 9;
int shape_numbers(const Shape& s, double out[kMaxShapeNumbers]);
int shape_number_count(ShapeKind k);
Shape shape_from_numbers(ShapeKind k, const double* numbers);

// The case format's fields of a shape, in shape_numbers' order: a name and how its numbers are
// nested — a number (`vectors` 0), a vector [x, y, z] (1), or an array of `vectors` vectors
// (a triangle's vertices). Every writer of a shape (JSON, the exec protocol) walks this list.
struct ShapeField {
  std::string_view name;
  int vectors;  // 0: one number; 1: [x, y, z]; n > 1: [[x, y, z], ...] n times
  bool nested() const { return vectors > 1; }
  int numbers() const { return vectors == 0 ? 1 : 3 * vectors; }
};
std::span<const ShapeField> shape_fields(ShapeKind k);

// Why a shape is degenerate in the sense of the case format, or null when it is valid (a static
// string: generators and every rounded float query ask, millions of times a second).
// Checks are exact: a triangle is collinear only when its cross product is exactly zero
// in exact arithmetic (decided by an exact orientation test on the doubles).
const char* degenerate_reason(const Shape& s);
const char* degenerate_reason(const Triangle& t);  // the same, without making a Shape of it

// The shape with every length multiplied by `factor` (centre, radius, plane offset, vertices,
// corners; a plane's normal keeps its direction). With a power of two as factor this is exact
// until the range runs out: the scale-invariance tests and the fuzz families rely on it.
Shape scaled(const Shape& s, double factor);

// Unit outward normal at a point on (or next to) the surface. Planes and triangles are
// two-sided: their "outward" normal is the front normal.
Vec3 outward_normal(const Shape& s, const Vec3& p);

}  // namespace rayproof
