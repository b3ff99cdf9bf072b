// Tables a person scans: one line per variant (per family, for campaigns) with its shape, cases,
// agree, wrong, cannot-tell, shared-edge holes, the t error in bits, and the commonest kinds of
// disagreement; as aligned text, markdown (pastes into a README or an issue tracker unchanged)
// or JSON. `check` and `fuzz` print their summaries with it, so both read alike.
#pragma once

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "rayproof/core/json_fields.h"
#include "rayproof/core/shapes.h"
#include "rayproof/verify/tally.h"

namespace rayproof {

enum class TableFormat { table, markdown, json };
std::optional<TableFormat> table_format_from_string(std::string_view s);

// Bits of error, as Herbie reports accuracy: log2(ulps + 1); 0 is correctly rounded, 53 means no
// bit of a double is right (24 for a float).
double bits_of_error(std::uint64_t ulps);

// The t error of a tally in bits (median, p99, max), over the cases whose class agrees.
json bits_json(const Tally& t);
json bits_json(const UlpHistogram& ulps);

// One variant's entry in `check --summary` (docs/spec/cases.md): its shape, the tally's counts
// and disagreements (failures of external code where there were any), the ULP error as
// quantiles (count, median, p99, max) rather than the mergeable histogram, and bits_json.
json check_summary_json(ShapeKind shape, const Tally& t);

// "exact->reported N" for the `top` commonest disagreements, then "+N more" kinds.
std::string disagreement_kinds(const Tally& t, size_t top = 3);

struct TallyRow {
  std::string family;  // empty: no family column (check)
  std::string variant;
  ShapeKind shape;
  Tally tally;
};

// Rows sorted by shape, then variant, then family (in the order given to `families`).
void write_tally_table(std::vector<TallyRow> rows, TableFormat format, std::ostream& out,
                       const std::vector<std::string>& families = {});
// The same rows as `--format json` prints them (one array), for a caller that adds its own.
json tally_table_json(std::vector<TallyRow> rows, const std::vector<std::string>& families = {});

}  // namespace rayproof
