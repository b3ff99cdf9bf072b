// Comparing an intersector's answer with the exact oracle's: the agreement classes, the ULP
// error of t, `check`'s result lines and summary (docs/spec/cases.md, "Results"), and the rule
// for holes between triangles that share an edge.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "rayproof/core/casefile.h"
#include "rayproof/core/fp.h"
#include "rayproof/core/variants.h"
#include "rayproof/verify/oracle.h"

namespace rayproof {

// How a reported class relates to the exact class.
enum class Agreement {
  agrees,
  cannot_tell,  // exact is tangent or boundary; the intersector said enter, exit or miss
  wrong,        // any other difference
};
Agreement agreement_of(HitClass exact, HitClass reported);

struct VariantOutcome {
  const Variant* variant = nullptr;  // null for answers that come from elsewhere (batched, peers)
  Hit hit;
  Agreement agreement = Agreement::agrees;
  std::optional<std::uint64_t> ulp;  // null where either t is absent
};

// An answer judged against the exact verdict.
VariantOutcome judge_answer(const Verdict& exact, const Hit& reported);
// A registered variant run on the query and judged.
VariantOutcome compare_variant(const Variant& v, const Verdict& exact, const Ray& ray, const Shape& shape,
                               HitRule rule);

// One result line: {"id", "exact": {"class", "t"}, "variants": {name: {"class", "t", "ulp", "agrees"}}}.
using nlohmann::ordered_json;
ordered_json check_line(const std::string& id, const Verdict& exact, const std::vector<VariantOutcome>& outcomes);

// Does the case's `expect` agree with the oracle? Empty when it does, else what differs.
std::string expectation_mismatch(const Expectation& expect, const Verdict& exact);

// Two triangles sharing an edge, one ray through that edge: whether the exact ray crosses the
// surface there — it meets the pair, and not as a silhouette (front of one triangle and back of
// the other, where the pair is seen folded and missing both is fair). An intersector that misses
// both triangles of such a pair leaves a hole in a closed mesh.
bool crosses_shared_edge(const Verdict& first, const Verdict& second);

}  // namespace rayproof
