// One mesh case judged for a whole tracer (docs/spec/tracer.md, verdicts.md): the tracer built
// over the case's mesh (as it sees it: float tracers get it rounded), its answer in the case's
// mode judged against the exact truth, the disagreement's backward error and level. The one judge
// of `fuzz --tracer`, `check`, `audit --tracers` and the Python module.
#pragma once

#include <optional>
#include <string>

#include "rayproof/core/json_fields.h"
#include "rayproof/core/mesh_case.h"
#include "rayproof/core/tracer.h"
#include "rayproof/verify/backward_error.h"
#include "rayproof/verify/mesh_truth.h"

namespace rayproof {

// How answers are read (docs/spec/verdicts.md): the tolerance K splitting bugs from rounding-level
// disagreements (0: the strict reading — no ties, every disagreement a bug) and, where given, a
// range that overrides the tracer's own (check replays a finding under the range it was found with).
struct VerdictSettings {
  double tolerance_ulps = kDefaultToleranceUlps;
  std::optional<RangeRule> range;
  // False: disagreements keep level bug and get no β (the baseline a benchmark measures β's cost against).
  bool backward_error = true;
  RangeRule range_of(const Tracer& t) const { return range.value_or(t.range); }
  JudgeRules rules_for(const Tracer& t) const { return {range_of(t), tolerance_ulps > 0}; }
};

// The outcome of one case.
struct TracerOutcome {
  TraceKind kind = TraceKind::right;
  TraceJudgement judgement;
  BackwardError backward;  // disagreements of the table's kinds: β and its witness
  Level level = Level::bug;
  RangeRule range = RangeRule::open;
  TraceAnswer answer;  // nearest mode
  AllHitsAnswer all;   // any-hit mode
  std::string reason;  // build failures, tracer errors, crashes: why
};
// The case as the tracer sees it (float: rounded; nullopt: not representable) ...
std::optional<MeshCase> as_seen_by(const Tracer& t, const MeshCase& c);
// ... and judged there: the tracer builds over the mesh and answers the ray in the case's mode.
TracerOutcome judge_tracer_on_case(const Tracer& t, const MeshCase& seen, const VerdictSettings& settings = {},
                                   bool with_backward_error = true);
// The β of the outcomes judged on one ray and truth (one mode), kept for the tracers after the
// first: backward_error reads of an outcome only its kind (and edge_double), the triangles it
// reports, its precision and its range, so tracers that answer a ray alike share one computation
// (the two watertight built-ins agree on most spawned rays).
class BackwardErrorMemo {
 public:
  const BackwardError* find(const TracerOutcome& o, Precision p, const MeshAnswer& a) const;
  void keep(const TracerOutcome& o, Precision p, const MeshAnswer& a);

 private:
  struct Entry {
    TraceKind kind;
    bool edge_double;
    Precision precision;
    RangeRule range;
    MeshAnswer answer;
    BackwardError backward;
  };
  std::vector<Entry> entries_;
};
// β and level of an outcome already judged (the table's kinds; errors, crashes: bugs, no β);
// `memo`: the β of other tracers' outcomes on the same ray and truth, read and added to.
void add_backward_error(TracerOutcome& o, const MeshOracle& oracle, const TracerRay& ray, const MeshTruth& truth,
                        Precision p, const VerdictSettings& settings, bool all, BackwardErrorMemo* memo = nullptr);
// The kind a tracer's failure to answer (or to build) is counted as.
TraceKind kind_of_failure(AnswerFailure f);
// The finding's verdict fields: level, beta, range, witness (verdicts.md §4).
void add_verdict_fields(json& found, const TracerOutcome& o);
// What the oracle expects of a case: {"touched", "nearest", "t"} (t: t* rounded, or null).
json expect_json(MeshOracle& oracle, const TracerRay& ray);
json expect_json(const MeshTruth& complete);  // from a truth(ray, true) at hand
// The answer as the findings and check lines show it.
json reported_json(const TracerOutcome& o, bool all);
// A tracer's entry in a `check` line (tracer.md, Outputs): the answer, "kind", and for a
// disagreement its "level" (with "beta" for the kinds that have one), "reason", "ulp". Shared by
// the CLI's check and the Python module's, so both write the same lines.
nlohmann::ordered_json check_entry(const TracerOutcome& o, bool all);

}  // namespace rayproof
