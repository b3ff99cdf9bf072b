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

#include <cstdint>
#include <memory>
#include <optional>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "rayproof/core/bvh.h"
#include "rayproof/core/tracer.h"
#include "rayproof/verify/oracle.h"

namespace rayproof {

enum class TraceKind {
  right,
  hole,
  false_hit,
  not_nearest,
  double_hit,
  missed_in_any_hit,
  in_plane,           // a miss where every contact is optional: cannot tell
  tracer_error,       // NaN t, a triangle out of range, a repeated index
  unsupported,        // any-hit asked of a tracer without it
  not_representable,  // a float tracer's case that overflows float (or the far family beyond 2^40)
  crash,
  timeout,
  build_failed,
};
std::string_view to_string(TraceKind k);
bool is_disagreement(TraceKind k);  // the table's kinds and tracer errors, crashes and timeouts

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
  const MeshContact* contact_of(std::uint32_t triangle) const;
  std::optional<double> t_star() const;        // the nearest crossing, rounded
  std::vector<std::uint32_t> touched() const;  // sorted
  std::vector<std::uint32_t> nearest() const;  // the triangles crossed at the first required point (else t*)
};

struct TraceJudgement {
  TraceKind kind = TraceKind::right;
  bool edge_ray = false;  // the ray meets a point under the one-hit rule
  bool edge_hole = false, edge_double = false;
  std::optional<std::uint64_t> ulp;  // right answers: t's error in the tracer's precision
  std::string detail;                // for tracer errors: what was wrong
};

// One per thread and mesh (it owns an oracle, which counts its stages).
class MeshOracle {
 public:
  explicit MeshOracle(std::shared_ptr<const TriangleMesh> mesh);
  const TriangleMesh& mesh() const { return *mesh_; }

  // complete: every contact in (tmin, tmax) (any-hit); else the nearest ones, up to and
  // including the first required crossing point (nearest mode; the BVH prunes beyond it).
  MeshTruth truth(const TracerRay& ray, bool complete);
  // One triangle's contact in range, or nullopt.
  std::optional<MeshContact> contact(const TracerRay& ray, std::uint32_t triangle);

  TraceJudgement judge_nearest(const TracerRay& ray, const MeshTruth& truth, const TraceAnswer& answer, Precision p);
  TraceJudgement judge_all_hits(const TracerRay& ray, const MeshTruth& truth, const AllHitsAnswer& answer);

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
  Oracle oracle_;
  Oracle with_parameter_{{.keep_exact_parameter = true}};
  // Exact parameters of the ray last asked about, by triangle: a fan's centre puts a dozen
  // contacts at one rounded t, and sorting them would otherwise rebuild each in rationals.
  Ray cached_ray_{Vec3::Constant(NAN), Vec3::Constant(NAN)};
  std::unordered_map<std::uint32_t, ExactParameter> exact_cache_;
};

}  // namespace rayproof
