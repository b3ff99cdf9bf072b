// What a user reads after `fuzz` or `check` (issue 25): per variant and kind of disagreement,
// one case and the command that replays it; then hints drawn from the disagreements, each
// stated with the numbers that support it (a count, a range, a threshold the data shows), never
// a guess: a t_min that drops near contacts, a threshold not scaled with |d|, overflow or
// underflow at a magnitude, contacts at t = 0, an early "centre behind" rejection, boundary
// contacts answered as misses, holes at shared edges.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "rayproof/core/casefile.h"
#include "rayproof/core/hit.h"
#include "rayproof/core/variants.h"

namespace rayproof {

// One variant's disagreement with the exact oracle on one case: a finding of `fuzz` (its
// found.disagreeing entry) or a result of `check`.
struct Disagreement {
  std::string variant;
  Case c;            // as it replays: id, ray, shape
  std::string file;  // the file that holds it
  HitClass exact = HitClass::miss;
  std::optional<double> exact_t;
  HitClass answered = HitClass::miss;
  std::optional<double> answered_t;
  std::string failure;  // "crash", "timeout", "protocol error", "plugin_error": no answer to compare
  // "enter->miss", or the failure.
  std::string kind() const;
};

// The disagreements a findings file holds, one per case and disagreeing variant (found.disagreeing,
// found.kind); mesh cases and lines without `expect` are skipped.
std::vector<Disagreement> disagreements_in_findings(const std::vector<Case>& findings, const std::string& file);

struct KindExample {
  std::string variant, kind;
  std::uint64_t count = 0;
  std::size_t first = 0;  // index of its first disagreement
};

// Per variant and kind: how many, and the first in the order given; most frequent first.
std::vector<KindExample> examples_by_kind(const std::vector<Disagreement>& all);

// One hint: its cause (a short name shared by every variant it applies to, so a report can print
// one line per cause) and the sentence with the numbers behind it.
struct Hint {
  std::string cause, text;
};

// Hints about one variant, from its disagreements (in any order); `precision` sets which
// magnitudes overflow; `shared_edge_holes` from its tally (0 when unknown).
std::vector<Hint> diagnose(const std::vector<const Disagreement*>& of_variant, Precision precision,
                           std::uint64_t shared_edge_holes = 0);

// The block printed after the table: at most `max_examples` examples (each a line describing the
// case and a line `replay(example)`), then the hints of each variant shown. `variants`: only
// these (empty: all). `shared_edge_holes`: per variant, from the tallies.
void print_examples_and_hints(std::ostream& out, const std::vector<Disagreement>& all,
                              const std::function<std::string(const Disagreement&)>& replay, std::size_t max_examples,
                              const std::vector<std::string>& variants = {},
                              const std::function<std::uint64_t(const std::string&)>& shared_edge_holes = nullptr);

// The flags that load a variant's code again: "--plugin PATH", "--exec 'NAME=CMD'", or "" for
// built-in code (answers files cannot be replayed this way: "").
std::string loading_flags(const Variant& v);

}  // namespace rayproof
