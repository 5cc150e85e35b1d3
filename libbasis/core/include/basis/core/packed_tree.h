// Packed quadtrees: the compact form in which tables and capture sets are stored, written to
// files and looked up. Values are half floats scaled by a power of two per tree, bounds are
// 8-bit codes rounded up so that they stay certified, and nodes lie breadth first with the
// children of a node consecutive, so that one link word replaces four child indices.
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <span>
#include <vector>

#include "basis/core/half.h"
#include "basis/core/quadtree.h"

namespace basis {

// What the bounds of a packed tree bound, per quadrant and channel of each bounded group:
//   l2: the RMS deviation of the texels under the quadrant from its packed value;
//   linf: the largest deviation, |texel - packed value| for every texel under it.
// Both bound the RMS deviation; an l2 bound times sqrt(texels under the quadrant) bounds the
// largest deviation.
enum class BoundKind : std::uint8_t { l2 = 0, linf = 1 };

struct PackedShape {
  int resolution = 0;  // N of the grid the tree was projected from (2..512, a power of two)
  int channels = 1;    // 1 or 3
  int groups = 1;      // channel groups
  BoundKind bounds = BoundKind::l2;
  int bounded_groups = 1;  // groups 0 .. bounded_groups - 1 carry bounds (1..groups)

  // 32-bit words per node: the link, the half-float values (groups x channels x 4 quadrants)
  // and the bound codes (bounded_groups x channels x 4 bytes).
  int words_per_node() const { return 1 + 2 * groups * channels + bounded_groups * channels; }
  bool operator==(const PackedShape&) const = default;
};

// A tree's scales: a value is its half times value_scale (a power of two), a bound its code's
// value times bound_scale.
struct TreeScales {
  float value_scale = 1;
  float bound_scale = 1;
  bool operator==(const TreeScales&) const = default;
};

// The value of bound code c relative to bound_scale: an unsigned float with 5 exponent and 3
// mantissa bits, 2^((c >> 3) - 31) (1 + (c & 7) / 8), from 2^-31 to 1.875. Its float bits are
// (c << 20) + kBoundCodeBias.
inline constexpr std::uint32_t kBoundCodeBias = std::uint32_t(127 - 31) << 23;
inline float bound_code_value(std::uint8_t c) {
  return std::bit_cast<float>((std::uint32_t(c) << 20) + kBoundCodeBias);
}

// A non-owning view of a packed tree. Node 0 is the root. Word 0 of a node is its link: the
// index of its first child shifted left by 4, or'ed with the mask of its refined quadrants (bit
// q for quadrant q); 0 for a node without children. The children of the refined quadrants
// follow one another in quadrant order, after every node of lower index's children.
class PackedTreeView {
 public:
  PackedTreeView() = default;
  PackedTreeView(PackedShape shape, TreeScales scales, std::span<const std::uint32_t> words)
      : shape_(shape), scales_(scales), words_(words) {}

  const PackedShape& shape() const { return shape_; }
  const TreeScales& scales() const { return scales_; }
  std::span<const std::uint32_t> words() const { return words_; }
  int node_count() const { return int(words_.size() / shape_.words_per_node()); }
  const std::uint32_t* node(int n) const {
    return words_.data() + std::size_t(n) * shape_.words_per_node();
  }

  std::uint32_t link(int n) const { return node(n)[0]; }
  // Child node of quadrant q of node n, 0 for a leaf quadrant.
  std::int32_t child(int n, int q) const {
    const std::uint32_t l = link(n);
    if (!(l >> q & 1)) return 0;
    return std::int32_t((l >> 4) + std::uint32_t(std::popcount(l & ((1u << q) - 1))));
  }
  // Value of group g, channel c over quadrant q of node n.
  float value(int n, int g, int c, int q) const {
    return half_to_float(reinterpret_cast<const std::uint16_t*>(
               node(n) + 1)[(g * shape_.channels + c) * 4 + q]) *
           scales_.value_scale;
  }
  // Bound code and bound of group g (< bounded_groups), channel c over quadrant q of node n
  // (see BoundKind); without a group, group 0's.
  std::uint8_t bound_code(int n, int g, int c, int q) const {
    return reinterpret_cast<const std::uint8_t*>(
        node(n) + 1 + 2 * shape_.groups * shape_.channels)[(g * shape_.channels + c) * 4 + q];
  }
  std::uint8_t bound_code(int n, int c, int q) const { return bound_code(n, 0, c, q); }
  float bound(int n, int g, int c, int q) const {
    return bound_code_value(bound_code(n, g, c, q)) * scales_.bound_scale;
  }
  float bound(int n, int c, int q) const { return bound(n, 0, c, q); }
  // Bound on |texel - value| for every texel of a quadrant at `level` (1 = a root quadrant),
  // group g (group 0 without one).
  float largest_deviation_bound(int n, int g, int c, int q, int level) const;
  float largest_deviation_bound(int n, int c, int q, int level) const {
    return largest_deviation_bound(n, 0, c, q, level);
  }

 private:
  PackedShape shape_;
  TreeScales scales_;
  std::span<const std::uint32_t> words_;
};

// An owning packed tree.
struct PackedTree {
  PackedShape shape;
  TreeScales scales;
  std::vector<std::uint32_t> words;

  PackedTreeView view() const { return {shape, scales, words}; }
  int node_count() const { return int(words.size() / shape.words_per_node()); }
};

// The packed form of a tree: nodes breadth first, values rounded to the nearest half after
// scaling, and bounds rounded up after adding what that rounding moved each value, so that
// they hold for the packed values: l2 from tree.deviations (tree.errors when there are none),
// linf from tree.errors. Bounds are kept for the first bounded_groups groups (at most the
// tree's bounded groups; std::invalid_argument otherwise).
PackedTree pack(const Quadtree& tree, BoundKind bounds = BoundKind::l2, int bounded_groups = 1);

}  // namespace basis
