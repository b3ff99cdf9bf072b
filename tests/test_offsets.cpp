// Spawn offsets (docs/spec/offsets.md): no witness ever lies farther off its surface than the
// proved bound (on every bundled mesh at 2^-30, 2^0 and 2^30, on planes and boxes), the search is
// strong enough to catch a derivation a few times too small, a rule that is too small is shown
// unsafe by a ray that re-hits (replayed by `check`), and `proved` is safe where it is.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "cli_run.h"
#include "rayproof/core/casefile.h"
#include "rayproof/core/mesh.h"
#include "rayproof/core/scene_index.h"
#include "rayproof/studies/offsets.h"
#include "rayproof/verify/certified.h"
#include "test_dir.h"

namespace rayproof {
namespace {

using studies::OffsetsOptions;
using studies::OffsetVerdict;
using testing_support::run_cli;
using testing_support::test_dir;

std::vector<const Variant*> named(std::initializer_list<const char*> names) {
  std::vector<const Variant*> out;
  for (const char* n : names) {
    const Variant* v = find_variant(n);
    EXPECT_NE(v, nullptr) << n;
    if (v) out.push_back(v);
  }
  return out;
}

Scene scene_of_mesh(const std::string& path) {
  const Mesh mesh = load_mesh(path);
  Scene s;
  for (const Triangle& t : mesh.triangles) s.objects.push_back({t});
  Bounds box;
  for (const Triangle& t : mesh.triangles)
    for (const Vec3& v : t.v) box.grow(v);
  // A light off the mesh's box, so that rays come from far across the scene as well.
  s.lights.push_back({box.hi + (box.hi - box.lo), 1});
  return s;
}

// Every witness within its bound (decided exactly, counted as a contradiction otherwise); and
// the distances the search found are real: some come within `within`× of the bound. Returns the
// largest fraction of a variant's hits whose computed point fell outside the proof's domain.
double expect_no_witness_beyond_bound(const Scene& scene, const std::vector<const Variant*>& variants,
                                      std::uint64_t rays, const std::string& what, double within = 3) {
  double outside_fraction = 0;
  const SceneIndex index(scene);
  OffsetsOptions options;
  options.rays = rays;
  options.threads = 2;
  const studies::OffsetsReport report = studies::run_offsets(index, what, variants, options);
  for (const studies::VariantOffsets& v : report.variants) {
    SCOPED_TRACE(what + " " + std::string(v.variant->name));
    EXPECT_TRUE(v.derived);
    EXPECT_EQ(v.contradictions, 0u);
    std::uint64_t witnesses = 0, beyond = 0, rehits = 0, hits = 0, outside = 0;
    for (const studies::PrimitiveOffsets& p : v.primitives)
      beyond += p.beyond_bound, rehits += p.rehit_where_safe, hits += p.hits, outside += p.outside_domain;
    outside_fraction = std::max(outside_fraction, double(outside) / double(std::max<std::uint64_t>(hits, 1)));
    EXPECT_EQ(beyond, 0u);
    EXPECT_EQ(rehits, 0u);
    double closest = INFINITY;  // the smallest bracket
    for (const studies::PrimitiveOffsets& p : v.primitives) {
      EXPECT_TRUE(p.proof.has_value());
      if (!p.proof) continue;
      if (!p.farthest) continue;
      ++witnesses;
      EXPECT_LE(std::abs(p.farthest->distance), p.proof->point * (1 + 1e-12));
      if (p.farthest->distance != 0) closest = std::min(closest, p.proof->point / std::abs(p.farthest->distance));
    }
    EXPECT_GT(witnesses, v.primitives.size() / 4);
    // A derivation `within` times too optimistic would have been contradicted: the search
    // reaches that close to the bound.
    EXPECT_LT(closest, within);
  }
  return outside_fraction;
}

const std::string kMeshDir = RAYPROOF_MESH_DIR;
const std::string kScenes = RAYPROOF_SCENES_DIR;

TEST(Offsets, NoWitnessBeyondTheBoundOnTheBundledMeshesAtThreeScales) {
  const std::vector<std::string> meshes = {kMeshDir + "/bunny00.off", kMeshDir + "/elephant.off",
                                           kMeshDir + "/armadillo.off", kScenes + "/audit/edge-grid-tilted.off",
                                           kScenes + "/audit/terrain.obj"};
  for (const std::string& path : meshes) {
    ASSERT_TRUE(std::filesystem::exists(path)) << path;
    const Scene base = scene_of_mesh(path);
    // 10^6 rays per mesh and scale, half to each precision.
    for (int k : {-30, 0, 30})
      expect_no_witness_beyond_bound(scaled(base, k), named({"moller-trumbore", "moller-trumbore-f32"}), 500000,
                                     path + " at 2^" + std::to_string(k));
  }
  // Far from the origin, where the point's own rounding is most of the bound (double only: a
  // float cannot hold the elephant at 2^20). There the bound is nearly met (the search comes
  // within 1.01×): a derivation even 1.25× too optimistic would be contradicted.
  const Scene far = translated(scene_of_mesh(kMeshDir + "/elephant.off"), Vec3(0x1p20, 0.75 * 0x1p20, 0.5 * 0x1p20));
  expect_no_witness_beyond_bound(far, named({"moller-trumbore"}), 500000, "elephant moved by 2^20", 1.25);
}

// The watertight test's derivation ((5)–(8) in offset_bounds.cpp: sheared edge functions, whose
// errors are paid for only by the depth across the triangle) on the same meshes and scales; the
// top-left rule computes the same numbers and only turns hits into misses. The search comes
// within 2.1–2.4× on the meshes (3× asked, as of Möller–Trumbore, which comes within 1.6–2.3×);
// on the terrain within 2.9× (3.5× asked): its bound there is set by grazing rays whose computed
// point lands at a corner of the domain, where (8) weighs the edge functions' errors up to three
// times, and which random rays seldom make.
TEST(Offsets, NoWitnessBeyondTheWatertightBound) {
  const std::vector<std::pair<std::string, double>> meshes = {{kMeshDir + "/bunny00.off", 3},
                                                              {kMeshDir + "/armadillo.off", 3},
                                                              {kScenes + "/audit/edge-grid-tilted.off", 3},
                                                              {kScenes + "/audit/terrain.obj", 3.5}};
  for (const auto& [path, within] : meshes) {
    const Scene base = scene_of_mesh(path);
    for (int k : {-30, 0, 30}) {
      // The domain is Möller–Trumbore's: it must hold the watertight test's hits too.
      const double outside = expect_no_witness_beyond_bound(scaled(base, k), named({"watertight", "watertight-f32"}),
                                                            200000, path + " at 2^" + std::to_string(k), within);
      EXPECT_LT(outside, 1e-3) << path;
    }
  }
  const Scene far = translated(scene_of_mesh(kMeshDir + "/elephant.off"), Vec3(0x1p20, 0.75 * 0x1p20, 0.5 * 0x1p20));
  expect_no_witness_beyond_bound(far, named({"watertight-top-left"}), 200000, "elephant moved by 2^20", 1.25);
}

TEST(Offsets, NoWitnessBeyondTheBoundOnPlanesAndBoxes) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  Scene base;
  for (int i = 0; i < 40; ++i) {
    const Vec3 lo(u(rng), u(rng), u(rng));
    base.objects.push_back({Box{lo, lo + Vec3(0.05 + 0.5 * std::abs(u(rng)), 0.02 + std::abs(u(rng)), 0.3)}});
  }
  for (int i = 0; i < 6; ++i) {
    const Vec3 n(u(rng), u(rng), u(rng));
    base.objects.push_back({Plane{i < 2 ? Vec3(0, 1, 0) : n, u(rng)}});
  }
  base.lights.push_back({Vec3(3, 2.5, -2), 1});
  for (int k : {-30, 0, 30}) {
    expect_no_witness_beyond_bound(scaled(base, k), named({"slab", "robust-slab", "slab-f32", "robust-slab-f32"}),
                                   200000, "boxes at 2^" + std::to_string(k));
    expect_no_witness_beyond_bound(scaled(base, k), named({"direct", "direct-f32"}), 200000,
                                   "planes at 2^" + std::to_string(k));
  }
}

// Balls from 0.02 to 0.42 across, lit from afar: the search comes within 2.1–2.8× (3.5× asked);
// before the discriminant's rounding was paid once ((4′)) and o − m's as a moved origin, 7.7–10.5×.
TEST(Offsets, NoWitnessBeyondTheBoundOnSpheres) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  Scene base;
  for (int i = 0; i < 30; ++i)
    base.objects.push_back({Sphere{Vec3(u(rng), u(rng), u(rng)), 0.02 + 0.4 * std::abs(u(rng))}});
  base.lights.push_back({Vec3(4, 3, -2), 1});
  for (int k : {-30, 0, 30})
    expect_no_witness_beyond_bound(scaled(base, k),
                                   named({"textbook", "stable", "stable-fma", "hearn-baker", "textbook-f32",
                                          "stable-f32", "stable-fma-f32", "hearn-baker-f32"}),
                                   100000, "spheres at 2^" + std::to_string(k), 3.5);
  // Balls up to 3 across with the light inside one of them: rays leave surfaces tangentially from
  // inside and out, where Hearn–Baker's bound is loosest ((12)'s d₀²/D_lo: 8–10×, 12× asked).
  Scene big;
  for (int i = 0; i < 12; ++i)
    big.objects.push_back({Sphere{Vec3(u(rng), u(rng), u(rng)), 0.001 + 1.5 * std::abs(u(rng))}});
  big.lights.push_back({Vec3(0.1, 0.2, 0.3), 1});
  for (int k : {0, 30})
    expect_no_witness_beyond_bound(scaled(big, k), named({"stable", "hearn-baker", "stable-f32", "hearn-baker-f32"}),
                                   200000, "big spheres at 2^" + std::to_string(k), 12);
}

// Hearn–Baker computes the discriminant from the centre's distance to the line: for an origin far
// from a small ball its error grows as γ·|o − m|·R, not γ·|o − m|² as the quadratic's b² − 4ac. The
// derivation keeps that ((12): c's rounding paid over |β̃|): its proved bound is far below stable's.
TEST(Offsets, HearnBakerIsProvedTighterThanStableFarFromTheBall) {
  Bounds box;
  box.grow(Vec3(-64, -64, -64));
  box.grow(Vec3(64, 64, 64));
  for (const double r : {0.01, 0.1, 1.0}) {
    const Sphere ball{Vec3(0.3, -0.2, 0.1), r};
    const auto hb = offset_proof(*find_variant("hearn-baker"), ball, box);
    const auto st = offset_proof(*find_variant("stable"), ball, box);
    ASSERT_TRUE(hb && st);
    EXPECT_LT(hb->point, st->point / 10) << r;
  }
  // At 10^150 every product of the formula is still finite, and so is the bound (its evaluation
  // must not overflow where the code does not: d₀·S did); at 10^200 |o − m|² overflows in the
  // code itself, and the report says the derivation has no finite bound there.
  Bounds far_box;
  far_box.grow(Vec3(-4e150, -4e150, -4e150));
  far_box.grow(Vec3(4e150, 4e150, 4e150));
  const auto huge = offset_proof(*find_variant("hearn-baker"), Sphere{Vec3(0, 0, 0), 1e150}, far_box);
  ASSERT_TRUE(huge.has_value());
  EXPECT_TRUE(std::isfinite(huge->point) && huge->point < 1e150 * 1e-12) << huge->point;
  Scene beyond;
  beyond.objects.push_back({Sphere{Vec3(0, 0, 0), 1e200}});
  beyond.lights.push_back({Vec3(3e200, 2e200, 1e200), 1});
  OffsetsOptions options;
  options.rays = 1000;
  const studies::OffsetsReport report =
      studies::run_offsets(SceneIndex(beyond), "beyond", named({"hearn-baker"}), options);
  const std::vector<std::string> lines = studies::offsets_summary_lines(report);
  ASSERT_FALSE(lines.empty());
  EXPECT_NE(lines[0].find("derived, but no finite bound on this scene"), std::string::npos) << lines[0];
}

// Exits from inside a robust slab's box overshoot the far face by its widening 1 + 2γ(3): the
// bound must hold for them (a derivation without the widening is contradicted here).
TEST(Offsets, RobustSlabExitsFromInsideStayWithinTheBound) {
  Scene scene;
  scene.objects.push_back({Box{Vec3(-0.5, -0.5, -0.5), Vec3(0.5, 0.5, 0.5)}});
  expect_no_witness_beyond_bound(scene, named({"robust-slab", "robust-slab-f32"}), 200000, "one box, from inside");
}

// Each rule's proved displacement range holds for the moves the rule really makes: points drawn
// from a box, moved by the rule, the move along the true normal computed exactly.
TEST(Offsets, RuleDisplacementsBoundTheRealMoves) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  for (Precision prec : {Precision::f64, Precision::f32})
    for (const char* name : {"fixed:1e-4", "ulps:32", "ulps:1", "pbrt", "waechter-binder", "proved"})
      for (int trial = 0; trial < 40; ++trial) {
        const OffsetRule rule = parse_offset_rule(name);
        const double scale = std::ldexp(1.0, int(u(rng) * 40) - 20);
        Bounds points;
        const Vec3 corner = scale * Vec3(u(rng) - 0.3, u(rng) - 0.6, u(rng) - 0.1);
        points.grow(corner);
        points.grow(corner + scale * Vec3(u(rng), u(rng), u(rng)) * (trial % 2 ? 1.0 : 0.01));
        const Vec3 n = Vec3(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5).normalized();
        const double proved = scale * 1e-9 * (1 + u(rng));
        const Displacement d = rule_displacement(rule, prec, points, n, proved);
        for (int k = 0; k < 50; ++k) {
          Vec3 p;
          for (int i = 0; i < 3; ++i) p[i] = points.lo[i] + u(rng) * (points.hi[i] - points.lo[i]);
          if (prec == Precision::f32)
            for (int i = 0; i < 3; ++i) p[i] = double(to_nearest_float(p[i]));
          for (int i = 0; i < 3 && prec == Precision::f32; ++i) ASSERT_EQ(p[i], double(to_nearest_float(p[i]))) << i;
          if (!(p.x() >= points.lo.x() && p.x() <= points.hi.x() && p.y() >= points.lo.y() && p.y() <= points.hi.y() &&
                p.z() >= points.lo.z() && p.z() <= points.hi.z()))
            continue;
          const Vec3 moved = apply_offset_rule(rule, prec, p, n, proved);
          // The move along n in long double: the difference of two doubles and three products,
          // far more precise than the margins compared.
          long double along = 0;
          for (int i = 0; i < 3; ++i) along += ((long double)moved[i] - (long double)p[i]) * (long double)n[i];
          EXPECT_GE(along, (long double)d.min * (1 - 1e-12L))
              << name << " " << to_string(prec) << " trial " << trial << " p " << p.transpose() << " moved "
              << moved.transpose() << " n " << n.transpose() << " box " << points.lo.transpose() << " / "
              << points.hi.transpose();
          EXPECT_LE(along, (long double)d.max * (1 + 1e-12L)) << name << " " << to_string(prec) << " trial " << trial;
        }
      }
}

// One small triangle near the origin lit from far away: its computed points lie many ulps of
// their own magnitude off the plane, so one ulp is not enough — and the proved offset is.
TEST(Offsets, OneUlpIsUnsafeWithAReplayableWitnessAndProvedIsSafe) {
  Scene scene;
  scene.objects.push_back({Triangle{{Vec3(0.01, 0.02, 0.015), Vec3(0.07, 0.025, 0.01), Vec3(0.03, 0.08, 0.02)}}});
  scene.lights.push_back({Vec3(40, 35, 50), 1});
  const SceneIndex index(scene);
  OffsetsOptions options;
  options.rules = {parse_offset_rule("ulps:1"), parse_offset_rule("proved")};
  options.rays = 4000;
  for (const Variant* v : named({"moller-trumbore", "moller-trumbore-f32"})) {
    SCOPED_TRACE(v->name);
    const auto report = studies::run_offsets(index, "pinned", {v}, options);
    const studies::VariantOffsets& out = report.variants.at(0);
    EXPECT_EQ(out.contradictions, 0u);
    EXPECT_EQ(out.rules[0].verdict(), OffsetVerdict::unsafe);
    EXPECT_EQ(out.rules[1].verdict(), OffsetVerdict::safe);
    ASSERT_TRUE(out.rules[0].witness.has_value());
    // The witness replays: the variant re-hits the triangle from the spawned origin, and the
    // oracle says the ray truly meets it (the origin is still behind the surface).
    const Case c = parse_case(out.rules[0].witness->dump());
    const Hit again = v->intersect(c.ray, c.shape, HitRule::nearest_contact);
    EXPECT_NE(again.cls, HitClass::miss);
    EXPECT_GT(again.t, 0);
    EXPECT_NE(certified_intersect(c.ray, c.shape, HitRule::nearest_contact).cls, HitClass::miss);
    EXPECT_EQ(c.found["rule"], "ulps:1");
    // The proof needs more than one ulp here, and says how many.
    EXPECT_GT(out.needs_ulps_at_most(), 1.0);
  }
}

TEST(Offsets, RulesParseAndRefuseNonsense) {
  EXPECT_EQ(parse_offset_rule("fixed:1e-4").amount, 1e-4);
  EXPECT_EQ(parse_offset_rule("ulps:32").kind, OffsetRule::Kind::ulps);
  EXPECT_EQ(default_offset_rules().size(), 5u);
  for (const char* bad : {"fixed:", "fixed:-1", "fixed:nan", "ulps:1.5", "ulps:inf", "pbrt2", "", "proved:3"})
    EXPECT_THROW(parse_offset_rule(bad), std::invalid_argument) << bad;
}

// difference_rounding against every float origin of ranges that do not hold zero (each error
// exact: v − o of two floats is exact in double here), and against random double origins (the
// error by TwoSum) over a range that does: never exceeded, met exactly where every origin is
// tried, and 0 for a float vertex judged in double from origins at least as far out.
TEST(Offsets, DifferenceRoundingBoundsEveryOrigin) {
  for (const float v : {0.3f, -0.1f, 1.7f, 0.001f, -5.25f, -5.5f}) {
    for (const auto& [lo, hi] : {std::pair{1.5f, 2.5f}, {-3.0f, -1.0f}, {0.25f, 0.75f}, {2.0f, 3.0f}}) {
      double most = 0;
      for (float o = lo; o <= hi; o = std::nextafter(o, INFINITY)) {
        const double exact = double(v) - double(o);
        most = std::max(most, std::abs(double(float(exact)) - exact));
      }
      const double bound = difference_rounding(Precision::f32, v, lo, hi);
      // Met exactly, but where the range ends at an A that is a power of two (−5.5 − 2.5 = −8,
      // exact, is taken for the start of its binade).
      if (v == -5.5f && hi == 2.5f)
        EXPECT_LE(most, bound);
      else
        EXPECT_EQ(bound, most) << v << " less [" << lo << ", " << hi << "]";
    }
  }
  EXPECT_EQ(difference_rounding(Precision::f64, double(0.3f), 2, 3), 0);
  EXPECT_GT(difference_rounding(Precision::f64, 0.3, 2, 3), 0);
  std::mt19937_64 random(7);
  for (const double v : {0.227139, double(0.3f), -0.0421, 3.25}) {
    const double lo = -0.5, hi = 3, bound = difference_rounding(Precision::f64, v, lo, hi);
    EXPECT_LE(bound, 0x1p-53 * 4) << v;  // half an ulp of |A| < 4
    std::uniform_real_distribution<double> in(lo, hi);
    for (int k = 0; k < 1'000'000; ++k) {
      const double o = k % 2 ? in(random) : std::ldexp(1.0 + 0x1p-52 * double(k % 64), -(k % 40));
      if (o < lo || o > hi) continue;
      const double a = v - o, z = a - v, error = (v - (a - z)) + (-o - z);  // TwoSum: a + error = v − o
      ASSERT_LE(std::abs(error), bound) << v << " less " << o;
    }
  }
}

// A point moved by more than its bound plus the re-hit bound is safe; one moved by less than its
// bound is not proved.
TEST(Offsets, ProvedSafeNeedsTheWholeMargin) {
  const Triangle tri{{Vec3(0.5, 0.5, 0.5), Vec3(0.7, 0.52, 0.5), Vec3(0.55, 0.8, 0.51)}};
  Bounds box;
  box.grow(Vec3(-1, -1, -1));
  box.grow(Vec3(2, 2, 2));
  const auto proof = offset_proof(*find_variant("moller-trumbore"), tri, box);
  ASSERT_TRUE(proof.has_value());
  EXPECT_GT(proof->point, 0);
  const Vec3 n = cross(tri.v[1] - tri.v[0], tri.v[2] - tri.v[0]).normalized();
  const double proved = proved_offset(*proof, Precision::f64, n);
  EXPECT_GT(proved, proof->point);
  EXPECT_LT(proved, 4 * (proof->point + proof->rehit_base) + 1e-30);
  const OffsetRule fixed_small{OffsetRule::Kind::fixed, proof->point / 2, "small"};
  EXPECT_FALSE(rule_proved_safe(*proof, rule_displacement(fixed_small, Precision::f64, proof->point_box, n, proved)));
  const OffsetRule fixed_big{OffsetRule::Kind::fixed, 4 * proved, "big"};
  EXPECT_TRUE(rule_proved_safe(*proof, rule_displacement(fixed_big, Precision::f64, proof->point_box, n, proved)));
  // The float variant's bound is the float unit roundoff's: about 2^29 times larger.
  const auto proof32 = offset_proof(*find_variant("moller-trumbore-f32"), tri, box);
  ASSERT_TRUE(proof32.has_value());
  EXPECT_GT(proof32->point, proof->point * 0x1p27);
  // The watertight bound far beyond the triangle's size: a tiny triangle (2^-40 across) left by
  // 10^-4 is proved safe in double (its re-hit bound stays linear that far), and the bound never
  // decreases with the reach across its knees.
  Triangle tiny = tri;
  for (Vec3& v : tiny.v) v *= 0x1p-40;
  Bounds tiny_box;
  tiny_box.grow(Vec3(-1, -1, -1) * 0x1p-40);
  tiny_box.grow(Vec3(2, 2, 2) * 0x1p-40);
  const auto wt = offset_proof(*find_variant("watertight"), tiny, tiny_box);
  ASSERT_TRUE(wt.has_value());
  const OffsetRule fixed{OffsetRule::Kind::fixed, 1e-4, "fixed:1e-4"};
  EXPECT_TRUE(rule_proved_safe(*wt, rule_displacement(fixed, Precision::f64, wt->point_box, n, 0)));
  double previous = 0;
  for (double reach = 0x1p-60; reach < 1e10; reach *= 3) {
    EXPECT_GE(wt->rehit_at(reach), previous) << reach;
    previous = wt->rehit_at(reach);
  }
  // Every built-in formula is derived, Hearn–Baker's too; the exact oracle has no rounding to bound
  // and users' code is a black box: the witness side only.
  EXPECT_TRUE(offset_proof(*find_variant("hearn-baker"), Sphere{Vec3(0, 0, 0), 1}, box).has_value());
  register_certified_variants();
  const Variant* oracle = find_variant("certified-sphere");
  ASSERT_NE(oracle, nullptr);
  EXPECT_FALSE(offset_proof(*oracle, Sphere{Vec3(0, 0, 0), 1}, box).has_value());
}

TEST(Offsets, CommandWritesItsFilesAndTheCasesReplay) {
  const std::string dir = test_dir() + "/out";
  const auto ran = run_cli("offsets " + kScenes + "/audit/edge-grid-tilted.off -o " + dir +
                           " --variants moller-trumbore,moller-trumbore-f32 --rules ulps:1,ulps:4096,proved "
                           "--count 20000 --threads 2");
  ASSERT_EQ(ran.status, 0) << ran.err;
  EXPECT_NE(ran.out.find("moller-trumbore: proved safe on"), std::string::npos) << ran.out;
  EXPECT_NE(ran.out.find("moller-trumbore-f32: ulps:1 unsafe: re-hits on"), std::string::npos) << ran.out;
  std::ifstream in(dir + "/offsets.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  ASSERT_EQ(j["variants"].size(), 2u);
  const auto& prim = j["variants"][0]["primitives"][0];
  for (const char* key : {"mesh", "index", "shape", "bound", "witness", "bracket"})
    EXPECT_TRUE(prim.contains(key)) << key;
  EXPECT_EQ(j["variants"][0]["rules"][2]["verdict"], "safe");
  // Every unsafe witness is a case `check` reads and replays.
  std::ifstream cases(dir + "/offsets-cases.jsonl");
  int lines = 0;
  for (std::string line; std::getline(cases, line); ++lines) EXPECT_NO_THROW(parse_case(line)) << line;
  EXPECT_GT(lines, 0);
  const auto check = run_cli("check " + dir + "/offsets-cases.jsonl --variants moller-trumbore-f32");
  EXPECT_EQ(check.status, 0) << check.err;
  EXPECT_NE(check.err.find("0 unreadable"), std::string::npos) << check.err;
  std::stringstream html;
  html << std::ifstream(dir + "/report.html").rdbuf();
  EXPECT_NE(html.str().find("data:image/png;base64,"), std::string::npos);
  // Bad input: an unknown rule and a missing scene name the problem and exit non-zero.
  const auto bad_rule = run_cli("offsets " + kScenes + "/audit/edge-grid.off -o " + dir + " --rules ulps:x");
  EXPECT_NE(bad_rule.status, 0);
  EXPECT_NE(bad_rule.err.find("ulps:x"), std::string::npos) << bad_rule.err;
  const auto missing = run_cli("offsets " + dir + "/nothing.off -o " + dir);
  EXPECT_NE(missing.status, 0);
  EXPECT_NE(missing.err.find("nothing.off"), std::string::npos) << missing.err;
  // A mesh named relative to the working directory (it was looked for under its own directory twice).
  const auto previous = std::filesystem::current_path();
  std::filesystem::current_path(kScenes);
  const auto relative = run_cli("offsets audit/edge-grid.off -o " + dir + " --count 100 --variants moller-trumbore");
  std::filesystem::current_path(previous);
  EXPECT_EQ(relative.status, 0) << relative.err;
  // A mesh near the largest doubles: its box's diagonal overflowed, and the camera placed beside
  // it was refused as a field of a scene the user never wrote.
  std::ofstream(dir + "/huge.off") << "OFF\n3 1 0\n1e300 0 0\n0 1e300 0\n0 0 1e300\n3 0 1 2\n";
  const auto huge = run_cli("offsets " + dir + "/huge.off -o " + dir + " --count 100 --variants watertight");
  EXPECT_EQ(huge.status, 0) << huge.err;
}

// `audit` says what the proof needs and, with --offset proved, spawns its shadow rays there: no
// acne left for the variants whose formula is derived (the terrain lit at a grazing angle).
TEST(Offsets, AuditSpawnsFromTheProvedOffset) {
  const std::string dir = test_dir() + "/audit";
  const auto ran = run_cli("audit " + kScenes + "/audit/terrain-grazing.json -o " + dir +
                           " --variants moller-trumbore,moller-trumbore-f32,stable --offset proved --threads 2");
  ASSERT_EQ(ran.status, 0) << ran.err;
  EXPECT_NE(ran.err.find("spawn offset: moller-trumbore needs"), std::string::npos) << ran.err;
  std::ifstream in(dir + "/audit.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  int seen = 0;
  for (const auto& v : j["variants"]) {
    SCOPED_TRACE(v["name"].get<std::string>());
    ASSERT_TRUE(v.contains("proved_offset_ulps"));
    EXPECT_GT(v["proved_offset_ulps"].get<double>(), 0);
    EXPECT_EQ(v["acne"], 0);
    ++seen;
  }
  EXPECT_EQ(seen, 3);
}

}  // namespace
}  // namespace rayproof
