// A bounding volume hierarchy in double for scenes with meshes: binned SAH build, deterministic,
// and a conservative traversal — it never skips a box that the exact ray meets, so whatever the
// leaves' test (a variant, the exact oracle) decides is decided over every primitive that could
// matter.
#pragma once

#include <cmath>
#include <cstddef>
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
  // lo x, y, z, then hi x, y, z (Eigen stores the two vectors back to back).
  const double* corners() const { return lo.data(); }
};
static_assert(sizeof(Vec3) == 3 * sizeof(double) && offsetof(Bounds, hi) == sizeof(Vec3));

// The parameter interval [lower, upper] over which a ray may be inside a box, widened so that it
// contains the exact interval (robust slab test). Per axis t = (bound − o)·(1/d) rounds three
// times (difference, reciprocal, product): the computed t lies within γ(3)·|t| of the exact one
// (Higham §3.1; pbrt-v4 widens tMax by 1 + 2γ(3) for the same reason). Widening each end by
// 3γ(3)·|t| covers that and the rounding of the widening itself, and 2^-1070 covers a product
// that underflowed. The bound holds while no reciprocal or difference over- or underflows:
// SlabRay::exotic flags the rays where it might not (|d| components outside [2^-1000, 2^1000],
// |o| beyond 2^1000), and Bvh::traverse visits every primitive for them instead.
struct SlabRay {
  Vec3 origin, inverse;  // 1/d per axis: ±inf for a zero component (its sign from d's sign bit)
  // Per axis the index of the near and the far bound in Bounds::corners() (lo k, hi k + 3;
  // swapped where d_k is negative or −0).
  std::array<int, 3> near_index{}, far_index{};
  bool exotic = false;
  explicit SlabRay(const Ray& ray) : origin(ray.origin) {
    for (int k = 0; k < 3; ++k) {
      const double d = ray.direction[k];
      inverse[k] = 1 / d;
      near_index[k] = std::signbit(d) ? k + 3 : k;
      far_index[k] = std::signbit(d) ? k : k + 3;
      if (d != 0 && !(std::abs(d) >= 0x1p-1000 && std::abs(d) <= 0x1p1000)) exotic = true;
      if (!(std::abs(ray.origin[k]) <= 0x1p1000)) exotic = true;
    }
  }
  // Whether the widened interval meets [0, t_limit]; `entry` receives its lower end.
  //  - A zero component (infinite reciprocal) gives ±inf ends, so the slab constrains nothing or
  //    excludes everything, as it should; an origin exactly on that slab's plane gives 0·inf =
  //    NaN, which the comparisons below ignore (no constraint: the closed slab holds the ray).
  //  - The widening is applied once, to the max of the lower ends and the min of the upper ends:
  //    x ↦ x ∓ |x|·w is increasing for w < 1, so that equals widening every end first.
  bool meets(const Bounds& b, double t_limit, double& entry) const {
    constexpr double kWiden = 3 * gamma(3), kTiny = 0x1p-1070;
    double lower = -std::numeric_limits<double>::infinity(), upper = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 3; ++k) {
      const double t_near = (b.corners()[near_index[k]] - origin[k]) * inverse[k];
      const double t_far = (b.corners()[far_index[k]] - origin[k]) * inverse[k];
      lower = t_near > lower ? t_near : lower;
      upper = t_far < upper ? t_far : upper;
    }
    // An end at +inf (lower) or −inf (upper): the ray runs parallel to a slab it lies outside
    // of, and no widening makes that a hit (widening inf would give NaN).
    if (!(lower < std::numeric_limits<double>::infinity()) || !(upper > -std::numeric_limits<double>::infinity()))
      return false;
    lower = lower - std::abs(lower) * kWiden - kTiny;
    upper = upper + std::abs(upper) * kWiden + kTiny;
    entry = lower > 0 ? lower : 0;
    return entry <= upper && entry <= t_limit;
  }
};

class Bvh {
 public:
  struct Node {
    Bounds box;              // double: a float box rounded outward would grow by 2^17 at 2^40 (headroom)
    std::int32_t first = 0;  // leaf: first index into order(); inner: the second child (the first is next)
    std::int32_t count = 0;  // leaf: number of primitives (> 0); inner: 0
  };
  static constexpr int kLeafSize = 4;
  static constexpr int kBins = 16;

  Bvh() = default;
  // Builds over one box per primitive (binned SAH on the box centroids, ties broken by index).
  explicit Bvh(std::span<const Bounds> boxes);

  // Calls visit(i) for every position i of order() whose primitive's box the ray may meet for
  // 0 ≤ t ≤ t_limit, nearer boxes first (leaves hold consecutive positions, so callers keep
  // their primitives in this order). visit returns true to stop; it may lower t_limit as it goes
  // (boxes entered beyond t_limit are then skipped).
  template <class Visit>
  void traverse(const Ray& ray, double& t_limit, Visit&& visit) const {
    if (nodes_.empty()) return;
    const SlabRay slab(ray);
    if (slab.exotic) {  // outside the range where the widening is proved: visit everything
      for (std::int32_t i = 0; i < static_cast<std::int32_t>(order_.size()); ++i)
        if (visit(i)) return;
      return;
    }
    struct Pending {
      std::int32_t node;
      double entry;
    };
    Pending stack[128];
    int top = 0;
    double entry;
    if (!slab.meets(nodes_[0].box, t_limit, entry)) return;
    stack[top++] = {0, entry};
    while (top > 0) {
      const Pending p = stack[--top];
      if (p.entry > t_limit) continue;  // t_limit dropped since the push
      const Node& node = nodes_[p.node];
      if (node.count > 0) {
        for (std::int32_t i = node.first; i < node.first + node.count; ++i)
          if (visit(i)) return;
        continue;
      }
      const std::int32_t a = p.node + 1, b = node.first;
      double entry_a = 0, entry_b = 0;
      const bool hit_a = slab.meets(nodes_[a].box, t_limit, entry_a);
      const bool hit_b = slab.meets(nodes_[b].box, t_limit, entry_b);
      if (hit_a && hit_b) {  // the nearer one on top
        if (entry_a <= entry_b) {
          stack[top++] = {b, entry_b};
          stack[top++] = {a, entry_a};
        } else {
          stack[top++] = {a, entry_a};
          stack[top++] = {b, entry_b};
        }
      } else if (hit_a) {
        stack[top++] = {a, entry_a};
      } else if (hit_b) {
        stack[top++] = {b, entry_b};
      }
    }
  }

  std::span<const Node> nodes() const { return nodes_; }
  std::span<const std::int32_t> order() const { return order_; }

 private:
  std::vector<Node> nodes_;
  std::vector<std::int32_t> order_;
};

}  // namespace rayproof
