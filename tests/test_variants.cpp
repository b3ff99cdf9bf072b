// Every variant on hand-worked cases whose answers follow from the formulas by hand.
#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <vector>

#include <algorithm>
#include <cmath>
#include <set>

#include "rayproof/core/variants.h"

namespace rayproof {
namespace {

const Sphere kUnitSphere{Vec3(0, 0, 0), 1};
const Plane kFloor{Vec3(0, 0, 1), 1};                                // z = 1, front faces +z
const Triangle kTri{{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)}};  // front faces +z
const Box kCube{Vec3(0, 0, 0), Vec3(1, 1, 1)};

Ray ray(Vec3 o, Vec3 d) { return Ray{o, d}; }

std::vector<std::string> names_for(ShapeKind k) {
  std::vector<std::string> out;
  for (const Variant* v : variants_for(k)) out.emplace_back(v->name);
  return out;
}

Hit run(const std::string& name, const Ray& r, const Shape& s, HitRule rule = HitRule::nearest_contact) {
  const Variant* v = find_variant(name);
  EXPECT_NE(v, nullptr) << name;
  return v->intersect(r, s, rule);
}

TEST(Registry, NamesAreUniqueAndEveryShapeHasVariants) {
  std::set<std::string_view> names;
  for (const Variant& v : all_variants()) {
    EXPECT_TRUE(names.insert(v.name).second) << v.name;
    EXPECT_FALSE(v.source.empty()) << v.name;
    EXPECT_EQ(find_variant(v.name), &v);
  }
  for (ShapeKind k : kAllShapeKinds) {
    EXPECT_FALSE(variants_for(k).empty()) << to_string(k);
    EXPECT_EQ(default_variant(k).shape, k);
  }
  for (auto n : {"textbook", "stable", "hearn-baker", "direct", "moller-trumbore", "watertight", "slab", "robust-slab"})
    EXPECT_NE(find_variant(n), nullptr) << n;
  EXPECT_EQ(find_variant("no-such-variant"), nullptr);
}

class SphereVariant : public testing::TestWithParam<std::string> {};

TEST_P(SphereVariant, ThroughTheCentreEntersAtTwo) {
  const Hit h = run(GetParam(), ray({-3, 0, 0}, {1, 0, 0}), kUnitSphere);
  EXPECT_EQ(h.cls, HitClass::enter);
  EXPECT_EQ(h.t, 2.0);
}

TEST_P(SphereVariant, DirectionIsNotRenormalised) {
  const Hit h = run(GetParam(), ray({-3, 0, 0}, {4, 0, 0}), kUnitSphere);
  EXPECT_EQ(h.cls, HitClass::enter);
  EXPECT_EQ(h.t, 0.5);  // units of the given direction
}

TEST_P(SphereVariant, ExactTangentIsTangentAtTwo) {
  // b = -4, a = 1, c = 4: b² − 4ac = 0 exactly in double too.
  const Hit h = run(GetParam(), ray({-2, 1, 0}, {1, 0, 0}), kUnitSphere);
  EXPECT_EQ(h.cls, HitClass::tangent);
  EXPECT_EQ(h.t, 2.0);
}

TEST_P(SphereVariant, OriginInsideExits) {
  const Hit h = run(GetParam(), ray({0, 0, 0}, {1, 0, 0}), kUnitSphere);
  EXPECT_EQ(h.cls, HitClass::exit);
  EXPECT_EQ(h.t, 1.0);
}

TEST_P(SphereVariant, OriginOnSurfaceMovingInwardExitsAtFarSide) {
  const Hit h = run(GetParam(), ray({-1, 0, 0}, {1, 0, 0}), kUnitSphere);
  EXPECT_EQ(h.cls, HitClass::exit);
  EXPECT_EQ(h.t, 2.0);
}

TEST_P(SphereVariant, OriginOnSurfaceMovingOutwardMisses) {
  EXPECT_EQ(run(GetParam(), ray({1, 0, 0}, {1, 0, 0}), kUnitSphere).cls, HitClass::miss);
}

TEST_P(SphereVariant, SphereBehindTheRayMisses) {
  EXPECT_EQ(run(GetParam(), ray({3, 0, 0}, {1, 0, 0}), kUnitSphere).cls, HitClass::miss);
}

TEST_P(SphereVariant, EnterOnlyRejectsAnExit) {
  EXPECT_EQ(run(GetParam(), ray({0, 0, 0}, {1, 0, 0}), kUnitSphere, HitRule::enter_only).cls, HitClass::miss);
  const Hit h = run(GetParam(), ray({-3, 0, 0}, {1, 0, 0}), kUnitSphere, HitRule::enter_only);
  EXPECT_EQ(h.cls, HitClass::enter);
  EXPECT_EQ(h.t, 2.0);
}

INSTANTIATE_TEST_SUITE_P(All, SphereVariant, testing::ValuesIn(names_for(ShapeKind::sphere)), [](const auto& info) {
  std::string n = info.param;
  std::replace(n.begin(), n.end(), '-', '_');
  return n;
});

TEST(SphereDiscriminant, CancellationInBSquaredMinus4acHidesASmallFarSphere) {
  // Radius 1 at distance 1e9, offset 0.5 from the ray: c = 1e18 − 0.75 rounds to 1e18, so
  // b² − 4ac cancels to 0 and textbook and stable see a tangent; Hearn–Baker's Δ from the
  // centre's distance to the line keeps 0.75 and finds the entry at 1e9 − √0.75.
  const Sphere far{Vec3(1e9, 0.5, 0), 1};
  const Ray toward = ray({0, 0, 0}, {1, 0, 0});
  EXPECT_NE(run("textbook", toward, far).cls, HitClass::enter);
  EXPECT_NE(run("stable", toward, far).cls, HitClass::enter);
  const Hit hb = run("hearn-baker", toward, far);
  ASSERT_EQ(hb.cls, HitClass::enter);
  EXPECT_NEAR(hb.t, 1e9 - std::sqrt(0.75), 1e-6);
}

TEST(Plane, FrontBackParallelAndInPlane) {
  Hit h = run("direct", ray({0, 0, 3}, {0, 0, -1}), kFloor);
  EXPECT_EQ(h.cls, HitClass::enter);
  EXPECT_EQ(h.t, 2.0);
  h = run("direct", ray({0, 0, -1}, {0, 0, 1}), kFloor);
  EXPECT_EQ(h.cls, HitClass::exit);
  EXPECT_EQ(h.t, 2.0);
  EXPECT_EQ(run("direct", ray({0, 0, -1}, {0, 0, 1}), kFloor, HitRule::enter_only).cls, HitClass::miss);
  EXPECT_EQ(run("direct", ray({0, 0, 3}, {1, 0, 0}), kFloor).cls, HitClass::miss);  // parallel
  h = run("direct", ray({0, 0, 1}, {1, 0, 0}), kFloor);                             // lies in the plane
  EXPECT_EQ(h.cls, HitClass::tangent);
  EXPECT_FALSE(h.has_t());
  EXPECT_EQ(run("direct", ray({0, 0, 3}, {0, 0, 1}), kFloor).cls, HitClass::miss);  // behind
}

class TriangleVariant : public testing::TestWithParam<std::string> {};

TEST_P(TriangleVariant, FrontAndBackFaceHits) {
  Hit h = run(GetParam(), ray({0.25, 0.25, 1}, {0, 0, -1}), kTri);
  EXPECT_EQ(h.cls, HitClass::enter);
  EXPECT_EQ(h.t, 1.0);
  h = run(GetParam(), ray({0.25, 0.25, -1}, {0, 0, 1}), kTri);
  EXPECT_EQ(h.cls, HitClass::exit);
  EXPECT_EQ(h.t, 1.0);
  EXPECT_EQ(run(GetParam(), ray({0.25, 0.25, -1}, {0, 0, 1}), kTri, HitRule::enter_only).cls, HitClass::miss);
}

TEST_P(TriangleVariant, HitAndMissNearAnEdge) {
  // 2^-20 off the edges: exact in float too, so the float variants see the same rays.
  EXPECT_EQ(run(GetParam(), ray({0.5, 0x1p-20, 1}, {0, 0, -1}), kTri).cls, HitClass::enter);
  EXPECT_EQ(run(GetParam(), ray({0.5, -0x1p-20, 1}, {0, 0, -1}), kTri).cls, HitClass::miss);
  EXPECT_EQ(run(GetParam(), ray({0.5, 0.5 + 0x1p-20, 1}, {0, 0, -1}), kTri).cls, HitClass::miss);
}

TEST_P(TriangleVariant, ExactEdgeAndVertexAreBoundary) {
  if (GetParam().starts_with("watertight-top-left")) GTEST_SKIP() << "owns only some of its edges: see TopLeftRule";
  Hit h = run(GetParam(), ray({0.5, 0, 1}, {0, 0, -1}), kTri);
  EXPECT_EQ(h.cls, HitClass::boundary);
  EXPECT_EQ(h.t, 1.0);
  EXPECT_EQ(run(GetParam(), ray({0, 0, 2}, {0, 0, -1}), kTri).cls, HitClass::boundary);
}

TEST_P(TriangleVariant, BehindAndParallelMiss) {
  EXPECT_EQ(run(GetParam(), ray({0.25, 0.25, 1}, {0, 0, 1}), kTri).cls, HitClass::miss);
  EXPECT_EQ(run(GetParam(), ray({0.25, 0.25, 1}, {1, 0, 0}), kTri).cls, HitClass::miss);
}

// watertight-top-left: of the triangles sharing an exact edge point or a closed fan's centre,
// exactly one reports it, from either side and for rays at any slant.
TEST(TopLeftRule, ExactlyOneTriangleOfAFanOwnsEachSharedPoint) {
  const Vec3 centre(0, 0, 0);
  const Vec3 ring[6] = {{4, 0, 1}, {2, 4, -1}, {-2, 4, 0}, {-4, 0, 2}, {-2, -4, 0}, {2, -4, -2}};
  std::vector<Triangle> fan;
  for (int i = 0; i < 6; ++i) fan.push_back(Triangle{{centre, ring[i], ring[(i + 1) % 6]}});
  std::vector<Vec3> points = {centre};
  for (const Vec3& r : ring) points.push_back(r / 2);  // the spokes' midpoints
  const Vec3 directions[] = {{0, 0, -1}, {0, 0, 1}, {1, 2, -8}, {-3, 1, 5}, {0.5, -0.25, -1}};
  for (const Vec3& p : points)
    for (const Vec3& d : directions) {
      int owners = 0;
      for (const Triangle& t : fan) owners += run("watertight-top-left", ray(p - 2 * d, d), t).cls != HitClass::miss;
      EXPECT_EQ(owners, 1) << "point " << p.transpose() << " direction " << d.transpose();
    }
}

INSTANTIATE_TEST_SUITE_P(All, TriangleVariant, testing::ValuesIn(names_for(ShapeKind::triangle)), [](const auto& info) {
  std::string n = info.param;
  std::replace(n.begin(), n.end(), '-', '_');
  return n;
});

TEST(TriangleWatertight, SharedEdgeIsHitByAtLeastOneOfTwoTriangles) {
  // Two triangles sharing the diagonal of the unit square; rays through points on the
  // diagonal must hit at least one (watertightness), for many positions along it.
  const Triangle lower{{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0)}};
  const Triangle upper{{Vec3(0, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)}};
  for (int i = 1; i < 1000; ++i) {
    const double s = i / 1000.0;
    const Vec3 d(0.1 * s, -0.3, -1);
    const Ray through{Vec3(s, s, 0) - d, d};  // aims at (s, s, 0) on the diagonal, up to rounding
    const bool hit_lower = triangle_watertight(through, lower, HitRule::nearest_contact).cls != HitClass::miss;
    const bool hit_upper = triangle_watertight(through, upper, HitRule::nearest_contact).cls != HitClass::miss;
    EXPECT_TRUE(hit_lower || hit_upper) << i;
  }
}

class BoxVariant : public testing::TestWithParam<std::string> {};

TEST_P(BoxVariant, ThroughAFace) {
  const Hit h = run(GetParam(), ray({-1, 0.5, 0.5}, {1, 0, 0}), kCube);
  EXPECT_EQ(h.cls, HitClass::enter);
  EXPECT_EQ(h.t, 1.0);
}

TEST_P(BoxVariant, OriginInsideExits) {
  const Hit h = run(GetParam(), ray({0.5, 0.5, 0.5}, {0, 0, 2}), kCube);
  EXPECT_EQ(h.cls, HitClass::exit);
  // robust-slab widens the far distance by 1 + 2γ(3) on purpose: a few ulps above 0.25 (ulps of
  // the precision the variant computes in).
  const bool f32 = find_variant(GetParam())->precision == Precision::f32;
  const double eps = f32 ? std::numeric_limits<float>::epsilon() : std::numeric_limits<double>::epsilon();
  EXPECT_GE(h.t, 0.25);
  EXPECT_LE(h.t, 0.25 * (1 + 8 * eps));
  EXPECT_EQ(run(GetParam(), ray({0.5, 0.5, 0.5}, {0, 0, 2}), kCube, HitRule::enter_only).cls, HitClass::miss);
}

TEST_P(BoxVariant, MissesBesideAndBehind) {
  EXPECT_EQ(run(GetParam(), ray({-1, 2, 0.5}, {1, 0, 0}), kCube).cls, HitClass::miss);
  EXPECT_EQ(run(GetParam(), ray({2, 0.5, 0.5}, {1, 0, 0}), kCube).cls, HitClass::miss);
  EXPECT_EQ(run(GetParam(), ray({-1, 0.5, 0.5}, {1, 2, 0}), kCube).cls, HitClass::miss);
}

TEST_P(BoxVariant, DiagonalThroughACornerRegionEnters) {
  const Hit h = run(GetParam(), ray({-1, -1, -1}, {1, 1, 1}), kCube);
  EXPECT_EQ(h.cls, HitClass::enter);
  EXPECT_EQ(h.t, 1.0);
}

INSTANTIATE_TEST_SUITE_P(All, BoxVariant, testing::ValuesIn(names_for(ShapeKind::box)), [](const auto& info) {
  std::string n = info.param;
  std::replace(n.begin(), n.end(), '-', '_');
  return n;
});

TEST(BoxRobustSlab, AlongAnEdgeStillReportsTheContact) {
  // The ray runs along the cube's edge y = z = 0: 0·inf is NaN on two axes; the NaN-safe
  // ordering ignores it and the contact at t = 1 is found.
  const Hit h = box_robust_slab(ray({-1, 0, 0}, {1, 0, 0}), kCube, HitRule::nearest_contact);
  EXPECT_NE(h.cls, HitClass::miss);
  EXPECT_EQ(h.t, 1.0);
  const Hit neg = box_robust_slab(ray({-1, 0, 1}, {1, -0.0, 0}), kCube, HitRule::nearest_contact);
  EXPECT_NE(neg.cls, HitClass::miss);
  EXPECT_EQ(neg.t, 1.0);
}

TEST(BoxSlab, NaiveSlabLosesARayAlongAFacePlane) {
  // Origin on the x = 0 slab plane with d.x = 0: (0 − 0)/0 is NaN and the naive test misses,
  // while the ray runs along the face (the exact class is tangent).
  EXPECT_EQ(box_slab(ray({0, -1, 0.5}, {0, 1, 0}), kCube, HitRule::nearest_contact).cls, HitClass::miss);
  EXPECT_NE(box_robust_slab(ray({0, -1, 0.5}, {0, 1, 0}), kCube, HitRule::nearest_contact).cls, HitClass::miss);
}

}  // namespace
}  // namespace rayproof

#include "rayproof/core/batch.h"
#include <cstring>
#include <random>

namespace rayproof {
namespace {

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

std::string isa_name(BatchIsa isa) {
  return isa == BatchIsa::sse2 ? "sse2" : isa == BatchIsa::avx2 ? "avx2" : "avx512";
}

// One run per instruction-set version of the batched kernels (SSE2, AVX2, AVX-512); a version
// this CPU cannot run is reported as skipped in ctest's summary, never as passed.
class Batched : public ::testing::TestWithParam<BatchIsa> {
 protected:
  void SetUp() override {
    const std::vector<BatchIsa> isas = runnable_batch_isas();
    if (std::find(isas.begin(), isas.end(), GetParam()) == isas.end())
      GTEST_SKIP() << "this CPU cannot run this version of the batched kernels";
  }
};

TEST_P(Batched, SphereStableBatchIsBitIdenticalToTheScalarVariant) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-2, 2);
  std::uniform_int_distribution<int> small(-3, 3), e(-60, 60);
  RaysSoA rays;
  SpheresSoA spheres;
  std::vector<std::pair<Ray, Sphere>> cases;
  for (int i = 0; i < 20000; ++i) {
    Ray r{Vec3(u(rng), u(rng), u(rng)) * 4, Vec3(u(rng), u(rng), u(rng))};
    Sphere s{Vec3(u(rng), u(rng), u(rng)), std::abs(u(rng)) + 0.1};
    if (i % 3 == 0) {  // small integers: exact tangents, zero discriminants, origins on the surface
      r = Ray{Vec3(small(rng), small(rng), small(rng)), Vec3(small(rng), small(rng), 1)};
      s = Sphere{Vec3(small(rng), small(rng), small(rng)), double(1 + std::abs(small(rng)))};
    }
    if (i % 5 == 0) s.center *= std::ldexp(1.0, e(rng)), r.origin *= std::ldexp(1.0, e(rng));
    cases.push_back({r, s});
    rays.push(r);
    spheres.push(s);
  }
  for (BatchIsa isa : {GetParam()}) {  // every compiled version, not only the one this CPU picks
    HitsSoA out;
    sphere_stable_batch(rays, spheres, out, isa);
    int hits = 0;
    for (size_t i = 0; i < cases.size(); ++i) {
      const Hit h = sphere_stable(cases[i].first, cases[i].second, HitRule::nearest_contact);
      ASSERT_EQ(out.at(i).cls, h.cls) << i << " isa " << int(isa);
      ASSERT_TRUE(same_bits(out.at(i).t, h.t) || (std::isnan(out.at(i).t) && std::isnan(h.t)))
          << i << " isa " << int(isa);
      hits += h.cls != HitClass::miss;
    }
    EXPECT_GT(hits, 2000);
  }
}

TEST_P(Batched, MollerTrumboreBatchIsBitIdenticalToTheScalarVariant) {
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-2, 2);
  std::uniform_int_distribution<int> small(-3, 3);
  RaysSoA rays;
  TrianglesSoA tris;
  std::vector<std::pair<Ray, Triangle>> cases;
  for (int i = 0; i < 20000; ++i) {
    Ray r{Vec3(u(rng), u(rng), 3), Vec3(u(rng) * 0.3, u(rng) * 0.3, -1)};
    Triangle t{{Vec3(-1, -1, u(rng)), Vec3(1, -1, u(rng)), Vec3(u(rng), 1, u(rng))}};
    if (i % 3 == 0) {  // through edges and vertices exactly
      t = Triangle{{Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(0, 2, 0)}};
      r = Ray{Vec3(small(rng) * 0.5, small(rng) * 0.5, 1), Vec3(0, 0, -1)};
    }
    if (i == 0) {  // found by `rayproof trade`: det overflows, u and v are NaN, the scalar test lets NaN pass
      r = Ray{Vec3(-0x1.d8711d2eaaf14p+339, 0x1.628d871e5ed0ap+342, -0x1.c3c6daed425cap+342),
              Vec3(0x1.d0abb40d1395ap+340, -0x1.dfa48b075d1b3p+342, 0x1.bec3dc5bed6a1p+342)};
      t = Triangle{{Vec3(0x1.e7bfafa558p+333, -0x1.4ad33c5b6276ep+340, 0x1.231788aee6a68p+338),
                    Vec3(-0x1.e82ce8f67cf7p+339, -0x1.981ca96a39c8ap+340, -0x1.44df2296b79c2p+340),
                    Vec3(0x1.4c3d0a0c709e8p+338, -0x1.aa6c37853736cp+339, -0x1.8ce66bbc6b36p+338)}};
    }
    cases.push_back({r, t});
    rays.push(r);
    tris.push(t);
  }
  for (BatchIsa isa : {GetParam()}) {
    HitsSoA out;
    triangle_moller_trumbore_batch(rays, tris, out, isa);
    int boundary = 0;
    for (size_t i = 0; i < cases.size(); ++i) {
      const Hit h = triangle_moller_trumbore(cases[i].first, cases[i].second, HitRule::nearest_contact);
      ASSERT_EQ(out.at(i).cls, h.cls) << i << " isa " << int(isa);
      ASSERT_TRUE(same_bits(out.at(i).t, h.t) || (std::isnan(out.at(i).t) && std::isnan(h.t)))
          << i << " isa " << int(isa);
      boundary += h.cls == HitClass::boundary;
    }
    EXPECT_GT(boundary, 100);
  }
}

}  // namespace
}  // namespace rayproof

namespace rayproof {
namespace {

// The sphere batch on what the kernel must not get wrong either: products overflowing to inf,
// NaN inputs, subnormals — answered bit for bit as the scalar variant answers.
TEST_P(Batched, SphereStableBatchMatchesTheScalarVariantOnOverflowAndNaN) {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = INFINITY, tiny = 0x1p-1070;
  const std::vector<std::pair<Ray, Sphere>> cases = {
      {Ray{Vec3(-1e200, 0, 0), Vec3(1e200, 0, 0)}, Sphere{Vec3(0, 0, 0), 1e199}},  // b² overflows
      {Ray{Vec3(-1e300, 1, 0), Vec3(1, 0, 0)}, Sphere{Vec3(0, 0, 0), 1e300}},      // |o−m|² overflows
      {Ray{Vec3(nan, 0, 0), Vec3(1, 0, 0)}, Sphere{Vec3(5, 0, 0), 1}},
      {Ray{Vec3(0, 0, 0), Vec3(nan, 1, 0)}, Sphere{Vec3(5, 0, 0), 1}},
      {Ray{Vec3(0, 0, 0), Vec3(1, 0, 0)}, Sphere{Vec3(inf, 0, 0), 1}},
      {Ray{Vec3(0, 0, 0), Vec3(tiny, 0, 0)}, Sphere{Vec3(5, 0, 0), 1}},  // a underflows to 0
      {Ray{Vec3(0, 0, 0), Vec3(0, 0, 0)}, Sphere{Vec3(5, 0, 0), 1}},     // no direction at all
      {Ray{Vec3(-2, 0, 0), Vec3(1, 0, 0)}, Sphere{Vec3(0, 0, 0), 0}},
  };
  RaysSoA rays;
  SpheresSoA spheres;
  for (const auto& [r, s] : cases) rays.push(r), spheres.push(s);
  for (BatchIsa isa : {GetParam()}) {
    HitsSoA out;
    sphere_stable_batch(rays, spheres, out, isa);
    for (size_t i = 0; i < cases.size(); ++i) {
      const Hit h = sphere_stable(cases[i].first, cases[i].second, HitRule::nearest_contact);
      EXPECT_EQ(out.at(i).cls, h.cls) << i;
      std::uint64_t a, b;
      const double ta = out.at(i).t, tb = h.t;
      std::memcpy(&a, &ta, 8), std::memcpy(&b, &tb, 8);
      EXPECT_TRUE(a == b || (std::isnan(ta) && std::isnan(tb))) << i << ": " << ta << " vs " << tb;
    }
  }
}

}  // namespace
}  // namespace rayproof

namespace rayproof {
namespace {

// The float batches against their scalar float twins, on the case rounded to float (what both
// are given), every instruction set this CPU runs: ordinary cases, exact edges and tangents,
// magnitudes that overflow float products (inf, NaN), subnormal inputs and ±0 directions.
std::vector<std::pair<Ray, Shape>> float_batch_cases(ShapeKind kind) {
  std::mt19937_64 rng(kind == ShapeKind::sphere ? 7 : 8);
  std::uniform_real_distribution<double> u(-2, 2);
  std::uniform_int_distribution<int> small(-3, 3), e(-30, 30);
  std::vector<std::pair<Ray, Shape>> out;
  for (int i = 0; i < 20000; ++i) {
    Ray r{Vec3(u(rng), u(rng), 3), Vec3(u(rng) * 0.3, u(rng) * 0.3, -1)};
    Shape s = kind == ShapeKind::sphere
                  ? Shape(Sphere{Vec3(u(rng), u(rng), u(rng)), std::abs(u(rng)) + 0.1})
                  : Shape(Triangle{{Vec3(-1, -1, u(rng)), Vec3(1, -1, u(rng)), Vec3(u(rng), 1, u(rng))}});
    if (i % 4 == 0) {  // small integers and halves: exact edges, vertices, tangents, zero discriminants
      r = Ray{Vec3(small(rng) * 0.5, small(rng) * 0.5, small(rng)), Vec3(0, small(rng) == 0 ? -0.0 : 0, -1)};
      s = kind == ShapeKind::sphere
              ? Shape(Sphere{Vec3(small(rng), small(rng), small(rng) - 4), double(1 + std::abs(small(rng)))})
              : Shape(Triangle{{Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(0, 2, 0)}});
    }
    if (i % 5 == 1)
      r.origin *= std::ldexp(1.0, 4 * e(rng)), r.direction *= std::ldexp(1.0, 4 * e(rng));  // overflow, underflow
    if (i % 97 == 2) r.direction = Vec3(0x1p-140, -0x1p-145, 0x1p-130);                     // float subnormals
    // Keep only what float can hold: the scalar twin is judged on rounded cases only.
    if (const auto q = rounded_to_float(Query{r, s, {}})) out.push_back({q->ray, q->shape});
  }
  return out;
}

TEST_P(Batched, FloatBatchesAreBitIdenticalToTheirScalarFloatTwins) {
  for (ShapeKind kind : {ShapeKind::sphere, ShapeKind::triangle}) {
    const auto cases = float_batch_cases(kind);
    ASSERT_GT(cases.size(), 15000u);
    RaysSoAF rays;
    SpheresSoAF spheres;
    TrianglesSoAF tris;
    for (const auto& [r, s] : cases) {
      rays.push(r);
      if (kind == ShapeKind::sphere)
        spheres.push(std::get<Sphere>(s));
      else
        tris.push(std::get<Triangle>(s));
    }
    const Variant& scalar = *find_variant(kind == ShapeKind::sphere ? "stable-f32" : "moller-trumbore-f32");
    for (BatchIsa isa : {GetParam()}) {
      HitsSoAF out;
      if (kind == ShapeKind::sphere)
        sphere_stable_f32_batch(rays, spheres, out, isa);
      else
        triangle_moller_trumbore_f32_batch(rays, tris, out, isa);
      int hits = 0;
      for (size_t i = 0; i < cases.size(); ++i) {
        const Hit h = scalar.intersect(cases[i].first, cases[i].second, HitRule::nearest_contact);
        ASSERT_EQ(out.at(i).cls, h.cls) << to_string(kind) << " " << i << " isa " << int(isa);
        ASSERT_TRUE(same_bits(out.at(i).t, h.t) || (std::isnan(out.at(i).t) && std::isnan(h.t)))
            << to_string(kind) << " " << i << " isa " << int(isa);
        hits += h.cls != HitClass::miss;
      }
      EXPECT_GT(hits, 1000) << to_string(kind);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Isa, Batched, ::testing::Values(BatchIsa::sse2, BatchIsa::avx2, BatchIsa::avx512),
                         [](const ::testing::TestParamInfo<BatchIsa>& info) { return isa_name(info.param); });

}  // namespace
}  // namespace rayproof
