// The oracle's fast stages may only ever answer what the exact stage answers: every stage
// configuration gives the same class, side and correctly rounded t on every generated family and
// shape, the same cases scaled by 2^±500 and 2^-537 (subnormal products), and rays whose products
// overflow. RAYPROOF_STAGE_CASES sets the cases per family and shape (default 1,000; the README's
// figure is 10^6 per shape).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

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
            ++compared;
            if (v.cls != truth.cls || v.t != truth.t || v.front != truth.front) {
              if (++differences <= 5)
                ADD_FAILURE() << kConfigurations[c].name << " differs on " << to_string(family) << "/" << to_string(shape)
                              << " case " << i << " scaled 2^" << k << ": " << to_string(v.cls) << " vs exact "
                              << to_string(truth.cls);
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
  }
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
        for (int a = 0; a < 3; ++a) num -= Q(pl.normal[a]) * Q(pq.ray.origin[a]), den += Q(pl.normal[a]) * Q(pq.ray.direction[a]);
        HitClass cls = HitClass::miss;
        if (den == 0) cls = num == 0 ? HitClass::tangent : HitClass::miss;
        else if (sgn(num) == sgn(den)) cls = den < 0 ? HitClass::enter : HitClass::exit;
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
