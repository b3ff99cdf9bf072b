// A bounding volume hierarchy in double for scenes with meshes: binned SAH build, deterministic,
// and a conservative traversal — it never skips a box that the exact ray meets, so whatever the
// leaves' test (a variant, the exact oracle) decides is decided over every primitive that could
// matter.
#pragma once

#include <algorithm>
#include <bit>
#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <span>
#include <vector>

#include "rayproof/core/batch.h"
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

// Four doubles, and four lanes' yes/no (all bits set or clear), as GCC and Clang vector
// extensions: the four-box test is written once over them. In code built for the baseline
// (x86-64: SSE2) each operation is two instructions; inlined into a function built for AVX2
// (with_best_box_lanes) the same source becomes one instruction an operation.
using Double4 = double __attribute__((vector_size(32)));
using Mask4 = std::int64_t __attribute__((vector_size(32)));

// The one step the two builds write differently: a Mask4 into four bits. AVX2's MOVMSKPD needs
// its caller built for AVX2 (with_best_box_lanes); the baseline reads the lanes one by one.
struct BaselineLanes {
  static unsigned bits(const Mask4& m) {
    return static_cast<unsigned>((m[0] & 1) | (m[1] & 2) | (m[2] & 4) | (m[3] & 8));
  }
};
#if defined(__x86_64__) || defined(__i386__)
struct Avx2Lanes {
  [[gnu::target("avx2")]] static unsigned bits(const Mask4& m) {
    return static_cast<unsigned>(_mm256_movemask_pd(reinterpret_cast<__m256d>(m)));
  }
};
namespace bvh_detail {
// flatten: the whole body, traversal and leaf rules included, is inlined here and compiled for
// AVX2 (never FMA: no product is fused, so every result is the baseline's bit for bit).
template <class Body>
[[gnu::flatten, gnu::target("avx2")]] void run_with_avx2(Body& body) {
  body(Avx2Lanes{});
}
}  // namespace bvh_detail
#endif

// Calls body(lanes) once, with lanes the best this CPU runs (Avx2Lanes, or BaselineLanes), body
// compiled for it: pass `lanes` on to Bvh::traverse. Chosen per call from best_batch_isa(), which
// asks the CPU once per process.
template <class Body>
void with_best_box_lanes(Body&& body) {
#if defined(__x86_64__) || defined(__i386__)
  if (best_batch_isa() != BatchIsa::sse2) return bvh_detail::run_with_avx2(body);
#endif
  body(BaselineLanes{});
}

// The parameter interval over which a ray may be inside a box, widened so that it contains the
// exact interval [ℓ*, υ*] wherever that meets t ≥ 0 (robust slab test). Per axis
// t = (bound − o)·(1/d) rounds three times (difference, reciprocal, product), so the computed
// t lies within γ(3)·|t*| of the exact t* and has its sign (Higham §3.1; pbrt-v4 widens tMax by
// 1 + 2γ(3) for the same reason); max and min are exact and x ↦ x ± γ(3)|x| is increasing, so
// the computed ends ℓ, υ obey the same bound. The widening, proved here once (meets and meets4
// use the same constants):
//  - entry = max(fl(fl(ℓ·kShrink) − kTiny), 0) ≤ max(ℓ*, 0): for ℓ ≤ 0 it is 0; for ℓ > 0,
//    fl(ℓ·kShrink) ≤ ℓ*(1 + γ(3))(1 − 3γ(3))(1 + u) < ℓ*, and subtracting rounds down to at most
//    its operand.
//  - exit = fl(fl(υ·kGrow) + kTiny) ≥ υ* wherever υ* ≥ 0: υ ≥ υ*(1 − γ(3)) ≥ 0, so
//    fl(υ·kGrow) ≥ υ*(1 − γ(3))(1 + 3γ(3))(1 − u) > υ*. (Where υ* < 0 the box lies behind the
//    ray and any answer is conservative.)
//  - kTiny = 2^-1070 covers products that underflowed (absolute error ≤ 2^-1075 each).
//  - The constants themselves round to within u/2 of 1 ∓ 3γ(3); with γ(3) > 3u the margins
//    above stay positive (about 2γ(3) − 1.5u).
// So the exact interval meets [0, t_limit] only if entry ≤ exit and entry ≤ t_limit. A product
// by a constant replaces the earlier x ∓ |x|·w (one rounding and no absolute value on the path
// every box waits for). The bound holds while no reciprocal or difference over- or underflows:
// SlabRay::exotic flags the rays where it might not (|d| components outside [2^-1000, 2^1000],
// |o| beyond 2^1000), and Bvh::traverse visits every primitive for them instead.
// A margin m ≥ 0 grows every box by m on each side: per axis the near bound moves by −m along
// the ray and the far bound by +m, written as the origin moved the other way (near_origin,
// far_origin: (lo − m) − o = lo − (o + m)), so m = 0 is the plain test bit for bit and the proof
// above holds for the box grown by the margin the rounded origins give exactly.
struct SlabRay {
  Vec3 near_origin, far_origin, inverse;  // inverse: 1/d per axis, ±inf for a zero component (sign from d's sign bit)
  // Per axis the index of the near and the far bound in Bounds::corners() (lo k, hi k + 3;
  // swapped where d_k is negative or −0).
  std::array<int, 3> near_index{}, far_index{};
  bool exotic = false;
  explicit SlabRay(const Ray& ray, double margin = 0) : near_origin(ray.origin), far_origin(ray.origin) {
    for (int k = 0; k < 3; ++k) {
      const double d = ray.direction[k];
      inverse[k] = 1 / d;
      near_index[k] = std::signbit(d) ? k + 3 : k;
      far_index[k] = std::signbit(d) ? k : k + 3;
      near_origin[k] += std::signbit(d) ? -margin : margin;
      far_origin[k] -= std::signbit(d) ? -margin : margin;
      if (d != 0 && !(std::abs(d) >= 0x1p-1000 && std::abs(d) <= 0x1p1000)) exotic = true;
      if (!(std::abs(ray.origin[k]) <= 0x1p1000)) exotic = true;
    }
  }
  // Whether the widened interval meets [0, t_limit]; `entry` receives its lower end.
  //  - A zero component (infinite reciprocal) gives ±inf ends, so the slab constrains nothing or
  //    excludes everything, as it should; an origin exactly on that slab's plane gives 0·inf =
  //    NaN, which the comparisons below ignore (no constraint: the closed slab holds the ray).
  static constexpr double kShrink = 1 - 3 * gamma(3), kGrow = 1 + 3 * gamma(3), kTiny = 0x1p-1070;
  // The widened ends of the proof above (before entry's max with 0), for a double or four lanes.
  template <class T>
  [[gnu::always_inline]] static T widened_entry(T lower) {
    return lower * kShrink - kTiny;
  }
  template <class T>
  [[gnu::always_inline]] static T widened_exit(T upper) {
    return upper * kGrow + kTiny;
  }
  bool meets(const Bounds& b, double t_limit, double& entry) const {
    double lower = -std::numeric_limits<double>::infinity(), upper = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 3; ++k) {
      const double t_near = (b.corners()[near_index[k]] - near_origin[k]) * inverse[k];
      const double t_far = (b.corners()[far_index[k]] - far_origin[k]) * inverse[k];
      lower = t_near > lower ? t_near : lower;
      upper = t_far < upper ? t_far : upper;
    }
    // An end at +inf (lower) or −inf (upper): the ray runs parallel to a slab it lies outside
    // of, and no widening makes that a hit (widening inf would give NaN).
    if (!(lower < std::numeric_limits<double>::infinity()) || !(upper > -std::numeric_limits<double>::infinity()))
      return false;
    lower = widened_entry(lower);
    upper = widened_exit(upper);
    entry = lower > 0 ? lower : 0;
    return entry <= upper && entry <= t_limit;
  }
  // meets() for four boxes at once, given as corners[axis][lane] and corners[3 + axis][lane] (lo,
  // then hi): the same operations lane by lane, written once over Double4 (`a > b ? a : b` is
  // MAXPD's rule, so NaN and ties keep `lower` and `upper` as meets() does). Returns bit i for box
  // i, with entry[i]. A lane whose box is empty (lo +inf, hi −inf) never meets.
  template <class Lanes = BaselineLanes>
  unsigned meets4(const double (&corners)[6][4], double t_limit, double (&entry)[4], Lanes = {}) const {
    constexpr double inf = std::numeric_limits<double>::infinity();
    Double4 lower = Double4{} - inf, upper = Double4{} + inf;
    for (int k = 0; k < 3; ++k) {
      Double4 near_bound, far_bound;
      std::memcpy(&near_bound, corners[near_index[k]], sizeof(Double4));
      std::memcpy(&far_bound, corners[far_index[k]], sizeof(Double4));
      const Double4 t_near = (near_bound - near_origin[k]) * inverse[k];
      const Double4 t_far = (far_bound - far_origin[k]) * inverse[k];
      lower = t_near > lower ? t_near : lower;
      upper = t_far < upper ? t_far : upper;
    }
    const Mask4 bounded = (lower < inf) & (upper > -inf);
    const Double4 lo = widened_entry(lower), hi = widened_exit(upper);
    const Double4 zero{}, at = lo > zero ? lo : zero;
    std::memcpy(entry, &at, sizeof(Double4));
    return Lanes::bits(bounded & (at <= hi) & (at <= t_limit));
  }
};

// A reach (Bvh::traverse) at which every primitive is visited.
constexpr double kEveryPrimitive = std::numeric_limits<double>::infinity();

class Bvh {
 public:
  struct Node {
    Bounds box;              // double: a float box rounded outward would grow by 2^17 at 2^40 (headroom)
    std::int32_t first = 0;  // leaf: first index into order(); inner: the second child (the first is next)
    std::int32_t count = 0;  // leaf: number of primitives (> 0); inner: 0
  };
  static constexpr int kLeafSize = 2;
  static constexpr int kMaxDepth = 100;  // past this depth a node becomes a leaf, so traversal's fixed stack holds
  static constexpr int kBins = 32;

  Bvh() = default;
  // Builds over one box per primitive (binned SAH on the box centroids, ties broken by index).
  explicit Bvh(std::span<const Bounds> boxes);

  // Calls visit(i) for every position i of order() whose primitive's box the ray may meet for
  // 0 ≤ t ≤ t_limit, nearer boxes first (leaves hold consecutive positions, so callers keep
  // their primitives in this order). visit returns true to stop; it may lower t_limit as it goes
  // (boxes entered beyond t_limit are then skipped).
  // `lanes`: the four-box test's instructions (with_best_box_lanes). `reach` ≥ 0: every box grown
  // on each side by reach · M, M the largest magnitude among the boxes' and the origin's
  // coordinates (SlabRay's margin), for leaves whose test may find contacts off the exact ray
  // (scene_rays.h's leaf_reach says how far); kEveryPrimitive visits every primitive.
  template <class Visit, class Lanes = BaselineLanes>
  void traverse(const Ray& ray, double& t_limit, Visit&& visit, Lanes lanes = {}, double reach = 0) const {
    if (wide_.empty()) return;
    const double margin = reach == 0 ? 0 : reach * std::max(magnitude_, ray.origin.cwiseAbs().maxCoeff());
    const SlabRay slab(ray, margin);
    // Outside the range where the widening is proved, or boxes grown without end (kEveryPrimitive:
    // an infinite margin would meet an empty slot's box, ∞ − ∞; with M = 0 it is NaN): visit
    // everything.
    if (slab.exotic || !(margin < std::numeric_limits<double>::infinity())) {
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
        unsigned hits = slab.meets4(node.corners, t_limit, entry, lanes);
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
    alignas(32) double corners[6][4];
    std::int32_t child[4];
    std::int32_t count[4];
  };
  void collapse();

  std::vector<Node> nodes_;
  std::vector<std::int32_t> order_;
  std::vector<WideNode> wide_;
  double magnitude_ = 0;  // the largest |coordinate| of any box
};

}  // namespace rayproof
