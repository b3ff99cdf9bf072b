// The failures README documents, each pinned by the case that shows it; the expected truth is
// worked out by hand (or by scenes/cases/generate.py's rational arithmetic), not by the oracle.
#include <gtest/gtest.h>

#include <cmath>

#include "rayproof/core/casefile.h"
#include "rayproof/core/fp.h"
#include "rayproof/core/variants.h"

namespace rayproof {
namespace {

Hit run(const char* variant, const Ray& ray, const Shape& shape) {
  return find_variant(variant)->intersect(ray, shape, HitRule::nearest_contact);
}

// x = −1 + t, y = (1 − 2^-53) − t: where x reaches the box (t = 1), y is already −2^-53, so the
// exact ray misses the edge x = 0, y = 0 of [0, 2]³ by 2^-53. The naive slab test sees the empty
// interval; robust-slab's far-bound widening 1 + 2γ(3) turns it into an entry at t = 1.
TEST(Pinned, RobustSlabWideningTurnsANearMissIntoAnEntry) {
  const Ray ray{Vec3(-1, 1 - 0x1p-53, 1), Vec3(1, -1, 0)};
  const Shape box = Box{Vec3(0, 0, 0), Vec3(2, 2, 2)};
  EXPECT_EQ(run("slab", ray, box).cls, HitClass::miss);
  const Hit h = run("robust-slab", ray, box);
  EXPECT_EQ(h.cls, HitClass::enter);
  EXPECT_EQ(h.t, 1.0);
}

// A ray in the plane z = 0 of the triangle crosses its edges: exactly a tangent at t = 1 (where
// it enters the closed triangle); Möller–Trumbore's determinant is 0 and it reports a miss.
TEST(Pinned, MollerTrumboreMissesACoplanarRay) {
  const Ray ray{Vec3(-1, 1, 0), Vec3(1, 0, 0)};
  const Shape tri = Triangle{{Vec3(0, 0, 0), Vec3(4, 0, 0), Vec3(0, 4, 0)}};
  EXPECT_EQ(run("moller-trumbore", ray, tri).cls, HitClass::miss);
}

// README's worked example: one ulp inside an exact tangent. generate.py's rationals give
// enter at 0x1.7fffffb7979ebp+1; Kahan's FMA discriminant gets the class, not t.
TEST(Pinned, StableFmaRightInClassWrongInT) {
  const Case c = parse_case(
      R"({"id": "x", "ray": {"origin": [-12, "0x1.1ffffffffffffp+4", 2], "direction": [4, -3, 0]},
          "shape": {"type": "sphere", "center": [-3, 5, 2], "radius": 5}})");
  const double exact_t = *parse_hex_double("0x1.7fffffb7979ebp+1");
  const Hit fma = run("stable-fma", c.ray, c.shape);
  EXPECT_EQ(fma.cls, HitClass::enter);
  EXPECT_GT(*ulp_distance(fma.t, exact_t), 10'000'000u);
  EXPECT_EQ(run("textbook", c.ray, c.shape).cls, HitClass::tangent);  // the cancelled discriminant
}

// A unit sphere 2^27 away, the ray through its centre: exactly an entry at t = 2^27 − 1. In
// double c = |o − m|² − r² = 2^54 − 1 rounds to 2^54 and b² − 4ac cancels to 0: a tangent.
TEST(Pinned, TextbookLosesASmallFarSphere) {
  const Ray ray{Vec3(0, 0, 0), Vec3(1, 0, 0)};
  const Shape far = Sphere{Vec3(0x1p27, 0, 0), 1};
  const Hit t = run("textbook", ray, far);
  EXPECT_EQ(t.cls, HitClass::tangent);
  const Hit h = run("hearn-baker", ray, far);
  EXPECT_EQ(h.cls, HitClass::enter);
  EXPECT_EQ(h.t, 0x1p27 - 1);
}

}  // namespace
}  // namespace rayproof
