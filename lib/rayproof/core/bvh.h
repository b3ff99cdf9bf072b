// A bounding volume hierarchy in double for scenes with meshes: binned SAH build, deterministic,
// and a conservative traversal — it never skips a box that the exact ray meets, so whatever the
// leaves' test (a variant, the exact oracle) decides is decided over every primitive that could
// matter.
#pragma once

#include <bit>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
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
  // meets() for four boxes at once, given as corners[axis][lane] and corners[3 + axis][lane] (lo,
  // then hi): the same operations lane by lane (SSE2, two lanes an instruction, where the target
  // has it: MAXPD and MINPD return their second operand on a NaN or a tie, as the comparisons of
  // meets() keep `lower` and `upper`). Returns bit i for box i, with entry[i]. A lane whose box is
  // empty (lo +inf, hi −inf) never meets.
  unsigned meets4(const double (&corners)[6][4], double t_limit, double (&entry)[4]) const {
    constexpr double kWiden = 3 * gamma(3), kTiny = 0x1p-1070, inf = std::numeric_limits<double>::infinity();
#if defined(__SSE2__)
    unsigned hits = 0;
    const __m128d sign = _mm_set1_pd(-0.0), widen = _mm_set1_pd(kWiden), tiny = _mm_set1_pd(kTiny);
    for (int half = 0; half < 4; half += 2) {
      __m128d lower = _mm_set1_pd(-inf), upper = _mm_set1_pd(inf);
      for (int k = 0; k < 3; ++k) {
        const __m128d o = _mm_set1_pd(origin[k]), inv = _mm_set1_pd(inverse[k]);
        const __m128d t_near = _mm_mul_pd(_mm_sub_pd(_mm_loadu_pd(corners[near_index[k]] + half), o), inv);
        const __m128d t_far = _mm_mul_pd(_mm_sub_pd(_mm_loadu_pd(corners[far_index[k]] + half), o), inv);
        lower = _mm_max_pd(t_near, lower);
        upper = _mm_min_pd(t_far, upper);
      }
      const __m128d bounded = _mm_and_pd(_mm_cmplt_pd(lower, _mm_set1_pd(inf)), _mm_cmpgt_pd(upper, _mm_set1_pd(-inf)));
      const __m128d lo = _mm_sub_pd(_mm_sub_pd(lower, _mm_mul_pd(_mm_andnot_pd(sign, lower), widen)), tiny);
      const __m128d hi = _mm_add_pd(_mm_add_pd(upper, _mm_mul_pd(_mm_andnot_pd(sign, upper), widen)), tiny);
      const __m128d at = _mm_max_pd(lo, _mm_setzero_pd());
      _mm_storeu_pd(entry + half, at);
      const __m128d met = _mm_and_pd(bounded, _mm_and_pd(_mm_cmple_pd(at, hi), _mm_cmple_pd(at, _mm_set1_pd(t_limit))));
      hits |= static_cast<unsigned>(_mm_movemask_pd(met)) << half;
    }
    return hits;
#else
    double lower[4] = {-inf, -inf, -inf, -inf}, upper[4] = {inf, inf, inf, inf};
    for (int k = 0; k < 3; ++k) {
      const double* near_bound = corners[near_index[k]];
      const double* far_bound = corners[far_index[k]];
      for (int i = 0; i < 4; ++i) {
        const double t_near = (near_bound[i] - origin[k]) * inverse[k];
        const double t_far = (far_bound[i] - origin[k]) * inverse[k];
        lower[i] = t_near > lower[i] ? t_near : lower[i];
        upper[i] = t_far < upper[i] ? t_far : upper[i];
      }
    }
    unsigned hits = 0;
    for (int i = 0; i < 4; ++i) {
      const bool bounded = lower[i] < inf && upper[i] > -inf;
      const double lo = lower[i] - std::abs(lower[i]) * kWiden - kTiny;
      const double hi = upper[i] + std::abs(upper[i]) * kWiden + kTiny;
      entry[i] = lo > 0 ? lo : 0;
      hits |= static_cast<unsigned>(bounded && entry[i] <= hi && entry[i] <= t_limit) << i;
    }
    return hits;
#endif
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
  static constexpr int kMaxDepth = 100;  // past this depth a node becomes a leaf, so traversal's fixed stack holds
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
    if (wide_.empty()) return;
    const SlabRay slab(ray);
    if (slab.exotic) {  // outside the range where the widening is proved: visit everything
      for (std::int32_t i = 0; i < static_cast<std::int32_t>(order_.size()); ++i)
        if (visit(i)) return;
      return;
    }
    // A pending entry is a wide node (count 0) or a leaf's run of positions, with the ray's
    // widened entry into its box; the nearest is popped first.
    struct Pending {
      std::int32_t first, count;
      double entry;
    };
    Pending stack[3 * kMaxDepth + 4];  // each wide level pops one and pushes at most three
    int top = 0;
    double root_entry;
    if (!slab.meets(nodes_[0].box, t_limit, root_entry)) return;
    // `at` is the entry being taken: the nearest child met goes on without a trip through the
    // stack, the others wait there, farthest deepest (on equal entries the lower slot first, as
    // the binary traversal took the first child).
    Pending at =
        nodes_[0].count > 0 ? Pending{nodes_[0].first, nodes_[0].count, root_entry} : Pending{0, 0, root_entry};
    for (;;) {
      if (at.count > 0) {
        for (std::int32_t i = at.first; i < at.first + at.count; ++i)
          if (visit(i)) return;
      } else {
        const WideNode& node = wide_[at.first];
        double entry[4];
        unsigned hits = slab.meets4(node.corners, t_limit, entry);
        if (hits != 0) {
          Pending met[4];  // farthest first
          int n = 0;
          for (; hits; hits &= hits - 1) {
            const int i = std::countr_zero(hits);
            const Pending c{node.child[i], node.count[i], entry[i]};
            int j = n++;
            for (; j > 0 && met[j - 1].entry <= c.entry; --j) met[j] = met[j - 1];
            met[j] = c;
          }
          for (int j = 0; j + 1 < n; ++j) stack[top++] = met[j];
          at = met[n - 1];
          continue;
        }
      }
      do {  // the next that may still matter (t_limit may have dropped since its push)
        if (top == 0) return;
        at = stack[--top];
      } while (at.entry > t_limit);
    }
  }

  std::span<const Node> nodes() const { return nodes_; }
  std::span<const std::int32_t> order() const { return order_; }

 private:
  // The binary tree collapsed to four children a node (madmann91/bvh v2 and Embree do the same:
  // one vector test of four boxes replaces three levels of two): corners[axis][slot] lo, then
  // corners[3 + axis][slot] hi; child[slot] a wide node (count 0) or a leaf's first position
  // (count > 0); an unused slot has an empty box.
  struct WideNode {
    double corners[6][4];
    std::int32_t child[4];
    std::int32_t count[4];
  };
  void collapse();

  std::vector<Node> nodes_;
  std::vector<std::int32_t> order_;
  std::vector<WideNode> wide_;
};

}  // namespace rayproof
