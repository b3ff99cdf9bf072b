// Stability maps: a grid over position scale × size scale (powers of two); per cell, the class
// disagreement rate and ULP p99 of every variant of a shape against the exact oracle. For the
// sphere the axes are the centre's distance from the ray origin and the radius.
#pragma once

#include <cstdint>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "rayproof/core/variants.h"
#include "rayproof/verify/backward_error.h"
#include "rayproof/verify/tally.h"

namespace rayproof::studies {

struct StabilityCell {
  int log2_scale = 0, log2_size = 0;
  Tally tally;
};

struct StabilityGrid {
  int lo = -200, hi = 200, step = 20;  // log2 range of both axes
  std::uint64_t cases_per_cell = 200;
  std::uint64_t seed = 1;
  double tolerance_ulps = kDefaultToleranceUlps;  // verdicts.md: bugs beyond it, rounding-level within
};

// Case i of cell (2^log2_scale, 2^log2_size): a pure function of its arguments (on every compiler).
Query stability_query(ShapeKind shape, int log2_scale, int log2_size, std::uint64_t seed, std::uint64_t i);

// Cells per variant name, in row-major order (size outer, scale inner).
std::map<std::string, std::vector<StabilityCell>> stability_study(ShapeKind shape,
                                                                  const std::vector<const Variant*>& variants,
                                                                  HitRule rule, const StabilityGrid& grid, int threads);

// CSV: variant,log2_scale,log2_size,cases,disagreement_rate,ulp_p99,bugs,bug_rate
void write_stability_csv(const std::map<std::string, std::vector<StabilityCell>>& cells, std::ostream& out);
// A heatmap of the bug-level rate (every disagreement's count in each cell's tooltip), with
// labelled axes and a colour legend.
void write_stability_svg(const std::string& title, const std::vector<StabilityCell>& cells, const StabilityGrid& grid,
                         std::ostream& out);

}  // namespace rayproof::studies
