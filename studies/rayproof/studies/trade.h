// The speed–accuracy trade: every contender (a variant, a batched variant, a peer library) timed
// on the same generated cases in one run, and judged against the exact oracle on them.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "rayproof/core/hit.h"
#include "rayproof/core/query.h"
#include "rayproof/core/variants.h"
#include "rayproof/fuzz/generators.h"
#include "rayproof/verify/report.h"
#include "rayproof/verify/backward_error.h"
#include "rayproof/verify/tally.h"

namespace rayproof::studies {

using fuzz::Family;

// A contender readied for one batch of queries: `run` answers them all (this is what is
// timed); `answer(i)` then reads the i-th answer.
struct Prepared {
  std::function<void()> run;
  std::function<Answer(size_t)> answer;  // a failure (external code) is tallied as one, not as a miss
  // Code behind a process boundary: one run that repeats the batch `repeats` times where the code
  // runs and returns one pass's seconds timed there (negative where it cannot), so the transport
  // is not charged to the formula (AnswerTiming). Empty for code rayproof times itself.
  std::function<double(int repeats)> time_where_it_runs;
};

// Something to measure: readies a whole batch of queries of one shape in its own layout (so
// batched and peer implementations are timed the way they are meant to be used).
struct Contender {
  std::string name;
  ShapeKind shape;
  std::function<Prepared(const std::vector<Query>&)> prepare;
  // Inputs as the contender really sees them (a float library rounds them); the oracle judges
  // these, and a query the contender cannot take (nullopt) is left out of its row. Empty: the
  // queries as generated.
  std::function<std::optional<Query>(const Query&)> effective_input;
  HitRule rule = HitRule::nearest_contact;  // the contact it reports (a plugin's fixed rule)
  bool users_code = false;                  // a plugin's or --exec command's: marked in the plot
  std::string precision = "double";         // "double", "float" or "exact": marked in the plot, a CSV column
};

std::vector<Contender> variant_contenders();  // every registered variant, called per query
std::vector<Contender> batched_contenders();  // the structure-of-arrays batched variants

struct TradeRow {
  std::string variant;
  ShapeKind shape;
  Family family;
  double ns_per_test = 0;
  Tally tally;                       // against the oracle on the contender's effective inputs
  bool pareto = false;               // no other contender on this shape and family is both as fast and as accurate
  bool users_code = false;           // a plugin's or an --exec command's: ringed in the plot
  std::string precision = "double";  // the contender's: float hollow, exact dotted in the plot
  // t's error in the contender's own precision: float ulps for float code (against the exact t
  // rounded to float), double ulps otherwise.
  const UlpHistogram& t_error() const {
    return precision == "float" && tally.ulps_own.count() ? tally.ulps_own : tally.ulps;
  }
  // Whether the row means something: cases were judged and the code did not stop on one (a
  // crash, timeout or protocol error leaves a time and a rate of nothing). Others stay out of
  // the plot and the Pareto front.
  bool measured() const { return tally.cases > 0 && tally.crashes + tally.timeouts + tally.protocol_errors == 0; }
  // verdicts.md §4: the plot's accuracy axis is bug-level wrong answers (backward error beyond
  // K, or none proved within it); the rate of all disagreements is the second series.
  double bug_rate() const { return tally.cases ? static_cast<double>(tally.bug_count()) / tally.cases : 0; }
};

// Marks every row that no other row of its shape and family beats on both speed and accuracy
// (as fast or faster and as accurate or more, strictly better on one).
void mark_pareto(std::vector<TradeRow>& rows);

std::vector<TradeRow> measure_trade(const std::vector<Contender>& contenders, const std::vector<ShapeKind>& shapes,
                                    const std::vector<Family>& families, std::uint64_t count, std::uint64_t seed,
                                    int threads, double tolerance_ulps = kDefaultToleranceUlps);

// CSV with exactly: variant,shape,family,cases,ns_per_test,disagreements,disagreement_rate,ulp_p99,ulp_max
void write_trade_csv(const std::vector<TradeRow>& rows, std::ostream& out);
// The table: aligned text, markdown (Pareto-optimal contenders marked ★) or JSON.
void write_trade_table(const std::vector<TradeRow>& rows, TableFormat format, std::ostream& out);
// Scatter plot: x ns per test (log), y disagreement rate (log), one mark per row.
void write_trade_svg(const std::vector<TradeRow>& rows, std::ostream& out);

}  // namespace rayproof::studies
