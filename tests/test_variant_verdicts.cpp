// Variants' verdicts (docs/spec/verdicts.md §3, "for a variant"): β of a class and of a t, each
// against a brute-force search, and witnesses the exact oracle alone accepts.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <random>
#include <sstream>

#include "cli_run.h"
#include "rayproof/core/casefile.h"
#include "rayproof/core/variants.h"
#include "rayproof/verify/backward_error.h"
#include "rayproof/verify/compare.h"
#include "rayproof/verify/oracle.h"
#include "rayproof/verify/tally.h"
#include "test_dir.h"

namespace rayproof {
namespace {

ExactQuery exact_query_of(const Query& q) {
  ExactQuery e;
  e.origin = exact_vec(q.ray.origin), e.direction = exact_vec(q.ray.direction), e.kind = kind_of(q.shape);
  double x[kMaxShapeNumbers];
  const int n = shape_numbers(q.shape, x);
  for (int i = 0; i < n; ++i) e.numbers[i] = exact_of(x[i]);
  return e;
}

// The smallest ε (in ulps of u) found by brute force: random moves of every number within
// ε·u·S (ε·u·‖d‖∞ for the direction), ε bisected per move over powers of 2^(1/4), each decided
// by exact_verdict. An upper bound on the true β, found without any of class_backward_error's moves.
double brute_force_beta(const Query& q, HitRule rule, HitClass reported, double u, int moves, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(-1, 1);
  const ExactQuery base = exact_query_of(q);
  double x[kMaxShapeNumbers];
  const int n = shape_numbers(q.shape, x);
  double scale = max_abs(q.ray.origin);
  for (int i = 0; i < n; ++i) scale = std::max(scale, std::abs(x[i]));
  const double dn = max_abs(q.ray.direction);
  double best = INFINITY;
  auto right = [&](const std::vector<double>& dir, double eps) {
    ExactQuery m = base;
    const mpq_class s = exact_of(eps * u * scale), sd = exact_of(eps * u * dn);
    for (int k = 0; k < 3; ++k) {
      m.origin[k] += s * exact_of(dir[k]);
      m.direction[k] += sd * exact_of(dir[3 + k]);
    }
    for (int i = 0; i < n; ++i) m.numbers[i] += s * exact_of(dir[6 + i]);
    const auto v = exact_verdict(m, rule);
    return v && agreement_of(v->cls, reported) == Agreement::agrees;
  };
  for (int trial = 0; trial < moves; ++trial) {
    std::vector<double> dir(6 + n);
    for (double& d : dir) d = trial % 2 ? unit(rng) : (unit(rng) < 0 ? -1 : 1);  // corners, then inside
    for (int k = -40 * 4; k <= 40 * 4; ++k) {
      const double eps = std::pow(2.0, k / 4.0);
      if (eps >= best) break;
      if (right(dir, eps)) {
        best = eps;
        break;
      }
    }
  }
  return best;
}

Query query(Vec3 o, Vec3 d, Shape s) { return Query{Ray{o, d}, s, ""}; }

TEST(VariantVerdicts, ClassBetaAgainstBruteForce) {
  // Near misses and near hits of each shape, off by a few ulps or a fraction of one, each
  // reported the other way by a double code: β within 4× of the smallest move brute force finds.
  const double r = 1.0;
  struct Case {
    Query q;
    HitClass reported;
  };
  const double off = 0x1p-50;  // 8 double ulps of 1 off the boundary
  std::vector<Case> cases = {
      {query({-4, r + off, 0}, {1, 0, 0}, Sphere{{0, 0, 0}, r}), HitClass::enter},  // passes outside
      {query({-4, r - off, 0}, {1, 0, 0}, Sphere{{0, 0, 0}, r}), HitClass::miss},   // passes inside
      {query({0.5, 0.5 - off, 3}, {0, 0, -1}, Triangle{{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}}}), HitClass::miss},
      {query({-off, 0.25, 3}, {0, 0, -1}, Triangle{{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}}}), HitClass::enter},
      {query({0, 0, 1}, {1, 1, -off}, Plane{{0, 0, 1}, 0}), HitClass::miss},               // crosses at t = 2^50
      {query({0, 0, off}, {1, 0, 1}, Plane{{0, 0, 1}, 0}), HitClass::exit},                // origin just above
      {query({-3, 1 + off, 0.5}, {1, 0, 0}, Box{{0, 0, 0}, {1, 1, 1}}), HitClass::enter},  // beside a face
      {query({-3, 0.5, 0.5}, {1, 0, 0}, Box{{0, 0, 0}, {1, 1, 1}}), HitClass::exit},       // far from right
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(std::string(to_string(kind_of(c.q.shape))) + " reported " + std::string(to_string(c.reported)));
    const BackwardError b = class_backward_error(c.q, HitRule::nearest_contact, c.reported, Precision::f64);
    ASSERT_TRUE(b.beta);
    const double brute = brute_force_beta(c.q, HitRule::nearest_contact, c.reported, 0x1p-53, 64, 7);
    if (std::isinf(brute)) {  // far beyond 2^40 ulps: a bug (unproved, or a β that large)
      EXPECT_EQ(level_of(b, kDefaultToleranceUlps), Level::bug);
      EXPECT_TRUE(b.refused || *b.beta > 0x1p40) << *b.beta;
      continue;
    }
    ASSERT_TRUE(b.witness);
    EXPECT_TRUE(
        shape_witness_holds(c.q, *b.witness, HitRule::nearest_contact, c.reported, std::nullopt, Precision::f64));
    EXPECT_LE(*b.beta, 4 * brute) << "brute force found " << brute;
  }
}

// A touch reported where the exact ray misses or crosses: the witness must put the ray exactly
// tangent (no dyadic point lies at a given distance along a given direction: a rational frame
// for the sphere, a solved linear equation for the plane and the triangle's plane).
TEST(VariantVerdicts, TouchesHaveExactWitnesses) {
  const double off = 0x1p-50;
  struct Case {
    Query q;
    double most;  // β at most this many ulps
  };
  const std::vector<Case> cases = {
      {query({-4, 1 + off, 0}, {1, 0, 0}, Sphere{{0, 0, 0}, 1}), 64},        // misses by 8 ulps of 1
      {query({-4, 1 - off, 0.25}, {1, 0, 0}, Sphere{{0, 0, 0.25}, 1}), 64},  // crosses by 8 ulps of 1
      {query({0.5, -0.3, off}, {5, -3, 0}, Plane{{3, 5, 7}, 0}), 64},        // parallel, just above
      {query({0.1, 0.2, 1}, {0.3, 0.7, -off}, Plane{{0, 0, 1}, 1}), 64},     // crosses far away
      {query({-1, 0.25, off}, {1, 0, 0}, Triangle{{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}}}), 64},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(std::string(to_string(kind_of(c.q.shape))));
    Oracle oracle;
    ASSERT_NE(oracle.judge(c.q.ray, c.q.shape).cls, HitClass::tangent);
    const BackwardError b = class_backward_error(c.q, HitRule::nearest_contact, HitClass::tangent, Precision::f64);
    ASSERT_TRUE(b.beta && b.checked && b.witness) << beta_json(b).dump();
    EXPECT_LE(*b.beta, c.most);
    // The witness, read back from its JSON, is exactly tangent for the rational stage alone.
    const Witness w = Witness::from_json(json::parse(b.witness->to_json().dump()));
    ExactQuery moved;
    moved.origin = w.origin, moved.direction = w.direction, moved.kind = *w.shape, moved.numbers = w.shape_numbers;
    const auto v = exact_verdict(moved, HitRule::nearest_contact);
    ASSERT_TRUE(v);
    EXPECT_EQ(v->cls, HitClass::tangent);
    EXPECT_TRUE(shape_witness_holds(c.q, w, HitRule::nearest_contact, HitClass::tangent, std::nullopt, Precision::f64));
  }
}

// A witness moved back towards the input (its move shortened, or its claimed ε cut) is refused.
TEST(VariantVerdicts, DoctoredWitnessIsRefused) {
  const Query q = query({-4, 1 + 0x1p-50, 0}, {1, 0, 0}, Sphere{{0, 0, 0}, 1});
  const BackwardError b = class_backward_error(q, HitRule::nearest_contact, HitClass::enter, Precision::f64);
  ASSERT_TRUE(b.witness);
  ASSERT_TRUE(
      shape_witness_holds(q, *b.witness, HitRule::nearest_contact, HitClass::enter, std::nullopt, Precision::f64));
  Witness claims_less = *b.witness;
  claims_less.ulps = *b.beta / 2;  // the same move, claimed as half of it
  EXPECT_FALSE(
      shape_witness_holds(q, claims_less, HitRule::nearest_contact, HitClass::enter, std::nullopt, Precision::f64));
  Witness short_move = *b.witness;  // half the move (origin and direction back towards the input)
  for (int k = 0; k < 3; ++k) {
    short_move.origin[k] = (short_move.origin[k] + exact_of(q.ray.origin[k])) / 2;
    short_move.direction[k] = (short_move.direction[k] + exact_of(q.ray.direction[k])) / 2;
    short_move.shape_numbers[k] = (short_move.shape_numbers[k] + exact_of(0)) / 2;
  }
  short_move.shape_numbers[3] = (short_move.shape_numbers[3] + exact_of(1)) / 2;
  EXPECT_FALSE(
      shape_witness_holds(q, short_move, HitRule::nearest_contact, HitClass::enter, std::nullopt, Precision::f64));
}

// A t whose forward error is tens of millions of ulps (a root near a tangent) can have a backward
// error of a few ulps: the formula is backward stable (verdicts.md §3, "for a variant").
TEST(VariantVerdicts, NearTangentRootIsBackwardStable) {
  const Query q = query({-0x1.2000000000000p-61, 0x1.9ffffffffffffp-61, 0},
                        {0x1.0000000000000p-62, -0x1.8000000000000p-63, 0}, Sphere{{0, 0, 0}, 0x1.4000000000000p-62});
  const Variant* stable = find_variant("stable");
  ASSERT_NE(stable, nullptr);
  const Hit h = stable->kernel(q.ray, q.shape, HitRule::nearest_contact);
  Oracle oracle;
  const Verdict exact = oracle.judge(q.ray, q.shape);
  ASSERT_EQ(h.cls, exact.cls);
  ASSERT_GT(*ulp_distance(h.t, *exact.t), 1000000u);
  const BackwardError b = t_backward_error(q, HitRule::nearest_contact, h.cls, h.t, Precision::f64);
  ASSERT_TRUE(b.beta && b.witness);
  EXPECT_LE(*b.beta, 16);
  EXPECT_TRUE(shape_witness_holds(q, *b.witness, HitRule::nearest_contact, h.cls, h.t, Precision::f64));
  // The same witness does not make a t one ulp to either side right (t's rounding interval is
  // closed on both sides).
  for (const double towards : {0.0, 4.0})
    EXPECT_FALSE(shape_witness_holds(q, *b.witness, HitRule::nearest_contact, h.cls, std::nextafter(h.t, towards),
                                     Precision::f64))
        << towards;
}

// Under a closed range, a contact reported at t = 0 from an origin on the shape is right.
TEST(VariantVerdicts, ClosedRangeAdmitsTZero) {
  const Query on = query({0.5, 0.25, 0}, {0, 0, 1}, Triangle{{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}}});
  const Query off = query({0.5, 0.25, 0x1p-60}, {0, 0, 1}, Triangle{{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}}});
  EXPECT_TRUE(origin_on_shape(on));
  EXPECT_FALSE(origin_on_shape(off));
  Variant closed = *find_variant("moller-trumbore");
  closed.range = RangeRule::closed;
  Oracle oracle;
  Hit at_zero;
  at_zero.cls = HitClass::exit, at_zero.t = 0;
  VariantOutcome o = judge_answer(oracle.judge(on.ray, on.shape), at_zero);
  o.variant = &closed;
  ASSERT_NE(o.agreement, Agreement::agrees);  // the case format's t > 0 says miss
  const auto v = outcome_verdict(on, o, HitRule::nearest_contact, kDefaultToleranceUlps, false);
  ASSERT_TRUE(v);
  EXPECT_TRUE(v->at_range_end);
  closed.range = RangeRule::open;
  const auto strict = outcome_verdict(on, o, HitRule::nearest_contact, kDefaultToleranceUlps, false);
  ASSERT_TRUE(strict);
  EXPECT_FALSE(strict->at_range_end);
  o = judge_answer(oracle.judge(off.ray, off.shape), at_zero);
  o.variant = &closed;
  closed.range = RangeRule::closed;
  const auto above = outcome_verdict(off, o, HitRule::nearest_contact, kDefaultToleranceUlps, false);
  ASSERT_TRUE(above);
  EXPECT_FALSE(above->at_range_end);
}

TEST(VariantVerdicts, TalliesOfOtherTolerancesDoNotMerge) {
  Tally a, b;
  a.tolerance_ulps = 16, b.tolerance_ulps = 4;
  EXPECT_THROW(a.merge(b), std::runtime_error);
  Tally fresh;
  fresh.merge(a);
  EXPECT_EQ(fresh.tolerance_ulps, 16);
  const Tally back = Tally::from_json(a.to_json());
  EXPECT_EQ(back.tolerance_ulps, 16);
}

// `check` and `fuzz` on variants: each disagreement's level, β and range, a witness for every
// rounding-level one that the exact judge accepts when read back; bugs + rounding-level =
// disagreements; K = 0 makes every disagreement a bug; findings bugs first.
TEST(VariantVerdictsCli, CheckAndFuzzCarryVerdicts) {
  using testing_support::run_cli;
  const std::string dir = testing_support::test_dir();
  const std::string cases = std::string(RAYPROOF_SOURCE_DIR) + "/scenes/cases/triangle.jsonl";
  ASSERT_EQ(run_cli("check " + cases + " -o " + dir + "/check.jsonl --summary " + dir + "/check.json").status, 0);
  ASSERT_EQ(
      run_cli("check " + cases + " --tolerance-ulps 0 -o " + dir + "/strict.jsonl --summary " + dir + "/strict.json")
          .status,
      0);
  const json summary = json::parse(std::ifstream(dir + "/check.json")).at("variants");
  const json strict = json::parse(std::ifstream(dir + "/strict.json")).at("variants");
  int rounding = 0;
  for (const auto& [name, t] : summary.items()) {
    const int disagreements = t.at("wrong").get<int>() + t.at("cannot_tell").get<int>();
    EXPECT_EQ(t.at("bugs").get<int>() + t.at("rounding").get<int>() + t.at("at_range_end").get<int>(), disagreements)
        << name;
    EXPECT_EQ(strict.at(name).at("bugs").get<int>(), disagreements) << name;
    rounding += t.at("rounding").get<int>();
  }
  EXPECT_GT(rounding, 0);
  std::map<std::string, Case> by_id;
  std::ifstream input(cases);
  for (std::string line; std::getline(input, line);)
    if (!line.empty()) {
      Case c = parse_case(line);
      by_id[c.id] = c;
    }
  std::ifstream lines(dir + "/check.jsonl");
  int witnesses = 0;
  for (std::string line; std::getline(lines, line);) {
    const json j = json::parse(line);
    for (const auto& [name, e] : j.at("variants").items()) {
      if (!e.contains("agrees") || e.at("agrees") == true) continue;
      ASSERT_TRUE(e.contains("level") && e.contains("beta") && e.contains("range")) << line;
      if (e.at("level") != "rounding") continue;
      // The witness, read back, makes the variant's class exactly right on what it saw.
      ASSERT_TRUE(e.contains("witness")) << line;
      const Variant* v = find_variant(name);
      ASSERT_NE(v, nullptr);
      const Case& c = by_id.at(j.at("id").get<std::string>());
      const std::optional<Query> seen = v->precision == Precision::f32 ? rounded_to_float(c) : std::optional<Query>(c);
      ASSERT_TRUE(seen);
      EXPECT_TRUE(shape_witness_holds(*seen, Witness::from_json(e.at("witness")), HitRule::nearest_contact,
                                      *answer_class_from_string(e.at("class").get<std::string>()), std::nullopt,
                                      v->precision))
          << line;
      ++witnesses;
    }
  }
  EXPECT_GT(witnesses, 0);
  // fuzz: levels in the summary, bugs first in the findings.
  ASSERT_EQ(run_cli("fuzz --shapes triangle,sphere --count 400 --threads 2 -o " + dir + "/f.jsonl --summary " + dir +
                    "/f.json")
                .status,
            0);
  const json fs = json::parse(std::ifstream(dir + "/f.json"));
  for (const auto& [key, t] : fs.at("tallies").items())
    EXPECT_EQ(t.at("bugs").get<int>() + t.at("rounding").get<int>() + t.at("at_range_end").get<int>(),
              t.at("wrong").get<int>() + t.at("cannot_tell").get<int>())
        << key;
  std::ifstream found(dir + "/f.jsonl");
  bool seen_rounding = false;
  for (std::string line; std::getline(found, line);) {
    const json f = json::parse(line).at("found");
    ASSERT_TRUE(f.contains("level")) << line;
    if (f.at("level") == "rounding")
      seen_rounding = true;
    else
      EXPECT_FALSE(seen_rounding) << "a bug after a rounding-level finding: " << line;
  }
  // --fail-on bug: exit 1 when a variant shows a bug-level disagreement.
  EXPECT_EQ(run_cli("check " + cases + " --fail-on bug -o " + dir + "/x.jsonl").status, 1);
}

}  // namespace
}  // namespace rayproof

namespace rayproof {
namespace {
// Rows of a CSV with a header, as maps from column to text.
std::vector<std::map<std::string, std::string>> read_csv(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> header;
  std::vector<std::map<std::string, std::string>> rows;
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) cells.push_back(cell);
    if (header.empty()) {
      header = cells;
      continue;
    }
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < header.size() && i < cells.size(); ++i) row[header[i]] = cells[i];
    rows.push_back(row);
  }
  return rows;
}

// trade and stability count bug-level disagreements apart (verdicts.md §4): never more than the
// disagreements, all of them under --tolerance-ulps 0, fewer somewhere under the default.
TEST(VariantVerdictsCli, TradeAndStabilityCountBugsApart) {
  using testing_support::run_cli;
  const std::string dir = testing_support::test_dir();
  const std::string trade =
      "trade --shapes sphere,triangle --families tangent,grazing --count 1500 --variants "
      "textbook,stable,moller-trumbore,watertight ";
  ASSERT_EQ(run_cli(trade + "-o " + dir + "/t.csv").status, 0);
  ASSERT_EQ(run_cli(trade + "--tolerance-ulps 0 -o " + dir + "/t0.csv").status, 0);
  const std::string stability =
      "stability --shapes sphere --variants textbook --from -40 --to 40 --step 40 --count 300 ";
  ASSERT_EQ(run_cli(stability + "-o " + dir + "/s").status, 0);
  ASSERT_EQ(run_cli(stability + "--tolerance-ulps 0 -o " + dir + "/s0").status, 0);
  for (const auto& [file, strict_file] : {std::pair{"/t.csv", "/t0.csv"}, {"/s/stability.csv", "/s0/stability.csv"}}) {
    const auto rows = read_csv(dir + file), strict = read_csv(dir + strict_file);
    ASSERT_EQ(rows.size(), strict.size());
    ASSERT_FALSE(rows.empty());
    bool fewer = false;
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const long bugs = std::stol(rows[i].at("bugs")), all = std::stol(strict[i].at("bugs"));
      const double rate = std::stod(rows[i].at("disagreement_rate")), cases = std::stod(rows[i].at("cases"));
      EXPECT_LE(bugs, all) << file << " row " << i;
      EXPECT_EQ(all, std::lround(rate * cases)) << strict_file << " row " << i;  // K = 0: every one a bug
      fewer = fewer || bugs < all;
    }
    EXPECT_TRUE(fewer) << file << ": no rounding-level disagreement anywhere";
  }
}
}  // namespace
}  // namespace rayproof
