// Pictures of quadtrees as in the paper's Figure 4: the reconstructed function over the unit
// square (u to the right, v downwards) with the cells of the tree outlined.
#pragma once

#include <span>

#include "basis/core/color.h"
#include "basis/core/packed_tree.h"
#include "basis/core/quadtree.h"
#include "basis/core/vector.h"
#include "basis/io/image.h"

namespace basis {

struct PictureOptions {
  int size = 512;             // pixels per side
  int group = 0;              // channel group to show
  bool outline_cells = true;  // draw the leaf cells' borders
  // Points (u, v) of the unit square to circle in yellow, such as a capture's directional
  // lights.
  std::span<const Vec2> markers;
};

// An RGB display image (values in [0,1]) of one tree: tone-mapped by the function's mean, a
// grey tree shown grey, signed groups (derivatives) shown blue for negative, red for positive.
Image draw_tree(const QuadtreeView& tree, const PictureOptions& options = {});
Image draw_tree(const PackedTreeView& tree, const PictureOptions& options = {});

// A view from above (orthographic, looking down the z axis, x to the right, y up) of points
// drawn as discs coloured by their values, tone-mapped by the values' mean, on a dark ground.
// The view fits the points' bounding box. Higher points are drawn over lower ones.
Image draw_points_from_above(std::span<const Vec3> positions, std::span<const Rgb> values,
                             int size);

}  // namespace basis
