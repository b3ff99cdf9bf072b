// GoogleTest matchers over rayproof::audit's report (rayproof/fuzz/audit.h), so a user's unit
// test reads EXPECT_THAT(rayproof::audit(my_sphere, {...}), rayproof::HasNoWrongClass()); a
// failure prints the tallies and the shrunk cases, each a line `rayproof check` replays.
#pragma once

#include <gmock/gmock.h>

#include <ostream>
#include <string>

#include "rayproof/fuzz/audit.h"

namespace rayproof {

// How GoogleTest shows a report in "Value of" lines: one line of totals, not its bytes (the
// matchers below add the table and the shrunk cases).
inline void PrintTo(const AuditReport& r, std::ostream* os) {
  *os << "rayproof audit of " << (r.name.empty() ? std::string("an intersector") : r.name) << " on "
      << to_string(r.shape) << ": " << r.total.cases << " cases, " << r.total.wrong << " wrong, " << r.total.cannot_tell
      << " cannot tell, " << r.total.failures() << " failures, " << r.findings.size() << " findings";
}

// No answer of a class the exact oracle refutes (cannot-tell answers at exact touches allowed).
MATCHER(HasNoWrongClass, "answers no class the exact oracle refutes") {
  if (arg.total.wrong == 0 && arg.total.failures() == 0) return true;
  *result_listener << "\n" << arg.summary();
  return false;
}

// Not even a cannot-tell answer: every class is the exact one.
MATCHER(HasNoDisagreements, "answers every class exactly") {
  if (arg.total.disagreements() == 0 && arg.total.failures() == 0) return true;
  *result_listener << "\n" << arg.summary();
  return false;
}

// Where the class is right, t is within `ulps` of the correctly rounded exact t.
MATCHER_P(HasUlpErrorAtMost, ulps, "has t within " + ::testing::PrintToString(ulps) + " ulps") {
  if (arg.total.ulps.max() <= static_cast<std::uint64_t>(ulps)) return true;
  *result_listener << "\nlargest t error " << arg.total.ulps.max() << " ulps\n" << arg.summary();
  return false;
}

}  // namespace rayproof
