// A weighted sum of packed trees folded into one tree, so that many convolutions with the sum
// (a batch of table lookups at one outgoing direction, one per capture) each descend once, over
// the union of the trees' nodes, instead of once per tree.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "basis/core/convolution.h"
#include "basis/core/packed_tree.h"

namespace basis {

// One term of a sum: groups 0 .. groups - 1 of a packed tree, weighted.
struct WeightedTerm {
  PackedTreeView tree;
  std::array<float, 3> weights = {1, 0, 0};
  int groups = 1;
};

// The most terms a fold takes (a table lookup reads four entries at most).
inline constexpr std::size_t kMaxFoldedTerms = 4;

// sum_t sum_g weights[g] tree_t[g] as one packed tree (l2 bounds, two groups), with what a
// descent needs to certify a convolution with it nearly as tightly as the terms' own descents
// would (see convolve below):
//   group 0: the sum's values; its bounds, the live terms' RMS bounds, sum_t |w| s_t (a term is
//            live on a quadrant its own tree has, leaf or not);
//   group 1: values at least half of sum_t |w a_t| over every term (how far the terms' rounding
//            may move the sum's value); its bounds, the RMS bounds of the terms whose own tree
//            stops on the quadrant while the sum goes on.
// A term that stops on a quadrant holds its value below it, as its own descent would; its
// bound there is added once, against the other tree's quadrant (convolve below).
// Made only by fold(), and read-only after it: its tree and the decoded nodes the descents read
// in its place always agree (one moved from holds neither, and convolve() refuses it).
class FoldedTree {
 public:
  // The folded sum as a packed tree.
  const PackedTree& tree() const { return tree_; }
  // The subnormal rounding the terms' values carry, in units of the folded tree's value scale
  // (sum_t sum_g |w| value_scale_t / value_scale), plus the folded values' own and what the
  // fold's float products lost below the normal floats.
  float floor_weight() const { return floor_weight_; }
  // The nodes decoded once for the SSE4.1 and AVX2 descents, so that no pair decodes them again:
  // per node its link word, then four blocks of channels x 4 floats (channel-major, as bits):
  // its values, its shares (|value| + 2 x group 1's value: the magnitude its rounding scales
  // with), its bounds and the bounds of the terms that stop where the sum goes on, in the
  // packed tree's units (before its scales), exactly the floats those descents would decode from
  // tree(); descent_words(channels) words a node.
  std::span<const std::uint32_t> descent_nodes() const { return descent_nodes_; }

  // The blocks of a node of descent_nodes(), in order after its link.
  enum DescentBlock : int { values = 0, shares = 1, bounds = 2, stopping_bounds = 3 };
  // Where channel c of a block starts in a node of descent_nodes(), in words from its link,
  // for a tree of `channels` channels (its four quadrants' floats follow).
  static constexpr std::size_t descent_offset(int channels, DescentBlock block, int c) {
    return 1 + 4 * std::size_t(int(block) * channels + c);
  }
  // Words of a node of descent_nodes(): its link, then the four blocks.
  static constexpr std::size_t descent_words(int channels) {
    return 1 + 4 * 4 * std::size_t(channels);
  }

 private:
  friend FoldedTree fold(std::span<const WeightedTerm> terms);
  FoldedTree() = default;

  PackedTree tree_;
  float floor_weight_ = 1;
  std::vector<std::uint32_t> descent_nodes_;
};

// Whether the library was built to convolve folded trees (it needs SSE4.1 and F16C), whatever
// the flags of the program that calls it; convolve() below throws std::logic_error where not.
bool folding_available();

// Folds 1 to kMaxFoldedTerms terms of equal resolution, l2 bounds on every weighted group and
// no exact texels (table entries); std::invalid_argument otherwise, or for non-finite weights;
// std::logic_error in a build without folding_available(). Runs with gradual underflow, as the
// convolutions do (convolution.h).
FoldedTree fold(std::span<const WeightedTerm> terms);

// The integral over [0,1]^2 of the folded sum times group 0 of b and its bound, in one descent:
// the sum of the terms' convolutions (convolve_weighted) up to the rounding of the folded sum to
// halves. The bound charges each term's quadrant bounds where that term's own descent would:
// where the sum goes on but a term stops, it adds area * s_term * sb. It differs from the
// terms' summed bounds by the folded codes' rounding up (at most 1/8), the folded sum's own
// rounding (2^-11 |f b| a quadrant, which can make the rounding terms 1.5 times theirs), and,
// against linf bounds of b, by taking their alternative only where the sum stops.
// std::invalid_argument for a FoldedTree moved from.
Convolution convolve(const FoldedTree& a, const PackedTreeView& b,
                     const ConvolutionOptions& options = {});

}  // namespace basis
