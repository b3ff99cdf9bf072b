// Fuzzing campaigns: every variant against the exact oracle on generated families, findings
// written whole, line by line, as replayable case-file lines; resumable from a checkpoint.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "rayproof/generators.h"
#include "rayproof/json_fields.h"
#include "rayproof/variants.h"

namespace rayproof::fuzz {

// ULP errors in buckets: exact below 128, then 8 buckets per power of two (≤ 12.5% wide), so
// quantiles of millions of cases cost a few kilobytes and merge by addition.
class UlpHistogram {
 public:
  void add(std::uint64_t ulp);
  void merge(const UlpHistogram& other);
  std::uint64_t count() const { return count_; }
  std::uint64_t quantile(double q) const;  // the bucket's lower bound; exact below 128
  std::uint64_t max() const { return max_; }
  json to_json() const;
  static UlpHistogram from_json(const json& j);

 private:
  static int bucket(std::uint64_t ulp);
  static std::uint64_t lower_bound(int bucket);
  std::map<int, std::uint64_t> buckets_;
  std::uint64_t count_ = 0, max_ = 0;
};

struct Tally {
  std::uint64_t cases = 0, agree = 0, wrong = 0, cannot_tell = 0;
  std::uint64_t shared_edge_holes = 0;  // grazing triangle pairs: the exact ray meets the union, the variant neither
  std::map<std::string, std::uint64_t> confusion;  // "exact->variant"
  UlpHistogram ulps;
  void merge(const Tally& o);
  json to_json() const;
  static Tally from_json(const json& j);
};

struct CampaignOptions {
  std::vector<Family> families;
  std::vector<ShapeKind> shapes;
  std::uint64_t count = 10000;  // cases per family × shape (before sharding)
  std::uint64_t seed = 1;
  unsigned shard = 0, shards = 1;
  int threads = 1;
  HitRule rule = HitRule::nearest_contact;
  std::string output;           // findings, JSON Lines; a checkpoint goes to output + ".checkpoint"
  bool resume = false;
  bool shrink = true;
  std::uint64_t max_findings = 1000;  // written per family × shape; all are still counted
  std::uint64_t batch = 8192;
  long crash_after_batches = -1;  // testing hook: exit hard after writing that many batches' findings
  std::function<void(const std::string& what, std::uint64_t done, std::uint64_t total)> progress;
};

struct CampaignReport {
  // key: family name + "\t" + variant name
  std::map<std::string, Tally> tallies;
  std::map<std::string, double> seconds;         // per family + "\t" + shape
  std::map<std::string, std::uint64_t> cases;    // per family + "\t" + shape
  std::uint64_t findings_written = 0;
  json to_json() const;
  static CampaignReport from_json(const json& j);
};

// Runs (or, with options.resume, continues) a campaign; throws std::runtime_error on I/O errors
// or a checkpoint that belongs to other options.
CampaignReport run_campaign(const CampaignOptions& options);

void print_report(const CampaignReport& report, int threads, std::ostream& out);

}  // namespace rayproof::fuzz
