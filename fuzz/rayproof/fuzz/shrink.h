// Shrinking a finding: the simplest numbers on which a variant still disagrees with the exact
// oracle — fewer significant bits, exponents nearer zero, components zeroed — so a user gets
// `origin (0, 1, −4)`, not seventeen digits, whenever such a case exists.
#pragma once

#include "rayproof/core/casefile.h"
#include "rayproof/verify/oracle.h"
#include "rayproof/core/variants.h"

namespace rayproof::fuzz {

// Whether the variant disagrees with the exact class on this query (as it sees it: f32 code the
// float-rounded query, under its own rule).
bool disagrees(const Variant& v, Oracle& oracle, const Ray& ray, const Shape& shape, HitRule rule);
// disagrees(), or for a plugin error (`failure`), whether the variant gives that same error.
bool fails_the_same_way(const Variant& v, Oracle& oracle, const Ray& ray, const Shape& shape, HitRule rule,
                        AnswerFailure failure);

// A simpler query on which `v` still disagrees (the input itself when nothing simpler does).
// Every accepted step strictly lowers the total cost of the numbers (significant bits plus
// |binary exponent|), so shrinking terminates; `budget` caps the oracle calls.
// A plugin-error finding (`failure`) shrinks while the variant still gives that error.
Case shrink(Case c, const Variant& v, Oracle& oracle, HitRule rule, int budget = 3000,
            AnswerFailure failure = AnswerFailure::none);

// The cost that shrinking lowers: 0 for zero, else significant bits + |unbiased exponent|.
int number_cost(double x);

}  // namespace rayproof::fuzz
