// The exact oracle: what is true about a ray and a shape, in exact arithmetic over the input
// doubles (shared/spec/cases.md, "Exact classification"). This header carries no CGAL: only
// oracle.cpp includes it, so the build stays lean.
//
// Filtered, then exact (CGAL's filtered-predicate pattern): every sign a classification needs
// is computed by one templated functor, first over CGAL::Interval_nt, answering only when all
// its signs are certain, then over exact GMP rationals. The correctly rounded t comes from a
// 128-bit MPFR enclosure, with an exact midpoint test when the enclosure straddles a rounding
// boundary. Each fallback is counted.
#pragma once

#include <gmpxx.h>

#include <array>
#include <cstdint>
#include <optional>

#include "rayproof/hit.h"
#include "rayproof/shapes.h"

namespace rayproof {

// An exact contact parameter t = (p + s·√radicand) / q with q > 0 and s ∈ {−1, 0, +1}:
// rational for planes, triangles and boxes (s = 0), a quadratic root for spheres.
struct ExactParameter {
  mpq_class p, radicand, q = 1;
  int s = 0;
};

// sign(t − m), decided exactly by signs of rational expressions (never a floating √).
int compare(const ExactParameter& t, const mpq_class& m);

struct RoundingStats {
  std::uint64_t rounded = 0;          // correctly rounded t values produced
  std::uint64_t exact_fallbacks = 0;  // ... that needed the exact midpoint test
};

// The double nearest to t (ties to even), over the whole double range: a positive t below
// half the smallest subnormal gives +0, one beyond the largest double gives +inf. Proved:
// either a rigorous MPFR enclosure rounds the same at both ends, or the exact midpoint test
// decides.
double round_to_nearest(const ExactParameter& t, RoundingStats& stats);

struct Verdict {
  HitClass cls = HitClass::miss;
  std::optional<double> t;               // correctly rounded; absent for miss and t-less tangents
  std::optional<ExactParameter> exact_t;
  bool front = false;                    // the contact is on the front side (plane, triangle)
};

struct OracleStats {
  std::uint64_t queries = 0;
  std::uint64_t class_exact = 0;  // interval filter could not decide the class
  RoundingStats rounding;
};

class Oracle {
 public:
  struct Options {
    bool filter = true;  // false: every class decided in exact rationals (for tests, benchmarks)
  };
  Oracle() = default;
  explicit Oracle(Options options) : options_(options) {}

  Verdict judge(const Ray& ray, const Shape& shape, HitRule rule = HitRule::nearest_contact);
  const OracleStats& stats(ShapeKind kind) const { return stats_[static_cast<int>(kind)]; }
  void merge_stats(const Oracle& other);

 private:
  Options options_{};
  std::array<OracleStats, 4> stats_{};
};

}  // namespace rayproof
