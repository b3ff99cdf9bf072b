// Campaigns against whole tracers (docs/spec/tracer.md): every tracer family's meshes and rays,
// each ray judged in nearest mode and (where the tracer has it) any-hit mode against the exact
// truth over the mesh; findings shrunk to the fewest triangles that still show the same kind,
// written whole as replayable mesh cases; resumable; summaries keyed "FAMILY\tTRACER" (any-hit
// tallies as "FAMILY-any\tTRACER").
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "rayproof/core/mesh_case.h"
#include "rayproof/core/tracer.h"
#include "rayproof/fuzz/campaign.h"
#include "rayproof/fuzz/tracer_families.h"
#include "rayproof/verify/backward_error.h"
#include "rayproof/verify/mesh_truth.h"
#include "rayproof/verify/report.h"
#include "rayproof/verify/tally.h"

namespace rayproof::fuzz {

// How answers are read (docs/spec/verdicts.md): the tolerance K splitting bugs from rounding-level
// disagreements (0: the strict reading — no ties, every disagreement a bug) and, where given, a
// range that overrides the tracer's own (check replays a finding under the range it was found with).
struct VerdictSettings {
  double tolerance_ulps = kDefaultToleranceUlps;
  std::optional<RangeRule> range;
  RangeRule range_of(const Tracer& t) const { return range.value_or(t.range); }
  JudgeRules rules_for(const Tracer& t) const { return {range_of(t), tolerance_ulps > 0}; }
};

struct TracerCampaignOptions {
  VerdictSettings verdicts;
  std::vector<TracerFamily> families;
  std::vector<const Tracer*> tracers;
  std::uint64_t count = 10000;  // rays per family (before sharding)
  std::uint64_t seed = 1;
  unsigned shard = 0, shards = 1;
  int threads = 1;
  std::string output;  // findings; the checkpoint is output + ".checkpoint"
  bool resume = false, keep_checkpoint = false, shrink = true;
  std::uint64_t max_findings = 20;  // written per family × tracer × mode × kind × level; all are counted
  std::uint64_t batch_meshes = 16;  // meshes per batch (the unit of checkpointing)
  long crash_after_batches = -1;    // testing hook
  std::function<void(TracerFamily, std::uint64_t done, std::uint64_t total)> progress;
};

struct TracerCampaignReport {
  std::map<ReportKey, TracerTally> tallies;   // "FAMILY\tTRACER", "FAMILY-any\tTRACER"
  std::map<std::string, double> seconds;      // per family: generating, judging and tracing
  std::map<std::string, std::uint64_t> rays;  // per family
  std::uint64_t findings_written = 0;
  ShardOf shard_of;  // the campaign and the share of it this report holds
  json to_json() const;
  static TracerCampaignReport from_json(const json& j);
  void merge(const TracerCampaignReport& o);
};

TracerCampaignReport run_tracer_campaign(const TracerCampaignOptions& options);

// The verdict table (one row per family × tracer × mode), then per tracer the one-hit rule's
// line: "one hit per shared edge and vertex: holds / fails (N holes, M double hits in K edge rays)".
void print_tracer_report(const TracerCampaignReport& report, TableFormat format, std::ostream& out);
std::string one_hit_rule_line(const TracerCampaignReport& report, const std::string& tracer);
// What the bug-level findings point at, each line with its numbers: an absolute determinant
// epsilon, an unscaled tmin, 1/0 or 0·∞ in a slab test, a triangle test that is not watertight,
// a closed test's double hits.
std::vector<std::string> tracer_diagnosis(const TracerCampaignReport& report, const std::string& tracer);

// ---- one mesh case, judged: shared by the campaign, shrinking and `check`.
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
// β and level of an outcome already judged (the table's kinds; errors, crashes: bugs, no β).
void add_backward_error(TracerOutcome& o, const MeshOracle& oracle, const TracerRay& ray, const MeshTruth& truth,
                        Precision p, const VerdictSettings& settings, bool all);
// Whether a kind is split into bugs and rounding-level disagreements (verdicts.md §4).
bool has_backward_error(TraceKind k);
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
// Fewer triangles (and only the vertices they use) on which the tracer still gives `kind`;
// `budget` caps the rebuilds. The case itself when nothing smaller shows it.
// With `level`, the shrunk case keeps that level too.
MeshCase shrink_mesh_case(const Tracer& t, const MeshCase& seen, TraceKind kind, int budget = 300,
                          const VerdictSettings& settings = {}, std::optional<Level> level = std::nullopt,
                          bool levels_each_probe = false, const TracerOutcome* found = nullptr);

}  // namespace rayproof::fuzz
