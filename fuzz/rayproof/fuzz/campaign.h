// Fuzzing campaigns: every variant against the exact oracle on generated families, findings
// written whole, line by line, as replayable case-file lines; resumable from a checkpoint.
#pragma once

#include <compare>
#include <cstdint>
#include <functional>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "rayproof/verify/backward_error.h"
#include "rayproof/core/json_fields.h"
#include "rayproof/core/variants.h"
#include "rayproof/fuzz/generators.h"
#include "rayproof/fuzz/shard_of.h"
#include "rayproof/verify/report.h"
#include "rayproof/verify/tally.h"

namespace rayproof::fuzz {

struct CampaignOptions {
  std::vector<Family> families;
  // Each adversarial family in each construction, tallied apart ("tangent", "tangent-full").
  std::vector<Construction> constructions = {Construction::exact, Construction::full};
  std::vector<ShapeKind> shapes;
  // Variants judged (those of each shape); empty: every variant but the oracle's own (certified-*).
  std::vector<const Variant*> variants;
  std::uint64_t count = 10000;  // cases per family × shape (before sharding)
  std::uint64_t seed = 1;
  unsigned shard = 0, shards = 1;
  int threads = 1;
  HitRule rule = HitRule::nearest_contact;
  // verdicts.md: disagreements whose backward error is at most K ulps, with a witness, are
  // rounding-level (tallied apart, findings written after the bugs, --max-findings each).
  double tolerance_ulps = kDefaultToleranceUlps;
  std::string output;  // findings, JSON Lines; a checkpoint goes to output + ".checkpoint"
  bool resume = false;
  bool keep_checkpoint = false;  // a completed campaign removes its checkpoint unless asked to keep it
  bool shrink = true;
  std::uint64_t max_findings = 1000;  // written per family × shape and level; all are still counted
  // Findings shrunk per family × shape × kind (the first disagreeing variant and its exact->reported
  // classes, or its failure); the rest are written as found, counted in findings_unshrunk.
  // Shrinking costs ~2.7 ms a finding (a round trip each probe for external code): unbounded, it
  // was 24 s of a 26 s campaign, while one shrunk case per kind is what a user reads.
  std::uint64_t max_shrunk = 10;
  std::uint64_t batch = 8192;
  long crash_after_batches = -1;  // testing hook: exit hard after writing that many batches' findings
  // A checkpoint holds the whole report: written after every batch it took 13% of a random
  // campaign's time. So it follows the batch that ends this many seconds of work (0: every batch)
  // or a family and shape; a kill loses at most that much, which --resume does again.
  double checkpoint_seconds = 1;
  std::function<void(Family, ShapeKind, std::uint64_t done, std::uint64_t total)> progress;
  // Called from the calling thread's worker while a batch's findings are shrunk.
  std::function<void(std::uint64_t done, std::uint64_t total)> shrink_progress;
};

// What a report row is about: a family and a variant (tallies) or a shape (cases, seconds).
// Serialised as "family\tname", the summary file's key.
struct ReportKey {
  std::string family, name;
  auto operator<=>(const ReportKey&) const = default;
  std::string to_string() const { return family + "\t" + name; }
  static ReportKey parse(const std::string& joined);
};

struct CampaignReport {
  std::map<ReportKey, Tally> tallies;          // family × variant
  std::map<ReportKey, double> seconds;         // family × shape: generating and judging
  std::map<ReportKey, double> shrink_seconds;  // family × shape: shrinking and writing findings
  std::map<ReportKey, std::uint64_t> cases;    // family × shape
  std::uint64_t findings_written = 0;
  std::uint64_t findings_unshrunk = 0;  // written as found: beyond max_shrunk, or code that stopped
  ShardOf shard_of;                     // the campaign and the share of it this report holds
  // Per variant: {"found": {"exact->reported": {family: count}}, "never_found": [kinds]}, the
  // kinds of disagreement each family finds, and those none found.
  json coverage() const;
  json to_json() const;
  static CampaignReport from_json(const json& j);
};

// A tally row's name: the variant's, with "@shape" for one that answers several shapes (an --exec
// command), so each shape it was fuzzed on has its own row; and back: the variant and the shape
// a row is about (nullptr for a name no loaded variant has).
std::string tally_name(const Variant& v, ShapeKind shape);
std::pair<const Variant*, ShapeKind> variant_of_tally(const std::string& name);

// What makes runs the same campaign (ShardOf::campaign): all but the shard and the run's settings.
json campaign_identity(const CampaignOptions& options);

// Runs (or, with options.resume, continues) a campaign; throws std::runtime_error on I/O errors
// or a checkpoint that belongs to other options.
CampaignReport run_campaign(const CampaignOptions& options);

// The tally table (verify/report.h) in `format`, then throughput lines (not for json).
void print_report(const CampaignReport& report, int threads, TableFormat format, std::ostream& out);

}  // namespace rayproof::fuzz
