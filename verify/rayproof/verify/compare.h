// Comparing an intersector's answer with the exact oracle's: the agreement classes, the ULP
// error of t, `check`'s result lines and summary (docs/spec/cases.md, "Results"), and the rule
// for holes between triangles that share an edge.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <ostream>
#include <span>
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
// A reported `hit` (code that does not say the contact's kind) agrees with every exact contact.
inline Agreement agreement_of(HitClass exact, HitClass reported) {
  if (reported == exact) return Agreement::agrees;
  if (reported == HitClass::hit) return exact == HitClass::miss ? Agreement::wrong : Agreement::agrees;
  const bool exact_is_a_touch = exact == HitClass::tangent || exact == HitClass::boundary;
  const bool reported_is_plain =
      reported == HitClass::enter || reported == HitClass::exit || reported == HitClass::miss;
  return exact_is_a_touch && reported_is_plain ? Agreement::cannot_tell : Agreement::wrong;
}

struct VariantOutcome {
  const Variant* variant = nullptr;  // null for answers that come from elsewhere (batched, peers)
  Answer answer;                     // answer.failed(): nothing to judge; agreement and ulp mean nothing
  Agreement agreement = Agreement::agrees;
  std::optional<std::uint64_t> ulp;  // null where either t is absent
  // Where the variant saw other numbers than the case (f32 code: the float-rounded query) or
  // follows another rule than asked (a plugin's fixed rule): the oracle's verdict on what it
  // saw, which the answer was judged against.
  struct OwnVerdict {
    HitClass cls;
    std::optional<double> t;
    // The contact's side (planes, triangles): shared-edge hole counts need it. (No default member
    // initializer: with one, clang finds OwnVerdict not default-constructible inside
    // VariantOutcome, and optional::emplace() fails; emplace() value-initialises it to false.)
    bool front;
  };
  std::optional<OwnVerdict> own_exact;   // (class and t only: outcomes are many, and small)
  std::optional<std::uint64_t> ulp_own;  // f32 code: t's error in floats (fp.h, ulp_distance_f32)
};

// An answer judged against the exact verdict, written field by field into `out` (inline:
// campaigns call it for every case and variant; an outcome built whole in a temporary and copied
// costs a failed store-to-load forward per copy, the campaign's largest cost before).
inline void judge_answer_into(VariantOutcome& out, const Verdict& exact, const Answer& reported) {
  out.answer = reported;
  out.agreement = agreement_of(exact.cls, reported.cls);
  if (exact.t && reported.has_t())
    out.ulp = ulp_distance(reported.t, *exact.t);
  else
    out.ulp.reset();
  out.own_exact.reset();
  out.ulp_own.reset();
}
inline VariantOutcome judge_answer(const Verdict& exact, const Answer& reported) {
  VariantOutcome out;
  judge_answer_into(out, exact, reported);
  return out;
}
// A variant asked once for a batch (Variant::intersect_all, so external code answers in one
// round trip) and each answer judged: on the queries as it sees them (f32: rounded to floats,
// or a `not_representable` failure) and under its own rule. `exact[i]` is the verdict on qs[i]
// under `rule`, reused where the variant sees the same numbers and rule; the oracle judges the rest.
std::vector<VariantOutcome> judge_variant_all(Oracle& oracle, const Variant& v, std::span<const Query> qs,
                                              std::span<const Verdict> exact, HitRule rule);
// What every float variant judged on one batch shares, computed by the first and reused by the
// rest (they see the same float-rounded numbers): the rounded queries, where each came from, the
// oracle's verdicts on them under `rule`, and those verdicts' t rounded to float. clear() it for
// each new batch.
class FloatView {
 public:
  void clear() { ready_ = false; }

 private:
  friend void judge_variant_all(Oracle&, const Variant&, std::span<const Query>, std::span<const Verdict>, HitRule,
                                std::vector<VariantOutcome>&, FloatView*);
  bool ready_ = false;
  HitRule rule_ = HitRule::nearest_contact;
  std::vector<Query> queries_;
  std::vector<std::size_t> from_;
  std::vector<Verdict> exact_;
  std::vector<float> exact_t_;  // NaN: not yet computed (exact_t_as_float, asked only where a t agrees)
};
// The same into `out` (resized), whose storage a loop over chunks reuses; `shared`, where given,
// is the batch's FloatView.
void judge_variant_all(Oracle& oracle, const Variant& v, std::span<const Query> qs, std::span<const Verdict> exact,
                       HitRule rule, std::vector<VariantOutcome>& out, FloatView* shared = nullptr);
// The same for one query.
VariantOutcome compare_variant(Oracle& oracle, const Variant& v, const Verdict& exact, const Query& q, HitRule rule);

// The exact t of the query's contact correctly rounded to float, from `d`, that t correctly rounded
// to double (the oracle's Verdict::t): fl32(d) unless d is a float midpoint, decided then in
// rationals. Float code's t error is measured against this (ulp_distance_f32).
float exact_t_as_float(const Query& q, HitRule rule, double d);

// One result line: {"id", "exact": {"class", "t"}, "variants": {name: {"class", "t", "ulp", "agrees"}}}.
// An f32 variant's entry adds its own "exact" and "ulp_own"; a case it could not be given is
// {"skipped": "not_representable"}; an answer it failed to give is {"error": why} (plugin.md).
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
