#include "rayproof/core/hit.h"

#include "rayproof/core/answer.h"

namespace rayproof {

std::string_view to_string(HitClass c) {
  switch (c) {
    case HitClass::miss: return "miss";
    case HitClass::enter: return "enter";
    case HitClass::exit: return "exit";
    case HitClass::tangent: return "tangent";
    case HitClass::boundary: return "boundary";
    case HitClass::hit: return "hit";
  }
  return "?";
}

std::optional<HitClass> answer_class_from_string(std::string_view s) {
  if (s == "hit") return HitClass::hit;
  return hit_class_from_string(s);
}

std::string_view to_string(AnswerFailure f) {
  switch (f) {
    case AnswerFailure::none: return "none";
    case AnswerFailure::bad_answer: return "answer outside 0..5";
    case AnswerFailure::nan_t: return "contact with a NaN t";
    case AnswerFailure::t_unwritten: return "contact with t left unwritten";
    case AnswerFailure::crash: return "crash";
    case AnswerFailure::timeout: return "timeout";
    case AnswerFailure::protocol: return "protocol error";
    case AnswerFailure::not_representable: return "not_representable";
    case AnswerFailure::stopped: return "stopped";
    case AnswerFailure::build_refused: return "build refused";
    case AnswerFailure::out_of_memory: return "out_of_memory";
  }
  return "?";
}

std::optional<HitClass> hit_class_from_string(std::string_view s) {
  for (HitClass c : {HitClass::miss, HitClass::enter, HitClass::exit, HitClass::tangent, HitClass::boundary})
    if (to_string(c) == s) return c;
  return std::nullopt;
}

std::string_view to_string(HitRule r) { return r == HitRule::enter_only ? "enter-only" : "nearest"; }

std::optional<HitRule> hit_rule_from_string(std::string_view s) {
  if (s == "nearest") return HitRule::nearest_contact;
  if (s == "enter-only") return HitRule::enter_only;
  return std::nullopt;
}

std::string_view to_string(RangeRule r) { return r == RangeRule::closed ? "closed" : "open"; }

std::optional<RangeRule> range_rule_from_string(std::string_view text) {
  if (text == "open") return RangeRule::open;
  if (text == "closed") return RangeRule::closed;
  return std::nullopt;
}

}  // namespace rayproof
