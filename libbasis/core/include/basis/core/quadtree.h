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
//   quad 1 + g * channels + c: the quadrants' averages of group g, channel c.
// Errors: quad n * channels + c bounds |texel - quadrant average| of group 0, channel c over
// every texel under each quadrant, whether the quadrant is a leaf or not.
struct QuadtreeShape {
  int resolution = 0;  // N of the grid the tree was projected from (2..512, a power of two)
  int channels = 1;    // 1 or 3
  int groups = 1;      // channel groups; group 0 decides where the tree is cut

  int stride() const { return 1 + groups * channels; }
  bool operator==(const QuadtreeShape&) const = default;
};

// Maximum depth of any tree: a node at level k covers a cell of side 2^-k, k < log2(512).
inline constexpr int kMaxTreeLevels = 9;

// A non-owning view of a quadtree: what convolution reads. Valid while its storage lives.
class QuadtreeView {
 public:
  QuadtreeView() = default;
  QuadtreeView(QuadtreeShape shape, std::span<const Quad> nodes, std::span<const Quad> errors)
      : shape_(shape), nodes_(nodes), errors_(errors) {}

  const QuadtreeShape& shape() const { return shape_; }
  int node_count() const { return int(nodes_.size() / shape_.stride()); }
  std::span<const Quad> nodes() const { return nodes_; }
  std::span<const Quad> errors() const { return errors_; }

  // Child link of quadrant q of node n: 0 for a leaf.
  std::int32_t child(int node, int quadrant) const;
  // Average of group g, channel c over quadrant q of node n.
  float value(int node, int group, int channel, int quadrant) const {
    return nodes_[std::size_t(node) * shape_.stride() + 1 + group * shape_.channels + channel]
        .lane[quadrant];
  }
  // Bound on |texel - value| for group 0, channel c over quadrant q of node n.
  float error(int node, int channel, int quadrant) const {
    return errors_[std::size_t(node) * shape_.channels + channel].lane[quadrant];
  }

 private:
  QuadtreeShape shape_;
  std::span<const Quad> nodes_;
  std::span<const Quad> errors_;
};

// An owning quadtree.
struct Quadtree {
  QuadtreeShape shape;
  std::vector<Quad> nodes;
  std::vector<Quad> errors;

  QuadtreeView view() const { return {shape, nodes, errors}; }
  int node_count() const { return int(nodes.size() / shape.stride()); }
};

// Where projection cuts the tree. A quadrant is refined while, for some channel c of group 0,
// its error bound exceeds the tolerance: tolerance * |mean_c| (relative, the default; mean_c is
// the channel's mean over the square) or tolerance itself (absolute). Stored error bounds are
// group 0's.
struct ProjectionOptions {
  enum class Mode { relative, absolute };
  double tolerance = 0.05;
  Mode mode = Mode::relative;
  int max_depth = 0;  // finest quadrant level, 1..log2(N); 0 means log2(N), the texels
  // Also refine where another channel group's bound exceeds group_tolerance_scale times group
  // 0's tolerance of the same channel (for groups that must stay accurate, such as the tilt
  // derivatives, whose contribution is scaled by a small tilt).
  bool cut_on_all_groups = false;
  double group_tolerance_scale = 10;
  // How the bound on |texel - average| is computed:
  //   exact: from the smallest and largest texel under each cell, max(hi - avg, avg - lo);
  //   paper: the paper's recursive bound max(child) - min(child) + max(child error), which
  //          grows by a child's range at every level (looser, so trees are larger).
  // Both bound every texel; the cut and the certified convolution bound use the chosen one.
  enum class Bound { exact, paper };
  Bound bound = Bound::exact;
  // Added to each channel's mean before a relative tolerance is applied: energy that belongs
  // to the function but lies outside the grid (a capture's directional lights).
  Color extra_mean{0, 0, 0};
};

// Builds and cuts quadtrees (section 2.2): bottom-up averages and error bounds (exact, or the
// paper's error = max(child average) - min(child average) + max(child error)), then a
// depth-first cut at the tolerance. Reuse one projector to avoid reallocating scratch.
class QuadtreeProjector {
 public:
  // Projects a grid of resolution 2..512 (power of two) with 1 or 3 channels and finite texels.
  // Throws std::invalid_argument otherwise.
  Quadtree project(const Grid& grid, const ProjectionOptions& options = {});
  // Same, writing into an existing tree so that its storage is reused.
  void project(const Grid& grid, const ProjectionOptions& options, Quadtree& out);

 private:
  struct PendingCell {
    int level, x, y;
    std::int32_t parent;  // node whose link to fill, -1 for the root
    int quadrant;
  };
  std::vector<float> values_;  // levels 0 .. log2(N)-1, planar per group and channel
  std::vector<float> errors_;  // the same levels, group 0 only
  std::vector<float*> value_planes_;
  std::vector<float*> error_planes_;
  std::vector<float*> extreme_planes_;  // exact bounds: smallest and largest texel per cell
  std::vector<PendingCell> pending_;
};

// Convenience wrapper around a temporary QuadtreeProjector.
Quadtree project(const Grid& grid, const ProjectionOptions& options = {});

// Absolute per-channel tolerances that options imply for a function with the given means.
std::vector<float> absolute_tolerances(const ProjectionOptions& options,
                                       std::span<const double> channel_means);

// The piecewise-constant function of the tree as a dense grid of its resolution, all groups.
Grid reconstruct(const QuadtreeView& tree);

// Value of group g, channel c at (u, v) in [0,1]^2: the average of the leaf cell holding it.
float evaluate(const QuadtreeView& tree, double u, double v, int group = 0, int channel = 0);

// The leaf quadrant holding (u, v) in [0,1]^2, for reading its values and error bounds.
struct LeafQuadrant {
  int node, quadrant;
};
LeafQuadrant find_leaf(const QuadtreeView& tree, double u, double v);

// Integral over [0,1]^2 of group g, channel c (equal to the mean of the source grid).
double integrate(const QuadtreeView& tree, int group = 0, int channel = 0);

// Node counts per level (index = level of the node, 0 = root) and the deepest level + 1.
std::vector<int> depth_histogram(const QuadtreeView& tree);

}  // namespace basis
