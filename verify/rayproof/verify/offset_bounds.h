// Spawn offsets, proved (docs/spec/offsets.md): how far off its surface a built-in variant's
// computed hit point can lie, how far off a new ray's origin must lie before that variant's own
// test can no longer report the surface it leaves, and what each offset rule guarantees. The
// derivations are written beside the code in offset_bounds.cpp, one per formula, the way
// filtered.h carries its proofs; every bound is evaluated with upward rounding.
#pragma once

#include <cmath>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rayproof/core/bvh.h"
#include "rayproof/core/geometry.h"
#include "rayproof/core/shapes.h"
#include "rayproof/core/variants.h"

namespace rayproof {

// Where a bound holds (offsets.md, `--domain`): primary rays whose origin lies in `scene_box`
// (`all`: anywhere: the scene box is then the precision's whole range and bounds are infinite),
// of any direction, and hits the variant reports whose computed point lies within `point_box`: the
// primitive's box widened by a first, coarser bound on the point (every computed point of a hit
// from the scene's box lies that close to the plane). A reported hit farther off is a wrong answer
// of the intersector (the exact contact is elsewhere or absent; `check` judges it), not a
// question of offsets. No product may under- or overflow (fp.h's proved range): the witness
// search keeps to it with unit directions.
struct OffsetProof {
  // |n̂·(p̃ − surface)| ≤ point for every computed hit point p̃ of the domain (n̂: the unit normal
  // of the surface at the hit; a box: its hit face's).
  double point = 0;
  // The re-intersection side: a ray leaving an origin that lies strictly more than
  // rehit_at(reach) off the surface on the side it leaves to, in any direction into that side,
  // whose origin lies within point_box widened by `reach` (a sphere: within `point` + `reach`
  // of its surface), cannot be reported hitting the primitive by the variant (within the domain).
  double rehit_base = 0, rehit_per_reach = 0, rehit_per_reach_squared = 0;
  // A derivation of degree 3 in the reach (the watertight test's): the line above is used up to
  // rehit_knee, then the chord from (knee, at_knee) to (knee2, at_knee2), then at_knee2·(reach/knee2)³.
  double rehit_knee = INFINITY, rehit_at_knee = INFINITY, rehit_knee2 = INFINITY, rehit_at_knee2 = INFINITY;
  double rehit_at(double reach) const;
  // Where the domain's computed hit points lie.
  Bounds point_box;
};

// The proof for one primitive and one variant's hit point o + t·d, or nullopt where no
// derivation is written (users' code, formulas not yet derived): those get the witness side only.
std::optional<OffsetProof> offset_proof(const Variant& v, const Shape& shape, const Bounds& scene_box);

// The names of the built-in variants offset_proof derives, for README and `rayproof offsets`.
std::vector<std::string_view> variants_with_offset_proofs();

// An offset rule (offsets.md): how a renderer moves a computed hit point p̃ along the unit
// normal n toward the side a new ray leaves by, in the variant's precision.
struct OffsetRule {
  enum class Kind { fixed, ulps, pbrt, waechter_binder, proved } kind = Kind::fixed;
  double amount = 0;  // fixed: the distance; ulps: N
  std::string name;   // as written: "fixed:1e-4", "ulps:32", "pbrt", "waechter-binder", "proved"
};
// Parses one rule; throws std::invalid_argument naming it.
OffsetRule parse_offset_rule(std::string_view text);
// The default of --rules: fixed:1e-4,ulps:32,pbrt,waechter-binder,proved.
std::vector<OffsetRule> default_offset_rules();

// The origin a renderer computing in `precision` spawns from: p moved along n (unit, toward the
// outgoing side) by the rule, every number in that precision. `proved_offset`: the primitive's
// proved offset, used by the `proved` rule.
Vec3 apply_offset_rule(const OffsetRule& rule, Precision precision, const Vec3& p, const Vec3& n, double proved_offset);

// Bounds on how far the rule moves a point of `points` along the true unit normal n_true, where
// `n` is the normal the renderer uses (within 2^-40 of n_true per coordinate).
struct Displacement {
  double min = 0, max = 0;
};
Displacement rule_displacement(const OffsetRule& rule, Precision precision, const Bounds& points, const Vec3& n,
                               double proved_offset);

// Whether the rule is proved safe for the primitive: the moved origin lies strictly beyond the
// re-intersection bound, the point's own error subtracted.
bool rule_proved_safe(const OffsetProof& proof, const Displacement& moved);

// The smallest offset (a distance along n, applied as `proved` applies it) that rule_proved_safe
// accepts for this primitive.
double proved_offset(const OffsetProof& proof, Precision precision, const Vec3& n);

// The unit of the last place of |x| in `precision` (the spacing of the grid at |x|; the smallest
// subnormal's at 0).
double ulp_in(Precision precision, double x);

// The largest rounding error |fl(v − o) − (v − o)| of a difference computed in `precision`, v
// fixed, over every number o of that precision in [o_lo, o_hi] (no underflow): grids, not only
// half an ulp (offset_bounds.cpp derives it). A vertex less an origin, as the variants compute it.
double difference_rounding(Precision precision, double v, double o_lo, double o_hi);

}  // namespace rayproof
