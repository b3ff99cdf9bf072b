// A bounding volume hierarchy in double for scenes with meshes: binned SAH build, deterministic,
// and a conservative traversal — it never skips a box that the exact ray meets, so whatever the
// leaves' test (a variant, the exact oracle) decides is decided over every primitive that could
// matter.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "rayproof/core/fp.h"
#include "rayproof/core/geometry.h"

namespace rayproof {

// A closed axis-aligned box with double corners (exact: a triangle's box is its vertices' min
// and max).
struct Bounds {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = Vec3::Constant(-std::numeric_limits<double>::infinity());
  void grow(const Bounds& b) {
    lo = lo.cwiseMin(b.lo);
    hi = hi.cwiseMax(b.hi);
  }
  void grow(const Vec3& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  bool empty() const { return !(lo.x() <= hi.x()); }
};

// The parameter interval [lower, upper] over which a ray may be inside a box, widened so that it
// contains the exact interval (robust slab test). Per axis t = (bound − o)·(1/d) rounds three
// times (difference, reciprocal, product): the computed t lies within γ(3)·|t| of the exact one
// (Higham §3.1; pbrt-v4 widens tMax by 1 + 2γ(3) for the same reason). Widening each end by
// 3γ(3)·|t| covers that and the rounding of the widening itself, and 2^-1070 covers a product
// that underflowed. The bound holds while no reciprocal or difference over- or underflows:
// SlabRay::exotic flags the rays where it might not (|d| components outside [2^-1000, 2^1000],
// |o| beyond 2^1000), and Bvh::traverse visits every primitive for them instead.
struct SlabRay {
  Vec3 origin, inverse;
  std::array<bool, 3> parallel{};  // d_k = 0: the slab is met for all t or never
  bool exotic = false;
  explicit SlabRay(const Ray& ray) : origin(ray.origin) {
    for (int k = 0; k < 3; ++k) {
      const double d = ray.direction[k];
      parallel[k] = d == 0;
      inverse[k] = parallel[k] ? 0 : 1 / d;
      if (!parallel[k] && !(std::abs(d) >= 0x1p-1000 && std::abs(d) <= 0x1p1000)) exotic = true;
      if (!(std::abs(ray.origin[k]) <= 0x1p1000)) exotic = true;
    }
  }
  // Whether the widened interval meets [0, t_limit]; `entry` receives its lower end.
  bool meets(const Bounds& b, double t_limit, double& entry) const {
    constexpr double kWiden = 3 * gamma(3), kTiny = 0x1p-1070;
    double lower = 0, upper = t_limit;
    for (int k = 0; k < 3; ++k) {
      if (parallel[k]) {
        if (origin[k] < b.lo[k] || origin[k] > b.hi[k]) return false;
        continue;
      }
      double t0 = (b.lo[k] - origin[k]) * inverse[k], t1 = (b.hi[k] - origin[k]) * inverse[k];
      if (t0 > t1) std::swap(t0, t1);
      t0 = t0 - std::abs(t0) * kWiden - kTiny;
      t1 = t1 + std::abs(t1) * kWiden + kTiny;
      lower = t0 > lower ? t0 : lower;
      upper = t1 < upper ? t1 : upper;
    }
    entry = lower;
    return lower <= upper;
  }
};

class Bvh {
 public:
  struct Node {
    Bounds box;
    std::int32_t first = 0;  // leaf: first index into order(); inner: the second child (the first is next)
    std::int32_t count = 0;  // leaf: number of primitives (> 0); inner: 0
  };
  static constexpr int kLeafSize = 4;
  static constexpr int kBins = 16;

  Bvh() = default;
  // Builds over one box per primitive (binned SAH on the box centroids, ties broken by index).
  explicit Bvh(std::span<const Bounds> boxes);

  // Calls visit(primitive) for every primitive whose box the ray may meet for 0 ≤ t ≤ t_limit,
  // nearer boxes first. visit returns true to stop; it may lower t_limit as it goes (boxes
  // entered beyond t_limit are then skipped).
  template <class Visit>
  void traverse(const Ray& ray, double& t_limit, Visit&& visit) const {
    if (nodes_.empty()) return;
    const SlabRay slab(ray);
    if (slab.exotic) {  // outside the range where the widening is proved: visit everything
      for (std::int32_t p : order_)
        if (visit(p)) return;
      return;
    }
    std::int32_t stack[128];
    int top = 0;
    double entry;
    if (!slab.meets(nodes_[0].box, t_limit, entry)) return;
    stack[top++] = 0;
    while (top > 0) {
      const Node& node = nodes_[stack[--top]];
      if (!slab.meets(node.box, t_limit, entry)) continue;  // t_limit may have dropped since the push
      if (node.count > 0) {
        for (std::int32_t i = node.first; i < node.first + node.count; ++i)
          if (visit(order_[i])) return;
        continue;
      }
      const std::int32_t a = static_cast<std::int32_t>(&node - nodes_.data()) + 1, b = node.first;
      double entry_a = 0, entry_b = 0;
      const bool hit_a = slab.meets(nodes_[a].box, t_limit, entry_a);
      const bool hit_b = slab.meets(nodes_[b].box, t_limit, entry_b);
      if (hit_a && hit_b) {  // the nearer one on top
        if (entry_a <= entry_b) {
          stack[top++] = b;
          stack[top++] = a;
        } else {
          stack[top++] = a;
          stack[top++] = b;
        }
      } else if (hit_a) {
        stack[top++] = a;
      } else if (hit_b) {
        stack[top++] = b;
      }
    }
  }

  std::span<const Node> nodes() const { return nodes_; }
  std::span<const std::int32_t> order() const { return order_; }
  int depth() const { return depth_; }

 private:
  std::vector<Node> nodes_;
  std::vector<std::int32_t> order_;
  int depth_ = 0;
};

}  // namespace rayproof
