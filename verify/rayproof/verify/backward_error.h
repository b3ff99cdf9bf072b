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
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rayproof/core/json_fields.h"
#include "rayproof/core/query.h"
#include "rayproof/core/tracer.h"
#include "rayproof/verify/compare.h"
#include "rayproof/verify/mesh_truth.h"
#include "rayproof/verify/oracle.h"

namespace rayproof {

// A dyadic rational as an exact hex float with as many digits as it needs ("0x1.0000000000000008p+3"),
// and back (also plain JSON numbers). A non-dyadic rational has no such text: hex_exact throws.
std::string hex_exact(const mpq_class& x);
std::optional<mpq_class> parse_hex_exact(std::string_view text);
mpq_class exact_of(double x);  // a finite double, exactly
ExactVec exact_vec(const Vec3& v);
json exact_vec_json(const ExactVec& v);  // [x, y, z] as hex_exact strings
// The double at or above |x|·(sign): the smallest double ≥ x (for bounds reported upward).
double round_up(const mpq_class& x);

// u of the code's precision: 2^-24 for float, 2^-53 for double.
double unit_roundoff(Precision p);

struct Witness {
  double ulps = 0;   // ε: moves within ε·u·S (coordinates) and ε·u·‖d‖∞ (direction components)
  double scale = 0;  // S
  ExactVec origin, direction;
  std::map<std::uint32_t, ExactVec> vertices;  // the moved mesh vertices, by index
  // A variant's witness: the moved shape, whole (numbers in shape_numbers' order).
  std::optional<ShapeKind> shape;
  std::array<mpq_class, kMaxShapeNumbers> shape_numbers;
  // {"ulps", "scale", "ray": {"origin", "direction"}, "vertices": {"INDEX": [x, y, z]}} for a mesh,
  // {..., "shape": {"type", ...}} (the case format's fields) for a variant; exact.
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
  std::optional<double> beta;  // ulps (ε of the witness); nullopt: none
  // Accepted by the exact judge (where the caller keeps it). Shared, never changed: a memo hands
  // one witness to every tracer that gave the same answer, and findings copy outcomes.
  std::shared_ptr<const Witness> witness;
  bool checked = false;    // a witness of ε = β passed the exact judge
  bool refused = false;    // no witness within the checked range passed the exact check
  bool estimated = false;  // β is the smallest try's ε, not checked (beyond check_up_to)
};

enum class Level { bug, rounding };
std::string_view to_string(Level l);
// Rounding-level: β ≤ K with a witness the exact judge accepted; everything else is a bug.
inline Level level_of(const BackwardError& b, double tolerance_ulps) {
  return b.beta && b.checked && *b.beta <= tolerance_ulps ? Level::rounding : Level::bug;
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

// ------------------------------------------------------------------------------ variants
// β of a variant's answer (verdicts.md §3, "for a variant"), on the query as the variant saw it
// (f32 code: rounded to float) under `rule`, S the largest magnitude of the ray's origin and the
// shape's numbers. How it is found (README, "Bug or rounding?"): each shape has a few moves that
// carry the input across the boundary where its exact class changes — the ray mirrored through
// the nearest point of an edge, a vertex or a sphere's silhouette, the origin mirrored through
// the surface, the direction through the plane's parallel, the radius through the ray's distance
// — each a whole moved query, computed in long double (only its size matters) and made exact;
// the exact class is then decided along the segment from the query to it (halving, then
// bisection), so β is the boundary's ε on the best of those lines. A mirrored move crosses at
// about half its length, where the nearest crossing of that kind lies: within 4× of the minimum
// for these moves (README). Every β ≤ `check_up_to` comes with a witness exact_verdict accepted.
// `keep_witness` false: the verdict alone (a campaign's tally), no witness kept or made exact.
BackwardError class_backward_error(const Query& seen, HitRule rule, HitClass reported, Precision p,
                                   double check_up_to = std::numeric_limits<double>::infinity(),
                                   bool keep_witness = true);
// β of a right class's t: the smallest of a few moves (the shape's surface to the reported contact,
// or the origin along d) under which the exact contact parameter rounds to `t` in the code's
// precision (the class still agreeing).
BackwardError t_backward_error(const Query& seen, HitRule rule, HitClass reported, double t, Precision p);
// Whether a variant's witness moves no more than it claims and makes the answer right exactly:
// the class (and, with `t`, the contact parameter rounded to p) of the moved query agree.
// Whether the ray's origin lies on the (closed) shape, exactly: a contact at t = 0.
bool origin_on_shape(const Query& q);
bool shape_witness_holds(const Query& seen, const Witness& w, HitRule rule, HitClass reported, std::optional<double> t,
                         Precision p);

// verdicts.md for one variant's outcome on query q (as the case gives it): β of its class where
// it disagrees (`of_t` false), else of its t where that is not t correctly rounded in the code's
// precision (`of_t`: check's "beta_t"); nullopt where the answer is right, failed or has no
// query to judge (f32 code on a case float cannot hold). Judged on what the variant saw, under
// its own rule; witnesses are checked up to `check_up_to` ulps (class) as backward_error's are.
// A variant whose range is closed and that reports a contact at t = 0 where the origin lies on
// the shape exactly is right (verdicts.md §1): `at_range_end`, no β.
struct OutcomeVerdict {
  BackwardError beta;
  bool of_t = false;
  bool at_range_end = false;
  Level level = Level::bug;
};
std::optional<OutcomeVerdict> outcome_verdict(const Query& q, const VariantOutcome& o, HitRule rule,
                                              double tolerance_ulps, bool with_t,
                                              double check_up_to = std::numeric_limits<double>::infinity(),
                                              bool keep_witness = true);
// The verdict's fields for a check line's or a finding's entry: "level", "beta" (ulps or "none" /
// "unproved"), "range", and "witness" for a rounding-level one ("beta_t", "level_t" and
// "witness_t" for a t's).
void add_verdict_fields(nlohmann::ordered_json& entry, const OutcomeVerdict& v, std::string_view range);
void add_verdict_fields(json& entry, const OutcomeVerdict& v, std::string_view range);

// The default tolerance K (verdicts.md §3; its derivation in README, "Bug or rounding?").
inline constexpr double kDefaultToleranceUlps = 16;

}  // namespace rayproof
