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

TEST(EmbreePeer, SharedEdgeHolesAreCountedOnCrossingPairs) {
  const HoleCount plain = embree_shared_edge_holes(4000, 2026, false);
  EXPECT_GT(plain.pairs, 1000u);
  EXPECT_GT(plain.crossing, plain.pairs / 2);
  EXPECT_LE(plain.holes, plain.crossing);
}

}  // namespace
}  // namespace rayproof::peers
