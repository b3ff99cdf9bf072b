#include "rayproof/core/bvh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>

namespace rayproof {

namespace {

double half_area(const Bounds& b) {
  if (b.empty()) return 0;
  const Vec3 e = b.hi - b.lo;
  return e.x() * e.y() + e.y() * e.z() + e.z() * e.x();
}

// The bin of centroid coordinate c in the centroid box [lo, hi] along one axis. Halves first, so
// hi − lo cannot overflow when centroids sit at ±1e308; a NaN (an infinite box's centroid) goes
// to bin 0 and a ratio that rounds to 1 or beyond to the last bin, so the index is always valid.
// Binning and partition call this one function, so a box always lands on the same side.
int bin_of(double c, double lo, double hi) {
  const double ratio = (0.5 * c - 0.5 * lo) / (0.5 * hi - 0.5 * lo);
  if (!(ratio > 0)) return 0;
  if (!(ratio < 1)) return Bvh::kBins - 1;
  return std::min(Bvh::kBins - 1, static_cast<int>(ratio * Bvh::kBins));
}

constexpr int kMaxDepth = Bvh::kMaxDepth;

struct Builder {
  std::span<const Bounds> boxes;
  std::vector<Vec3> centroids;
  std::vector<std::int32_t>& order;
  std::vector<Bvh::Node>& nodes;

  // Builds the node for order[begin, end) at nodes[index].
  void build(std::int32_t index, std::int32_t begin, std::int32_t end, int depth) {
    Bounds box, centre_box;
    for (std::int32_t i = begin; i < end; ++i) {
      box.grow(boxes[order[i]]);
      centre_box.grow(centroids[order[i]]);
    }
    nodes[index].box = box;
    const std::int32_t n = end - begin;
    auto make_leaf = [&] {
      nodes[index].first = begin;
      nodes[index].count = n;
    };
    if (n <= Bvh::kLeafSize || depth >= kMaxDepth) return make_leaf();

    // Binned SAH (Wald 2007): kBins bins along each axis of the centroid box, the cheapest plane.
    int best_axis = -1, best_plane = 0;
    double best_cost = half_area(box) * n;  // the cost of not splitting, in the same units
    for (int axis = 0; axis < 3; ++axis) {
      const double lo = centre_box.lo[axis], hi = centre_box.hi[axis];
      if (!(hi > lo)) continue;
      std::array<Bounds, Bvh::kBins> bin_box;
      std::array<int, Bvh::kBins> bin_count{};
      for (std::int32_t i = begin; i < end; ++i) {
        const int b = bin_of(centroids[order[i]][axis], lo, hi);
        bin_box[b].grow(boxes[order[i]]);
        ++bin_count[b];
      }
      std::array<double, Bvh::kBins> right_cost{};
      Bounds acc;
      int count = 0;
      for (int b = Bvh::kBins - 1; b > 0; --b) {
        acc.grow(bin_box[b]);
        count += bin_count[b];
        right_cost[b] = half_area(acc) * count;
      }
      acc = Bounds{};
      count = 0;
      for (int b = 0; b < Bvh::kBins - 1; ++b) {
        acc.grow(bin_box[b]);
        count += bin_count[b];
        const double cost = 0.5 * half_area(box) + half_area(acc) * count + right_cost[b + 1];
        if (count > 0 && count < n && cost < best_cost) {
          best_cost = cost;
          best_axis = axis;
          best_plane = b + 1;
        }
      }
    }
    std::int32_t mid;
    if (best_axis >= 0) {
      const double lo = centre_box.lo[best_axis], hi = centre_box.hi[best_axis];
      auto left_of_plane = [&](std::int32_t p) { return bin_of(centroids[p][best_axis], lo, hi) < best_plane; };
      mid = static_cast<std::int32_t>(std::stable_partition(order.begin() + begin, order.begin() + end, left_of_plane) -
                                      order.begin());
    } else if (n > 4 * Bvh::kLeafSize) {
      // No plane pays (all centroids equal, or one huge box): split by index so leaves stay small.
      mid = begin + n / 2;
    } else {
      return make_leaf();
    }
    const std::int32_t left = static_cast<std::int32_t>(nodes.size());
    nodes.emplace_back();
    build(left, begin, mid, depth + 1);
    const std::int32_t right = static_cast<std::int32_t>(nodes.size());
    nodes.emplace_back();
    nodes[index].first = right;
    nodes[index].count = 0;
    build(right, mid, end, depth + 1);
  }
};

}  // namespace

Bvh::Bvh(std::span<const Bounds> boxes) {
  if (boxes.empty()) return;
  order_.resize(boxes.size());
  std::iota(order_.begin(), order_.end(), 0);
  std::vector<Vec3> centroids(boxes.size());
  for (size_t i = 0; i < boxes.size(); ++i) centroids[i] = 0.5 * boxes[i].lo + 0.5 * boxes[i].hi;
  nodes_.reserve(2 * boxes.size() / kLeafSize + 1);
  nodes_.emplace_back();
  Builder builder{boxes, std::move(centroids), order_, nodes_};
  builder.build(0, 0, static_cast<std::int32_t>(boxes.size()), 0);
  magnitude_ = std::max(nodes_[0].box.lo.cwiseAbs().maxCoeff(), nodes_[0].box.hi.cwiseAbs().maxCoeff());
  collapse();
}

void Bvh::collapse() {
  if (nodes_[0].count > 0) {  // a single leaf: no wide node is needed (traverse visits it directly)
    wide_.push_back({});
    return;
  }
  auto area = [](const Bounds& b) {
    const Vec3 e = b.hi - b.lo;
    return e.x() * e.y() + e.y() * e.z() + e.z() * e.x();
  };
  // Binary node b becomes wide node w: its children, then repeatedly the inner child of largest
  // surface area replaced by its two children, until four slots are used or all are leaves.
  std::vector<std::pair<std::int32_t, std::int32_t>> pending = {{0, 0}};  // (binary, wide)
  wide_.emplace_back();
  while (!pending.empty()) {
    const auto [b, w] = pending.back();
    pending.pop_back();
    std::vector<std::int32_t> slots = {b + 1, nodes_[b].first};
    while (slots.size() < 4) {
      int widest = -1;
      for (int i = 0; i < static_cast<int>(slots.size()); ++i)
        if (nodes_[slots[i]].count == 0 && (widest < 0 || area(nodes_[slots[i]].box) > area(nodes_[slots[widest]].box)))
          widest = i;
      if (widest < 0) break;
      const std::int32_t inner = slots[widest];
      slots[widest] = inner + 1;
      slots.insert(slots.begin() + widest + 1, nodes_[inner].first);
    }
    WideNode node;
    for (int i = 0; i < 4; ++i) {
      const Bounds box = i < static_cast<int>(slots.size()) ? nodes_[slots[i]].box : Bounds{};
      for (int k = 0; k < 3; ++k) node.corners[k][i] = box.lo[k], node.corners[3 + k][i] = box.hi[k];
      node.child[i] = 0, node.count[i] = -1;
      if (i >= static_cast<int>(slots.size())) continue;
      const Node& child = nodes_[slots[i]];
      if (child.count > 0) {
        node.child[i] = child.first, node.count[i] = child.count;
      } else {
        node.child[i] = static_cast<std::int32_t>(wide_.size()), node.count[i] = 0;
        wide_.emplace_back();
        pending.emplace_back(slots[i], node.child[i]);
      }
    }
    wide_[w] = node;
  }
}

}  // namespace rayproof
