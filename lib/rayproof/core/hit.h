// What an intersector answers: the class of the first contact and its parameter t. A kernel
// returns a hit or a miss; code that can fail to answer returns an Answer (answer.h).
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string_view>

namespace rayproof {

// The classes of docs/spec/cases.md, in that order, then `hit`: what code answers that says only
// "a contact at t" without its kind (docs/spec/plugin.md, RAYPROOF_HIT). The oracle never says hit.
enum class HitClass { miss, enter, exit, tangent, boundary, hit };

std::string_view to_string(HitClass c);
// The exact classes of cases.md (no "hit": a case's `expect` names what is true).
std::optional<HitClass> hit_class_from_string(std::string_view s);
// An answer's class (answers files, the exec protocol): the exact classes and "hit".
std::optional<HitClass> answer_class_from_string(std::string_view s);

struct Hit {
  HitClass cls = HitClass::miss;
  double t = std::numeric_limits<double>::quiet_NaN();  // NaN where there is no t
  bool has_t() const { return !std::isnan(t); }
  static Hit miss() { return {}; }
};

// Which contact counts. nearest_contact: the first contact with t > 0 (the case format's truth).
// enter_only: the first tutorial's rule — a contact counts only where the ray enters.
enum class HitRule { nearest_contact, enter_only };
std::string_view to_string(HitRule r);
std::optional<HitRule> hit_rule_from_string(std::string_view s);

// Which contact parameters a tracer's or variant's range admits (docs/spec/verdicts.md §1):
// `open`, tmin < t < tmax (DXR's rule for triangles, the case format's: a variant's range is
// t > 0), or `closed`, tmin ≤ t ≤ tmax (Embree's tnear/tfar, CGAL's Ray_3 and Segment_3, most
// BVH libraries).
enum class RangeRule { open, closed };
std::string_view to_string(RangeRule r);
std::optional<RangeRule> range_rule_from_string(std::string_view text);

}  // namespace rayproof
