// The oracle's fast stages may only ever answer what the exact stage answers: every stage
// configuration gives the same class (judged, and classified alone), side and correctly rounded t
// on every generated family and shape, the same cases scaled by 2^±500 and 2^-537 (subnormal
// products), and rays whose products overflow. RAYPROOF_STAGE_CASES sets the cases per family
// and shape (default 1,000; the README's figure is 10^6 per shape).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <random>

#include "rayproof/core/eft.h"
#include "rayproof/fuzz/generators.h"
#include "rayproof/verify/oracle.h"

namespace rayproof {
namespace {

struct Configuration {
  const char* name;
  Oracle::Options options;
};

const Configuration kConfigurations[] = {
    {"every stage", {}},
    {"no static filter", {.static_filter = false}},
    {"no double-double", {.double_double = false}},
    {"no expansions", {.expansions = false}},
    {"static filter, then rationals", {.expansions = false, .double_double = false}},
    {"double-double by Dekker's product (no FMA)", {.fma = false}},
    {"no direct rounding of t", {.direct = false}},
};

Query scaled_query(const Query& q, int k) {
  const double f = std::ldexp(1.0, k);
  return {Ray{q.ray.origin * f, q.ray.direction * f}, scaled(q.shape, f)};
}

TEST(OracleStages, EveryConfigurationAnswersLikeTheRationalStage) {
  const char* env = std::getenv("RAYPROOF_STAGE_CASES");
  const std::uint64_t count = env ? std::strtoull(env, nullptr, 10) : 1000;
  Oracle exact(Oracle::Options{.filter = false});
  std::vector<Oracle> fast;
  for (const Configuration& c : kConfigurations) fast.emplace_back(c.options);
  std::uint64_t compared = 0, differences = 0;
  for (ShapeKind shape : kAllShapeKinds) {
    for (fuzz::Family family : fuzz::kAllFamilies) {
      for (std::uint64_t i = 0; i < count; ++i) {
        const Query base = fuzz::generate(family, shape, 77, i);
        for (int k : {0, 500, -500, -537}) {
          const Query q = k == 0 ? base : scaled_query(base, k);
          if (!is_valid_query(q.ray, q.shape)) continue;
          const Verdict truth = exact.judge(q.ray, q.shape);
          for (size_t c = 0; c < fast.size(); ++c) {
            const Verdict v = fast[c].judge(q.ray, q.shape);
            const HitClass cls = fast[c].classify(q.ray, q.shape);  // the class alone takes its own path
            ++compared;
            if (v.cls != truth.cls || v.t != truth.t || v.front != truth.front || cls != truth.cls) {
              if (++differences <= 5)
                ADD_FAILURE() << kConfigurations[c].name << " differs on " << to_string(family) << "/"
                              << to_string(shape) << " case " << i << " scaled 2^" << k << ": " << to_string(v.cls)
                              << " vs exact " << to_string(truth.cls);
            }
          }
        }
      }
    }
  }
  EXPECT_EQ(differences, 0u);
  // A comparison of no case proves nothing (RAYPROOF_STAGE_CASES=0 or unreadable): it fails.
  EXPECT_GT(compared, 0u) << "no case was compared (RAYPROOF_STAGE_CASES=" << (env ? env : "unset") << ")";
  std::printf("oracle stages: %llu comparisons, %llu differences\n", (unsigned long long)compared,
              (unsigned long long)differences);
}

// The oracle's double-double stage takes its exact products from one FMA where the CPU has one
// (core/eft.h): the same pair (p, e) as Dekker's product, bit for bit, so every verdict is the
// same either way. Products over the whole range the stage accepts (|a·b| from 2^-800 to 2^800),
// of random signs and mantissas, and near-ties.
#if defined(__x86_64__)
[[gnu::target("fma")]] void fma_product(double a, double b, double& p, double& e) { two_product_fma(a, b, p, e); }
TEST(OracleStages, TheFmaProductIsDekkersBitForBit) {
  if (!__builtin_cpu_supports("fma")) GTEST_SKIP() << "this CPU has no FMA";
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> mantissa(1, 2);
  std::uniform_int_distribution<int> exponent(-400, 400);
  long nonzero_errors = 0;
  for (int i = 0; i < 200000; ++i) {
    const double a = std::ldexp(mantissa(rng), exponent(rng)) * (rng() % 2 ? 1 : -1);
    double b = std::ldexp(mantissa(rng), exponent(rng)) * (rng() % 2 ? 1 : -1);
    if (i % 4 == 0) b = std::nextafter(1 / a, 0.0);  // a·b just below 1: a long error term
    double p1, e1, p2, e2;
    two_product_dekker(a, b, p1, e1);
    fma_product(a, b, p2, e2);
    ASSERT_EQ(p1, p2) << a << " * " << b;
    ASSERT_EQ(e1, e2) << a << " * " << b;
    nonzero_errors += e1 != 0;
  }
  EXPECT_GT(nonzero_errors, 100000);  // the products tested are mostly inexact
}
#endif

// The fast stages do the work they are there for: on random rays the static filter decides the
// class and double-double rounds t nearly always.
TEST(OracleStages, TheStaticFilterDecidesRandomRays) {
  for (ShapeKind shape : kAllShapeKinds) {
    Oracle oracle;
    for (std::uint64_t i = 0; i < 4000; ++i) {
      const Query q = fuzz::generate(fuzz::Family::random, shape, 5, i);
      oracle.judge(q.ray, q.shape);
    }
    const OracleStats& s = oracle.stats(shape);
    const std::uint64_t beyond_static = s.class_interval + s.class_expansion + s.class_exact;
    EXPECT_LT(beyond_static, s.queries / 100) << to_string(shape);
    EXPECT_LT(s.rounding.expansion + s.rounding.rational, s.rounding.rounded / 100 + 1) << to_string(shape);
    // ... and the shape's direct path rounds it without the generic double-double stage.
    EXPECT_GT(s.rounding.direct, s.rounding.rounded * 99 / 100) << to_string(shape);
    std::printf("%s: %llu of %llu t rounded directly\n", std::string(to_string(shape)).c_str(),
                (unsigned long long)s.rounding.direct, (unsigned long long)s.rounding.rounded);
  }
}

// A random box about the unit cube (half-widths 0.1 to 1.1), its centre in c and its half-widths in half.
Box random_box(std::mt19937_64& rng, Vec3& c, Vec3& half) {
  std::uniform_real_distribution<double> u(-1, 1);
  c = Vec3(u(rng), u(rng), u(rng));
  half = Vec3(0.1 + std::abs(u(rng)), 0.1 + std::abs(u(rng)), 0.1 + std::abs(u(rng)));
  return Box{c - half, c + half};
}

// One box query judged and classified by the filtered oracle against the rational one, counting
// the queries whose class the static filter decided (judge's stage counters unchanged).
struct AgainstRationals {
  Oracle exact{Oracle::Options{.filter = false}}, filtered;
  long compared = 0, decided_static = 0;
  ::testing::AssertionResult same(const Ray& ray, const Box& box) {
    const OracleStats before = filtered.stats(ShapeKind::box);
    const Verdict truth = exact.judge(ray, box), v = filtered.judge(ray, box);
    const OracleStats after = filtered.stats(ShapeKind::box);
    decided_static += after.class_interval + after.class_expansion + after.class_exact ==
                      before.class_interval + before.class_expansion + before.class_exact;
    ++compared;
    const HitClass cls = filtered.classify(ray, box);
    if (v.cls != truth.cls || v.t != truth.t || v.front != truth.front || cls != truth.cls)
      return ::testing::AssertionFailure() << "judged " << to_string(v.cls) << ", classified " << to_string(cls)
                                           << ", exact " << to_string(truth.cls) << " (or t or side differ)";
    return ::testing::AssertionSuccess();
  }
};

// The direct rounding of t (oracle.cpp's round_static) where t is a rounding midpoint exactly or
// within 2^-105 of one: a box's entry and a plane's crossing at t = 1 + 2^-52 + 2^-53 − k·2^-105
// (o_x = −2^-53 + k·2^-105, the plane at 1 + 2^-52, d_x = 1: t = plane − o_x exactly). Ties go
// to even and the near-ties to their side, as the rationals say; the exact tie cannot be proved
// by the quotient test, so it must be left to the stages (not counted as rounded directly).
TEST(OracleStages, DirectRoundingAtAndBesideMidpoints) {
  Oracle exact(Oracle::Options{.filter = false});
  const double plane = 1 + 0x1p-52;
  for (int k = -3; k <= 3; ++k) {
    const Ray ray{Vec3(-0x1p-53 + k * 0x1p-105, 0, 0), Vec3(1, 0x1p-10, 0x1p-12)};
    const Shape shapes[] = {Box{Vec3(plane, -1, -1), Vec3(3, 1, 1)}, Plane{Vec3(1, 0, 0), plane}};
    for (const Shape& shape : shapes) {
      Oracle filtered;
      const Verdict truth = exact.judge(ray, shape), v = filtered.judge(ray, shape);
      ASSERT_TRUE(truth.t.has_value()) << k;
      EXPECT_EQ(v.cls, truth.cls) << k;
      EXPECT_EQ(v.t, truth.t) << "k = " << k;
      const double expected = k <= 0 ? 1 + 0x1p-51 : plane;  // the tie to even (1 + 2^-52 is odd)
      EXPECT_EQ(*truth.t, expected) << k;
      const OracleStats& stats = filtered.stats(static_cast<ShapeKind>(shape.index()));
      if (k == 0) {
        EXPECT_EQ(stats.rounding.direct, 0u) << "a tie was 'proved' by the quotient test";
      }
    }
  }
}

// The shapes' static filters where a sign is within rounding of zero: rays aimed a few ulps off a
// box's edges and corners from random origins, so two slab parameters (or t_min and t_max) are
// about equal and their computed order may differ from the exact one. The filtered oracle must
// answer as the rational one; the static filter must still decide some of them (else this tests
// nothing of it).
TEST(OracleStages, TheBoxFilterIsNotFooledAtEdgesAndCorners) {
  std::mt19937_64 rng(41);
  std::uniform_real_distribution<double> u(-1, 1);
  AgainstRationals check;
  for (int i = 0; i < 20000; ++i) {
    Vec3 c, half;
    const Box box = random_box(rng, c, half);
    Vec3 target;  // a corner, or an edge point (the axis i % 3 free)
    for (int k = 0; k < 3; ++k) target[k] = rng() % 2 ? box.min[k] : box.max[k];
    if (i % 2) target[i % 3] = c[i % 3] + 0.5 * half[i % 3] * u(rng);
    for (int k = 0; k < 3; ++k)  // a few ulps either way
      for (int steps = static_cast<int>(rng() % 7) - 3; steps != 0; steps += steps > 0 ? -1 : 1)
        target[k] = std::nextafter(target[k], steps > 0 ? 10.0 : -10.0);
    const Vec3 origin(4 * u(rng), 4 * u(rng), 4 * u(rng));
    const Ray ray{origin, target - origin};
    if (is_valid_query(ray, box)) {
      ASSERT_TRUE(check.same(ray, box)) << "ray " << i;
    }
  }
  EXPECT_GT(check.compared, 19000);
  EXPECT_GT(check.decided_static, check.compared / 100);  // 846 of 20,000 when written: most are within rounding
}

// Axis-parallel rays at boxes (one or two direction components zero, as a camera looking down an
// axis makes them), origins on, inside and outside the faces those axes do not cross: the box
// filters' d = 0 path (a slab the ray never leaves, a miss, or undecided on a face) must answer
// as the rational stage, and decide some of the rays itself.
TEST(OracleStages, AxisParallelRaysAtBoxesAnswerAsTheRationalStage) {
  std::mt19937_64 rng(47);
  std::uniform_real_distribution<double> u(-1, 1);
  AgainstRationals check;
  for (int i = 0; i < 20000; ++i) {
    Vec3 c, half;
    const Box box = random_box(rng, c, half);
    Vec3 origin(4 * u(rng), 4 * u(rng), 4 * u(rng)), direction(u(rng), u(rng), u(rng));
    const int zeros = 1 + static_cast<int>(rng() % 2);
    for (int z = 0; z < zeros; ++z) {
      const int k = static_cast<int>(rng() % 3);
      direction[k] = rng() % 2 ? 0.0 : -0.0;
      switch (rng() % 4) {  // where the origin sits along that axis
        case 0: origin[k] = box.min[k]; break;
        case 1: origin[k] = box.max[k]; break;
        case 2: origin[k] = c[k] + 0.5 * half[k] * u(rng); break;  // strictly inside the slab
        default: break;                                            // anywhere, mostly outside
      }
    }
    const Ray ray{origin, direction};
    if (is_valid_query(ray, box)) {
      ASSERT_TRUE(check.same(ray, box)) << "ray " << i;
    }
  }
  EXPECT_GT(check.compared, 19000);
  EXPECT_GT(check.decided_static, check.compared / 2);  // faces are undecided; the rest is the filters'
}

// Degenerate triangles (collinear vertices), which case files refuse but meshes may hold: the
// terms read every ray as coplanar with them, and the static filter, whose edges then take both
// signs on most rays, must not call those a plain miss on its own.
TEST(OracleStages, DegenerateTrianglesAnswerAsTheRationalStage) {
  std::mt19937_64 rng(43);
  std::uniform_int_distribution<int> small(-64, 64);
  auto dyadic = [&]() -> Vec3 { return Vec3(small(rng), small(rng), small(rng)) / 16; };  // exact sums, doubles
  Oracle exact(Oracle::Options{.filter = false}), filtered;
  long tangent = 0;
  for (int i = 0; i < 4000; ++i) {
    const Vec3 v0 = dyadic(), step = dyadic();
    const Triangle tri{{v0, v0 + step, v0 + 2 * step}};
    const Ray ray{dyadic() + Vec3(0.01, 0.02, 0.03), dyadic() + Vec3(0.1, 0, 0)};
    const Verdict truth = exact.judge(ray, tri), v = filtered.judge(ray, tri);
    ASSERT_EQ(v.cls, truth.cls) << "ray " << i;
    ASSERT_EQ(v.t, truth.t) << "ray " << i;
    ASSERT_EQ(filtered.classify(ray, tri), truth.cls) << "ray " << i;
    tangent += truth.cls == HitClass::tangent;
  }
  EXPECT_GT(tangent, 0);
}

}  // namespace
}  // namespace rayproof

#include <gmpxx.h>

namespace rayproof {
namespace {

using Q = mpq_class;

// sign(p + s·√D) for rationals, D ≥ 0 (written here, apart from the oracle's code).
int sign_with_root(const Q& p, int s, const Q& D) {
  const int sp = sgn(p);
  if (s == 0 || sgn(D) == 0) return sp;
  if (sp == 0 || sp == s) return s;
  const int c = cmp(p * p, D);  // |p| against √D
  return c == 0 ? 0 : (c > 0 ? sp : s);
}

// Whether x is the double nearest to t = (p + s√D)/q, q > 0: t lies between the midpoints to
// x's neighbours (ties either way).
bool nearest_double(double x, const Q& p, int s, const Q& D, const Q& q) {
  if (!(x > 0) || std::isinf(x)) return true;  // 0 and inf are checked by the rounding tests
  const Q lo = (Q(std::nextafter(x, 0.0)) + Q(x)) / 2, hi = (Q(x) + Q(std::nextafter(x, INFINITY))) / 2;
  return sign_with_root(p - lo * q, s, D) >= 0 && sign_with_root(p - hi * q, s, D) <= 0;
}

// The spec's table for a sphere in rationals: with f = o − m, a = d·d, h = −f·d, c = f·f − r²,
// the roots are (h ∓ √(h² − ac))/a. Returns the class and checks the oracle's t.
struct SphereTruth {
  HitClass cls = HitClass::miss;
  int s = 0;  // which root: −1 near, +1 far, 0 double root or 2h/a
  Q p, D, q;
};
SphereTruth sphere_truth(const Ray& ray, const Sphere& sp) {
  Q f[3], d[3];
  for (int i = 0; i < 3; ++i) f[i] = Q(ray.origin[i]) - Q(sp.center[i]), d[i] = Q(ray.direction[i]);
  const Q a = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
  const Q h = -(f[0] * d[0] + f[1] * d[1] + f[2] * d[2]);
  const Q c = f[0] * f[0] + f[1] * f[1] + f[2] * f[2] - Q(sp.radius) * Q(sp.radius);
  const Q D = h * h - a * c;
  SphereTruth t;
  if (D < 0) return t;
  if (D == 0) {
    if (h > 0) t = {HitClass::tangent, 0, h, 0, a};
    return t;
  }
  if (c > 0) {
    if (h > 0) t = {HitClass::enter, -1, h, D, a};  // both roots positive: the near one
  } else if (c == 0) {
    if (h > 0) t = {HitClass::exit, 0, 2 * h, 0, a};  // roots 0 and 2h/a
  } else {
    t = {HitClass::exit, +1, h, D, a};
  }
  return t;
}

// Spheres and planes on the adversarial families, at 2^±500 too: the oracle's class and its
// correctly rounded t against the spec's table worked in rationals here.
TEST(OracleVersusRationals, SpheresAndPlanesOnEveryFamily) {
  Oracle oracle;
  long checked = 0, with_t = 0;
  for (fuzz::Family family : fuzz::kAllFamilies)
    for (std::uint64_t i = 0; i < 1500; ++i)
      for (int k : {0, 500, -500}) {
        const Query sq = k == 0 ? Query(fuzz::generate(family, ShapeKind::sphere, 11, i))
                                : scaled_query(fuzz::generate(family, ShapeKind::sphere, 11, i), k);
        if (is_valid_query(sq.ray, sq.shape)) {
          const SphereTruth truth = sphere_truth(sq.ray, std::get<Sphere>(sq.shape));
          const Verdict v = oracle.judge(sq.ray, sq.shape);
          ASSERT_EQ(v.cls, truth.cls) << to_string(family) << " " << i << " 2^" << k;
          ASSERT_EQ(v.t.has_value(), truth.cls != HitClass::miss);
          if (v.t) {
            ASSERT_TRUE(nearest_double(*v.t, truth.p, truth.s, truth.D, truth.q)) << to_string(family) << " " << i;
            ++with_t;
          }
          ++checked;
        }
        const Query pq = k == 0 ? Query(fuzz::generate(family, ShapeKind::plane, 11, i))
                                : scaled_query(fuzz::generate(family, ShapeKind::plane, 11, i), k);
        if (!is_valid_query(pq.ray, pq.shape)) continue;
        const Plane& pl = std::get<Plane>(pq.shape);
        Q num = Q(pl.offset), den = 0;
        for (int a = 0; a < 3; ++a)
          num -= Q(pl.normal[a]) * Q(pq.ray.origin[a]), den += Q(pl.normal[a]) * Q(pq.ray.direction[a]);
        HitClass cls = HitClass::miss;
        if (den == 0)
          cls = num == 0 ? HitClass::tangent : HitClass::miss;
        else if (sgn(num) == sgn(den))
          cls = den < 0 ? HitClass::enter : HitClass::exit;
        const Verdict v = oracle.judge(pq.ray, pq.shape);
        ASSERT_EQ(v.cls, cls) << "plane " << to_string(family) << " " << i << " 2^" << k;
        if (den != 0 && cls != HitClass::miss) {
          ASSERT_TRUE(v.t.has_value());
          ASSERT_TRUE(den > 0 ? nearest_double(*v.t, num, 0, 0, den) : nearest_double(*v.t, -num, 0, 0, -den));
          ++with_t;
        }
        ++checked;
      }
  EXPECT_GT(checked, 40000);
  EXPECT_GT(with_t, 10000);
}

}  // namespace
}  // namespace rayproof

#include <algorithm>
#include <random>

#include "rayproof/verify/filtered.h"

namespace rayproof {
namespace {

// The filters' bounds on directed cases (issue 23): 3×3 determinants whose third row is a
// combination of the first two plus a perturbation swept from 2^-80 to 2^-20 of the rows' size,
// so the exact value sits anywhere from far inside the bound to far outside, with the rows scaled
// by 2^±500 and into subnormal products. Every sign a filter certifies must be the exact sign;
// and many must be certified close to the bound (|v| within 8 bounds), or the test saw only easy
// cases.
template <class Filtered>
std::optional<int> filtered_det3(const std::array<double, 9>& m) {
  const Filtered a(m[0]), b(m[1]), c(m[2]), d(m[3]), e(m[4]), f(m[5]), g(m[6]), h(m[7]), i(m[8]);
  return (a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)).sign();
}
int exact_det3(const std::array<double, 9>& m) {
  std::array<Q, 9> q;
  for (int k = 0; k < 9; ++k) q[k] = m[k];
  return sgn(q[0] * (q[4] * q[8] - q[5] * q[7]) - q[1] * (q[3] * q[8] - q[5] * q[6]) +
             q[2] * (q[3] * q[7] - q[4] * q[6]));
}

TEST(FilterBounds, NearSingularDeterminantsNeverGetAWrongSign) {
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> u(-1, 1);
  std::uniform_int_distribution<int> sweep(-80, -20);
  long certified = 0, near_the_bound = 0, wrong = 0, dd_certified = 0;
  for (int n = 0; n < 60000; ++n) {
    const int scale = std::array{0, 0, 500, -500, -300}[n % 5];
    std::array<double, 9> m;
    for (int k = 0; k < 6; ++k) m[k] = u(rng);
    const double alpha = u(rng), beta = u(rng), tiny = std::ldexp(1.0, sweep(rng));
    for (int k = 0; k < 3; ++k) m[6 + k] = alpha * m[k] + beta * m[3 + k] + tiny * u(rng);
    for (double& x : m) x = std::ldexp(x, scale / 3);  // each product of three scales by 2^scale
    const int truth = exact_det3(m);
    if (const auto s = filtered_det3<FilteredDouble>(m)) {
      ++certified;
      if (*s != truth && ++wrong <= 5) ADD_FAILURE() << "FilteredDouble certified " << *s << ", exact " << truth;
    }
    if (const auto s = filtered_det3<FilteredDD>(m)) {
      ++dd_certified;
      if (*s != truth && ++wrong <= 5) ADD_FAILURE() << "FilteredDD certified " << *s << ", exact " << truth;
    }
    // How close the certified cases come: the same determinant with the perturbation at the
    // double filter's edge, 2^-50..2^-46 of the rows' size.
    if (n % 5 < 2 && tiny < 0x1p-44 && tiny > 0x1p-54 && filtered_det3<FilteredDouble>(m)) ++near_the_bound;
  }
  EXPECT_EQ(wrong, 0);
  EXPECT_GT(certified, 20000);
  EXPECT_GT(dd_certified, certified);
  EXPECT_GT(near_the_bound, 50) << "certified cases within a few bits of the filter's bound";
}

// The premise of FilteredDD's bound: each double-double operation is one rounding of the model
// at ε = kEpsilonDD, fl(x ∘ y) = (x ∘ y)(1 + δ) with |δ| ≤ ε. Normalised pairs whose low parts
// reach half an ulp of the high, sums that cancel to a few bits, products across 2^±30: the
// relative errors met, measured in rationals, must stay below ε — and must exceed u² = 2^-106
// (about 4u² for products), or an ε 64 times too small would pass here as everywhere else.
TEST(FilterBounds, DoubleDoubleOperationsAreOneRoundingAtTheirEpsilon) {
  std::mt19937_64 rng(100);
  std::uniform_real_distribution<double> mantissa(1, 2), u(-1, 1);
  const auto pick = [&](double& hi, double& lo) {  // a normalised pair, |lo| ≤ ulp(hi)/2
    hi = (rng() & 1 ? 1 : -1) * mantissa(rng);
    const double half_ulp = std::ldexp(1.0, std::ilogb(hi) - 53);
    switch (rng() % 3) {
      case 0: lo = half_ulp * u(rng); break;
      case 1: lo = half_ulp * (1 - std::ldexp(std::abs(u(rng)), -20)) * (rng() & 1 ? 1 : -1); break;
      default: lo = half_ulp * std::ldexp(u(rng), -static_cast<int>(rng() % 30)); break;
    }
    const double sum = hi + lo;
    lo -= sum - hi;
    hi = sum;
  };
  const auto relative_error = [](double rh, double rl, const Q& exact) {
    return Q(abs(Q(rh) + Q(rl) - exact) / abs(exact)).get_d();
  };
  double worst_sum = 0, worst_product = 0;
  for (int n = 0; n < 60000; ++n) {
    double ah, al, bh, bl, rh, rl;
    pick(ah, al);
    pick(bh, bl);
    const int scale = static_cast<int>(rng() % 61) - 30;
    bh = std::ldexp(bh, scale), bl = std::ldexp(bl, scale);
    if (rng() & 1) {  // b about −a: the sum cancels to anywhere between 1 and 50 bits
      bh = -ah * (1 + std::ldexp(u(rng), -static_cast<int>(rng() % 50)));
      bl = std::ldexp(u(rng), std::ilogb(bh) - 54);
      const double sum = bh + bl;
      bl -= sum - bh;
      bh = sum;
    }
    dd_sum(ah, al, bh, bl, rh, rl);
    if (const Q exact = Q(ah) + Q(al) + Q(bh) + Q(bl); exact != 0)
      worst_sum = std::max(worst_sum, relative_error(rh, rl, exact));
    dd_product<DekkerProduct>(ah, al, bh, bl, rh, rl);
    worst_product = std::max(worst_product, relative_error(rh, rl, (Q(ah) + Q(al)) * (Q(bh) + Q(bl))));
  }
  EXPECT_LE(worst_sum, filter_detail::kEpsilonDD);
  EXPECT_LE(worst_product, filter_detail::kEpsilonDD);
  EXPECT_GT(worst_sum, 0x1p-106) << "no sum met an error above u²";
  EXPECT_GT(worst_product, 0x1p-105) << "no product met an error above 2u²";
}

}  // namespace
}  // namespace rayproof
