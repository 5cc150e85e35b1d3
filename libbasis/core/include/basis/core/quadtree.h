// The hierarchical piecewise-constant basis (Vostryakov, section 2.2): a quadtree over the unit
// square whose nodes hold the averages of their four quadrants, cut where a bound is met.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "basis/core/color.h"
#include "basis/core/grid.h"

namespace basis {

// Four 32-bit lanes, one per quadrant, aligned for one SSE load. Quadrant q covers the half
// [q & 1 ? mid : lo, ...) in u and [q & 2 ? mid : lo, ...) in v of its node's cell.
struct alignas(16) Quad {
  float lane[4];
};

// Node layout, shared by memory and files so that a loaded file convolves in place.
// Node n occupies quads [n * stride, (n + 1) * stride), stride = 1 + groups * channels:
//   quad 0: the child links as int32 lanes; 0 marks a leaf quadrant, otherwise the index of the
//           child node, always greater than n (nodes are stored in depth-first pre-order);
//   quad 1 + g * channels + c: the quadrants' averages of group g, channel c (projection: each
//           the nearest float to its texels' mean, summed in double).
// Errors: quad (n * bounded_groups + g) * channels + c bounds |texel - quadrant average| of
// group g, channel c over every texel under each quadrant, whether the quadrant is a leaf or
// not, for the first bounded_groups groups.
struct QuadtreeShape {
  int resolution = 0;      // N of the grid the tree was projected from (2..512, a power of two)
  int channels = 1;        // 1 or 3
  int groups = 1;          // channel groups; group 0 decides where the tree is cut
  int bounded_groups = 1;  // groups with error bounds (1..groups), group 0 first

  int stride() const { return 1 + groups * channels; }
  // Quads of errors per node.
  int error_stride() const { return bounded_groups * channels; }
  bool operator==(const QuadtreeShape&) const = default;
};

// Maximum depth of any tree: a node at level k covers a cell of side 2^-k, k < log2(512).
inline constexpr int kMaxTreeLevels = 9;

// A non-owning view of a quadtree: what convolution reads. Valid while its storage lives.
class QuadtreeView {
 public:
  QuadtreeView() = default;
  // non_negative: whether every texel of group 0 is known to be >= 0 (Quadtree::non_negative).
  QuadtreeView(QuadtreeShape shape, std::span<const Quad> nodes, std::span<const Quad> errors,
               bool non_negative = false)
      : shape_(shape), nodes_(nodes), errors_(errors), non_negative_(non_negative) {}

  const QuadtreeShape& shape() const { return shape_; }
  int node_count() const { return int(nodes_.size() / shape_.stride()); }
  std::span<const Quad> nodes() const { return nodes_; }
  std::span<const Quad> errors() const { return errors_; }
  // Whether every texel of group 0 is known to be >= 0: only then is the mean of |texel| over a
  // quadrant its |value|, which convolution's largest-deviation bound takes (convolution.h).
  bool non_negative() const { return non_negative_; }

  // Child link of quadrant q of node n: 0 for a leaf.
  std::int32_t child(int node, int quadrant) const;
  // Average of group g, channel c over quadrant q of node n.
  float value(int node, int group, int channel, int quadrant) const {
    return nodes_[std::size_t(node) * shape_.stride() + 1 + group * shape_.channels + channel]
        .lane[quadrant];
  }
  // Bound on |texel - value| for group 0, channel c over quadrant q of node n.
  float error(int node, int channel, int quadrant) const {
    return error(node, 0, channel, quadrant);
  }
  // The same for bounded group g.
  float error(int node, int group, int channel, int quadrant) const {
    return errors_[std::size_t(node) * shape_.error_stride() + group * shape_.channels + channel]
        .lane[quadrant];
  }

 private:
  QuadtreeShape shape_;
  std::span<const Quad> nodes_;
  std::span<const Quad> errors_;
  bool non_negative_ = false;
};

// An owning quadtree. `deviations`, laid out like `errors`, holds for each quadrant the RMS
// deviation of each bounded group's texels from the quadrant's value, rounded up (a bound in the
// L2 sense, at most the error bound); projection fills it, and it may be empty for trees made
// otherwise.
struct Quadtree {
  QuadtreeShape shape;
  std::vector<Quad> nodes;
  std::vector<Quad> errors;
  std::vector<Quad> deviations;
  // Whether every texel of group 0 the tree was made from is >= 0 (projection sets it).
  bool non_negative = false;

  QuadtreeView view() const { return {shape, nodes, errors, non_negative}; }
  int node_count() const { return int(nodes.size() / shape.stride()); }
};

// Walks and queries for any view of a tree with child(), value() and shape(): QuadtreeView, or
// PackedTreeView (packed_tree.h).

// Calls visit(node, quadrant, level, x, y) for every leaf quadrant, depth first in pre-order:
// the quadrant is cell (x, y) of level `level`, [x, x + 1) x [y, y + 1) times 2^-level of the
// unit square.
template <typename Tree, typename Visit>
void for_each_leaf(const Tree& tree, Visit&& visit) {
  auto descend = [&](auto&& self, int node, int level, int x, int y) -> void {
    for (int q = 0; q < 4; ++q) {
      const int qx = 2 * x + (q & 1), qy = 2 * y + (q >> 1);
      if (const int child = tree.child(node, q))
        self(self, child, level + 1, qx, qy);
      else
        visit(node, q, level + 1, qx, qy);
    }
  };
  descend(descend, 0, 0, 0, 0);
}

// The piecewise-constant function of the tree as a dense grid of its resolution, all groups.
template <typename Tree>
Grid reconstruct(const Tree& tree) {
  const auto& s = tree.shape();
  Grid grid(s.resolution, s.channels, s.groups);
  for_each_leaf(tree, [&](int node, int q, int level, int x, int y) {
    const int size = s.resolution >> level, x0 = x * size, y0 = y * size;
    for (int g = 0; g < s.groups; ++g)
      for (int c = 0; c < s.channels; ++c) {
        const float v = tree.value(node, g, c, q);
        for (int ty = y0; ty < y0 + size; ++ty)
          for (int tx = x0; tx < x0 + size; ++tx)
            grid.at(g, c, tx, ty) = v;
      }
  });
  return grid;
}

// The leaf quadrant holding (u, v) in [0,1]^2, for reading its values and bounds; level 1 is a
// quadrant of the root. With `deepest_level`, the quadrant of that level holding (u, v) where
// the tree is refined below it (a texel of a grid of 2^deepest_level texels a side).
struct LeafQuadrant {
  int node, quadrant, level;
};
template <typename Tree>
LeafQuadrant find_leaf(const Tree& tree, double u, double v, int deepest_level = 1 << 30) {
  int node = 0;
  double u0 = 0, v0 = 0, size = 1;
  for (int level = 1;; ++level) {
    size /= 2;
    const int qx = u >= u0 + size, qy = v >= v0 + size;
    const int q = qx + 2 * qy;
    const int child = tree.child(node, q);
    if (!child || level >= deepest_level) return {node, q, level};
    u0 += qx * size;
    v0 += qy * size;
    node = child;
  }
}

// Value of group g, channel c at (u, v) in [0,1]^2: the average of the leaf cell holding it.
template <typename Tree>
float evaluate(const Tree& tree, double u, double v, int group = 0, int channel = 0) {
  const LeafQuadrant leaf = find_leaf(tree, u, v);
  return tree.value(leaf.node, group, channel, leaf.quadrant);
}

// Integral over [0,1]^2 of group g, channel c (equal to the mean of the source grid).
template <typename Tree>
double integrate(const Tree& tree, int group = 0, int channel = 0) {
  double sum = 0;
  for (int q = 0; q < 4; ++q)
    sum += tree.value(0, group, channel, q);
  return sum / 4;
}

// Node counts per level (index = level of the node, 0 = root) and the deepest level + 1.
template <typename Tree>
std::vector<int> depth_histogram(const Tree& tree) {
  std::vector<int> histogram;
  auto visit = [&](auto&& self, int node, int level) -> void {
    if (int(histogram.size()) <= level) histogram.resize(level + 1, 0);
    ++histogram[level];
    for (int q = 0; q < 4; ++q)
      if (const int child = tree.child(node, q)) self(self, child, level + 1);
  };
  if (tree.node_count() > 0) visit(visit, 0, 0);
  return histogram;
}

}  // namespace basis
