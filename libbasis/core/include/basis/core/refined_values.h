// Values that a node's children determine. In a tree with shared-exponent values (a capture's),
// a node whose four quadrants are all refined has values and bounds that follow from its
// children's: each quadrant's value is the mean of what lies below it, rounded to a word, and
// its bound follows from the child's values and bounds. Such trees are made with those derived
// values, so files can leave them out (the node's link alone, format version 7) and readers
// restore exactly the tree that was written.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "basis/core/packed_tree.h"

namespace basis {

// Whether trees of this shape carry derived values: shared-exponent values (packed_tree.h).
inline bool has_derived_values(const PackedShape& shape) {
  return shape.shared_values();
}

// How a derived bound that the tree's bound scale cannot code is met: by doubling the scale
// (every code recoded, rounded up) until it can, or by refusing the tree.
enum class DerivedBoundRange { rescale, refuse };

// Sets the values and bound codes of every node whose four quadrants are refined, children
// before parents, to what its child over each quadrant determines (per channel, v_i the child's
// four values, s_i their bounds, e_i a bound on |M_i - v_i|, M_i the mean of quadrant i's
// texels):
//   value: the estimate of the mean, rounded to the nearest shared-exponent word (v). The
//     estimate is the mean of the children's estimates (a derived child's, unrounded; any other
//     value's, itself), so that roundings do not add up from level to level: its error is at
//     most the mean of the half steps of the stored values below it;
//   l2 bound: sqrt(mean of s_i^2 + d_i^2 + 2 |d_i| e_i), d_i = v_i - v, the RMS deviation of the
//     texels from v (the mean square splits over the children into their variances and the
//     squares of their means' offsets);
//   linf bound: largest s_i + |d_i|.
// e_i is half a texel's step for texels, and min(s_i, how far the value may lie from M_i) for
// other nodes: half its word's step for a stored value, the estimate's error plus its rounding
// for a derived one. Sets tree.derived_rounding to the largest of the latter over the derived
// values, in their half steps (at least 1). Does nothing to trees without derived values.
// Throws std::invalid_argument for a tree whose links do not lead to later nodes, whose values
// cannot be rounded to words, or, with `refuse`, whose derived bounds its scale cannot code.
void derive_refined_values(PackedTree& tree, DerivedBoundRange range = DerivedBoundRange::rescale);
// The same, with working memory reused from call to call (for sets of many trees).
void derive_refined_values(PackedTree& tree, DerivedBoundRange range, std::vector<double>& scratch);

// The words of a tree with derived values, those values left out: a node whose four quadrants
// are refined holds its link alone. The tree's derived values must be current (as
// derive_refined_values leaves them). Trees without derived values: their words.
std::vector<std::uint32_t> elide_refined_values(const PackedTreeView& tree);

// Reads a tree back from the start of `words` in that layout into `tree` (its storage reused),
// the derived values zero (to be restored by derive_refined_values once its links are checked);
// returns how many words it took. Throws std::invalid_argument when the words run out first.
std::size_t read_elided_tree(const PackedShape& shape, const TreeScales& scales,
                             std::span<const std::uint32_t> words, std::size_t node_count,
                             std::size_t texel_start, PackedTree& tree);

}  // namespace basis
