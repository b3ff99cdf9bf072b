// The failures README documents, each pinned by the case that shows it; the expected truth is
// worked out by hand (or by scenes/cases/generate.py's rational arithmetic), not by the oracle.
#include <gtest/gtest.h>

#include <cmath>

#include "rayproof/core/casefile.h"
#include "rayproof/core/eft.h"
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
// Watertight's fallback for a zero edge function must be exact in sign (issue 23). Ray (0,0,0) +
// t(0,0,1) against a = (1, −1, 1), b = (1 + 2^-34, 1 + 2^-35, 1), c = (−1 − 2^-35, −1, 1): the
// sheared 2D coordinates are the vertices' x, y, and the edge function of b→c at the origin is
// cx·by − cy·bx = −(1 + 2^-35)² + (1 + 2^-34) = −2^-70, while v = −2 − 2^-35 and w = −2 − 2^-34 −
// 2^-35: all negative, so the point (0, 0, 1) is strictly inside. (b − a) × (c − a) has z =
// (2 + 2^-35)² > 0 and the ray runs along it: the back face, `exit` at t = 1. In double cx·by
// rounds to −(1 + 2^-34) and U is 0; long double (64 bits) rounds the same way, so the old
// fallback called it an edge (`boundary`), and the top-left rule could drop it as a hole.
TEST(Pinned, WatertightRecomputesAZeroEdgeFunctionExactly) {
  const double p34 = 1 + 0x1p-34, p35 = 1 + 0x1p-35;
  const double rounded_product = p35 * p35;  // alone: no compiler may fuse it into an FMA
  EXPECT_EQ(rounded_product, p34) << "so the double edge function p34 − fl(p35²) is 0";
  EXPECT_EQ(difference_of_products(-p35, p35, -1.0, p34), -0x1p-70);
  EXPECT_EQ(difference_of_products(3.0, 5.0, 5.0, 3.0), 0.0);
  const Ray ray{Vec3(0, 0, 0), Vec3(0, 0, 1)};
  const Shape tri = Triangle{{Vec3(1, -1, 1), Vec3(p34, p35, 1), Vec3(-p35, -1, 1)}};
  for (const char* variant : {"watertight", "watertight-top-left"}) {
    const Hit h = run(variant, ray, tri);
    EXPECT_EQ(h.cls, HitClass::exit) << variant;
    EXPECT_EQ(h.t, 1.0) << variant;
  }
}

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
