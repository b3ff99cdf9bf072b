// The comparison every accuracy table rests on: the agree / wrong / cannot-tell split and the
// ULP distance, each against expectations written out by hand.
#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "rayproof/verify/compare.h"

namespace rayproof {
namespace {

TEST(Compare, AgreementOfEveryPairOfClasses) {
  using C = HitClass;
  const C classes[] = {C::miss, C::enter, C::exit, C::tangent, C::boundary};
  // Rows: exact class; columns: reported class. a = agrees, c = cannot tell, w = wrong.
  const char* table[] = {
      //        miss enter exit tangent boundary
      /* miss */ "awwww",
      /* enter */ "wawww",
      /* exit */ "wwaww",
      /* tangent */ "cccaw",
      /* boundary */ "cccwa",
  };
  for (int e = 0; e < 5; ++e)
    for (int r = 0; r < 5; ++r) {
      const Agreement want = table[e][r] == 'a'   ? Agreement::agrees
                             : table[e][r] == 'c' ? Agreement::cannot_tell
                                                  : Agreement::wrong;
      EXPECT_EQ(agreement_of(classes[e], classes[r]), want) << to_string(classes[e]) << " -> " << to_string(classes[r]);
    }
}

// The one double-to-float conversion (fp.h): round to nearest, ties to even, ±inf from
// FLT_MAX + ½ulp (0x1.ffffffp+127) on, NaN for NaN, subnormal floats and their ties included:
// checked against an independent rounding written from the bits.
TEST(Compare, ToNearestFloat) {
  const float inf = std::numeric_limits<float>::infinity();
  EXPECT_EQ(to_nearest_float(0x1.ffffffp+127), inf);
  EXPECT_EQ(to_nearest_float(-0x1.ffffffp+127), -inf);
  EXPECT_EQ(to_nearest_float(std::nextafter(0x1.ffffffp+127, 0.0)), FLT_MAX);
  EXPECT_EQ(to_nearest_float(-std::nextafter(0x1.ffffffp+127, 0.0)), -FLT_MAX);
  EXPECT_EQ(to_nearest_float(DBL_MAX), inf);
  EXPECT_EQ(to_nearest_float(-INFINITY), -inf);
  EXPECT_TRUE(std::isnan(to_nearest_float(NAN)));
  EXPECT_EQ(to_nearest_float(1 + 0x1p-24), 1.0f);                    // a tie: to even
  EXPECT_EQ(to_nearest_float(1 + 0x1p-24 + 0x1p-52), 1 + 0x1p-23f);  // just above it
  EXPECT_EQ(to_nearest_float(1 + 3 * 0x1p-24), 1 + 0x1p-22f);        // a tie: to even, upwards
  EXPECT_EQ(to_nearest_float(0x1p-150), 0.0f);                       // half the smallest subnormal: to 0
  EXPECT_EQ(to_nearest_float(0x1.8p-150), 0x1p-149f);                // above it
  EXPECT_EQ(to_nearest_float(-0.0), -0.0f);
  EXPECT_TRUE(std::signbit(to_nearest_float(-0.0)));
  // Random doubles over float's whole range against a rounding from the bits: the two floats
  // around x (by nextafter from the truncation) and the nearer, ties to the even one.
  std::uint64_t state = 1;
  for (int i = 0; i < 100000; ++i) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    const double x = std::ldexp(1 + double(state >> 11) * 0x1p-53, int(state % 300) - 160) * (state & 1 ? -1 : 1);
    const double a = std::abs(x);
    if (!(a < double(FLT_MAX))) continue;
    float lo = float(a);  // some float next to a (the cast rounds in the current mode)
    if (double(lo) > a) lo = std::nextafter(lo, 0.0f);
    const float hi = std::nextafter(lo, inf);
    const double below = a - double(lo), above = double(hi) - a;
    std::uint32_t bits;
    std::memcpy(&bits, &lo, sizeof bits);
    const float nearest = below < above ? lo : above < below ? hi : (bits % 2 == 0 ? lo : hi);
    ASSERT_EQ(to_nearest_float(x), x < 0 ? -nearest : nearest) << std::hexfloat << x;
  }
}

TEST(Compare, UlpDistance) {
  const double tiny = std::numeric_limits<double>::denorm_min(), inf = INFINITY;
  EXPECT_EQ(ulp_distance(1.0, 1.0), 0u);
  EXPECT_EQ(ulp_distance(0.0, -0.0), 0u);
  EXPECT_EQ(ulp_distance(1.0, std::nextafter(1.0, 2.0)), 1u);
  EXPECT_EQ(ulp_distance(std::nextafter(1.0, 2.0), 1.0), 1u);
  EXPECT_EQ(ulp_distance(1.0, 2.0), 1ull << 52);  // one binade: 2^52 doubles
  EXPECT_EQ(ulp_distance(0.5, 1.0), 1ull << 52);
  EXPECT_EQ(ulp_distance(-tiny, tiny), 2u);  // across zero: −tiny, 0, tiny
  EXPECT_EQ(ulp_distance(-0.0, tiny), 1u);
  EXPECT_EQ(ulp_distance(0.0, 5 * tiny), 5u);  // subnormals are evenly spaced
  EXPECT_EQ(ulp_distance(DBL_MIN, std::nextafter(DBL_MIN, 0.0)), 1u);
  EXPECT_EQ(ulp_distance(DBL_MAX, inf), 1u);  // inf is the double just beyond DBL_MAX
  EXPECT_EQ(ulp_distance(-inf, inf), 2 * 0x7ff0000000000000ull);
  EXPECT_EQ(ulp_distance(-1.0, 1.0), 2 * 0x3ff0000000000000ull);
  EXPECT_FALSE(ulp_distance(NAN, 1.0).has_value());
  EXPECT_FALSE(ulp_distance(1.0, NAN).has_value());
}

TEST(Compare, JudgedAnswerCarriesTheUlpOnlyWhereBothHaveAT) {
  Verdict exact;
  exact.cls = HitClass::enter;
  exact.t = 2.0;
  EXPECT_EQ(judge_answer(exact, Hit{HitClass::enter, std::nextafter(2.0, 0.0)}).ulp, 1u);
  EXPECT_FALSE(judge_answer(exact, Hit::miss()).ulp.has_value());
  Verdict no_t;
  no_t.cls = HitClass::tangent;  // a ray lying in a plane
  EXPECT_FALSE(judge_answer(no_t, Hit{HitClass::tangent, 1.0}).ulp.has_value());
  EXPECT_EQ(judge_answer(no_t, Hit{HitClass::tangent}).agreement, Agreement::agrees);
}

TEST(Compare, SharedEdgeCrossingRule) {
  auto verdict = [](HitClass c, bool front) {
    Verdict v;
    v.cls = c;
    v.front = front;
    return v;
  };
  const Verdict miss = verdict(HitClass::miss, false);
  EXPECT_TRUE(crosses_shared_edge(verdict(HitClass::boundary, true), verdict(HitClass::boundary, true)));
  EXPECT_TRUE(crosses_shared_edge(verdict(HitClass::enter, true), miss));
  EXPECT_TRUE(crosses_shared_edge(miss, verdict(HitClass::exit, false)));
  EXPECT_FALSE(crosses_shared_edge(miss, miss));
  // Seen folded (front of one, back of the other): a silhouette, where missing both is fair.
  EXPECT_FALSE(crosses_shared_edge(verdict(HitClass::boundary, true), verdict(HitClass::boundary, false)));
}

}  // namespace
}  // namespace rayproof

namespace rayproof {
namespace {

// The built-in float variants (NAME-f32) are judged as float plugins are (plugin.md): on the case
// rounded to float, against the oracle's verdict on those numbers, with the t error in floats;
// a case that overflows float is not_representable.
std::vector<const Variant*> float_variants() {
  std::vector<const Variant*> out;
  for (const Variant& v : all_variants())
    if (v.precision == Precision::f32 && v.kernel) out.push_back(&v);
  return out;
}

Shape sample_shape(ShapeKind k, double wobble) {
  switch (k) {
    case ShapeKind::sphere: return Sphere{Vec3(0.1, -0.2, 0.3 + wobble), 1.1};
    case ShapeKind::plane: return Plane{Vec3(0.1, 0.2, 1), 0.7 + wobble};
    case ShapeKind::triangle:
      return Triangle{{Vec3(-1.1, -0.9, 0.3), Vec3(1.3, -1, 0.1 + wobble), Vec3(0.2, 1.7, -0.1)}};
    case ShapeKind::box: return Box{Vec3(-0.9, -1.1, -0.7 + wobble), Vec3(1.3, 0.9, 1.1)};
  }
  return {};
}

TEST(FloatVariants, EveryFormulaHasAFloatTwinJudgedOnTheFloatRoundedCase) {
  const std::vector<const Variant*> floats = float_variants();
  EXPECT_EQ(floats.size(), 10u);
  for (const Variant* v : floats) {
    const std::string name(v->name);
    ASSERT_TRUE(name.ends_with("-f32")) << name;
    EXPECT_NE(find_variant(name.substr(0, name.size() - 4)), nullptr) << name;  // its double twin
    Oracle oracle;
    int agree = 0, judged = 0;
    for (int i = 0; i < 200; ++i) {
      // 0.1, 0.3 + i·1e-9, ... are not floats: the variant sees them rounded.
      const Query q{
          Ray{Vec3(0.01 * i - 1, 0.3, 5.1), Vec3(0.001 * i, -0.01, -1)}, sample_shape(v->shape, 1e-9 * i), {}};
      const Verdict exact = oracle.judge(q.ray, q.shape);
      const VariantOutcome o = compare_variant(oracle, *v, exact, q, HitRule::nearest_contact);
      ASSERT_FALSE(o.answer.failed()) << name << " " << i;
      ASSERT_TRUE(o.own_exact) << name;  // judged on what it saw
      const Query seen = *rounded_to_float(q);
      const Verdict truth = oracle.judge(seen.ray, seen.shape);
      EXPECT_EQ(o.own_exact->cls, truth.cls) << name << " " << i;
      EXPECT_EQ(o.own_exact->t, truth.t) << name << " " << i;
      ++judged, agree += o.agreement == Agreement::agrees;
      if (o.agreement == Agreement::agrees && truth.t && o.answer.has_t()) {
        ASSERT_TRUE(o.ulp_own) << name;
        EXPECT_LE(*o.ulp_own, 64u) << name << " " << i;  // a few float ulps on these tame cases
      }
    }
    EXPECT_GE(agree, judged * 9 / 10) << name;
    // Beyond float's range: not representable, never a wrong answer.
    const Query huge{Ray{Vec3(1e39, 0, 5), Vec3(0, 0, -1)}, sample_shape(v->shape, 0), {}};
    EXPECT_EQ(
        compare_variant(oracle, *v, oracle.judge(huge.ray, huge.shape), huge, HitRule::nearest_contact).answer.failure,
        AnswerFailure::not_representable)
        << name;
  }
}

}  // namespace
}  // namespace rayproof
