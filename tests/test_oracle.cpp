// The exact oracle: every row of the class table, proved correct rounding, scale invariance,
// the filter, and an independent cross-check against CGAL's exact do_intersect.
#include <gtest/gtest.h>

#include <CGAL/Exact_rational.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Sqrt_extension.h>
#include <CGAL/intersections.h>

#include <cfloat>
#include <cmath>
#include <cstring>
#include <random>

#include "rayproof/core/fp.h"
#include "rayproof/verify/oracle.h"

namespace rayproof {
namespace {

using K = CGAL::Simple_cartesian<mpq_class>;

struct Expected {
  HitClass cls;
  std::optional<double> t;
};

void expect_verdict(const Ray& ray, const Shape& shape, Expected want, const char* what) {
  for (bool filter : {true, false}) {
    Oracle oracle(Oracle::Options{filter});
    const Verdict v = oracle.judge(ray, shape);
    EXPECT_EQ(v.cls, want.cls) << what << " (filter " << filter << "): got " << to_string(v.cls);
    EXPECT_EQ(v.t.has_value(), want.t.has_value()) << what;
    if (v.t && want.t) {
      EXPECT_EQ(*v.t, *want.t) << what;
    }
  }
}

Ray R(Vec3 o, Vec3 d) { return Ray{o, d}; }
const Sphere kS5{Vec3(0, 0, 0), 5};

TEST(OracleSphere, EveryRowOfTheTable) {
  expect_verdict(R({-10, 0, 0}, {1, 0, 0}), kS5, {HitClass::enter, 5}, "through the centre");
  expect_verdict(R({-10, 3, 0}, {1, 0, 0}), kS5, {HitClass::enter, 6}, "Pythagorean chord (-4, 3)");
  expect_verdict(R({3, 4, -10}, {0, 0, 1}), kS5, {HitClass::tangent, 10}, "tangent at (3, 4, 0)");
  expect_verdict(R({-10, 5, 0}, {2, 0, 0}), kS5, {HitClass::tangent, 5}, "tangent, direction not unit");
  expect_verdict(R({-10, 5, 0}, {-1, 0, 0}), kS5, {HitClass::miss, {}}, "tangent behind");
  expect_verdict(R({-10, 5.000000000000001, 0}, {1, 0, 0}), kS5, {HitClass::miss, {}}, "one ulp above tangent");
  expect_verdict(R({0, 0, 0}, {0, 1, 0}), kS5, {HitClass::exit, 5}, "origin at the centre");
  expect_verdict(R({-4, 3, 0}, {1, 0, 0}), kS5, {HitClass::exit, 8}, "origin on the sphere moving inward");
  expect_verdict(R({-4, 3, 0}, {-1, 0, 0}), kS5, {HitClass::miss, {}}, "origin on the sphere moving outward");
  expect_verdict(R({3, 4, 0}, {0, 0, 1}), kS5, {HitClass::miss, {}}, "origin on the sphere along the tangent plane");
  expect_verdict(R({-10, 6, 0}, {1, 0, 0}), kS5, {HitClass::miss, {}}, "passes beside");
  expect_verdict(R({10, 0, 0}, {1, 0, 0}), kS5, {HitClass::miss, {}}, "sphere behind");
}

TEST(OracleSphere, EnterOnlyRule) {
  Oracle oracle;
  EXPECT_EQ(oracle.judge(R({0, 0, 0}, {0, 1, 0}), kS5, HitRule::enter_only).cls, HitClass::miss);
  EXPECT_EQ(oracle.judge(R({3, 4, -10}, {0, 0, 1}), kS5, HitRule::enter_only).cls, HitClass::miss);
  EXPECT_EQ(oracle.judge(R({-10, 0, 0}, {1, 0, 0}), kS5, HitRule::enter_only).cls, HitClass::enter);
}

TEST(OraclePlane, EveryRowOfTheTable) {
  const Plane p{Vec3(0, 0, 2), 2};  // z = 1, normal not unit
  expect_verdict(R({0, 0, 5}, {0, 0, -1}), p, {HitClass::enter, 4}, "front");
  expect_verdict(R({0, 0, -3}, {0, 1, 1}), p, {HitClass::exit, 4}, "back");
  expect_verdict(R({0, 0, 5}, {1, 0, 0}), p, {HitClass::miss, {}}, "parallel");
  expect_verdict(R({7, 0, 1}, {1, 1, 0}), p, {HitClass::tangent, {}}, "in the plane");
  expect_verdict(R({0, 0, 1}, {0, 0, 1}), p, {HitClass::miss, {}}, "met only at t = 0");
  expect_verdict(R({0, 0, 5}, {0, 0, 1}), p, {HitClass::miss, {}}, "behind");
  expect_verdict(R({0, 0, 0}, {0, 0, 3}), p, {HitClass::exit, 1.0 / 3}, "t = 1/3 rounded");
}

const Triangle kT{{Vec3(0, 0, 0), Vec3(4, 0, 0), Vec3(0, 4, 0)}};  // front +z

TEST(OracleTriangle, EveryRowOfTheTable) {
  expect_verdict(R({1, 1, 3}, {0, 0, -1}), kT, {HitClass::enter, 3}, "front interior");
  expect_verdict(R({1, 1, -3}, {0, 0, 1}), kT, {HitClass::exit, 3}, "back interior");
  expect_verdict(R({2, 0, 3}, {0, 0, -1}), kT, {HitClass::boundary, 3}, "edge v0v1");
  expect_verdict(R({2, 2, 3}, {0, 0, -1}), kT, {HitClass::boundary, 3}, "hypotenuse");
  expect_verdict(R({4, 0, 3}, {0, 0, -1}), kT, {HitClass::boundary, 3}, "vertex v1");
  expect_verdict(R({5, 5, 1}, {-1, -1, -1}), kT, {HitClass::miss, {}}, "plane met at (4, 4, 0), outside");
}

TEST(OracleTriangle, SlantedAndCoplanarRays) {
  expect_verdict(R({3, 3, 1}, {-1, -1, -1}), kT, {HitClass::boundary, 1},
                 "slanted ray through (2,2,0) on the hypotenuse");
  expect_verdict(R({3, 3.0000000000000004, 1}, {-1, -1, -1}), kT, {HitClass::miss, {}}, "one ulp outside");
  expect_verdict(R({2.9999999999999996, 3, 1}, {-1, -1, -1}), kT, {HitClass::enter, 1}, "one ulp inside");
  expect_verdict(R({-2, 1, 0}, {1, 0, 0}), kT, {HitClass::tangent, 2}, "coplanar, enters through the edge x = 0");
  expect_verdict(R({1, 1, 0}, {1, 0, 0}), kT, {HitClass::tangent, {}}, "coplanar, origin inside");
  expect_verdict(R({0, 0, 0}, {-1, -1, 0}), kT, {HitClass::miss, {}}, "coplanar, origin on a vertex moving out");
  expect_verdict(R({0, 0, 0}, {1, 1, 0}), kT, {HitClass::tangent, {}}, "coplanar, origin on a vertex moving in");
  expect_verdict(R({-2, 5, 0}, {1, 0, 0}), kT, {HitClass::miss, {}}, "coplanar, passes above");
  expect_verdict(R({-4, 8, 0}, {1, -1, 0}), kT, {HitClass::tangent, 4}, "coplanar, first contact at the vertex (0,4)");
  expect_verdict(R({1, 1, 0}, {0, 0, 1}), kT, {HitClass::miss, {}}, "origin on the triangle, leaving: t = 0 only");
}

const Box kB{Vec3(0, 0, 0), Vec3(2, 2, 2)};

TEST(OracleBox, EveryRowOfTheTable) {
  expect_verdict(R({-2, 1, 1}, {1, 0, 0}), kB, {HitClass::enter, 2}, "through a face");
  expect_verdict(R({1, 1, 1}, {0, 0, 4}), kB, {HitClass::exit, 0.25}, "origin inside");
  expect_verdict(R({0, 1, 1}, {1, 0, 0}), kB, {HitClass::exit, 2}, "origin on a face moving in");
  expect_verdict(R({0, 1, 1}, {-1, 0, 0}), kB, {HitClass::miss, {}}, "origin on a face moving out");
  expect_verdict(R({0, 0, 0}, {1, 1, 1}), kB, {HitClass::exit, 2}, "origin on a corner moving in");
  expect_verdict(R({-2, 0, 0}, {1, 0, 0}), kB, {HitClass::tangent, 2}, "along an edge");
  expect_verdict(R({-2, 1, 0}, {1, 0, 0}), kB, {HitClass::tangent, 2}, "along a face from outside");
  expect_verdict(R({1, 1, 0}, {1, 0, 0}), kB, {HitClass::tangent, {}}, "along a face from a point of it");
  expect_verdict(R({-1, -1, 1}, {1, 1, 0}), kB, {HitClass::enter, 1}, "enters through the vertical edge x = y = 0");
  expect_verdict(R({-1, 1, 1}, {1, -1, 0}), kB, {HitClass::tangent, 1}, "touches the vertical edge x = y = 0 only");
  expect_verdict(R({-1, -1, -1}, {1, 1, 1}), kB, {HitClass::enter, 1}, "enters through the corner");
  expect_verdict(R({-1, 1, 1}, {1, 0, 1}), kB, {HitClass::tangent, 1}, "touches the edge x = 0, z = 2 only");
  expect_verdict(R({-1, 1, 1}, {1, 1, 0}), kB, {HitClass::tangent, 1}, "touches the edge x = 0, y = 2 only");
  expect_verdict(R({-1, 1.0000000000000002, 1}, {1, 1, 0}), kB, {HitClass::miss, {}}, "one ulp beyond the edge");
  expect_verdict(R({-1, 0.9999999999999999, 1}, {1, 1, 0}), kB, {HitClass::enter, 1}, "one ulp inside the edge");
  expect_verdict(R({-2, 1, 1}, {-1, 0, 0}), kB, {HitClass::miss, {}}, "behind");
  expect_verdict(R({-2, 1, 1}, {1, -0.0, 0}), kB, {HitClass::enter, 2}, "-0.0 direction component");
}

// ---------------------------------------------------------------------------------------------
// Correct rounding, checked with CGAL's Sqrt_extension (a + b·√c compared exactly), which
// shares no code with the oracle's own comparison.
using SqrtExt = CGAL::Sqrt_extension<mpq_class, mpq_class, CGAL::Tag_true, CGAL::Tag_true>;

int sign_t_minus(const ExactParameter& t, const mpq_class& m) {
  const mpq_class a = t.p / t.q - m;
  if (t.s == 0 || sgn(t.radicand) == 0) return sgn(a);
  return static_cast<int>(CGAL::sign(SqrtExt(a, mpq_class(t.s) / t.q, t.radicand)));
}

mpq_class two_to_1024() {
  mpz_class z = 1;
  z <<= 1024;
  return mpq_class(z);
}
mpq_class as_q(double x) { return std::isinf(x) ? two_to_1024() : mpq_class(x); }
bool even(double x) {
  std::uint64_t b;
  std::memcpy(&b, &x, 8);
  return (b & 1) == 0;
}

::testing::AssertionResult correctly_rounded(const ExactParameter& t, double x) {
  if (std::isinf(x)) {
    if (sign_t_minus(t, (mpq_class(DBL_MAX) + two_to_1024()) / 2) >= 0) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "rounded to inf but t is below the overflow threshold";
  }
  const double below = std::nextafter(x, -INFINITY), above = std::nextafter(x, INFINITY);
  const int lo = sign_t_minus(t, (as_q(below) + as_q(x)) / 2);
  const int hi = sign_t_minus(t, (as_q(x) + as_q(above)) / 2);
  if ((lo > 0 || (lo == 0 && even(x))) && (hi < 0 || (hi == 0 && even(x)))) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "t is outside the rounding interval of " << std::hexfloat << x
                                       << " (low side " << lo << ", high side " << hi << ")";
}

double random_double(std::mt19937_64& rng, int min_exp, int max_exp) {
  std::uniform_int_distribution<int> e(min_exp, max_exp);
  std::uniform_real_distribution<double> m(1, 2);
  std::bernoulli_distribution neg(0.5);
  return (neg(rng) ? -1 : 1) * std::ldexp(m(rng), e(rng));
}
Vec3 random_vec(std::mt19937_64& rng, int lo, int hi) {
  return Vec3(random_double(rng, lo, hi), random_double(rng, lo, hi), random_double(rng, lo, hi));
}

// Rays aimed close to the silhouette of random spheres: near-tangent and grazing chords.
std::vector<std::pair<Ray, Sphere>> adversarial_spheres(int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g;
  std::vector<std::pair<Ray, Sphere>> out;
  for (int i = 0; i < n; ++i) {
    const double r = std::ldexp(1.0 + (rng() % 1000) / 1000.0, static_cast<int>(rng() % 40) - 20);
    const Vec3 m = random_vec(rng, -20, 20);
    const Vec3 n = normalized(Vec3(g(rng), g(rng), g(rng)));
    Vec3 side = normalized(cross(n, Vec3(g(rng), g(rng), g(rng))));
    const double offset = r * (1 + std::ldexp(g(rng), -(static_cast<int>(rng() % 50))));
    const Vec3 target = m + offset * side;
    const Vec3 o = target - std::ldexp(1.0, static_cast<int>(rng() % 30)) * r * n;
    out.push_back({Ray{o, target - o}, Sphere{m, r}});
  }
  return out;
}

// An oracle that also returns the exact parameter, so the test can audit the rounding.
Oracle auditing_oracle() { return Oracle(Oracle::Options{.keep_exact_parameter = true}); }

TEST(OracleRounding, SphereRootsAreCorrectlyRounded) {
  Oracle oracle = auditing_oracle();
  int with_t = 0;
  for (const auto& [ray, sphere] : adversarial_spheres(4000, 11)) {
    const Verdict v = oracle.judge(ray, sphere);
    if (!v.t) continue;
    ++with_t;
    ASSERT_TRUE(v.exact_t);
    ASSERT_TRUE(v.t.has_value());
    ASSERT_TRUE(v.exact_t != nullptr);
    EXPECT_TRUE(correctly_rounded(*v.exact_t, *v.t));
  }
  std::mt19937_64 rng(5);
  for (int i = 0; i < 4000; ++i) {
    const Sphere s{random_vec(rng, -3, 3), std::abs(random_double(rng, 0, 3))};
    const Ray ray{random_vec(rng, -3, 3), random_vec(rng, -3, 3)};
    const Verdict v = oracle.judge(ray, s);
    if (!v.t) continue;
    ++with_t;
    ASSERT_TRUE(v.t.has_value());
    ASSERT_TRUE(v.exact_t != nullptr);
    EXPECT_TRUE(correctly_rounded(*v.exact_t, *v.t));
  }
  EXPECT_GT(with_t, 3000);
}

TEST(OracleRounding, RationalTiesRoundToEven) {
  Oracle oracle = auditing_oracle();
  // Plane x = 2^-53 seen from x = −1: t = 1 + 2^-53 exactly, halfway between 1 and 1 + 2^-52,
  // whose even neighbour is 1.
  const Plane tie1{Vec3(1, 0, 0), std::ldexp(1.0, -53)};
  Verdict v = oracle.judge(R({-1, 0, 0}, {1, 0, 0}), tie1);
  ASSERT_TRUE(v.t);
  ASSERT_TRUE(v.t.has_value());
  EXPECT_EQ(*v.t, 1.0);
  const Plane tie2{Vec3(1, 0, 0), 3 * std::ldexp(1.0, -53)};
  v = oracle.judge(R({-1, 0, 0}, {1, 0, 0}), tie2);
  ASSERT_TRUE(v.t.has_value());
  EXPECT_EQ(*v.t, 1 + 2 * std::ldexp(1.0, -52));
  ASSERT_TRUE(v.t.has_value());
  ASSERT_TRUE(v.exact_t != nullptr);
  EXPECT_TRUE(correctly_rounded(*v.exact_t, *v.t));
  // Beyond the double range: rounds to inf; below half the smallest subnormal: to 0.
  v = oracle.judge(R({0, 0, 0}, {DBL_TRUE_MIN, 0, 0}), Plane{Vec3(1, 0, 0), 1e300});
  ASSERT_TRUE(v.t);
  ASSERT_TRUE(v.t.has_value());
  EXPECT_TRUE(std::isinf(*v.t));
  v = oracle.judge(R({0, 0, 0}, {1e300, 0, 0}), Plane{Vec3(1, 0, 0), DBL_TRUE_MIN});
  ASSERT_TRUE(v.t);
  ASSERT_TRUE(v.t.has_value());
  EXPECT_EQ(*v.t, 0.0);
  EXPECT_EQ(v.cls, HitClass::exit);  // the ray leaves the plane's back side (d·n > 0)
}

// ---------------------------------------------------------------------------------------------
std::vector<std::pair<Ray, Shape>> table_cases() {
  std::vector<std::pair<Ray, Shape>> c;
  for (const auto& [r, s] : adversarial_spheres(300, 3)) c.push_back({r, s});
  c.push_back({R({-10, 3, 0}, {1, 0, 0}), kS5});
  c.push_back({R({3, 4, -10}, {0, 0, 1}), kS5});
  c.push_back({R({-4, 3, 0}, {1, 0, 0}), kS5});
  c.push_back({R({0, 0, 5}, {0, 0, -1}), Plane{Vec3(0, 0, 2), 2}});
  c.push_back({R({0, 0, 0}, {0, 0, 3}), Plane{Vec3(0, 0, 2), 2}});
  c.push_back({R({3, 3, 1}, {-1, -1, -1}), kT});
  c.push_back({R({-2, 1, 0}, {1, 0, 0}), kT});
  c.push_back({R({1, 1, 3}, {0.125, 0.375, -1}), kT});
  c.push_back({R({-1, 1, 1}, {1, 1, 0}), kB});
  c.push_back({R({-1, -1, -1}, {1, 1, 1}), kB});
  c.push_back({R({-2, 1, 0}, {1, 0, 0}), kB});
  c.push_back({R({1, 1, 1}, {0, 0, 4}), kB});
  return c;
}

TEST(OracleExtremes, PowerOfTwoScalingLeavesClassAndTUnchanged) {
  for (const auto& [ray, shape] : table_cases()) {
    Oracle oracle;
    const Verdict base = oracle.judge(ray, shape);
    for (int k : {-500, -300, -100, 100, 300, 500}) {
      const double f = std::ldexp(1.0, k);
      const Verdict v = oracle.judge(Ray{ray.origin * f, ray.direction * f}, rayproof::scaled(shape, f));
      EXPECT_EQ(v.cls, base.cls) << "2^" << k;
      EXPECT_EQ(v.t, base.t) << "2^" << k;
    }
  }
}

// The filters' outward rounding steps by the bits (fp.h); it must be nextafter's step exactly,
// signs, the largest double, the least subnormal and zeros included.
TEST(OracleExtremes, NeighbouringDoublesAreNextaftersOnEveryKindOfDouble) {
  std::vector<double> xs = {0.0,
                            -0.0,
                            DBL_MIN,
                            -DBL_MIN,
                            DBL_MAX,
                            -DBL_MAX,
                            5e-324,
                            -5e-324,
                            1.0,
                            -1.0,
                            INFINITY,
                            -INFINITY,
                            0x1p-1022 - 0x1p-1074,
                            -(0x1p-1022 - 0x1p-1074)};
  std::mt19937_64 rng(3);
  for (int i = 0; i < 20000; ++i) {
    const std::uint64_t bits = rng();
    double x;
    std::memcpy(&x, &bits, sizeof x);
    if (!std::isnan(x)) xs.push_back(x);
  }
  auto same = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  for (double x : xs) {
    EXPECT_TRUE(same(next_up(x), std::nextafter(x, INFINITY))) << std::hexfloat << x;
    EXPECT_TRUE(same(next_down(x), std::nextafter(x, -INFINITY))) << std::hexfloat << x;
  }
  EXPECT_TRUE(std::isnan(next_up(NAN)) && std::isnan(next_down(NAN)));
}

TEST(OracleExtremes, SubnormalsAndOverflowingProducts) {
  Oracle oracle = auditing_oracle();
  // Sphere of radius 2^-1070 at the origin, ray from −2^-1060: enters at 2^-1060 − 2^-1070.
  const double tiny = std::ldexp(1.0, -1070);
  Verdict v = oracle.judge(R({-std::ldexp(1.0, -1060), 0, 0}, {1, 0, 0}), Sphere{Vec3(0, 0, 0), tiny});
  EXPECT_EQ(v.cls, HitClass::enter);
  ASSERT_TRUE(v.t.has_value());
  EXPECT_EQ(*v.t, std::ldexp(1.0, -1060) - tiny);
  // b² ≈ 1e600 and |o − m|² overflow doubles; the oracle still answers exactly.
  v = oracle.judge(R({0, 0, 0}, {1, 0, 0}), Sphere{Vec3(1e300, 0, 0), 1e299});
  EXPECT_EQ(v.cls, HitClass::enter);
  ASSERT_TRUE(v.exact_t);
  ASSERT_TRUE(v.t.has_value());
  ASSERT_TRUE(v.exact_t != nullptr);
  EXPECT_TRUE(correctly_rounded(*v.exact_t, *v.t));
  v = oracle.judge(R({-DBL_MAX, 0, 0}, {DBL_MAX, 0, 0}), Sphere{Vec3(DBL_MAX, 0, 0), DBL_MAX});
  EXPECT_EQ(v.cls, HitClass::enter);  // through the centre; enters at x = 0, t = 1
  ASSERT_TRUE(v.t.has_value());
  EXPECT_EQ(*v.t, 1.0);
  v = oracle.judge(R({-DBL_MAX, DBL_MAX, 0}, {DBL_MAX, 0, 0}), Sphere{Vec3(DBL_MAX, 0, 0), DBL_MAX});
  EXPECT_EQ(v.cls, HitClass::tangent);  // touches (DBL_MAX, DBL_MAX, 0) at t = 2
  ASSERT_TRUE(v.t.has_value());
  EXPECT_EQ(*v.t, 2.0);
  v = oracle.judge(R({-0.0, 0, 0}, {1, 0, -0.0}), Sphere{Vec3(3, 0, 0), 1});
  EXPECT_EQ(v.cls, HitClass::enter);
  ASSERT_TRUE(v.t.has_value());
  EXPECT_EQ(*v.t, 2.0);
}

// ---------------------------------------------------------------------------------------------
std::vector<std::pair<Ray, Shape>> random_cases(int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> small(-3, 3);
  auto iv = [&] { return Vec3(small(rng), small(rng), small(rng)); };
  std::vector<std::pair<Ray, Shape>> out;
  for (int i = 0; i < n; ++i) {
    // Small integers make exact degeneracies (edges, vertices, coplanarity, tangents) common.
    Vec3 d = iv();
    if (d == Vec3::Zero()) d = Vec3(1, 0, 0);
    const Ray ray{i % 2 ? iv() : random_vec(rng, -2, 2), i % 3 ? d : random_vec(rng, -2, 2)};
    Shape shape;
    switch (i % 4) {
      case 0: shape = Sphere{iv(), double(1 + rng() % 3)}; break;
      case 1: {
        Vec3 nrm = iv();
        if (nrm == Vec3::Zero()) nrm = Vec3(0, 0, 1);
        shape = Plane{nrm, double(small(rng))};
        break;
      }
      case 2: {
        Triangle t{{iv(), iv(), iv()}};
        if (degenerate_reason(t)) t = kT;
        shape = t;
        break;
      }
      default: {
        const Vec3 a = iv(), b = iv();
        Box box{a.cwiseMin(b), a.cwiseMax(b)};
        if (degenerate_reason(box)) box = kB;
        shape = box;
      }
    }
    out.push_back({ray, shape});
  }
  return out;
}

TEST(OracleFilter, FilteredAndExactAnswersAreIdentical) {
  // Three configurations: intervals → expansions → rationals (default); intervals → rationals;
  // rationals only. Their answers must be identical.
  Oracle filtered, no_expansions(Oracle::Options{.expansions = false}), exact(Oracle::Options{.filter = false});
  auto cases = random_cases(40000, 99);
  for (const auto& [ray, sphere] : adversarial_spheres(4000, 21)) cases.push_back({ray, sphere});
  for (const auto& [ray, shape] : cases) {
    const Verdict a = filtered.judge(ray, shape), b = exact.judge(ray, shape), c = no_expansions.judge(ray, shape);
    ASSERT_EQ(a.cls, b.cls);
    ASSERT_EQ(a.t, b.t);
    ASSERT_EQ(c.cls, b.cls);
    ASSERT_EQ(c.t, b.t);
  }
  // The filter decides most classes; the exact path still runs on the degenerate ones.
  std::uint64_t decided_exactly = 0, queries = 0;
  for (ShapeKind k : kAllShapeKinds) {
    decided_exactly += filtered.stats(k).class_exact + filtered.stats(k).class_expansion;
    queries += filtered.stats(k).queries;
  }
  EXPECT_LT(decided_exactly, queries / 2);
  std::uint64_t by_expansions = 0, t_fast = 0, t_total = 0;
  for (ShapeKind k : kAllShapeKinds) {
    by_expansions += filtered.stats(k).class_expansion;
    t_total += filtered.stats(k).rounding.rounded;
    t_fast += filtered.stats(k).rounding.rounded - filtered.stats(k).rounding.rational;
  }
  EXPECT_GT(by_expansions, 0u);  // the degenerate cases reached the expansion stage
  EXPECT_GT(t_fast, t_total / 2);
}

// An independent judge of hit-or-miss: CGAL's exact do_intersect on rational objects, for rays
// whose origin is strictly outside the (closed) shape, where "not a miss" ⇔ "intersects".
TEST(OracleCrossCheck, AgreesWithCgalDoIntersectOnHitOrMiss) {
  Oracle oracle;
  int compared = 0;
  for (const auto& [ray, shape] : random_cases(20000, 7)) {
    const K::Point_3 o(mpq_class(ray.origin.x()), mpq_class(ray.origin.y()), mpq_class(ray.origin.z()));
    const K::Vector_3 d(mpq_class(ray.direction.x()), mpq_class(ray.direction.y()), mpq_class(ray.direction.z()));
    const K::Ray_3 kray(o, d);
    auto P = [](const Vec3& v) { return K::Point_3(mpq_class(v.x()), mpq_class(v.y()), mpq_class(v.z())); };
    std::optional<bool> cgal;
    if (const auto* t = std::get_if<Triangle>(&shape)) {
      const K::Triangle_3 tri(P(t->v[0]), P(t->v[1]), P(t->v[2]));
      if (!tri.has_on(o)) cgal = CGAL::do_intersect(kray, tri);
    } else if (const auto* b = std::get_if<Box>(&shape)) {
      const K::Iso_cuboid_3 box(P(b->min), P(b->max));
      if (box.has_on_unbounded_side(o)) cgal = CGAL::do_intersect(kray, box);
    }
    if (!cgal) continue;
    ++compared;
    EXPECT_EQ(oracle.judge(ray, shape).cls != HitClass::miss, *cgal);
  }
  EXPECT_GT(compared, 8000);
}

}  // namespace
}  // namespace rayproof

namespace rayproof {
namespace {

// The enter-only rule keeps a contact only where the ray enters: an entry, or an edge hit on a
// triangle's front face (worked out from the spec's table by hand).
TEST(OracleEnterOnly, PlanesTrianglesAndBoxes) {
  Oracle oracle;
  auto cls = [&](const Ray& r, const Shape& s) { return oracle.judge(r, s, HitRule::enter_only).cls; };
  const Plane floor{Vec3(0, 0, 1), 0};
  EXPECT_EQ(cls(R({0, 0, 2}, {0, 0, -1}), floor), HitClass::enter);   // arrives from the front
  EXPECT_EQ(cls(R({0, 0, -2}, {0, 0, 1}), floor), HitClass::miss);    // from the back: an exit
  EXPECT_EQ(cls(R({0, 0, 0}, {1, 0, 0}), floor), HitClass::miss);     // lying in it: a tangent
  const Triangle tri{{Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(0, 2, 0)}};  // front +z
  EXPECT_EQ(cls(R({0.5, 0.5, 1}, {0, 0, -1}), tri), HitClass::enter);
  EXPECT_EQ(cls(R({0.5, 0.5, -1}, {0, 0, 1}), tri), HitClass::miss);
  EXPECT_EQ(cls(R({1, 0, 1}, {0, 0, -1}), tri), HitClass::boundary);  // edge hit on the front face
  EXPECT_EQ(cls(R({1, 0, -1}, {0, 0, 1}), tri), HitClass::miss);      // edge hit from behind
  const Box box{Vec3(0, 0, 0), Vec3(2, 2, 2)};
  EXPECT_EQ(cls(R({-1, 1, 1}, {1, 0, 0}), box), HitClass::enter);
  EXPECT_EQ(cls(R({1, 1, 1}, {1, 0, 0}), box), HitClass::miss);   // from inside: an exit
  EXPECT_EQ(cls(R({-1, 0, 1}, {1, 0, 0}), box), HitClass::miss);  // along a face: a tangent
  // classify answers the same as judge under the rule.
  EXPECT_EQ(oracle.classify(R({1, 0, 1}, {0, 0, -1}), tri, HitRule::enter_only), HitClass::boundary);
  EXPECT_EQ(oracle.classify(R({1, 1, 1}, {1, 0, 0}), box, HitRule::enter_only), HitClass::miss);
}

}  // namespace
}  // namespace rayproof
