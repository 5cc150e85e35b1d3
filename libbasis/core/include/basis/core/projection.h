// Projection of a grid of texel averages into a quadtree (Vostryakov, section 2.2): bottom-up
// averages and error bounds of every cell, then a top-down cut where the bounds meet a tolerance.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "basis/core/color.h"
#include "basis/core/grid.h"
#include "basis/core/quadtree.h"

namespace basis {

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
  // derivatives, whose contribution is scaled by a small tilt). The tree then stores every
  // group's bounds (QuadtreeShape::bounded_groups), else group 0's.
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
  // Locally relative tolerance (relative mode, when positive): a quadrant is refined while its
  // bound exceeds tolerance x max(|its value|, local_floor x |mean|), so that dim parts of a
  // function (a lobe's tails) are as accurate relative to themselves as bright ones, down to
  // the floor.
  double local_floor = 0;
};

// Builds and cuts quadtrees: averages, the bounds the cut uses, and the RMS deviation of every
// quadrant (Quadtree::deviations). Reuse one projector to avoid reallocating its scratch.
class QuadtreeProjector {
 public:
  // Projects a grid of resolution 2..512 (power of two) with 1 or 3 channels, 1 to 3 groups
  // and finite texels. Throws std::invalid_argument for other grids, and std::overflow_error
  // when the texels' error bounds leave the float range (texels of both signs near 3.4e38, the
  // paper's bound of steps that add up past it); averages, summed in double, never do.
  Quadtree project(const Grid& grid, const ProjectionOptions& options = {});
  // Same, writing into an existing tree so that its storage is reused.
  void project(const Grid& grid, const ProjectionOptions& options, Quadtree& out);

 private:
  // Bottom-up: the averages of every cell of levels 0 .. log2(N) - 1 for every plane, and the
  // error bounds (with the smallest and largest texel under each cell, for exact bounds) of the
  // planes the cut looks at, rounded up so that they bound every texel's distance from the
  // stored average.
  void build_levels(const Grid& grid, const ProjectionOptions& options, int bounded);
  // The averages of every cell of levels 0 .. log2(N) - 1 for the planes without bounds (the
  // bounded ones get theirs from build_deviations): summed in double and rounded once to the
  // nearest float, within half a float's step of the texels' mean, plus the double sums'
  // rounding (at most 2^-48 of the largest texel under the cell).
  void build_means(const Grid& grid);
  // Top-down: emits nodes in depth-first pre-order, refining the quadrants whose bound exceeds
  // the plane's tolerance, down to max_depth.
  void cut(const Grid& grid, std::span<const float> tolerances, int max_depth, Quadtree& out);

  // Plane p of level k (side 2^k): averages (the grid's texels at level log2(N)), and for
  // bounded planes the error bounds.
  const float* values(const Grid& grid, int k, int p) const;
  float* scratch_values(int k, int p) { return value_planes_[std::size_t(k) * planes_ + p]; }
  float* errors(int k, int p) { return error_planes_[std::size_t(k) * bounded_ + p]; }
  // RMS deviation of the texels under each cell of level k from its stored average, bounded
  // plane p, rounded up (levels 0 .. log2(N) - 1).
  float* deviations(int k, int p) { return deviation_planes_[std::size_t(k) * bounded_ + p]; }
  // The bounded planes' averages (summed in double, each the nearest float to its texels' mean)
  // and their RMS deviations.
  void build_deviations(const Grid& grid);
  // Exact bounds: smallest (0) and largest (1) texel under each cell of level k, plane p.
  float* extremes(int k, int p, int which) {
    return extreme_planes_[2 * (std::size_t(k) * bounded_ + p) + which];
  }

  struct PendingCell {
    int level, x, y;
    std::int32_t parent;  // node whose link to fill, -1 for the root
    int quadrant;
  };
  int levels_ = 0, planes_ = 0, bounded_ = 0, channels_ = 0;
  std::vector<float> value_storage_;  // levels 0 .. log2(N)-1, planar per group and channel
  std::vector<float> error_storage_;  // the same levels, bounded planes; then the extremes
  std::vector<float*> value_planes_;
  std::vector<float*> error_planes_;
  std::vector<float*> extreme_planes_;
  std::vector<float> deviation_storage_;
  std::vector<float*> deviation_planes_;
  std::vector<double> moments_[4];  // means (and sums of squared deviations) of two levels
  std::vector<PendingCell> pending_;
  std::vector<float> local_tolerance_;  // per bounded plane, empty unless locally relative
};

// Convenience wrapper around a temporary QuadtreeProjector.
Quadtree project(const Grid& grid, const ProjectionOptions& options = {});

// Throws std::invalid_argument naming the option when the tolerance or its floor is not a finite
// number >= 0.
void check_projection_options(const ProjectionOptions& options);

// Absolute per-channel tolerances that options imply for a function with the given means
// (checked as check_projection_options checks them).
std::vector<float> absolute_tolerances(const ProjectionOptions& options,
                                       std::span<const double> channel_means);

}  // namespace basis
