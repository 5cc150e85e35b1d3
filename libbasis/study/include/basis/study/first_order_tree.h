// First-order quadtrees, a study of lookups that stop earlier: a grid over the unit square as a
// quadtree whose quadrants each hold the least-squares plane of the function over them (its
// mean and its two slopes) and the RMS of what the plane leaves out. The product of two such
// trees may stop on a pair of quadrants once the planes' product is certified close enough: the
// residuals are orthogonal to both planes, so the pair's error is at most area x residual_a x
// residual_b (Cauchy-Schwarz), and where the functions are smooth the residuals shrink with the
// square of the quadrant's side instead of with its side, as the deviations from the mean do.
// Built from full-resolution grids (refined wherever the function is not constant, or cut as
// projection cuts, a quadrant within a tolerance of its plane a leaf), whose bound is then
// against those grids; or from packed trees, whose bound then covers the data the trees were
// made from. In floats (320 bytes a block of four quadrants) or, for the side read from memory,
// in halves (128 bytes): it measures how many pairs planes save against means in one layout, not
// what a packed form in files would cost.
#pragma once

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "basis/core/convolution.h"
#include "basis/core/folded_tree.h"
#include "basis/core/grid.h"
#include "basis/core/packed_tree.h"

namespace basis {

// The four quadrants of one node, each channel of each quadrant in lane 3 q + c (quadrant q is
// u-half q & 1, v-half q >> 1). For a quadrant of area a, side h and centre (cu, cv), with
// psi_u = sqrt(12) (u - cu) / h (so that the integral of psi_u^2 over it is a):
//   mean = (1/a) integral f,  slope_u = (1/a) integral f psi_u,  slope_v likewise,
//   residual >= the RMS over the quadrant of f - (mean + slope_u psi_u + slope_v psi_v),
// the three coefficients rounded to nearest and the residual rounded up. child[q] is the block
// of quadrant q's own quadrants, or -1 where the function is constant on it, it is a texel, or
// (in a cut tree) it is a leaf.
struct alignas(64) FirstOrderBlock {
  // Sixteen lanes each, the last four zero, so that one vector holds them.
  std::array<float, 16> mean{}, slope_u{}, slope_v{}, residual{};
  std::array<std::int32_t, 4> child{-1, -1, -1, -1};
  std::int32_t child_block(int q) const { return child[std::size_t(q)]; }
};
static_assert(sizeof(FirstOrderBlock) == 320);

// What a tree built from packed trees adds to each block so that its bound covers their data
// (lanes as in FirstOrderBlock; D is the data minus the packed trees' piecewise-constant
// function, over the terms still live on the quadrant, those whose leaves lie inside it):
//   residual: at least the RMS over the quadrant of the data minus the plane (the block's
//           residual with D's added; the descent uses it in place of the block's);
//   rms, rounding_rms: at least the RMS of D and of the leaves' values' rounding (which moves
//           D's means over them off zero) over the quadrant;
//   moment, rounding: for any plane p over the quadrant, |integral of p D| <= area x (moment x
//           (|slope_u| + |slope_v|) + rounding x |mean|): the leaves' bounds times the plane's
//           variation across them, and their rounding;
//   charge: the bounds of the terms whose leaf is the quadrant while the tree goes on below it
//           (a sum of terms): a descent that goes on adds area x charge x the other side's RMS,
//           once, and treats those terms as their values below.
struct alignas(64) FirstOrderData {
  std::array<float, 16> residual{}, rms{}, rounding_rms{}, moment{}, rounding{}, charge{};
};
static_assert(sizeof(FirstOrderData) == 384);

// A first-order tree; block 0 holds the root's quadrants, the rest follow breadth first (a
// level's blocks next to each other, as in packed trees). data is empty for a tree built from a
// grid, and holds one FirstOrderData per block for a tree built from packed trees.
struct FirstOrderTree {
  int resolution = 0;
  std::vector<FirstOrderBlock> blocks;
  std::vector<FirstOrderData> data;
  int terms = 0;       // packed trees summed (0: built from a grid)
  bool slopes = true;  // false after without_slopes: means alone
};

// Group 0 of the grid (1 or 3 channels; one channel is repeated in the three lanes) as a
// first-order tree, refined down to its texels wherever it is not constant. Exact up to the
// coefficients' rounding to floats. std::invalid_argument unless the resolution is a power of
// two from 2, the channels 1 or 3, and every texel finite and within +-2^60.
FirstOrderTree first_order_tree(const Grid& grid);

// What a cut measures on a quadrant: the largest deviation of its texels from its plane, or
// from its mean.
enum class FirstOrderCut { planes, means };

// The grid's first-order tree cut as projection cuts a packed tree from its texels: a quadrant
// whose texels all lie within tolerances[c] of its plane (or mean), in every channel c, is a
// leaf, holding its plane and its residual (computed from the texels, so that the bound covers
// them). A tree cut on means convolves as means after without_slopes. std::invalid_argument for
// what first_order_tree(grid) refuses and for negative or non-finite tolerances.
FirstOrderTree first_order_tree(const Grid& grid, const std::array<double, 3>& tolerances,
                                FirstOrderCut cut);

// The weighted sum of packed trees' groups (the table entries a lookup at wo reads, weighted as
// it weights them; folded_tree.h) as a first-order tree of the sum's piecewise-constant function,
// whose convolutions' bounds also cover what the trees leave out of the data they were made
// from, as their RMS bounds and values' rounding say. 1 to kMaxFoldedTerms terms of one
// resolution, 1 or 3 channels, bounds for every weighted group and finite weights;
// std::invalid_argument otherwise.
FirstOrderTree first_order_tree(std::span<const WeightedTerm> terms);
// One packed tree's group 0 so (a capture's radiance).
FirstOrderTree first_order_tree(const PackedTreeView& tree);

// The integral over [0,1]^2 of a * b, per channel, by a simultaneous descent of two first-order
// trees of one resolution, and a certified bound on |value - the integral of the two source
// grids' product|. A pair of quadrants on which both trees go on stops once, in every channel,
// its bound is at most accuracy / 2 x (|its planes' product| + E), E the whole integral as the
// root's planes estimate it (the stops' bounds then add up to at most about accuracy times the
// value); accuracy 0 descends until one side is constant or a leaf, which for uncut trees built
// from grids is exact up to rounding. The
// bound is against what the trees were built from: the grids, for trees built from grids (what
// those leave out of the functions they stand for is not in it), or the packed trees' data,
// for trees built from packed trees (their data terms added: their data residuals' product in
// place of the residuals', the moments times the other side's absolute slopes and the
// roundings times its absolute mean, and the charges). std::invalid_argument for different
// resolutions, a negative or non-finite accuracy, or a tree of planes against one of means (the
// product would leave out the slopes' cross term).
struct FirstOrderConvolution {
  Convolution convolution;
  std::size_t pairs = 0;  // pairs of blocks descended (each four pairs of quadrants)
};
FirstOrderConvolution convolve_first_order(const FirstOrderTree& a, const FirstOrderTree& b,
                                           double accuracy);

// The same planes in 40 % of the memory, for the side read from memory at every lookup (a
// capture): four quadrants' coefficients as halves of coefficient / scale (rounded to nearest)
// and their residuals as halves rounded up, 128 bytes a block (two cache lines) against 320.
// Group g (mean, slope_u, slope_v, residual) holds lanes 0..11 at halves[12 g]; then four halves,
// quadrant by quadrant, hold the largest data moment of its channels and four more the largest
// data rounding (0 for a tree built from a grid), and the residuals include the data RMS. Each
// group loads as sixteen halves (the last four masked off). A block's children follow one
// another: the first one's index and a mask of the quadrants that have one.
struct alignas(64) CompactFirstOrderBlock {
  std::array<std::uint16_t, 56> halves{};
  std::int32_t first_child = -1;
  std::uint8_t children = 0;  // bit q: quadrant q has a child block
  std::int32_t child_block(int q) const {
    if (!(children >> q & 1)) return -1;
    return first_child + std::popcount(unsigned(children) & ((1u << q) - 1));
  }
};
static_assert(sizeof(CompactFirstOrderBlock) == 128);
struct CompactFirstOrderTree {
  int resolution = 0;
  float scale = 1;         // a power of two: every coefficient / scale is within the half range
  bool with_data = false;  // built from a packed tree: the blocks hold data moments
  bool slopes = true;      // false for a compact form of means alone
  std::vector<CompactFirstOrderBlock> blocks;
};
// The tree's blocks in halves, in the same order, with one scale for the tree.
// std::invalid_argument for a tree with charges (a sum of terms; the compact form is for one).
CompactFirstOrderTree compact(const FirstOrderTree& tree);

// convolve_first_order with b compact: the bound adds, per pair, the planes' product's change
// from b's rounding to halves (|a's coefficients| summed times b's largest rounding).
FirstOrderConvolution convolve_first_order(const FirstOrderTree& a, const CompactFirstOrderTree& b,
                                           double accuracy);

// The tree with the slopes dropped: each quadrant its mean alone and, as residual, its RMS
// deviation from the mean (rounded up), the zeroth-order bound of the packed trees; its data,
// if any, as it was. Convolved, it is the same descent and accuracy rule with means instead of
// planes.
FirstOrderTree without_slopes(const FirstOrderTree& tree);

}  // namespace basis
