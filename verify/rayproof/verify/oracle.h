// The exact oracle: what is true about a ray and a shape, in exact arithmetic over the input
// doubles (docs/spec/cases.md, "Exact classification"). This header carries no CGAL: only
// oracle.cpp includes it, so the build stays lean.
//
// Filtered, then exact (CGAL's Filtered_predicate pattern): each shape's meaning is fixed once,
// as a policy — its terms over any number type, one decision over their signs, and the contact
// parameter the decision names — and one driver layers four stages over it: a semi-static
// double filter with a proved error bound (verify/filtered.h), CGAL::Interval_nt, exact
// floating-point expansions (while no product under- or overflows), then GMP rationals; each
// answers only when every sign is certain. judge first tries each shape's direct path: the static
// filter's class and t's terms once in double-double with a priori bounds, one quotient test
// (verify/direct_rounding.h). Else the correctly rounded t comes from midpoint tests in
// double-double with error bounds, else in expansions, else from a 128-bit MPFR enclosure with
// exact midpoint tests where it straddles a rounding boundary. Each fallback is counted.
#pragma once

#include <gmpxx.h>

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "rayproof/core/hit.h"
#include "rayproof/core/json_fields.h"
#include "rayproof/core/shapes.h"

namespace rayproof {

// An exact contact parameter t = (p + s·√radicand) / q with q > 0 and s ∈ {−1, 0, +1}:
// rational for planes, triangles and boxes (s = 0), a quadratic root for spheres. NT is an
// exact number type: GMP rationals here, exact floating-point expansions inside the oracle.
template <class NT>
struct ParameterOf {
  NT p, radicand, q = NT(1);
  int s = 0;
};
using ExactParameter = ParameterOf<mpq_class>;

// sign(t − m), decided exactly by signs of rational expressions (never a floating √).
int compare(const ExactParameter& t, const mpq_class& m);
// sign(a − b) for two exact parameters (two quadratic roots included), likewise exact.
int compare(const ExactParameter& a, const ExactParameter& b);

struct RoundingStats {
  std::uint64_t rounded = 0;          // correctly rounded t values produced
  std::uint64_t direct = 0;           // ... by the shape's direct path (oracle.cpp's round_static)
  std::uint64_t expansion = 0;        // ... that needed expansions (double-double could not)
  std::uint64_t rational = 0;         // ... that needed GMP rationals (expansions could not)
  std::uint64_t exact_fallbacks = 0;  // ... of those, where the MPFR enclosure straddled a midpoint
};

// The double nearest to t > 0 (ties to even), over the whole double range: a t below half
// the smallest subnormal gives +0, one beyond the largest double gives +inf. Proved: either a
// rigorous MPFR enclosure rounds the same at both ends, or exact midpoint tests decide.
double round_to_nearest(const ExactParameter& t, RoundingStats& stats);

struct Verdict {
  HitClass cls = HitClass::miss;
  std::optional<double> t;  // correctly rounded; absent for miss and t-less tangents
  // Kept behind a shared pointer (immutable, so copies may share it): inline, three rationals made
  // every Verdict 144 bytes, zero-filled on each judge and copied per variant judged.
  std::shared_ptr<const ExactParameter> exact_t;
  bool front = false;  // the contact is on the front side (plane, triangle)
};

struct OracleStats {
  std::uint64_t queries = 0;          // the static filter decided the rest
  std::uint64_t class_interval = 0;   // the static filter failed; intervals decided
  std::uint64_t class_expansion = 0;  // the interval filter failed; exact expansions decided
  std::uint64_t class_exact = 0;      // ... and GMP rationals had to (expansions under/overflowed)
  RoundingStats rounding;

  // merge and to_json walk one list of the counters (oracle.cpp).
  void merge(const OracleStats& o);
  json to_json() const;  // check --summary's "oracle", per shape
  // One line: queries, how many needed more than the static filter, and how t was rounded.
  std::string describe() const;
};

// Where a ray passes a triangle, exactly: the signs of TrianglePolicy's terms — `plane`, of
// n·d (0: the ray is parallel to the plane); edge[i], of d·((v_i−o)×(v_{i+1}−o)), which is 0
// where the ray's line meets the line of edge (v_i, v_{i+1}). A crossing reported as `boundary`
// lies on edge i where edge[i] = 0, on the vertex two zero edges share. Decided in GMP
// rationals (no filter: meant for the few boundary crossings).
struct TriangleSides {
  int plane = 0;
  std::array<int, 3> edge{};
};
TriangleSides triangle_sides(const Ray& ray, const Triangle& tri);
// sign(t_a − t_b) for the parameters where the ray crosses the planes of two triangles (neither
// parallel to the ray), exactly: expansions first, else rationals.
int compare_crossing_parameters(const Ray& ray, const Triangle& a, const Triangle& b);

// A query over rational numbers: a witness's moved ray and shape (backward_error.h), whose
// numbers are doubles moved by fractions of their ulps. Shape numbers in shape_numbers' order.
using ExactVec = std::array<mpq_class, 3>;
struct ExactQuery {
  ExactVec origin, direction;
  ShapeKind kind = ShapeKind::sphere;
  std::array<mpq_class, kMaxShapeNumbers> numbers;
};
struct ExactVerdict {
  HitClass cls = HitClass::miss;
  std::optional<ExactParameter> t;  // absent for miss and t-less tangents
  bool front = false;
};
// The exact verdict on a rational query under `rule`, from the shapes' one meaning (the same
// policies Oracle::judge layers its stages over, here in GMP rationals alone; a ray in a
// triangle's plane as Oracle::judge decides it); nullopt where the shape is degenerate (a zero
// radius, normal or triangle area, a box corner not below the other on every axis).
std::optional<ExactVerdict> exact_verdict(const ExactQuery& q, HitRule rule);

// A query whose every number is a double-double value hi + lo, exactly (a witness's moved
// numbers, made in long double), in the order origin, direction, shape_numbers.
struct SplitQuery {
  ShapeKind kind = ShapeKind::sphere;
  std::array<double, 6 + kMaxShapeNumbers> hi{}, lo{};
};
// Its exact class under `rule` where intervals, then exact expansions decide it (Oracle::judge's
// stages), else nullopt (exact_verdict decides: a ray in a triangle's plane, a product that
// under- or overflows): a filter in front of exact_verdict for the many witnesses a campaign checks.
std::optional<HitClass> filtered_class(const SplitQuery& q, HitRule rule);

class Oracle {
 public:
  struct Options {
    bool filter = true;                 // false: every class and t decided in GMP rationals (tests, benchmarks)
    bool expansions = true;             // the exact floating-point expansion stage between interval and GMP
    bool static_filter = true;          // the semi-static double filter in front of the intervals
    bool double_double = true;          // t's midpoint tests in double-double before expansions
    bool keep_exact_parameter = false;  // fill Verdict::exact_t (in rationals) for audits and tests
    bool fma = true;     // double-double products by the CPU's FMA where it has one (Dekker's values, faster)
    bool direct = true;  // judge: the static filter and the shape's direct rounding of t before the stages
  };
  Oracle() = default;
  explicit Oracle(Options options) : options_(options) {}

  Verdict judge(const Ray& ray, const Shape& shape, HitRule rule = HitRule::nearest_contact);
  // The exact class alone (no t): what a predicate costs.
  HitClass classify(const Ray& ray, const Shape& shape, HitRule rule = HitRule::nearest_contact);
  const OracleStats& stats(ShapeKind kind) const { return stats_[static_cast<int>(kind)]; }
  void merge_stats(const Oracle& other);

 private:
  Verdict judge_in_stages(const Ray& ray, const Shape& shape, HitRule rule);  // judge past the direct path
  Verdict judge_as_given(const Ray& ray, const Shape& shape);                 // no scaling, no rule
  Options options_{};
  std::array<OracleStats, 4> stats_{};
};

}  // namespace rayproof
