// The one tally of how an intersector fared against the exact oracle: class agreement split into
// wrong and cannot-tell, the confusion of classes, ULP errors of t as a mergeable histogram,
// shared-edge holes and crashes. `check`, `fuzz`, `trade`, `stability` and the Embree peer all
// count with it, so a number means the same thing in every report.
#pragma once

#include <cstdint>
#include <map>
#include <vector>
#include <optional>
#include <string_view>
#include <string>

#include "rayproof/core/json_fields.h"
#include "rayproof/verify/compare.h"
#include "rayproof/verify/trace_kind.h"

namespace rayproof {

// ULP errors in buckets: exact below 128, then 8 buckets per power of two (≤ 12.5% wide), so
// quantiles of millions of cases cost a few kilobytes and merge by addition.
class UlpHistogram {
 public:
  void add(std::uint64_t ulp);
  void merge(const UlpHistogram& other);
  std::uint64_t count() const { return count_; }
  // Nearest rank, as the bucket's lower bound (exact below 128; the maximum is exact too).
  std::uint64_t quantile(double q) const;
  std::uint64_t max() const { return max_; }
  json to_json() const;
  static UlpHistogram from_json(const json& j);

 private:
  static int bucket(std::uint64_t ulp);
  static std::uint64_t lower_bound(int bucket);
  // Counts by bucket index, grown to the highest bucket used (a campaign adds one ulp per judged
  // t, and a map's lookup cost more than the rest of the tally).
  std::vector<std::uint64_t> buckets_;
  void add_to(int bucket, std::uint64_t n) {
    if (static_cast<std::size_t>(bucket) >= buckets_.size()) buckets_.resize(bucket + 1);
    buckets_[bucket] += n;
  }
  std::uint64_t count_ = 0, max_ = 0;
};

// A kind of disagreement: the exact class and the class the code reported. Written
// "exact->reported" ("tangent->miss") in reports and summaries, a typed key everywhere else.
struct DisagreementKind {
  HitClass exact, reported;
  auto operator<=>(const DisagreementKind&) const = default;
  std::string to_string() const;
  // "exact->reported" with an exact class of cases.md and an answer class; nullopt otherwise.
  static std::optional<DisagreementKind> from_string(std::string_view text);
};

struct Tally {
  std::uint64_t cases = 0, agree = 0, wrong = 0, cannot_tell = 0;
  std::uint64_t shared_edge_holes = 0;  // see crosses_shared_edge (verify/compare.h)
  // Answers external code failed to give (plugin.md), not among `cases`; serialised when > 0.
  std::uint64_t crashes = 0, timeouts = 0, protocol_errors = 0;  // each stops the variant
  std::uint64_t plugin_errors = 0;                               // a return outside 0..5, a NaN t, a contact without t
  std::uint64_t not_representable = 0;  // f32 code: cases that overflow float or degenerate when rounded
  std::map<DisagreementKind, std::uint64_t> confusion;  // disagreements only
  UlpHistogram ulps;      // t error, where the class agrees and both t exist (a wrong class's t is no error of t)
  UlpHistogram ulps_own;  // the same in the variant's own precision (f32 code only)

  // verdicts.md §4, where the run judged levels (tolerance_ulps set): per kind of disagreement the
  // bug-level ones and the rounding-level ones (the rest, `at_range_end`: a closed range's answers
  // at t = 0, are neither), and the β histogram ("2^k" buckets, "none", "unproved").
  std::optional<double> tolerance_ulps;
  std::map<DisagreementKind, std::uint64_t> bugs, rounding;
  std::uint64_t at_range_end = 0;
  std::map<std::string, std::uint64_t> beta;
  void add_level(const DisagreementKind& kind, bool bug, const std::string& beta_bucket);
  std::uint64_t bug_count() const;
  std::uint64_t rounding_count() const;

  // `exact`: the case's verdict class (the outcome's own_exact, where it has one, wins).
  void add(HitClass exact, const VariantOutcome& outcome);
  // A built-in double variant's answer (it cannot fail and sees the case as given) judged and
  // counted in one step, as add(exact.cls, judge_answer(exact, h)) would: a campaign's hot loop.
  Agreement add_answer(const Verdict& exact, const Hit& h);
  std::uint64_t failures() const { return crashes + timeouts + protocol_errors + plugin_errors; }
  std::uint64_t disagreements() const { return wrong + cannot_tell; }
  double disagreement_rate() const { return cases ? static_cast<double>(disagreements()) / cases : 0; }
  void merge(const Tally& o);
  json to_json() const;
  static Tally from_json(const json& j);
};

// How a whole tracer fared on one family in one mode (docs/spec/tracer.md, "Outputs"): one count
// per kind of TraceKind (verify/mesh_truth.h), the t error over right answers, the one-hit rule's
// evidence (rays meeting a shared edge or fan centre, and the holes and double hits there), and
// the time the tracer took, so ns per ray comes out of the same object in every report.

struct TracerTally {
  std::map<std::string, std::uint64_t> kinds;  // tally_key (trace_kind.h) → count (every ray once)
  std::uint64_t cases = 0;
  std::uint64_t edge_rays = 0, edge_holes = 0, edge_double_hits = 0;
  // verdicts.md §4: per kind of disagreement KIND_bugs and KIND_rounding (they add up to KIND);
  // the notes `ties` and `at_range_end` (of it `at_tmin`, `at_tmax`) among the right answers;
  // `edge_hole_bugs` (bug-level edge holes: the one-hit line counts these); `witness_refused`.
  std::map<std::string, std::uint64_t> levels;
  std::map<std::string, std::uint64_t> beta;  // histogram of β over disagreements: "2^k" buckets, "none"
  std::optional<double> tolerance_ulps;       // K this tally was judged with (absent: before verdicts.md)
  std::string range;                          // the tracer's range: "open" or "closed"
  std::uint64_t level(std::string_view key) const;
  // Evidence for the diagnosis lines (tracer_diagnosis): the largest t* over bug-level holes and
  // the smallest over right answers with a crossing. (`levels` holds the rest: |det| by powers
  // of two, "det_hole:K" and "det_right:K", and "zero_direction_hole_bugs".)
  std::map<std::string, double> extremes;  // "hole_t_max", "right_t_min"
  void note_max(const std::string& key, double x);
  void note_min(const std::string& key, double x);
  UlpHistogram ulps;   // right answers' t error, in the tracer's precision
  double seconds = 0;  // inside the tracer's calls (round trips included for external code)
  std::uint64_t timed_rays = 0;
  std::uint64_t count(TraceKind kind) const;
  void add(TraceKind kind);             // one ray of that kind: cases and its count
  std::uint64_t disagreements() const;  // the kinds kTraceKinds marks as disagreements
  double ns_per_ray() const { return timed_rays ? seconds * 1e9 / static_cast<double>(timed_rays) : 0; }
  void merge(const TracerTally& o);
  json to_json() const;
  static TracerTally from_json(const json& j);
};

}  // namespace rayproof
