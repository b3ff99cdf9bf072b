// The Embree peer (built only with libembree-dev): its classes follow the case format, its
// inputs are the float-rounded queries, and the oracle can count its shared-edge holes.
#include <gtest/gtest.h>

#include "rayproof/peers/embree.h"
#include "rayproof/verify/oracle.h"

namespace rayproof::peers {
namespace {

Hit ask(const studies::Contender& c, const Query& q) {
  const std::vector<Query> qs = {q};
  const studies::Prepared p = c.prepare(qs);
  p.run();
  return p.answer(0);
}

TEST(EmbreePeer, FrontBackAndMissFollowTheCaseFormat) {
  const Triangle tri{{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)}};  // front +z
  const Sphere sphere{Vec3(0, 0, 0), 1};
  for (const studies::Contender& c : embree_contenders()) {
    if (c.shape == ShapeKind::triangle) {
      EXPECT_EQ(ask(c, {Ray{Vec3(0.25, 0.25, 1), Vec3(0, 0, -1)}, tri}).cls, HitClass::enter) << c.name;
      EXPECT_EQ(ask(c, {Ray{Vec3(0.25, 0.25, -1), Vec3(0, 0, 1)}, tri}).cls, HitClass::exit) << c.name;
      EXPECT_EQ(ask(c, {Ray{Vec3(2, 2, 1), Vec3(0, 0, -1)}, tri}).cls, HitClass::miss) << c.name;
    } else {
      const Hit h = ask(c, {Ray{Vec3(-3, 0, 0), Vec3(1, 0, 0)}, sphere});
      EXPECT_EQ(h.cls, HitClass::enter) << c.name;
      EXPECT_NEAR(h.t, 2.0, 1e-6);
      EXPECT_EQ(ask(c, {Ray{Vec3(0, 0, 0), Vec3(1, 0, 0)}, sphere}).cls, HitClass::exit) << c.name;
      EXPECT_EQ(ask(c, {Ray{Vec3(-3, 2, 0), Vec3(1, 0, 0)}, sphere}).cls, HitClass::miss) << c.name;
    }
  }
}

TEST(EmbreePeer, FloatRoundingIsWhatTheOracleJudges) {
  const Query q{Ray{Vec3(0.1, 0.2, 0.3), Vec3(1, 1e-3, 0)}, Sphere{Vec3(5, 0.2, 0.3), 0.7}};
  const auto f = as_float_query(q);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->ray.origin.x(), double(0.1f));
  EXPECT_FALSE(as_float_query({Ray{Vec3(1e39, 0, 0), Vec3(1, 0, 0)}, Sphere{Vec3(0, 0, 0), 1}}));
}

// README: the default mode leaves holes on shared edges (about 1% of crossing pairs below 2^40),
// RTC_SCENE_FLAG_ROBUST almost none (one in these 20,000 pairs, at coordinates near 10).
TEST(EmbreePeer, RobustModeLeavesFarFewerHolesThanTheDefault) {
  const HoleCount plain = embree_shared_edge_holes(20000, 2026, false);
  const HoleCount robust = embree_shared_edge_holes(20000, 2026, true);
  const std::uint64_t plain_small = plain.holes - plain.holes_large, robust_small = robust.holes - robust.holes_large;
  EXPECT_GT(plain.crossing - plain.crossing_large, 5000u);
  EXPECT_GT(plain_small, 20u);
  EXPECT_LE(robust_small * 20, plain_small);
  EXPECT_EQ(robust.crossing, plain.crossing);  // the same pairs, judged by the same oracle
}

}  // namespace
}  // namespace rayproof::peers
