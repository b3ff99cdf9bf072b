// A renderer's own unit test of its sphere code, against rayproof's exact oracle.
#include <gtest/gtest.h>

#include <cmath>

#include "rayproof/fuzz/testing.h"

namespace {

// The renderer's sphere: the numerically stable quadratic (q = -(b + sgn(b) sqrt D) / 2),
// nearest contact with t > 0, reporting whether the ray enters or leaves.
rayproof::Hit my_sphere(const rayproof::Ray& ray, const rayproof::Sphere& s) {
  const rayproof::Vec3 oc = ray.origin - s.center;
  const double a = ray.direction.dot(ray.direction), b = 2 * ray.direction.dot(oc);
  const double c = oc.dot(oc) - s.radius * s.radius, disc = b * b - 4 * a * c;
  if (disc < 0) return rayproof::Hit::miss();
  const double q = -0.5 * (b + std::copysign(std::sqrt(disc), b));
  double t0 = q / a, t1 = c / q;
  if (t0 > t1) std::swap(t0, t1);
  if (t0 > 0) return {rayproof::HitClass::enter, t0};
  if (t1 > 0) return {rayproof::HitClass::exit, t1};
  return rayproof::Hit::miss();
}

TEST(MySphere, RandomRaysAreRight) {
  EXPECT_THAT(rayproof::audit(my_sphere, {.families = "random", .count = 20000}), rayproof::HasNoWrongClass());
}

TEST(MySphere, TangentRaysAreWhereItFails) {
  // The stable formula still misjudges rays that barely touch: the audit finds and shrinks them.
  const rayproof::AuditReport report = rayproof::audit(my_sphere, {.families = "tangent", .count = 20000});
  EXPECT_THAT(report, ::testing::Not(rayproof::HasNoWrongClass()));
  ASSERT_FALSE(report.findings.empty());
  EXPECT_TRUE(report.findings[0].expect.has_value());
  // A failing EXPECT_THAT shows the report as a line of totals, not as its bytes.
  EXPECT_EQ(::testing::PrintToString(report).rfind("rayproof audit of", 0), 0u) << ::testing::PrintToString(report);
}

}  // namespace
