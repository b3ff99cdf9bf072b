#include "rayproof/core/hit.h"

namespace rayproof {

std::string_view to_string(HitClass c) {
  switch (c) {
    case HitClass::miss: return "miss";
    case HitClass::enter: return "enter";
    case HitClass::exit: return "exit";
    case HitClass::tangent: return "tangent";
    case HitClass::boundary: return "boundary";
  }
  return "?";
}

std::optional<HitClass> hit_class_from_string(std::string_view s) {
  for (HitClass c : {HitClass::miss, HitClass::enter, HitClass::exit, HitClass::tangent,
                     HitClass::boundary})
    if (to_string(c) == s) return c;
  return std::nullopt;
}

std::string_view to_string(HitRule r) {
  return r == HitRule::enter_only ? "enter-only" : "nearest";
}

std::optional<HitRule> hit_rule_from_string(std::string_view s) {
  if (s == "nearest") return HitRule::nearest_contact;
  if (s == "enter-only") return HitRule::enter_only;
  return std::nullopt;
}

}  // namespace rayproof
