// CGAL's AABB tree as a whole tracer, "cgal-aabb" (docs/spec/tracer.md): triangles of the Epick
// kernel (exact predicates, constructions in double). Nearest: first_intersection, t read back
// from the constructed point along the direction's largest axis; any-hit:
// all_intersected_primitives. For a ray with tmin > 0 or a finite tmax (which CGAL's Ray_3
// cannot express) every intersection is constructed and those with t in (tmin, tmax) are kept.
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/version.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <iterator>

#include "rayproof/peers/tracers.h"

namespace rayproof::peers {

namespace {

using K = CGAL::Epick;
using Triangles = std::vector<K::Triangle_3>;
using Primitive = CGAL::AABB_triangle_primitive<K, Triangles::const_iterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, Primitive>>;

std::mutex last_error_mutex;
std::string last_error;
void note(const std::exception& e) {
  std::string what = e.what();
  std::replace(what.begin(), what.end(), '\n', ' ');
  std::lock_guard lock(last_error_mutex);
  last_error = what;
}

class CgalAabbScene final : public TracerScene {
 public:
  explicit CgalAabbScene(const TriangleMesh& mesh) {
    for (std::size_t i = 0; i < mesh.triangle_count(); ++i) {
      const Triangle t = mesh.triangle(i);
      auto p = [](const Vec3& v) { return K::Point_3(v.x(), v.y(), v.z()); };
      triangles_.emplace_back(p(t.v[0]), p(t.v[1]), p(t.v[2]));
    }
    tree_.insert(triangles_.begin(), triangles_.end());
    tree_.build();  // now, not lazily on the first (concurrent) query
  }

  // CGAL reports a violated precondition (a degenerate triangle, ...) by throwing: that ray's
  // answer is a tracer error, its message kept for the finding.
  void nearest(std::span<const TracerRay> rays, std::span<TraceAnswer> out) override {
    for (std::size_t i = 0; i < rays.size(); ++i) try {
        const TracerRay& r = rays[i];
        out[i] = {};
        const K::Ray_3 ray = to_cgal(r);
        if (whole_ray(r)) {
          const auto hit = tree_.first_intersection(ray);
          if (hit) out[i] = {index_of(hit->second), parameter(r, hit->first)};
          continue;
        }
        for_each_in_range(r, [&](std::uint32_t id, double t) {
          if (!out[i].hit() || t < out[i].t) out[i] = {id, t};
        });
      } catch (const std::exception& e) {
        out[i] = {kNoTriangle, NAN, AnswerFailure::bad_answer};
        note(e);
      }
  }

  void all_hits(std::span<const TracerRay> rays, std::span<AllHitsAnswer> out) override {
    for (std::size_t i = 0; i < rays.size(); ++i) try {
        out[i] = {};
        if (whole_ray(rays[i])) {
          std::vector<Primitive::Id> ids;
          tree_.all_intersected_primitives(to_cgal(rays[i]), std::back_inserter(ids));
          for (const auto& id : ids) out[i].triangles.push_back(index_of(id));
          continue;
        }
        for_each_in_range(rays[i], [&](std::uint32_t id, double) { out[i].triangles.push_back(id); });
      } catch (const std::exception& e) {
        out[i] = {{}, AnswerFailure::bad_answer};
        note(e);
      }
  }

 private:
  static bool whole_ray(const TracerRay& r) { return r.tmin == 0 && std::isinf(r.tmax); }
  static K::Ray_3 to_cgal(const TracerRay& r) {
    const K::Point_3 o(r.ray.origin.x(), r.ray.origin.y(), r.ray.origin.z());
    return K::Ray_3(o, K::Vector_3(r.ray.direction.x(), r.ray.direction.y(), r.ray.direction.z()));
  }
  std::uint32_t index_of(Primitive::Id id) const { return static_cast<std::uint32_t>(id - triangles_.begin()); }
  // t of a constructed point (a segment: its end nearer the origin), along d's largest axis.
  template <class Where>  // CGAL 5's boost::variant<Point_3, Segment_3>
  static double parameter(const TracerRay& r, const Where& where) {
    K::Point_3 p;
    if (const auto* point = boost::get<K::Point_3>(&where))
      p = *point;
    else {
      const auto& s = *boost::get<K::Segment_3>(&where);
      const double d0 = CGAL::to_double(CGAL::squared_distance(s.source(), to_cgal(r).source()));
      const double d1 = CGAL::to_double(CGAL::squared_distance(s.target(), to_cgal(r).source()));
      p = d0 <= d1 ? s.source() : s.target();
    }
    int k = 0;
    for (int a = 1; a < 3; ++a)
      if (std::abs(r.ray.direction[a]) > std::abs(r.ray.direction[k])) k = a;
    return (p[k] - r.ray.origin[k]) / r.ray.direction[k];
  }
  template <class Visit>
  void for_each_in_range(const TracerRay& r, Visit visit) const {
    std::vector<Tree::Intersection_and_primitive_id<K::Ray_3>::Type> hits;
    tree_.all_intersections(to_cgal(r), std::back_inserter(hits));
    for (const auto& h : hits) {
      const double t = parameter(r, h.first);
      if (t > r.tmin && t < r.tmax) visit(index_of(h.second), t);
    }
  }
  Triangles triangles_;
  Tree tree_;
};

}  // namespace

void register_cgal_aabb_tracer() {
  Tracer t;
  t.name = "cgal-aabb";
  t.precision = Precision::f64;
  t.range = RangeRule::closed;  // a Ray_3 contains its source: a contact at t = 0 is a hit
  t.source =
      "CGAL " CGAL_VERSION_STR " AABB_tree over Epick triangles: first_intersection / all_intersected_primitives";
  t.origin = "peer: CGAL (header-only)";
  t.build = [](const TriangleMesh& mesh) { return BuiltScene{std::make_unique<CgalAabbScene>(mesh)}; };
  t.stop_reason = [] {
    std::lock_guard lock(last_error_mutex);
    return last_error;
  };
  register_tracer(std::move(t));
}

}  // namespace rayproof::peers
