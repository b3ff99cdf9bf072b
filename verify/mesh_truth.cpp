#include "rayproof/verify/mesh_truth.h"

#include <chrono>
#include <cstdio>

#include <algorithm>
#include <cmath>
#include <set>

#include "rayproof/core/json_fields.h"
#include "rayproof/verify/compare.h"

namespace rayproof {

// ------------------------------------------------------------------------------- MeshTruth
const CrossingPoint* MeshTruth::first_required() const {
  for (const CrossingPoint& p : points)
    if (p.required()) return &p;
  return nullptr;
}

const MeshContact* MeshTruth::contact_of(std::uint32_t triangle) const {
  const auto it = std::lower_bound(by_triangle.begin(), by_triangle.end(), std::pair{triangle, std::uint32_t{0}});
  return it != by_triangle.end() && it->first == triangle ? &contacts[it->second] : nullptr;
}

void MeshTruth::index_contacts() {
  by_triangle.clear();
  by_triangle.reserve(contacts.size());
  for (std::size_t i = 0; i < contacts.size(); ++i)
    by_triangle.emplace_back(contacts[i].triangle, static_cast<std::uint32_t>(i));
  std::sort(by_triangle.begin(), by_triangle.end());
}

std::optional<double> MeshTruth::t_star() const {
  if (points.empty()) return std::nullopt;
  return points.front().t;
}

std::vector<std::uint32_t> MeshTruth::touched() const {
  std::vector<std::uint32_t> out;
  for (const MeshContact& c : contacts) out.push_back(c.triangle);
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<std::uint32_t> MeshTruth::nearest() const {
  const CrossingPoint* p = first_required();
  if (!p && !points.empty()) p = &points.front();
  if (!p) return {};
  std::vector<std::uint32_t> out = p->triangles;
  std::sort(out.begin(), out.end());
  return out;
}

// ------------------------------------------------------------------------------- MeshOracle
namespace {
std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  return a < b ? (std::uint64_t(a) << 32 | b) : (std::uint64_t(b) << 32 | a);
}
// Where a boundary crossing lies on its triangle: an edge (two corners) or a vertex (one).
struct Feature {
  std::uint32_t a = 0, b = 0;
  bool vertex = false;
  bool operator==(const Feature&) const = default;
};
}  // namespace

MeshOracle::MeshOracle(std::shared_ptr<const TriangleMesh> mesh) : mesh_(std::move(mesh)) {
  const TriangleMesh& m = *mesh_;
  const std::size_t n = m.triangle_count();
  std::vector<Bounds> boxes(n);
  degenerate_.resize(n);
  around_vertex_.resize(m.vertex_count());
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = m.corners(i);
    for (std::uint32_t v : c)
      boxes[i].grow(m.vertex(v)), magnitude_ = std::max(magnitude_, m.vertex(v).cwiseAbs().maxCoeff());
    degenerate_[i] = m.degenerate(i);
    for (int k = 0; k < 3; ++k) {
      edges_[edge_key(c[k], c[(k + 1) % 3])].push_back(static_cast<std::uint32_t>(i));
      around_vertex_[c[k]].push_back(static_cast<std::uint32_t>(i));
    }
  }
  bvh_ = Bvh(boxes);
  for (std::int32_t i : bvh_.order()) leaf_order_.push_back(static_cast<std::uint32_t>(i));
}

ExactParameter MeshOracle::exact_t(const Ray& ray, std::uint32_t triangle) {
  if (!(ray.origin == cached_ray_.origin && ray.direction == cached_ray_.direction)) {
    cached_ray_ = ray;
    exact_cache_.clear();
  }
  if (const auto it = exact_cache_.find(triangle); it != exact_cache_.end()) return it->second;
  return exact_cache_[triangle] = exact_t_uncached(ray, triangle);
}

ExactParameter MeshOracle::exact_t_uncached(const Ray& ray, std::uint32_t triangle) {
  const Verdict v = with_parameter_.judge(ray, mesh_->triangle(triangle));
  if (!v.exact_t) return ExactParameter{};  // an in-plane contact without t starts at the origin: t = 0
  return *v.exact_t;
}

int MeshOracle::compare_t(const Ray& ray, const MeshContact& a, const MeshContact& b) {
  // Rounding to nearest is monotone: different rounded values order the exact ones.
  if (a.t != b.t) return a.t < b.t ? -1 : 1;
  if (a.triangle == b.triangle) return 0;
  if (a.crossing && b.crossing)
    return compare_crossing_parameters(ray, mesh_->triangle(a.triangle), mesh_->triangle(b.triangle));
  return compare(exact_t(ray, a.triangle), exact_t(ray, b.triangle));
}

namespace {
struct OracleBudget {
  bool active = false;
  double seconds = 0;
  std::chrono::steady_clock::time_point deadline;
  unsigned calls = 0;
};
thread_local OracleBudget oracle_budget;
void spend_oracle_budget() {
  OracleBudget& b = oracle_budget;
  if (!b.active || (++b.calls & 255u) != 0 || std::chrono::steady_clock::now() <= b.deadline) return;
  b.active = false;  // thrown once: what handles it may ask the oracle again
  char text[96];
  std::snprintf(text, sizeof text, "the exact oracle took longer than %g s (--case-timeout)", b.seconds);
  throw OracleTimeout(text);
}
}  // namespace

ScopedOracleBudget::ScopedOracleBudget(double seconds) {
  oracle_budget = {true, seconds,
                   std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                          std::chrono::duration<double>(seconds)),
                   0};
}
ScopedOracleBudget::~ScopedOracleBudget() { oracle_budget.active = false; }
PausedOracleBudget::PausedOracleBudget() : paused_(oracle_budget.active) {
  if (!paused_) return;
  left_ = oracle_budget.deadline - std::chrono::steady_clock::now();
  oracle_budget.active = false;
}
PausedOracleBudget::~PausedOracleBudget() {
  if (!paused_) return;
  oracle_budget.deadline = std::chrono::steady_clock::now() + left_;
  oracle_budget.active = true;
}

std::optional<MeshContact> MeshOracle::contact(const TracerRay& r, std::uint32_t triangle) {
  if (triangle >= mesh_->triangle_count()) return std::nullopt;
  spend_oracle_budget();
  MeshContact c;
  c.triangle = triangle;
  if (degenerate_[triangle]) {
    // Optional, extent not computed: kept only where its box meets the ray's range at all.
    c.t = std::numeric_limits<double>::quiet_NaN();
    Bounds box;
    for (std::uint32_t v : mesh_->corners(triangle)) box.grow(mesh_->vertex(v));
    double entry = 0;
    if (!SlabRay(r.ray).meets(box, r.tmax, entry)) return std::nullopt;
    return c;
  }
  const Verdict v = oracle_.judge(r.ray, mesh_->triangle(triangle));
  if (v.cls == HitClass::miss) return std::nullopt;
  if (v.cls == HitClass::tangent) {  // the ray lies in the plane: optional
    c.t = v.t.value_or(0);           // no t: it starts on the triangle at the origin
    if (v.t && !(*v.t < r.tmax)) {
      if (*v.t > r.tmax || compare(exact_t(r.ray, triangle), mpq_class(r.tmax)) >= 0) return std::nullopt;
    }
    return c;
  }
  c.t = *v.t;
  c.crossing = true;
  c.boundary = v.cls == HitClass::boundary;
  c.front = v.front;
  // tmin < t < tmax, exactly. tmin and tmax are doubles and rounding is monotone: a rounded t
  // strictly between them puts the exact t strictly between; equal to one, the exact test decides.
  if (c.t < r.tmin || c.t > r.tmax) return std::nullopt;
  if (c.t == r.tmin && compare(exact_t(r.ray, triangle), mpq_class(r.tmin)) <= 0) return std::nullopt;
  if (c.t == r.tmax && compare(exact_t(r.ray, triangle), mpq_class(r.tmax)) >= 0) return std::nullopt;
  return c;
}

void MeshOracle::analyse_point(const Ray& ray, CrossingPoint& point, const MeshTruth& truth) {
  std::vector<PointContact> at;
  for (std::uint32_t t : point.triangles) {
    const MeshContact& c = *truth.contact_of(t);
    PointContact p{t, c.boundary, c.front, {}};
    if (c.boundary) {
      const TriangleSides s = triangle_sides(ray, mesh_->triangle(t));
      for (int k = 0; k < 3; ++k) p.zero_edge[k] = s.edge[k] == 0;
    }
    at.push_back(p);
  }
  point.has_interior = std::any_of(at.begin(), at.end(), [](const PointContact& p) { return !p.boundary; });
  point.one_hit_rule = one_hit_rule_applies(at);
}

bool MeshOracle::manifold_edge(std::uint32_t a, std::uint32_t b) const {
  const auto it = edges_.find(edge_key(a, b));
  if (it == edges_.end() || it->second.size() != 2) return false;
  auto runs_a_to_b = [&](std::uint32_t t) {
    const auto c = mesh_->corners(t);
    for (int k = 0; k < 3; ++k)
      if (c[k] == a && c[(k + 1) % 3] == b) return true;
    return false;
  };
  return runs_a_to_b(it->second[0]) != runs_a_to_b(it->second[1]);
}

bool MeshOracle::one_hit_rule_applies(const std::vector<PointContact>& at) const {
  std::vector<Feature> features;
  bool facing_front = false, facing_back = false;
  for (const PointContact& p : at) {
    if (!p.boundary) return false;  // an interior crossing there: required, no rule
    (p.front ? facing_front : facing_back) = true;
    const auto corner = mesh_->corners(p.triangle);
    int zeros = 0, first_zero = -1, second_zero = -1;
    for (int k = 0; k < 3; ++k)
      if (p.zero_edge[k]) (zeros++ == 0 ? first_zero : second_zero) = k;
    if (zeros == 1) {
      features.push_back({std::min(corner[first_zero], corner[(first_zero + 1) % 3]),
                          std::max(corner[first_zero], corner[(first_zero + 1) % 3]), false});
    } else if (zeros == 2) {
      // Edges k = (v_k, v_k+1): two zero edges meet at the vertex they share.
      const int v = (second_zero == first_zero + 1) ? second_zero : first_zero;
      features.push_back({corner[v], corner[v], true});
    } else {
      return false;  // not a boundary crossing after all: no rule
    }
  }
  if (features.empty() || (facing_front && facing_back)) return false;
  if (!std::all_of(features.begin(), features.end(), [&](const Feature& f) { return f == features.front(); }))
    return false;
  const Feature f = features.front();
  std::set<std::uint32_t> group;
  for (const PointContact& p : at) group.insert(p.triangle);
  if (!f.vertex) {
    // A manifold edge: exactly two triangles have it, both crossed here, wound oppositely.
    const auto it = edges_.find(edge_key(f.a, f.b));
    if (it == edges_.end() || group != std::set<std::uint32_t>(it->second.begin(), it->second.end())) return false;
    return manifold_edge(f.a, f.b);
  }
  // A closed fan: every triangle around the vertex crossed here.
  const auto& around = around_vertex_[f.a];
  if (group != std::set<std::uint32_t>(around.begin(), around.end())) return false;
  return closed_fan_centre(f.a);
}

bool MeshOracle::closed_fan_centre(std::uint32_t v) const {
  // Around the centre each neighbour is left once (centre → x) and arrived at once (y → centre).
  const auto& around = around_vertex_[v];
  if (around.size() < 3) return false;
  // As multisets: sorted vectors (a fan has a handful of triangles; no node allocations).
  std::vector<std::uint32_t> leaving, arriving;
  leaving.reserve(around.size()), arriving.reserve(around.size());
  for (std::uint32_t t : around) {
    const auto c = mesh_->corners(t);
    for (int k = 0; k < 3; ++k)
      if (c[k] == v) leaving.push_back(c[(k + 1) % 3]), arriving.push_back(c[(k + 2) % 3]);
  }
  std::sort(leaving.begin(), leaving.end()), std::sort(arriving.begin(), arriving.end());
  return leaving == arriving && std::adjacent_find(leaving.begin(), leaving.end()) == leaving.end();
}

MeshTruth MeshOracle::truth(const TracerRay& r, bool complete) {
  MeshTruth truth;
  truth.complete = complete;
  double t_limit = r.tmax;
  // Nearest mode prunes at the best interior crossing: its exact t lies below next_up(rounded t)
  // (rounding to nearest moves it by at most half an ulp), so boxes entered beyond cannot hold a
  // nearer contact. Boundary crossings do not prune: one may turn out not to be required.
  double best_interior = std::numeric_limits<double>::infinity();
  bvh_.traverse(r.ray, t_limit, [&](std::int32_t i) {
    const std::uint32_t tri = leaf_order_[i];
    const auto c = contact(r, tri);
    if (!c) return false;
    truth.contacts.push_back(*c);
    if (!complete && c->crossing && !c->boundary && c->t < best_interior) {
      best_interior = c->t;
      t_limit = std::min(t_limit, next_up(best_interior));
    }
    return false;
  });
  // Exact order: by t (optional contacts with unknown t last), then by triangle.
  std::sort(truth.contacts.begin(), truth.contacts.end(), [&](const MeshContact& a, const MeshContact& b) {
    const bool unknown_a = std::isnan(a.t), unknown_b = std::isnan(b.t);
    if (unknown_a || unknown_b) return unknown_a != unknown_b ? unknown_b : a.triangle < b.triangle;
    const int c = compare_t(r.ray, a, b);
    return c != 0 ? c < 0 : a.triangle < b.triangle;
  });
  truth.index_contacts();
  const MeshContact* point_start = nullptr;  // the first contact of the last point
  for (std::size_t i = 0; i < truth.contacts.size(); ++i) {
    const MeshContact& c = truth.contacts[i];
    if (!c.crossing) continue;
    if (point_start && compare_t(r.ray, *point_start, c) == 0) {
      truth.points.back().triangles.push_back(c.triangle);
      continue;
    }
    truth.points.push_back({{c.triangle}, c.t});
    point_start = &c;
  }
  for (CrossingPoint& p : truth.points) analyse_point(r.ray, p, truth);
  if (!complete) {  // drop what lies beyond the first required point
    const CrossingPoint* req = truth.first_required();
    if (req) {
      const MeshContact limit = *truth.contact_of(req->triangles.front());
      std::erase_if(truth.contacts,
                    [&](const MeshContact& c) { return !std::isnan(c.t) && compare_t(r.ray, c, limit) > 0; });
      truth.points.resize(static_cast<std::size_t>(req - truth.points.data()) + 1);
      truth.index_contacts();
    }
  }
  return truth;
}

namespace {
// t's error in the tracer's precision: doubles, or floats against the exact t correctly rounded
// to float (verify/compare.h).
std::optional<std::uint64_t> t_error(double reported, double exact_rounded, Precision p, const Query& q) {
  if (p == Precision::f64) return ulp_distance(reported, exact_rounded);
  return ulp_distance_f32(to_nearest_float(reported), exact_t_as_float(q, HitRule::nearest_contact, exact_rounded));
}
}  // namespace

TraceJudgement MeshOracle::judge_nearest(const TracerRay& r, const MeshTruth& truth, const TraceAnswer& a, Precision p,
                                         JudgeRules rules) {
  TraceJudgement j;
  const CrossingPoint* req = truth.first_required();
  j.edge_ray = req && req->one_hit_rule && req == &truth.points.front();
  auto done = [&](TraceKind k) {
    j.kind = k;
    if (j.edge_ray) {
      const bool reported_one =
          a.hit() && std::find(req->triangles.begin(), req->triangles.end(), a.triangle) != req->triangles.end();
      j.edge_hole = !reported_one && (k == TraceKind::hole || k == TraceKind::not_nearest);
    }
    return j;
  };
  if (!a.hit()) {
    if (req) return done(TraceKind::hole);
    if (truth.points.empty() && !truth.contacts.empty()) return done(TraceKind::in_plane);
    return done(TraceKind::right);
  }
  if (a.triangle >= mesh_->triangle_count()) {
    j.detail = "triangle " + std::to_string(a.triangle) + " out of range (" + std::to_string(mesh_->triangle_count()) +
               " triangles)";
    return done(TraceKind::tracer_error);
  }
  if (std::isnan(a.t)) {
    j.detail = "t is NaN";
    return done(TraceKind::tracer_error);
  }
  // A t outside [tmin, tmax] is no answer to this ray (a t equal to an end is judged below: a
  // contact there is excluded, so reporting it is a false hit).
  if (a.t < r.tmin || a.t > r.tmax || std::isinf(a.t)) {
    j.detail = "t " + hex_double(a.t) + " outside (tmin, tmax)";
    return done(TraceKind::tracer_error);
  }
  std::optional<MeshContact> c;
  if (const MeshContact* known = truth.contact_of(a.triangle))
    c = *known;
  else
    c = contact(r, a.triangle);
  if (!c) {
    // Closed range (verdicts.md §1): a contact at exactly tmin or tmax is in range. At tmin
    // nothing lies before it; at tmax every crossing in range lies before it.
    if (rules.range == RangeRule::closed) {
      const RangeEnd end = range_end_touched(r, a.triangle);
      if (end == RangeEnd::tmin) return j.at_range_end = RangeEnd::tmin, done(TraceKind::right);
      if (end == RangeEnd::tmax) {
        if (req) return done(TraceKind::not_nearest);
        return j.at_range_end = RangeEnd::tmax, done(TraceKind::right);
      }
    }
    return done(TraceKind::false_hit);
  }
  if (std::isnan(c->t)) return done(TraceKind::right);  // a degenerate triangle: optional
  // Precision ties (verdicts.md §2): no code computing t in precision p can order two contacts
  // whose exact t round to the same number there. For doubles c->t is that rounding; for floats
  // exact_t_as_float rounds the exact t itself (never the double, which could round twice).
  auto tie_with = [&](const MeshContact& first) {
    if (!rules.ties || std::isnan(first.t)) return false;
    if (p == Precision::f64) return c->t == first.t;
    const float mine = exact_t_as_float(Query{r.ray, mesh_->triangle(c->triangle), {}}, HitRule::nearest_contact, c->t);
    const float theirs =
        exact_t_as_float(Query{r.ray, mesh_->triangle(first.triangle), {}}, HitRule::nearest_contact, first.t);
    return mine == theirs;
  };
  auto later_than = [&](const MeshContact& first) {
    if (compare_t(r.ray, *c, first) <= 0) return false;
    if (tie_with(first)) return j.tie = true, false;
    return true;
  };
  if (!c->crossing) {
    const bool after = !truth.points.empty() && later_than(*truth.contact_of(truth.points.front().triangles.front()));
    return done(after ? TraceKind::not_nearest : TraceKind::right);
  }
  if (req && later_than(*truth.contact_of(req->triangles.front()))) return done(TraceKind::not_nearest);
  j.ulp = t_error(a.t, c->t, p, Query{r.ray, mesh_->triangle(a.triangle), {}});
  return done(TraceKind::right);
}

TraceJudgement MeshOracle::judge_all_hits(const TracerRay& r, const MeshTruth& truth, const AllHitsAnswer& a,
                                          JudgeRules rules) {
  TraceJudgement j;
  std::set<std::uint32_t> reported;
  for (std::uint32_t t : a.triangles) {
    if (t >= mesh_->triangle_count()) {
      j.detail =
          "triangle " + std::to_string(t) + " out of range (" + std::to_string(mesh_->triangle_count()) + " triangles)";
      j.kind = TraceKind::tracer_error;
      return j;
    }
    if (!reported.insert(t).second) {
      j.detail = "triangle " + std::to_string(t) + " reported twice";
      j.kind = TraceKind::tracer_error;
      return j;
    }
  }
  bool hole = false, doubled = false, missed = false, false_hit = false;
  for (const CrossingPoint& p : truth.points) {
    std::size_t n = 0;
    for (std::uint32_t t : p.triangles) {
      const bool in = reported.contains(t);
      n += in;
      if (!in && !truth.contact_of(t)->boundary) missed = true;
    }
    if (p.one_hit_rule) {
      j.edge_ray = true;
      if (n == 0) hole = j.edge_hole = true;
      if (n >= 2) doubled = j.edge_double = true;
    }
  }
  if (reported.empty() && truth.first_required()) hole = true;
  for (std::uint32_t t : reported) {
    if (truth.contact_of(t)) continue;
    if (rules.range == RangeRule::closed) {  // a contact at a closed range's end: in range, optional
      if (const RangeEnd end = range_end_touched(r, t); end != RangeEnd::none) {
        j.at_range_end = end;
        continue;
      }
    }
    false_hit = true;
  }
  if (hole)
    j.kind = TraceKind::hole;
  else if (false_hit)
    j.kind = TraceKind::false_hit;
  else if (doubled)
    j.kind = TraceKind::double_hit;
  else if (missed)
    j.kind = TraceKind::missed_in_any_hit;
  else if (reported.empty() && truth.points.empty() && !truth.contacts.empty())
    j.kind = TraceKind::in_plane;
  return j;
}

}  // namespace rayproof
