// Verdicts a developer can act on (docs/spec/verdicts.md): declared ranges, precision ties, and
// the backward error of every disagreement with a witness the exact judge checks. Each β is
// compared with a brute-force search (random moves of ray and vertices at a given ε, bisected,
// every move judged by the exact judge): the computed β must be within 4× of the smallest ε found.
#include <gtest/gtest.h>

#include <fstream>
#include <random>
#include <set>

#include "cli_run.h"
#include "rayproof/fuzz/tracer_campaign.h"
#include "rayproof/fuzz/tracer_families.h"
#include "rayproof/verify/backward_error.h"
#include "rayproof/verify/mesh_truth.h"
#include "test_dir.h"

namespace rayproof {
namespace {

using testing_support::run_cli;
using testing_support::test_dir;

std::shared_ptr<TriangleMesh> mesh_of(std::vector<double> vertices, std::vector<std::uint32_t> indices) {
  auto m = std::make_shared<TriangleMesh>();
  m->vertices = std::move(vertices), m->indices = std::move(indices);
  return m;
}

// A unit square at z = 0 split along its diagonal (0,0)–(1,1): triangles 0 (below) and 1 (above),
// wound the same way (both counter-clockwise seen from +z), so the diagonal is a manifold edge.
std::shared_ptr<TriangleMesh> square() { return mesh_of({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}, {0, 1, 2, 0, 2, 3}); }

struct Judged {
  MeshTruth truth;
  TraceJudgement j;
  MeshAnswer a;
  BackwardError b;
};

Judged judge(MeshOracle& oracle, const TracerRay& r, std::uint32_t reported, Precision p = Precision::f64,
             RangeRule range = RangeRule::open) {
  Judged out;
  out.truth = oracle.truth(r, false);
  TraceAnswer answer;
  answer.triangle = reported;
  answer.t = 1;
  if (reported != kNoTriangle)
    if (const MeshContact* c = out.truth.contact_of(reported)) answer.t = c->t;
  out.j = oracle.judge_nearest(r, out.truth, answer, p, {range, true});
  out.a.triangle = reported;
  out.b = backward_error(oracle, r, out.truth, out.j, out.a, p, range);
  return out;
}

// The smallest ε (bisection over powers of 2^(1/4)) at which some of `samples` random moves —
// origin and vertices by up to ε·u·S per coordinate, direction by up to ε·u·‖d‖∞ — makes the
// answer exactly right, by the exact judge.
double brute_force_epsilon(const MeshOracle& oracle, const TracerRay& r, const MeshAnswer& a, Precision p,
                           RangeRule range, double scale, int samples = 300) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1, 1);
  const double u = unit_roundoff(p), dn = r.ray.direction.cwiseAbs().maxCoeff();
  auto works = [&](double eps) {
    for (int s = 0; s < samples; ++s) {
      Witness w;
      w.scale = scale;
      for (int k = 0; k < 3; ++k) {
        w.origin[k] = exact_of(r.ray.origin[k]) + exact_of(unit(rng) * eps * u * scale);
        w.direction[k] = exact_of(r.ray.direction[k]) + exact_of(unit(rng) * eps * u * dn);
      }
      for (std::uint32_t v = 0; v < oracle.mesh().vertex_count(); ++v) {
        ExactVec q;
        for (int k = 0; k < 3; ++k) q[k] = exact_of(oracle.mesh().vertex(v)[k]) + exact_of(unit(rng) * eps * u * scale);
        w.vertices[v] = q;
      }
      w.ulps = eps * 1.0001;
      if (witness_holds(oracle, r, w, range, a, p) == true) return true;
    }
    return false;
  };
  double hi = 1;
  while (!works(hi)) {
    hi *= 4;
    if (hi > 1e12) return INFINITY;
  }
  double lo = hi / 4;
  while (lo > 1e-9 && works(lo)) lo /= 4;
  for (int i = 0; i < 6; ++i) {
    const double mid = std::sqrt(lo * hi);
    (works(mid) ? hi : lo) = mid;
  }
  return hi;
}

void expect_within_four_of_brute_force(const MeshOracle& oracle, const TracerRay& r, const Judged& x, Precision p,
                                       RangeRule range = RangeRule::open) {
  ASSERT_TRUE(x.b.beta && x.b.witness) << "no witness";
  EXPECT_EQ(witness_holds(oracle, r, *x.b.witness, range, x.a, p), true);
  const double brute = brute_force_epsilon(oracle, r, x.a, p, range, x.b.witness->scale);
  ASSERT_TRUE(std::isfinite(brute));
  EXPECT_LE(*x.b.beta, 4 * brute) << "beta " << *x.b.beta << " brute force " << brute;
}

TEST(Verdicts, HexExactRoundTrips) {
  for (const char* text :
       {"0x1p+0", "-0x1.8p-3", "0x1.0000000000000008p+3", "0x1.23456789abcdef0123p-1070", "0x0p+0"}) {
    const auto q = parse_hex_exact(text);
    ASSERT_TRUE(q) << text;
    EXPECT_EQ(hex_exact(*q), text);
  }
  EXPECT_EQ(*parse_hex_exact("0x10p0"), mpq_class(16));
  EXPECT_FALSE(parse_hex_exact("0x1.g"));
  EXPECT_FALSE(parse_hex_exact("1.5"));
  EXPECT_THROW(hex_exact(mpq_class(1, 3)), std::runtime_error);
}

// The neighbour across a shared edge, reported a fraction of an ulp from the edge: rounding-level,
// its witness moves the ray onto the edge.
TEST(Verdicts, NeighbourAcrossAnEdgeIsRoundingLevel) {
  MeshOracle oracle(square());
  // The crossing point lies one ulp below the diagonal: in triangle 0.
  const TracerRay r{{Vec3(0.5 + 0x1p-53, 0.5 - 0x1p-54, 1), Vec3(0, 0, -1)}, 0, INFINITY};
  const Judged x = judge(oracle, r, 1);
  ASSERT_EQ(x.j.kind, TraceKind::false_hit);
  ASSERT_TRUE(x.b.beta);
  EXPECT_LT(*x.b.beta, 1);
  EXPECT_EQ(level_of(x.b, kDefaultToleranceUlps), Level::rounding);
  EXPECT_EQ(level_of(x.b, 0), Level::bug);  // the strict reading
  expect_within_four_of_brute_force(oracle, r, x, Precision::f64);
}

// A doctored witness — its move one part in 2^20 short of the edge, or claiming fewer ulps than it
// moves — is refused.
TEST(Verdicts, DoctoredWitnessIsRefused) {
  MeshOracle oracle(square());
  const TracerRay r{{Vec3(0.5 + 0x1p-53, 0.5 - 0x1p-54, 1), Vec3(0, 0, -1)}, 0, INFINITY};
  const Judged x = judge(oracle, r, 1);
  ASSERT_TRUE(x.b.witness);
  Witness short_of = *x.b.witness;
  for (int k = 0; k < 3; ++k) {
    const mpq_class o = exact_of(r.ray.origin[k]), d = exact_of(r.ray.direction[k]);
    short_of.origin[k] = o + (short_of.origin[k] - o) * mpq_class(1048575, 1048576);
    short_of.direction[k] = d + (short_of.direction[k] - d) * mpq_class(1048575, 1048576);
  }
  EXPECT_EQ(witness_holds(oracle, r, short_of, RangeRule::open, x.a, Precision::f64), false);
  Witness understated = *x.b.witness;
  understated.ulps = x.b.witness->ulps / 2;
  EXPECT_EQ(witness_holds(oracle, r, understated, RangeRule::open, x.a, Precision::f64), false);
  // And the witness read back from its JSON is the same witness.
  const Witness back = Witness::from_json(x.b.witness->to_json());
  EXPECT_EQ(witness_holds(oracle, r, back, RangeRule::open, x.a, Precision::f64), true);
  EXPECT_EQ(back.origin, x.b.witness->origin);
}

// A hole just inside an open edge of a lone triangle: the ray moved onto that edge.
TEST(Verdicts, HoleNearAnOpenEdgeIsMeasured) {
  MeshOracle oracle(mesh_of({0, 0, 0, 4, 0, 0, 0, 4, 0}, {0, 1, 2}));
  for (const double off : {0x1p-30, 0x1p-20, 0x1p-8}) {  // float ulps of 4: 2^-22
    const TracerRay r{{Vec3(1, off, 3), Vec3(0.25, 0, -1)}, 0, INFINITY};
    const Judged x = judge(oracle, r, kNoTriangle, Precision::f32);
    ASSERT_EQ(x.j.kind, TraceKind::hole);
    expect_within_four_of_brute_force(oracle, r, x, Precision::f32);
    EXPECT_EQ(level_of(x.b, kDefaultToleranceUlps), off < 0x1p-17 ? Level::rounding : Level::bug) << off;
  }
}

// Two shells 2^-50 apart, the farther one reported: a tie in float (their t round to the same
// float); in double a rounding-level not_nearest (2 ulps of S = 4), made right by moving the
// farther shell. 2^-40 apart they are a bug in double (2^11 ulps).
TEST(Verdicts, ShellsAreTiesOrRounding) {
  const double gap = 0x1p-50;
  MeshOracle oracle(mesh_of({0, 0, 0, 4, 0, 0, 0, 4, 0, 0, 0, -gap, 4, 0, -gap, 0, 4, -gap}, {0, 1, 2, 3, 4, 5}));
  const TracerRay r{{Vec3(1, 1, 2), Vec3(0, 0, -1)}, 0, INFINITY};
  const Judged f = judge(oracle, r, 1, Precision::f32);
  EXPECT_EQ(f.j.kind, TraceKind::right);
  EXPECT_TRUE(f.j.tie);
  MeshTruth truth = oracle.truth(r, false);
  TraceAnswer answer{1, 2 + gap};
  const TraceJudgement strict = oracle.judge_nearest(r, truth, answer, Precision::f32, {RangeRule::open, false});
  EXPECT_EQ(strict.kind, TraceKind::not_nearest);  // ties off: the strict reading
  const Judged d = judge(oracle, r, 1, Precision::f64);
  ASSERT_EQ(d.j.kind, TraceKind::not_nearest);
  EXPECT_EQ(level_of(d.b, kDefaultToleranceUlps), Level::rounding);
  expect_within_four_of_brute_force(oracle, r, d, Precision::f64);
  MeshOracle apart(
      mesh_of({0, 0, 0, 4, 0, 0, 0, 4, 0, 0, 0, -0x1p-40, 4, 0, -0x1p-40, 0, 4, -0x1p-40}, {0, 1, 2, 3, 4, 5}));
  const Judged far = judge(apart, r, 1, Precision::f64);
  ASSERT_EQ(far.j.kind, TraceKind::not_nearest);
  ASSERT_TRUE(far.b.beta);
  EXPECT_NEAR(*far.b.beta, 2048, 1);
  EXPECT_EQ(level_of(far.b, kDefaultToleranceUlps), Level::bug);
}

// A ray leaving a triangle (tmin = 0) that reports it at t = 0: right under `closed`
// (at_range_end), a false hit under `open` whose witness moves the ray's origin a sliver back
// along d (every contact's t grows alike; no vertex moves), checked exactly. Likewise at tmax,
// forward. (No brute-force bound here: any move into the range will do, the room is a choice.)
TEST(Verdicts, RangeEndsUnderEachRange) {
  MeshOracle oracle(mesh_of({0, 0, 0, 4, 0, 0, 0, 4, 0}, {0, 1, 2}));
  const TracerRay r{{Vec3(1, 1, 0), Vec3(0.5, 0.25, 1)}, 0, INFINITY};
  const Judged closed = judge(oracle, r, 0, Precision::f64, RangeRule::closed);
  EXPECT_EQ(closed.j.kind, TraceKind::right);
  EXPECT_EQ(closed.j.at_range_end, RangeEnd::tmin);
  const Judged open = judge(oracle, r, 0, Precision::f64, RangeRule::open);
  ASSERT_EQ(open.j.kind, TraceKind::false_hit);
  ASSERT_TRUE(open.b.witness);
  EXPECT_LE(*open.b.beta, 0x1p-10);
  EXPECT_TRUE(open.b.witness->vertices.empty());
  EXPECT_LT(open.b.witness->origin[2], 0);  // back along d = (0.5, 0.25, 1)
  EXPECT_EQ(witness_holds(oracle, r, *open.b.witness, RangeRule::open, open.a, Precision::f64), true);
  // tmax exactly on the triangle: a shadow ray to a point on the surface.
  const TracerRay shadow{{Vec3(1, 1, 2), Vec3(0, 0, -1)}, 0, 2};
  const Judged blocked = judge(oracle, shadow, 0, Precision::f64, RangeRule::closed);
  EXPECT_EQ(blocked.j.kind, TraceKind::right);
  EXPECT_EQ(blocked.j.at_range_end, RangeEnd::tmax);
  const Judged shadow_open = judge(oracle, shadow, 0, Precision::f64, RangeRule::open);
  ASSERT_EQ(shadow_open.j.kind, TraceKind::false_hit);
  ASSERT_TRUE(shadow_open.b.beta && shadow_open.b.witness);
  EXPECT_LE(*shadow_open.b.beta, 0x1p-10);
  EXPECT_TRUE(shadow_open.b.witness->vertices.empty());
  EXPECT_LT(shadow_open.b.witness->origin[2], 2);  // forward along d = (0, 0, −1)
  EXPECT_EQ(witness_holds(oracle, shadow, *shadow_open.b.witness, RangeRule::open, shadow_open.a, Precision::f64),
            true);
  // The same move short of the range end (the origin where it was) is refused.
  Witness unmoved = *shadow_open.b.witness;
  unmoved.origin = {exact_of(1), exact_of(1), exact_of(2)};
  EXPECT_EQ(witness_holds(oracle, shadow, unmoved, RangeRule::open, shadow_open.a, Precision::f64), false);
}

// A hole at an interior point of a closed, consistently wound surface, and a double hit on a
// shared edge, can never be made right: β none, a bug at any tolerance.
TEST(Verdicts, HolesInClosedSurfacesAndDoubleHitsAreNone) {
  // A tetrahedron, outward wound.
  MeshOracle tet(mesh_of({0, 0, 0, 4, 0, 0, 0, 4, 0, 0, 0, 4}, {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3}));
  const TracerRay r{{Vec3(1, 1, -3), Vec3(0, 0, 1)}, 0, INFINITY};
  const Judged hole = judge(tet, r, kNoTriangle);
  ASSERT_EQ(hole.j.kind, TraceKind::hole);
  // Only a move of the size of the tetrahedron (past a silhouette) ends the crossing: a witness
  // shows that (β > 10^14 ulps), or none.
  EXPECT_TRUE(!hole.b.beta || *hole.b.beta > 1e14) << *hole.b.beta;
  EXPECT_EQ(level_of(hole.b, 1e12), Level::bug);
  // Seen straight on, every neighbour facing the ray the same way: none.
  MeshOracle flat(mesh_of({0, 0, 0, 4, 0, 0, 4, 4, 0, 0, 4, 0, 2, 2, 0}, {0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0, 4}));
  const TracerRay centre{{Vec3(1.5, 1, 2), Vec3(0.125, 0.25, -1)}, 0, INFINITY};
  const Judged fan_hole = judge(flat, centre, kNoTriangle);
  ASSERT_EQ(fan_hole.j.kind, TraceKind::hole);
  EXPECT_TRUE(fan_hole.b.beta && fan_hole.b.witness) << "the square's open border is in reach";
  EXPECT_EQ(level_of(fan_hole.b, kDefaultToleranceUlps), Level::bug);

  MeshOracle sq(square());
  const TracerRay edge{{Vec3(0.5, 0.5, 1), Vec3(0, 0, -1)}, 0, INFINITY};
  const MeshTruth truth = sq.truth(edge, true);
  AllHitsAnswer both;
  both.triangles = {0, 1};
  const TraceJudgement j = sq.judge_all_hits(edge, truth, both);
  ASSERT_EQ(j.kind, TraceKind::double_hit);
  MeshAnswer a;
  a.all = true, a.triangles = {0, 1};
  EXPECT_FALSE(backward_error(sq, edge, truth, j, a, Precision::f64, RangeRule::open).beta);
}

// The one-hit rule's winding condition on a wedge: two triangles sharing an edge, both facing the
// ray but wound the same way along it — not a consistently wound pair, so no rule applies and
// either answer (one or both) is right there.
TEST(Verdicts, WedgeWoundTheSameWayHasNoOneHitRule) {
  // Edge (0,1) along x; both triangles open toward +y (one up, one down) and face a ray from
  // above, and both list the edge 0 → 1: the ray grazes the wedge's edge, not a surface.
  MeshOracle wedge(mesh_of({0, 0, 0, 4, 0, 0, 2, 2, 1, 2, 2, -1}, {0, 1, 2, 0, 1, 3}));
  const TracerRay r{{Vec3(2, 0, 5), Vec3(0, 0, -1)}, 0, INFINITY};
  const MeshTruth truth = wedge.truth(r, true);
  ASSERT_EQ(truth.points.size(), 1u);
  EXPECT_EQ(truth.points[0].triangles.size(), 2u);
  EXPECT_FALSE(truth.points[0].one_hit_rule);
  AllHitsAnswer both;
  both.triangles = {0, 1};
  EXPECT_EQ(wedge.judge_all_hits(r, truth, both).kind, TraceKind::right);
  // A roof ridge wound consistently (the edge run in opposite directions), both facing the ray:
  // the same ray is under the rule, and both is a double hit.
  MeshOracle ridge(mesh_of({0, 0, 0, 4, 0, 0, 2, 2, 1, 2, -2, 1}, {0, 1, 2, 1, 0, 3}));
  const MeshTruth t2 = ridge.truth(r, true);
  ASSERT_EQ(t2.points.size(), 1u);
  EXPECT_TRUE(t2.points[0].one_hit_rule);
  EXPECT_EQ(ridge.judge_all_hits(r, t2, both).kind, TraceKind::double_hit);
}

// A contact whose rounded t equals tmin while the exact t lies inside the range is decided
// exactly: in range, and a hole when not reported.
TEST(Verdicts, RoundedTAtTminIsDecidedExactly) {
  // The plane z = 1 met from the origin along (0, 0, 3): exact t = 1/3, just above fl(1/3).
  MeshOracle oracle(mesh_of({-4, -4, 1, 4, -4, 1, 0, 4, 1}, {0, 1, 2}));
  const double third = 1.0 / 3;
  ASSERT_LT(mpq_class(third), mpq_class(1, 3));
  const TracerRay r{{Vec3(0, 0, 0), Vec3(0, 0, 3)}, third, INFINITY};
  const MeshTruth truth = oracle.truth(r, false);
  ASSERT_EQ(truth.contacts.size(), 1u);
  EXPECT_EQ(truth.contacts[0].t, third);
  EXPECT_EQ(oracle.judge_nearest(r, truth, TraceAnswer{}, Precision::f64).kind, TraceKind::hole);
  // tmin one double above: the exact t lies below it, out of range.
  const TracerRay past{{Vec3(0, 0, 0), Vec3(0, 0, 3)}, std::nextafter(third, 1.0), INFINITY};
  EXPECT_TRUE(oracle.truth(past, false).contacts.empty());
  // And at tmax likewise.
  const TracerRay ending{{Vec3(0, 0, 0), Vec3(0, 0, 3)}, 0, third};
  EXPECT_TRUE(oracle.truth(ending, false).contacts.empty());
}

// Two distinct crossings whose exact t round to the same double: a shared edge at t = 1/3 and
// a third triangle just beyond it. Grouped by exact t, the edge is still a one-hit point, and
// reporting both of its triangles is still a double hit.
TEST(JudgeLacks, CrossingsGroupedByExactTNotRoundedT) {
  // Triangles 0 and 1 share the edge x = 0 of the plane z = 1 (consistently wound); the ray from
  // the origin along (0, 0, 3) at (0, −7) crosses it at t = 1/3. Triangle 2 is tilted to
  // z = 1 + 2^-52·(y + 8)/16: met at z = 1 + 2^-56, t = 1/3 + 2^-56/3 — a different point whose t
  // rounds to the same double as 1/3.
  MeshOracle oracle(mesh_of({0, -8, 1, 0, 8, 1, -4, 0, 1, 4, 0, 1, -8, -8, 1, 8, -8, 1, 0, 8, 1 + 0x1p-52},
                            {0, 1, 2, 1, 0, 3, 4, 5, 6}));
  const TracerRay r{{Vec3(0, -7, 0), Vec3(0, 0, 3)}, 0, INFINITY};
  const MeshTruth truth = oracle.truth(r, true);
  ASSERT_EQ(truth.points.size(), 2u);
  EXPECT_TRUE(truth.points[0].one_hit_rule);
  EXPECT_EQ(truth.points[0].triangles.size(), 2u);
  EXPECT_EQ(truth.points[0].t, truth.points[1].t);  // one rounded t, two exact ones
  AllHitsAnswer all;
  all.triangles = {0, 1, 2};
  EXPECT_EQ(oracle.judge_all_hits(r, truth, all).kind, TraceKind::double_hit);
  all.triangles = {0, 2};
  EXPECT_EQ(oracle.judge_all_hits(r, truth, all).kind, TraceKind::right);
}

// An any-hit index equal to the triangle count, and a nearest t beyond a finite tmax, are tracer
// errors (not a false hit, not right).
TEST(JudgeLacks, IndexAtTheCountAndTBeyondTmaxAreTracerErrors) {
  MeshOracle oracle(square());
  const TracerRay r{{Vec3(0.25, 0.5, 1), Vec3(0, 0, -1)}, 0, 4};
  AllHitsAnswer all;
  all.triangles = {1, 2};
  EXPECT_EQ(oracle.judge_all_hits(r, oracle.truth(r, true), all).kind, TraceKind::tracer_error);
  const MeshTruth truth = oracle.truth(r, false);
  EXPECT_EQ(oracle.judge_nearest(r, truth, TraceAnswer{1, 4.5}, Precision::f64).kind, TraceKind::tracer_error);
  EXPECT_EQ(oracle.judge_nearest(r, truth, TraceAnswer{1, 1}, Precision::f64).kind, TraceKind::right);
  EXPECT_EQ(oracle.judge_nearest(r, truth, TraceAnswer{2, 1}, Precision::f64).kind, TraceKind::tracer_error);
}

// Every exactly aimed ray meets what its detail names: "edge 1/4" the point a quarter (or three
// quarters, from the neighbour's side) along an edge, "edge 1/2" its middle, "vertex" a vertex.
TEST(JudgeLacks, FamilyRaysMeetWhatTheirDetailNames) {
  using Q = mpq_class;
  int checked = 0;
  for (fuzz::TracerFamily f : {fuzz::TracerFamily::shared_edges, fuzz::TracerFamily::needles}) {
    for (std::uint64_t m = 0; m < 12; ++m) {
      const fuzz::MeshWork w = fuzz::generate_mesh_work(f, 1, m, fuzz::kRaysPerMesh);
      MeshOracle oracle(w.mesh);
      for (std::size_t i = 0; i < w.rays.size(); ++i) {
        const std::string& detail = w.details[i];
        if (detail.find("full precision") != std::string::npos) continue;
        const bool edge = detail.find("edge ") != std::string::npos,
                   vertex = detail.find("vertex") != std::string::npos;
        if (!edge && !vertex) continue;
        const Ray& ray = w.rays[i].ray;
        std::set<Q> fractions;  // where along each zero edge the ray crosses
        int vertices = 0;
        for (const MeshContact& c : oracle.truth(w.rays[i], true).contacts) {
          if (!c.crossing || !c.boundary) continue;
          const Triangle tri = w.mesh->triangle(c.triangle);
          const TriangleSides s = triangle_sides(ray, tri);
          const int zeros = (s.edge[0] == 0) + (s.edge[1] == 0) + (s.edge[2] == 0);
          vertices += zeros == 2;
          if (zeros != 1) continue;
          const int k = s.edge[0] == 0 ? 0 : s.edge[1] == 0 ? 1 : 2;
          // The crossing point p = o + t·d, t = n·(v0 − o) / n·d, exactly; its fraction along v_k → v_k+1.
          auto q = [](const Vec3& v) { return std::array<Q, 3>{Q(v.x()), Q(v.y()), Q(v.z())}; };
          const auto o = q(ray.origin), d = q(ray.direction), a = q(tri.v[0]), b = q(tri.v[1]), cc = q(tri.v[2]);
          std::array<Q, 3> e1, e2, n, ao, p, from, along;
          for (int j = 0; j < 3; ++j) e1[j] = b[j] - a[j], e2[j] = cc[j] - a[j], ao[j] = a[j] - o[j];
          for (int j = 0; j < 3; ++j) n[j] = e1[(j + 1) % 3] * e2[(j + 2) % 3] - e1[(j + 2) % 3] * e2[(j + 1) % 3];
          const Q t = (n[0] * ao[0] + n[1] * ao[1] + n[2] * ao[2]) / (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]);
          const auto vk = q(tri.v[k]), vn = q(tri.v[(k + 1) % 3]);
          Q dot = 0, len = 0;
          for (int j = 0; j < 3; ++j) {
            p[j] = o[j] + t * d[j], from[j] = p[j] - vk[j], along[j] = vn[j] - vk[j];
            dot += from[j] * along[j], len += along[j] * along[j];
          }
          fractions.insert(dot / len);
        }
        if (vertex) {
          EXPECT_GT(vertices, 0) << to_string(f) << " " << detail;
        } else {
          const Q want = detail.find("1/2") != std::string::npos ? Q(1, 2) : Q(1, 4);
          EXPECT_TRUE(fractions.contains(want) || fractions.contains(1 - want)) << to_string(f) << " " << detail;
        }
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 200);
}

// A resumed campaign with other --tracers (or another tolerance) is refused: its checkpoint
// describes another campaign.
TEST(JudgeLacks, ResumeWithOtherTracersIsRefused) {
  const std::string dir = test_dir();
  const std::string common = "fuzz --families shared-edges --count 640 --threads 1 --no-shrink -o " + dir + "/f.jsonl ";
  EXPECT_NE(run_cli(common + "--tracers bvh-watertight --crash-after-batches 0").status, 0);
  const auto other = run_cli(common + "--tracers bvh-moller-trumbore --resume");
  EXPECT_NE(other.status, 0);
  EXPECT_NE(other.err.find("checkpoint"), std::string::npos) << other.err;
  const auto tolerance = run_cli(common + "--tracers bvh-watertight --tolerance-ulps 4 --resume");
  EXPECT_NE(tolerance.status, 0);
  const auto same = run_cli(common + "--tracers bvh-watertight --resume");
  EXPECT_EQ(same.status, 0) << same.err;
}

// A library built against ABI 1 (no `range` in its rows) loads through the fallback, both rows
// read at their own stride, judged `open`; --tracer-range declares it closed.
TEST(VerdictsCli, AbiOneTracersLoadAsOpen) {
  const std::string lib = ABI1_TRACER;
  const auto listed = run_cli("variants --tracer " + lib);
  ASSERT_EQ(listed.status, 0) << listed.err;
  EXPECT_NE(listed.out.find("abi-one-first\tmesh\tdouble\ttest: an ABI 1 library"), std::string::npos) << listed.out;
  EXPECT_NE(listed.out.find("abi-one-second\tmesh\tdouble\ttest: its second row"), std::string::npos);
  EXPECT_NE(listed.out.find("its second row ["), std::string::npos);
  const auto second = listed.out.substr(listed.out.find("abi-one-second"));
  EXPECT_NE(second.find("(range: open)"), std::string::npos) << second;
  const auto closed = run_cli("variants --tracer " + lib + " --tracer-range abi-one-second=closed");
  ASSERT_EQ(closed.status, 0) << closed.err;
  EXPECT_NE(closed.out.substr(closed.out.find("abi-one-second")).find("(range: closed)"), std::string::npos);
  const std::string dir = test_dir();
  const auto run = run_cli("fuzz --tracer " + lib + " --tracers abi-one-second --families shared-edges,spawned " +
                           "--count 128 -o " + dir + "/f.jsonl --summary " + dir + "/s.json");
  ASSERT_EQ(run.status, 0) << run.err;
  const json s = json::parse(std::ifstream(dir + "/s.json"));
  EXPECT_EQ(s.at("tallies").at("spawned\tabi-one-second").at("range"), "open");
  EXPECT_EQ(s.at("tallies").at("spawned\tabi-one-second").at("cases"), 128);
  // It keeps pointers into the mesh (tracer.md: valid until release): no crash, every ray judged.
  for (const char* family : {"shared-edges\tabi-one-second", "spawned\tabi-one-second"}) {
    EXPECT_EQ(s.at("tallies").at(family).at("crash"), 0) << family;
    EXPECT_EQ(s.at("tallies").at(family).at("right").get<int>() + s.at("tallies").at(family).at("hole").get<int>() +
                  s.at("tallies").at(family).at("false_hit").get<int>() +
                  s.at("tallies").at(family).at("not_nearest").get<int>() +
                  s.at("tallies").at(family).at("in_plane").get<int>(),
              128)
        << family;
  }
}

// Through the CLI: a closed tracer's range-end hits are notes, not false hits; --tracer-range
// overrides; the strict reading counts ties as not_nearest and every disagreement a bug; levels
// add up to their kinds; --fail-on bug exits 1 exactly when a bug was found.
TEST(VerdictsCli, RangesTolerancesAndFailOn) {
  const std::string dir = test_dir();
  const std::string common = " --count 512 --threads 2 --families spawned,shells,shared-edges ";
  auto summary = [&](const std::string& name) { return json::parse(std::ifstream(dir + "/" + name)); };
  auto run = [&](const std::string& flags, const std::string& name) {
    const auto r = run_cli("fuzz --tracers cgal-aabb,bvh-watertight-top-left" + common + flags + " -o " + dir + "/" +
                           name + ".jsonl --summary " + dir + "/" + name + ".json");
    return r.status;
  };
  ASSERT_EQ(run("", "closed"), 0);
  ASSERT_EQ(run("--tracer-range cgal-aabb=open", "open"), 0);
  ASSERT_EQ(run("--tolerance-ulps 0", "strict"), 0);
  const json closed = summary("closed.json"), open = summary("open.json"), strict = summary("strict.json");
  const json& c = closed.at("tallies").at("spawned\tcgal-aabb");
  const json& o = open.at("tallies").at("spawned\tcgal-aabb");
  EXPECT_EQ(c.at("range"), "closed");
  EXPECT_EQ(o.at("range"), "open");
  EXPECT_GT(c.at("at_tmin").get<int>(), 100);
  EXPECT_EQ(o.at("at_range_end"), 0);
  EXPECT_EQ(o.at("false_hit").get<int>(), c.at("false_hit").get<int>() + c.at("at_range_end").get<int>());
  for (const auto& [key, t] : closed.at("tallies").items()) {
    for (const char* k : {"hole", "false_hit", "not_nearest", "double_hit", "missed_in_any_hit"})
      EXPECT_EQ(t.at(std::string(k) + "_bugs").get<int>() + t.at(std::string(k) + "_rounding").get<int>(),
                t.at(k).get<int>())
          << key << " " << k;
    const json& s = strict.at("tallies").at(key);
    for (const char* k : {"hole", "false_hit", "double_hit", "missed_in_any_hit"}) {
      EXPECT_EQ(s.at(k), t.at(k)) << key << " " << k;
      EXPECT_EQ(s.at(std::string(k) + "_rounding"), 0) << key;
    }
    EXPECT_EQ(s.at("not_nearest").get<int>(), t.at("not_nearest").get<int>() + t.at("ties").get<int>()) << key;
  }
  // Findings carry their verdict; bugs come first.
  std::ifstream in(dir + "/closed.jsonl");
  bool seen_rounding = false;
  int witnesses = 0;
  for (std::string line; std::getline(in, line);) {
    const json f = json::parse(line).at("found");
    ASSERT_TRUE(f.contains("level") && f.contains("range")) << line;
    if (f.at("level") == "rounding") {
      seen_rounding = true;
      ASSERT_TRUE(f.contains("witness")) << line;
      ++witnesses;
    } else {
      EXPECT_FALSE(seen_rounding) << "a bug after a rounding-level finding";
    }
  }
  EXPECT_GT(witnesses, 0);
  // check replays them under the range they were found with, and --fail-on gates.
  const auto replay = run_cli("check " + dir + "/closed.jsonl --tracers cgal-aabb,bvh-watertight-top-left");
  EXPECT_EQ(replay.status, 0) << replay.err;
  EXPECT_NE(replay.out.find("\"level\":\"rounding\""), std::string::npos);
  const auto gate = run_cli("check " + dir + "/closed.jsonl --tracers cgal-aabb,bvh-watertight-top-left --fail-on bug");
  EXPECT_EQ(gate.status, replay.out.find("\"level\":\"bug\"") != std::string::npos ? 1 : 0) << gate.err;
  const auto none = run_cli("fuzz --tracers bvh-certified-triangle --count 256 --families random --fail-on bug -o " +
                            dir + "/cert.jsonl");
  EXPECT_EQ(none.status, 0) << none.err;  // the exact tracer: no bug-level disagreement there ...
  const auto some = run_cli("fuzz --tracers bvh-certified-triangle --count 256 --families fans --fail-on bug -o " +
                            dir + "/cert-fans.jsonl");
  EXPECT_EQ(some.status, 1) << some.err;  // ... but its closed test reports every triangle of a fan in any-hit mode
  // Bad input: a tolerance that is no number of ulps, a finding's range that is no range.
  for (const char* k : {"nan", "inf", "-1", "x"})
    EXPECT_EQ(
        run_cli("fuzz --tracers cgal-aabb --count 8 --tolerance-ulps " + std::string(k) + " -o " + dir + "/x.jsonl")
            .status,
        2)
        << k;
  {
    std::ofstream f(dir + "/bad-range.jsonl");
    f << R"({"id":"x","mesh":{"vertices":[[0,0,0],[1,0,0],[0,1,0]],"triangles":[[0,1,2]]},)"
      << R"("ray":{"origin":[0.2,0.2,1],"direction":[0,0,-1]},"found":{"range":"sideways"}})"
      << "\n";
  }
  const auto bad_range = run_cli("check " + dir + "/bad-range.jsonl --tracers bvh-watertight");
  EXPECT_EQ(bad_range.status, 1);
  EXPECT_NE(bad_range.err.find("bad-range.jsonl:1: field 'found.range'"), std::string::npos) << bad_range.err;
  const auto bad = run_cli("fuzz --tracers cgal-aabb --tracer-range nope=closed --count 8 -o " + dir + "/x.jsonl");
  EXPECT_EQ(bad.status, 2);
  EXPECT_NE(bad.err.find("no tracer is named 'nope'"), std::string::npos) << bad.err;
}

}  // namespace
}  // namespace rayproof
