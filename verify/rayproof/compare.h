// Comparing double-precision variants with the exact oracle: per-case outcomes and the
// per-variant summary of `rayproof check` (shared/spec/cases.md, "Results").
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "rayproof/casefile.h"
#include "rayproof/oracle.h"
#include "rayproof/variants.h"

namespace rayproof {

// The number of doubles between a and b (0 when equal; +0 and −0 are one point), or nullopt
// when either is NaN. ±inf count as the doubles just beyond ±DBL_MAX.
std::optional<std::uint64_t> ulp_distance(double a, double b);

// How a variant's class relates to the exact class.
enum class Agreement {
  agrees,
  cannot_tell,  // exact is tangent or boundary; the variant said enter, exit or miss
  wrong,        // any other difference
};

struct VariantOutcome {
  const Variant* variant = nullptr;
  Hit hit;
  Agreement agreement = Agreement::agrees;
  std::optional<std::uint64_t> ulp;  // null where either t is absent
};

VariantOutcome compare_variant(const Variant& v, const Verdict& exact, const Ray& ray, const Shape& shape,
                               HitRule rule);

// One result line: {"id", "exact": {"class", "t"}, "variants": {name: {"class", "t", "ulp", "agrees"}}}.
using nlohmann::ordered_json;
ordered_json check_line(const std::string& id, const Verdict& exact, const std::vector<VariantOutcome>& outcomes);

// Does the case's `expect` agree with the oracle? Empty when it does, else what differs.
std::string expectation_mismatch(const Expectation& expect, const Verdict& exact);

class CheckSummary {
 public:
  void add(const Verdict& exact, const std::vector<VariantOutcome>& outcomes);
  void print_table(std::ostream& out) const;
  json to_json() const;

 private:
  struct PerVariant {
    std::string shape;
    std::uint64_t cases = 0, agree = 0, wrong = 0, cannot_tell = 0;
    std::map<std::string, std::uint64_t> confusion;  // "exact->reported"
    std::vector<std::uint64_t> ulps;
  };
  std::map<std::string, PerVariant> variants_;
};

// The q-quantile (0..1) of values, nearest rank; 0 for none. Sorts a copy.
std::uint64_t quantile(std::vector<std::uint64_t> values, double q);

}  // namespace rayproof
