// Backward error of a tracer's answer (docs/spec/verdicts.md §3): the smallest ε for which the
// answer is exactly right for an input moved by at most ε·u·S per coordinate (the ray's origin and
// the mesh's vertices, a shared vertex moving once) and ε·u·‖d‖∞ per direction component; u is
// the unit roundoff of the code's precision, S the largest magnitude among the ray's origin and
// the vertices of the triangles involved (reported, and crossed first).
//
// How β is found (README, "Bug or rounding?"): a disagreement is made right by one of three moves,
// each to an exact target, so the minimum is met at a boundary, not approached —
//  - the ray moved through a point of an edge (a reported triangle the ray misses: the edge point
//    nearest the ray; a hole or a missed triangle: an edge point where the crossing stops being
//    required, i.e. an open edge, or a shared edge whose neighbour was reported); the move is split
//    between origin and direction in proportion to what each may move;
//  - the reported triangle's vertices moved along d, so its contact comes to lie in range and at
//    or before the first required crossing (shells, range ends);
//  - both, the second computed on the moved ray.
// Each candidate is a *witness*; the smallest that the exact judge below accepts gives β.
// Ray-only moves give up at most 2× (vertices could take half the move) and Euclidean nearest
// points at most √3 in ∞-norm: β is within 4× of the true minimum for these kinds of fix. A double
// hit on a manifold edge or closed fan, and a hole whose crossing has no open edge to escape by,
// can never be made right: β = none.
//
// The exact judge reads the witness in GMP rationals (a witness moves doubles by fractions of
// their ulp, so its numbers are dyadic rationals, written as long hex floats): every contact of
// the moved ray with the moved mesh, grouped by exact t, the one-hit rule from the mesh's
// connectivity (MeshOracle::one_hit_rule_applies), and the answer judged as judge_nearest /
// judge_all_hits would, without ties (a witness makes the answer exactly right).
#pragma once

#include <gmpxx.h>

#include <array>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rayproof/core/json_fields.h"
#include "rayproof/core/tracer.h"
#include "rayproof/verify/mesh_truth.h"

namespace rayproof {

using ExactVec = std::array<mpq_class, 3>;

// A dyadic rational as an exact hex float with as many digits as it needs ("0x1.0000000000000008p+3"),
// and back (also plain JSON numbers). A non-dyadic rational has no such text: hex_exact throws.
std::string hex_exact(const mpq_class& x);
std::optional<mpq_class> parse_hex_exact(std::string_view text);
mpq_class exact_of(double x);  // a finite double, exactly
// The double at or above |x|·(sign): the smallest double ≥ x (for bounds reported upward).
double round_up(const mpq_class& x);

// u of the code's precision: 2^-24 for float, 2^-53 for double.
double unit_roundoff(Precision p);

struct Witness {
  double ulps = 0;   // ε: moves within ε·u·S (coordinates) and ε·u·‖d‖∞ (direction components)
  double scale = 0;  // S
  ExactVec origin, direction;
  std::map<std::uint32_t, ExactVec> vertices;  // the moved mesh vertices, by index
  // {"ulps", "scale", "ray": {"origin", "direction"}, "vertices": {"INDEX": [x, y, z]}}, exact.
  json to_json() const;
  static Witness from_json(const json& j);  // FieldError naming the field
};

// What a witness is checked against: a nearest answer (triangle or kNoTriangle) or an any-hit list.
struct MeshAnswer {
  bool all = false;
  std::uint32_t triangle = kNoTriangle;
  std::vector<std::uint32_t> triangles;
};

struct BackwardError {
  std::optional<double> beta;      // ulps (ε of the witness); nullopt: none
  std::optional<Witness> witness;  // accepted by the exact judge
  bool refused = false;            // no witness within the checked range passed the exact check
  bool estimated = false;          // β is the smallest try's ε, not checked (beyond check_up_to)
};

enum class Level { bug, rounding };
std::string_view to_string(Level l);
// Rounding-level: β ≤ K with a witness the exact judge accepted; everything else is a bug.
inline Level level_of(const BackwardError& b, double tolerance_ulps) {
  return b.beta && b.witness && *b.beta <= tolerance_ulps ? Level::rounding : Level::bug;
}
// "none", or ε to two significant digits.
json beta_json(const BackwardError& b);
// The β histogram's bucket: "2^k" for 2^(k-1) < β ≤ 2^k (k from −20: "2^-20" holds all below;
// an estimate beyond the checked range too), "none", or "unproved" (every witness within the
// checked range refused by the exact judge: a bug).
std::string beta_bucket(const BackwardError& b);

// S of verdicts.md §3 for this ray, answer and truth.
double involved_scale(const MeshOracle& oracle, const TracerRay& ray, const MeshTruth& truth, const MeshAnswer& a,
                      std::optional<std::uint32_t> subject = std::nullopt);

// Whether the witness moves nothing farther than it claims (against the original ray and mesh,
// with S = scale) and the answer is exactly right for the moved input (nullopt: the judge cannot
// say: a reported triangle in-plane or degenerate after the move).
std::optional<bool> witness_holds(const MeshOracle& oracle, const TracerRay& ray, const Witness& w, RangeRule range,
                                  const MeshAnswer& a, Precision p);

// β of a disagreement judged by MeshOracle (judge_nearest / judge_all_hits: `j`, on `truth`).
// Witnesses are checked only up to `check_up_to` ulps (a campaign passes its tolerance K: beyond
// it the disagreement is a bug whatever the check says, so β is the smallest try's ε, an
// estimate without a witness).
BackwardError backward_error(const MeshOracle& oracle, const TracerRay& ray, const MeshTruth& truth,
                             const TraceJudgement& j, const MeshAnswer& a, Precision p, RangeRule range,
                             double check_up_to = std::numeric_limits<double>::infinity());

// The default tolerance K (verdicts.md §3; its derivation in README, "Bug or rounding?").
inline constexpr double kDefaultToleranceUlps = 16;

}  // namespace rayproof
