// What an intersector answers: the class of the first contact and its parameter t.
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

// Why an intersector gave no answer to judge (only code rayproof did not write fails).
enum class HitFailure : std::uint8_t {
  none,
  bad_answer,         // plugin error: a return value outside 0..5
  nan_t,              // plugin error: a contact with a NaN t
  t_unwritten,        // plugin error: a contact whose t was left unwritten
  crash,              // the code died on this case (signal, early exit)
  timeout,            // no answer within --case-timeout
  protocol,           // exec: an unreadable line or a wrong id
  not_representable,  // a float variant's case overflows float or rounds to a degenerate one
  stopped,            // the code failed earlier: it is not asked again
};
std::string_view to_string(HitFailure f);
inline bool is_plugin_error(HitFailure f) {
  return f == HitFailure::bad_answer || f == HitFailure::nan_t || f == HitFailure::t_unwritten;
}
// The failures that end a variant's run and become findings of their own kind.
inline bool stops_variant(HitFailure f) {
  return f == HitFailure::crash || f == HitFailure::timeout || f == HitFailure::protocol;
}

struct Hit {
  HitClass cls = HitClass::miss;
  double t = std::numeric_limits<double>::quiet_NaN();  // NaN where there is no t
  HitFailure failure = HitFailure::none;                // not none: no answer; cls and t mean nothing
  bool has_t() const { return !std::isnan(t); }
  bool failed() const { return failure != HitFailure::none; }
  static Hit miss() { return {}; }
  static Hit failure_of(HitFailure f) { return {HitClass::miss, std::numeric_limits<double>::quiet_NaN(), f}; }
};

// Which contact counts. nearest_contact: the first contact with t > 0 (the case format's truth).
// enter_only: the first tutorial's rule — a contact counts only where the ray enters.
enum class HitRule { nearest_contact, enter_only };
std::string_view to_string(HitRule r);
std::optional<HitRule> hit_rule_from_string(std::string_view s);

}  // namespace rayproof
