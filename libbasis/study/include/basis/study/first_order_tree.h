// First-order quadtrees, a study of lookups that stop earlier: a grid over the unit square as a
// quadtree whose quadrants each hold the least-squares plane of the function over them (its
// mean and its two slopes) and the RMS of what the plane leaves out. The product of two such
// trees may stop on a pair of quadrants once the planes' product is certified close enough: the
// residuals are orthogonal to both planes, so the pair's error is at most area x residual_a x
// residual_b (Cauchy-Schwarz), and where the functions are smooth the residuals shrink with the
// square of the quadrant's side instead of with its side, as the deviations from the mean do.
// Built from full-resolution grids, in floats (320 bytes a block of four quadrants) or, for the
// side read from memory, in halves (128 bytes): it measures how many pairs planes save against
// means in one layout, not what a packed form in files would cost.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "basis/core/convolution.h"
#include "basis/core/grid.h"

namespace basis {

// The four quadrants of one node, each channel of each quadrant in lane 3 q + c (quadrant q is
// u-half q & 1, v-half q >> 1). For a quadrant of area a, side h and centre (cu, cv), with
// psi_u = sqrt(12) (u - cu) / h (so that the integral of psi_u^2 over it is a):
//   mean = (1/a) integral f,  slope_u = (1/a) integral f psi_u,  slope_v likewise,
//   residual >= the RMS over the quadrant of f - (mean + slope_u psi_u + slope_v psi_v),
// the three coefficients rounded to nearest and the residual rounded up. child[q] is the block
// of quadrant q's own quadrants, or -1 where the function is constant on it (or it is a texel).
struct alignas(64) FirstOrderBlock {
  // Sixteen lanes each, the last four zero, so that one vector holds them.
  std::array<float, 16> mean{}, slope_u{}, slope_v{}, residual{};
  std::array<std::int32_t, 4> child{-1, -1, -1, -1};
};

// A grid's first-order tree; block 0 holds the root's quadrants, the rest follow breadth first
// (a level's blocks next to each other, as in packed trees).
struct FirstOrderTree {
  int resolution = 0;
  std::vector<FirstOrderBlock> blocks;
};

// Group 0 of the grid (1 or 3 channels; one channel is repeated in the three lanes) as a
// first-order tree, refined down to its texels wherever it is not constant. Exact up to the
// coefficients' rounding to floats. std::invalid_argument unless the resolution is a power of
// two from 2, the channels 1 or 3, and every texel finite and within +-2^60.
FirstOrderTree first_order_tree(const Grid& grid);

// The integral over [0,1]^2 of a * b, per channel, by a simultaneous descent of two first-order
// trees of one resolution, and a certified bound on |value - the integral of the two source
// grids' product|. A pair of quadrants on which both trees go on stops once, in every channel,
// its bound is at most accuracy / 2 x (|its planes' product| + E), E the whole integral as the
// root's planes estimate it (the stops' bounds then add up to at most about accuracy times the
// value); accuracy 0 descends until one side is constant, which is exact up to rounding. The
// bound is against the grids the trees were built from: what those grids leave out of the
// functions they stand for is not in it. std::invalid_argument for different resolutions or a
// negative or non-finite accuracy.
struct FirstOrderConvolution {
  Convolution convolution;
  std::size_t pairs = 0;  // pairs of blocks descended (each four pairs of quadrants)
};
FirstOrderConvolution convolve_first_order(const FirstOrderTree& a, const FirstOrderTree& b,
                                           double accuracy);

// The same planes in 40 % of the memory, for the side read from memory at every lookup (a
// capture): four quadrants' coefficients as halves of coefficient / scale (rounded to nearest)
// and their residuals as halves rounded up, 128 bytes a block (two cache lines) against 320.
// Group g (mean, slope_u, slope_v, residual) holds lanes 0..11 at halves[12 g]; four zero halves
// close the block, so that each group loads as sixteen halves (the last four masked off).
struct alignas(64) CompactFirstOrderBlock {
  std::array<std::uint16_t, 52> halves{};
  std::array<std::int32_t, 4> child{-1, -1, -1, -1};
};
struct CompactFirstOrderTree {
  int resolution = 0;
  float scale = 1;  // a power of two: every coefficient / scale is within the half range
  std::vector<CompactFirstOrderBlock> blocks;
};
// The tree's blocks in halves, in the same order, with one scale for the tree.
CompactFirstOrderTree compact(const FirstOrderTree& tree);

// convolve_first_order with b compact: the bound adds, per pair, the planes' product's change
// from b's rounding to halves (|a's coefficients| summed times b's largest rounding).
FirstOrderConvolution convolve_first_order(const FirstOrderTree& a, const CompactFirstOrderTree& b,
                                           double accuracy);

// The tree with the slopes dropped: each quadrant its mean alone and, as residual, its RMS
// deviation from the mean (rounded up), the zeroth-order bound of the packed trees. Convolved,
// it is the same descent and accuracy rule with means instead of planes.
FirstOrderTree without_slopes(const FirstOrderTree& tree);

}  // namespace basis
