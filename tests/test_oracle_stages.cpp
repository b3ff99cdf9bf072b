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
