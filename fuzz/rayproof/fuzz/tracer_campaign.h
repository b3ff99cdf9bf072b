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
#include "rayproof/verify/tracer_judge.h"

namespace rayproof::fuzz {

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

// Fewer triangles (and only the vertices they use) on which the tracer still gives `kind`;
// `budget` caps the rebuilds. The case itself when nothing smaller shows it.
// With `level`, the shrunk case keeps that level too.
MeshCase shrink_mesh_case(const Tracer& t, const MeshCase& seen, TraceKind kind, int budget = 300,
                          const VerdictSettings& settings = {}, std::optional<Level> level = std::nullopt,
                          bool levels_each_probe = false, const TracerOutcome* found = nullptr);

// A finding as written: shrunk (shrink_mesh_case, keeping its kind and level; `budget` probes),
// the outcome of the case kept (re-judged where it shrank, else `found`), and its `expect`
// (seen's where the case did not shrink and seen has one, else computed).
struct ShrunkFinding {
  MeshCase c;
  TracerOutcome now;
  bool shrunk = false;
};
ShrunkFinding shrink_finding(const Tracer& t, const MeshCase& seen, const TracerOutcome& found,
                             const VerdictSettings& settings, int budget);

}  // namespace rayproof::fuzz
