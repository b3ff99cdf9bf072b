// What code rayproof did not write answers: a Hit, or why there is none. Built-in kernels cannot
// fail and return a Hit; plugins, --exec commands, answers files and float variants (whose case
// may not exist in float) can, and everything that asks them — the judge, campaigns, `check` —
// counts the failures, so the type lives in core beside Hit rather than in peers/.
#pragma once

#include <cstdint>
#include <limits>
#include <string_view>

#include "rayproof/core/hit.h"

namespace rayproof {

// Why there is no answer to judge (only code rayproof did not write fails).
enum class AnswerFailure : std::uint8_t {
  none,
  bad_answer,         // plugin error: a return value outside 0..5
  nan_t,              // plugin error: a contact with a NaN t
  t_unwritten,        // plugin error: a contact whose t was left unwritten
  crash,              // the code died on this case (signal, early exit)
  timeout,            // no answer within --case-timeout
  protocol,           // exec: an unreadable line or a wrong id
  not_representable,  // a float variant's case overflows float or rounds to a degenerate one
  stopped,            // the code failed earlier: it is not asked again
  build_refused,      // a whole tracer refused the mesh (an exec tracer's {"error": ...}): as a build
                      // that returned NULL, every ray of that mesh is build_failed
  out_of_memory,      // the code's worker died at its --worker-memory limit
};
std::string_view to_string(AnswerFailure f);
inline bool is_plugin_error(AnswerFailure f) {
  return f == AnswerFailure::bad_answer || f == AnswerFailure::nan_t || f == AnswerFailure::t_unwritten;
}
// The failures that end a variant's run and become findings of their own kind.
inline bool stops_variant(AnswerFailure f) {
  return f == AnswerFailure::crash || f == AnswerFailure::timeout || f == AnswerFailure::protocol ||
         f == AnswerFailure::out_of_memory;
}

// A Hit, or a failure. A failed answer reads as a miss with no t (cls and t mean nothing): the
// renderer draws it as background, the judge counts `failure` instead.
struct Answer : Hit {
  AnswerFailure failure = AnswerFailure::none;

  Answer() = default;
  Answer(const Hit& h) : Hit(h) {}  // NOLINT(google-explicit-constructor): every hit is an answer
  bool failed() const { return failure != AnswerFailure::none; }
  static Answer failure_of(AnswerFailure f) {
    Answer a;
    a.failure = f;
    return a;
  }
};

}  // namespace rayproof
