#include "rayproof/fuzz/shrink.h"

#include "rayproof/verify/compare.h"

#include <cmath>
#include <cstring>
#include <vector>

namespace rayproof::fuzz {

bool disagrees(const Variant& v, Oracle& oracle, const Ray& ray, const Shape& shape, HitRule rule) {
  const Query q{ray, shape, {}};
  const VariantOutcome o = compare_variant(oracle, v, oracle.judge(ray, shape, rule), q, rule);
  return !o.answer.failed() && o.agreement != Agreement::agrees;
}

bool fails_the_same_way(const Variant& v, Oracle& oracle, const Ray& ray, const Shape& shape, HitRule rule,
                        AnswerFailure failure) {
  if (failure == AnswerFailure::none) return disagrees(v, oracle, ray, shape, rule);
  const Query q{ray, shape, {}};
  if (stops_variant(failure)) {  // a crash: each probe in a fresh copy of the code, outside its crash budget
    if (!v.external) return false;
    const std::optional<Query> given = v.precision == Precision::f32 ? rounded_to_float(q) : std::optional<Query>(q);
    return given && v.external->probe(*given).failure == failure;
  }
  return compare_variant(oracle, v, oracle.judge(ray, shape, rule), q, rule).answer.failure == failure;
}

int number_cost(double x) {
  if (x == 0) return 0;
  int exponent;
  double mantissa = std::frexp(std::abs(x), &exponent);  // [0.5, 1)
  int bits = 0;
  while (mantissa != 0) {
    mantissa = mantissa * 2 - std::floor(mantissa * 2);
    ++bits;
  }
  return bits + std::abs(exponent - 1);
}

namespace {

// Pointers to every number of a query, in the order shrinking visits them.
std::vector<double*> numbers_of(Case& c) {
  std::vector<double*> out;
  for (int i = 0; i < 3; ++i) out.push_back(&c.ray.origin[i]);
  for (int i = 0; i < 3; ++i) out.push_back(&c.ray.direction[i]);
  std::visit(
      [&](auto& s) {
        using S = std::decay_t<decltype(s)>;
        if constexpr (std::is_same_v<S, Sphere>) {
          for (int i = 0; i < 3; ++i) out.push_back(&s.center[i]);
          out.push_back(&s.radius);
        } else if constexpr (std::is_same_v<S, Plane>) {
          for (int i = 0; i < 3; ++i) out.push_back(&s.normal[i]);
          out.push_back(&s.offset);
        } else if constexpr (std::is_same_v<S, Triangle>) {
          for (auto& v : s.v)
            for (int i = 0; i < 3; ++i) out.push_back(&v[i]);
        } else {
          for (int i = 0; i < 3; ++i) out.push_back(&s.min[i]);
          for (int i = 0; i < 3; ++i) out.push_back(&s.max[i]);
        }
      },
      c.shape);
  return out;
}

// Simpler replacements for x, simplest first.
std::vector<double> candidates(double x) {
  std::vector<double> out = {0.0, std::round(x)};
  for (int bits : {1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 40, 48}) {
    int e;
    const double m = std::frexp(x, &e);
    out.push_back(std::ldexp(std::round(std::ldexp(m, bits)), e - bits));
  }
  int e;
  std::frexp(x, &e);
  if (e > 1) out.push_back(std::ldexp(x, -1));  // exponent one step nearer zero
  if (e < 1) out.push_back(std::ldexp(x, 1));
  return out;
}

}  // namespace

Case shrink(Case c, const Variant& v, Oracle& oracle, HitRule rule, int budget, AnswerFailure failure) {
  bool changed = true;
  while (changed && budget > 0) {
    changed = false;
    Case trial = c;
    const std::vector<double*> fields = numbers_of(trial);
    for (size_t k = 0; k < fields.size() && budget > 0; ++k) {
      double* x = fields[k];
      const double original = *x;
      for (double candidate : candidates(original)) {
        if (number_cost(candidate) >= number_cost(*x) || !std::isfinite(candidate)) continue;
        const double before = *x;
        *x = candidate;
        --budget;
        if (is_valid_query(trial.ray, trial.shape) &&
            fails_the_same_way(v, oracle, trial.ray, trial.shape, rule, failure)) {
          changed = true;
          break;  // keep the simplest candidate that still disagrees
        }
        *x = before;
        if (budget <= 0) break;
      }
    }
    if (changed) c = trial;
  }
  return c;
}

}  // namespace rayproof::fuzz
