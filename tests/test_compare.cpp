// The comparison every accuracy table rests on: the agree / wrong / cannot-tell split and the
// ULP distance, each against expectations written out by hand.
#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
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
      const Agreement want = table[e][r] == 'a' ? Agreement::agrees : table[e][r] == 'c' ? Agreement::cannot_tell : Agreement::wrong;
      EXPECT_EQ(agreement_of(classes[e], classes[r]), want) << to_string(classes[e]) << " -> " << to_string(classes[r]);
    }
}

TEST(Compare, UlpDistance) {
  const double tiny = std::numeric_limits<double>::denorm_min(), inf = INFINITY;
  EXPECT_EQ(ulp_distance(1.0, 1.0), 0u);
  EXPECT_EQ(ulp_distance(0.0, -0.0), 0u);
  EXPECT_EQ(ulp_distance(1.0, std::nextafter(1.0, 2.0)), 1u);
  EXPECT_EQ(ulp_distance(std::nextafter(1.0, 2.0), 1.0), 1u);
  EXPECT_EQ(ulp_distance(1.0, 2.0), 1ull << 52);          // one binade: 2^52 doubles
  EXPECT_EQ(ulp_distance(0.5, 1.0), 1ull << 52);
  EXPECT_EQ(ulp_distance(-tiny, tiny), 2u);               // across zero: −tiny, 0, tiny
  EXPECT_EQ(ulp_distance(-0.0, tiny), 1u);
  EXPECT_EQ(ulp_distance(0.0, 5 * tiny), 5u);             // subnormals are evenly spaced
  EXPECT_EQ(ulp_distance(DBL_MIN, std::nextafter(DBL_MIN, 0.0)), 1u);
  EXPECT_EQ(ulp_distance(DBL_MAX, inf), 1u);              // inf is the double just beyond DBL_MAX
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
