// The exact truth about a ray and a whole triangle mesh, and a tracer's answer judged against it
// (docs/spec/tracer.md, "What is judged"). Every decision is the oracle's: doubles only prune the
// BVH search, with the bound beside it.
//
// How the spec's words are read here (README, "Tracers"):
//  - A *crossing* at an interior point must be reported. A crossing on an edge shared by exactly
//    two consistently wound triangles, or at the centre of a closed consistently wound fan, with
//    the ray on the same side of all of them (it passes through the surface, not along a
//    silhouette), falls under the one-hit rule: exactly one of them must be reported. Together
//    these are the *required* crossings. A crossing anywhere else on a boundary (an open edge, a
//    non-manifold edge, a silhouette) may be reported or not: "either answer is right".
//  - nearest: no report while a required crossing exists is a `hole`; a reported triangle is
//    right when its exact contact lies at or before the first required crossing (an optional
//    in-plane contact: starts at or before t*); later is `not_nearest`.
//  - In-plane contacts count inside (tmin, tmax) by their first point; a degenerate triangle's
//    contact is optional and any report of it is taken as right (its extent is not computed).
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "rayproof/core/bvh.h"
#include "rayproof/core/tracer.h"
#include "rayproof/verify/oracle.h"
#include "rayproof/verify/trace_kind.h"

namespace rayproof {

// One triangle's contact with the ray inside (tmin, tmax).
struct MeshContact {
  std::uint32_t triangle = 0;
  double t = 0;           // the exact t rounded to double (in-plane: the first point; NaN: unknown)
  bool crossing = false;  // false: optional (in-plane, or a degenerate triangle)
  bool boundary = false;  // a crossing on an edge or a vertex
  bool front = false;
};

// The crossings at one point of the ray (equal exact t), nearest first.
struct CrossingPoint {
  std::vector<std::uint32_t> triangles;
  double t = 0;
  bool has_interior = false;  // some triangle is crossed at an interior point there
  bool one_hit_rule = false;  // a shared manifold edge or a closed fan's centre, crossed through
  bool required() const { return has_interior || one_hit_rule; }
};

struct MeshTruth {
  std::vector<MeshContact> contacts;  // by exact t; complete: all in range, else up to the first required crossing
  std::vector<CrossingPoint> points;  // likewise
  bool complete = false;
  const CrossingPoint* first_required() const;
  // By binary search over by_triangle (a linear search made `check` quadratic in a stack of
  // crossed triangles: 5 s at 80,000, issue 42); index_contacts() after contacts change.
  const MeshContact* contact_of(std::uint32_t triangle) const;
  void index_contacts();
  std::vector<std::pair<std::uint32_t, std::uint32_t>> by_triangle;  // (triangle, index in contacts), sorted
  std::optional<double> t_star() const;                              // the nearest crossing, rounded
  std::vector<std::uint32_t> touched() const;                        // sorted
  std::vector<std::uint32_t> nearest() const;  // the triangles crossed at the first required point (else t*)
};

// How a tracer's answers are read (docs/spec/verdicts.md §1–2): its declared range, and whether
// precision ties count as right (off in the strict reading, --tolerance-ulps 0).
struct JudgeRules {
  RangeRule range = RangeRule::open;
  bool ties = true;
};

// Where a right answer's contact lies at an end of a closed range (a note, not a disagreement).
enum class RangeEnd { none, tmin, tmax };

struct TraceJudgement {
  TraceKind kind = TraceKind::right;
  RangeEnd at_range_end = RangeEnd::none;  // right: the reported contact is exactly at tmin or tmax (closed)
  bool tie = false;       // right: a precision tie (its rounded t equals the first required crossing's)
  bool edge_ray = false;  // the ray meets a point under the one-hit rule
  bool edge_hole = false, edge_double = false;
  std::optional<std::uint64_t> ulp;  // right answers: t's error in the tracer's precision
  std::string detail;                // for tracer errors: what was wrong
};

// One per thread and mesh (it owns an oracle, which counts its stages).
// A time budget for the exact oracle on one case (issue 42: check's --case-timeout covers the
// oracle too): while a ScopedOracleBudget lives on this thread, MeshOracle throws OracleTimeout
// once its work runs past it (checked every 256 triangle contacts, the unit its cost grows by).
struct OracleTimeout : std::runtime_error {
  using std::runtime_error::runtime_error;
};
class ScopedOracleBudget {
 public:
  explicit ScopedOracleBudget(double seconds);
  ~ScopedOracleBudget();
  ScopedOracleBudget(const ScopedOracleBudget&) = delete;
  ScopedOracleBudget& operator=(const ScopedOracleBudget&) = delete;
};
// The budget stopped while the code under test runs (its own --case-timeout bounds it): only
// the oracle's time is spent.
class PausedOracleBudget {
 public:
  PausedOracleBudget();
  ~PausedOracleBudget();
  PausedOracleBudget(const PausedOracleBudget&) = delete;
  PausedOracleBudget& operator=(const PausedOracleBudget&) = delete;

 private:
  bool paused_ = false;
  std::chrono::steady_clock::duration left_{};
};

class MeshOracle {
 public:
  explicit MeshOracle(std::shared_ptr<const TriangleMesh> mesh);
  const TriangleMesh& mesh() const { return *mesh_; }

  // complete: every contact in (tmin, tmax) (any-hit); else the nearest ones, up to and
  // including the first required crossing point (nearest mode; the BVH prunes beyond it).
  MeshTruth truth(const TracerRay& ray, bool complete);
  // One triangle's contact in range, or nullopt.
  std::optional<MeshContact> contact(const TracerRay& ray, std::uint32_t triangle);

  TraceJudgement judge_nearest(const TracerRay& ray, const MeshTruth& truth, const TraceAnswer& answer, Precision p,
                               JudgeRules rules = {});
  TraceJudgement judge_all_hits(const TracerRay& ray, const MeshTruth& truth, const AllHitsAnswer& answer,
                                JudgeRules rules = {});

  // The mesh's connectivity, as the one-hit rule reads it. One triangle's contact at a crossing
  // point: boundary crossings name their zero edges (edge k runs from corner k to corner k + 1).
  struct PointContact {
    std::uint32_t triangle = 0;
    bool boundary = false, front = false;
    std::array<bool, 3> zero_edge{};
  };
  // Whether the crossings at one point fall under the one-hit rule (a shared manifold edge or a
  // closed fan's centre, crossed through from one side).
  bool one_hit_rule_applies(const std::vector<PointContact>& at) const;
  // An edge shared by exactly two triangles that run along it in opposite directions.
  bool manifold_edge(std::uint32_t a, std::uint32_t b) const;
  // A vertex whose triangles form one closed, consistently wound fan around it.
  bool closed_fan_centre(std::uint32_t v) const;
  const std::vector<std::uint32_t>& triangles_around(std::uint32_t v) const { return around_vertex_[v]; }
  bool degenerate(std::uint32_t t) const { return degenerate_[t]; }  // exactly collinear, as given
  // Where the ray touches the triangle at exactly parameter t0 (closed triangle, exact), or none.
  bool touches_at(const Ray& ray, std::uint32_t triangle, double t0) const;
  // Which end of the range (tmin, else a finite tmax) the triangle touches exactly, if either:
  // one rational contact for both ends.
  RangeEnd range_end_touched(const TracerRay& ray, std::uint32_t triangle) const;
  // The largest |coordinate| of the mesh.
  double magnitude() const { return magnitude_; }
  // Calls visit(triangle) for every triangle whose box, grown by `margin` on each side, the ray
  // may meet at some 0 ≤ t ≤ t_limit (conservative: Bvh::traverse).
  template <class Visit>
  void triangles_near(const Ray& ray, double margin, Visit&& visit,
                      double t_limit = std::numeric_limits<double>::infinity()) const {
    double limit = t_limit;
    const double scale = std::max(magnitude_, ray.origin.cwiseAbs().maxCoeff());
    const double reach = scale > 0 ? margin / scale * (1 + 0x1p-20) : kEveryPrimitive;
    bvh_.traverse(
        ray, limit, [&](std::int32_t i) { return visit(leaf_order_[i]), false; }, BaselineLanes{}, reach);
  }
  const Oracle& oracle() const { return oracle_; }

 private:
  ExactParameter exact_t(const Ray& ray, std::uint32_t triangle);
  ExactParameter exact_t_uncached(const Ray& ray, std::uint32_t triangle);
  int compare_t(const Ray& ray, const MeshContact& a, const MeshContact& b);  // sign(t_a − t_b), exact
  void analyse_point(const Ray& ray, CrossingPoint& point, const MeshTruth& truth);
  std::shared_ptr<const TriangleMesh> mesh_;
  Bvh bvh_;
  std::vector<std::uint32_t> leaf_order_;
  std::vector<bool> degenerate_;
  // Undirected edge (lo << 32 | hi) → the triangles having it; vertex → its triangles.
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> edges_;
  std::vector<std::vector<std::uint32_t>> around_vertex_;
  double magnitude_ = 0;
  Oracle oracle_;
  Oracle with_parameter_{{.keep_exact_parameter = true}};
  // Exact parameters of the ray last asked about, by triangle: a fan's centre puts a dozen
  // contacts at one rounded t, and sorting them would otherwise rebuild each in rationals.
  Ray cached_ray_{Vec3::Constant(NAN), Vec3::Constant(NAN)};
  std::unordered_map<std::uint32_t, ExactParameter> exact_cache_;
};

}  // namespace rayproof
