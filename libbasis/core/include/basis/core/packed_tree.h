// Packed quadtrees: the compact form in which tables and capture sets are stored, written to
// files and looked up. Values are half floats scaled by a power of two per tree, bounds are
// 8-bit codes rounded up so that they stay certified, and nodes lie breadth first with the
// children of a node consecutive, so that one link word replaces four child indices. In trees
// with exact texels (captures: a texel is its own average), the nodes whose quadrants are
// single texels hold their values alone: they have no children, and their bound is their
// values' rounding. RGB trees with exact texels (captures, radiance >= 0) hold every node's
// values as a shared-exponent word per quadrant (shared_exponent.h): 16 bytes where halves take
// 24, so a texel node of 16 bytes and a full node of 32 instead of 40.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "basis/core/half.h"
#include "basis/core/quadtree.h"
#include "basis/core/shared_exponent.h"

namespace basis {

// What the bounds of a packed tree bound, per quadrant and channel of each bounded group:
//   l2: the RMS deviation of the texels under the quadrant from its packed value;
//   linf: the largest deviation, |texel - packed value| for every texel under it.
// Both bound the RMS deviation; an l2 bound times sqrt(texels under the quadrant) bounds the
// largest deviation.
enum class BoundKind : std::uint8_t { l2 = 0, linf = 1 };

// How the nodes of a tree with exact texels hold their values:
//   halves: groups x channels x 4 quadrants of halves, as every other tree;
//   shared_exponent: one shared-exponent word per quadrant (RGB trees of one group, values >= 0).
enum class ValueEncoding : std::uint8_t { halves = 0, shared_exponent = 1 };

struct PackedShape {
  int resolution = 0;  // N of the grid the tree was projected from (2..512, a power of two)
  int channels = 1;    // 1 or 3
  int groups = 1;      // channel groups
  BoundKind bounds = BoundKind::l2;
  int bounded_groups = 1;  // groups 0 .. bounded_groups - 1 carry bounds (1..groups)
  // Whether texel nodes (at depth texel_depth(), their quadrants single texels) hold only their
  // values: texels are exact, up to their values' rounding.
  bool exact_texels = false;
  ValueEncoding value_encoding = ValueEncoding::halves;

  // 32-bit words per node: the link, the values (groups x channels x 4 quadrants of halves, or
  // 4 shared-exponent words) and the bound codes (bounded_groups x channels x 4 bytes).
  int words_per_node() const { return 1 + value_words() + bounded_groups * channels; }
  // 32-bit words of a node's values.
  int value_words() const { return shared_values() ? 4 : 2 * groups * channels; }
  // 32-bit words per texel node: its values alone with exact texels, a node's otherwise.
  int words_per_texel_node() const {
    if (!exact_texels) return words_per_node();
    return value_words();
  }
  // Whether nodes hold their values as shared-exponent words.
  bool shared_values() const {
    return exact_texels && value_encoding == ValueEncoding::shared_exponent;
  }
  // Depth of the nodes whose quadrants are single texels (the root's depth is 0).
  int texel_depth() const { return std::countr_zero(unsigned(resolution)) - 1; }
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

// Values and bounds that packing takes: below 2^125, so that a tree's value scale is at most
// 2^110 and its bound scale below 2^125, and whatever halves, shared-exponent words or bound codes
// a file holds decode to finite floats (readers refuse larger scales: kLargestValueScale,
// kLargestBoundScale). pack() throws std::overflow_error beyond.
inline constexpr double kPackedValueLimit = 0x1p125;
inline constexpr float kLargestValueScale = 0x1p110f, kLargestBoundScale = 0x1p125f;

// The value scale of halves for values up to `largest` in magnitude: the power of two that puts
// `largest` in the halves' top binade, at least the smallest normal float (so that values as
// small as subnormals get a scale that is not zero); 1 when every value is 0.
float half_value_scale(double largest);

// The smallest bound code whose value times bound_scale is at least `bound`, both as the float
// product and as the exact one (255 when none is): a bound rounded up to a code, so that it
// still holds however a reader scales it.
std::uint8_t bound_code_at_least(double bound, float bound_scale);

// How far a half-rounded value may lie from what it rounds, in units of its tree's value scale:
// half an ulp, 2^-11 of the value, or half the subnormal spacing. An exact texel's bound in
// halves; in shared-exponent words, half its word's step.
inline constexpr double kHalfRounding = 0x1p-11, kHalfSubnormalRounding = 0x1p-25;

// Where node n of a tree lies, in 32-bit words from its first node, when its nodes from
// texel_start on are texel nodes (breadth first, they come last).
inline std::size_t packed_node_offset(const PackedShape& shape, std::size_t texel_start,
                                      std::size_t n) {
  const std::size_t full = std::size_t(shape.words_per_node());
  if (n <= texel_start) return n * full;
  return texel_start * full + (n - texel_start) * std::size_t(shape.words_per_texel_node());
}

// A non-owning view of a packed tree. Node 0 is the root. Word 0 of a node is its link: the
// index of its first child shifted left by 4, or'ed with the mask of its refined quadrants (bit
// q for quadrant q); 0 for a node without children. The children of the refined quadrants
// follow one another in quadrant order, after every node of lower index's children. With
// exact texels, nodes from texel_start on are texel nodes, values alone (no link word).
class PackedTreeView {
 public:
  PackedTreeView() = default;
  // A tree of full nodes only (texel_start = their count).
  PackedTreeView(PackedShape shape, TreeScales scales, std::span<const std::uint32_t> words)
      : PackedTreeView(shape, scales, words, words.size() / std::size_t(shape.words_per_node())) {}
  // derived_rounding: see derived_rounding().
  PackedTreeView(PackedShape shape, TreeScales scales, std::span<const std::uint32_t> words,
                 std::size_t texel_start, float derived_rounding = 1)
      : shape_(shape),
        scales_(scales),
        words_(words),
        derived_rounding_(derived_rounding),
        texel_start_(int(texel_start)),
        node_count_(
            int(texel_start + (words.size() - packed_node_offset(shape, texel_start, texel_start)) /
                                  std::size_t(shape.words_per_texel_node()))) {}

  const PackedShape& shape() const { return shape_; }
  const TreeScales& scales() const { return scales_; }
  std::span<const std::uint32_t> words() const { return words_; }
  int node_count() const { return node_count_; }
  // Nodes [texel_start(), node_count()) are texel nodes of values alone.
  int texel_start() const { return texel_start_; }
  bool is_texel_node(int n) const { return n >= texel_start_; }
  // How far a derived value (refined_values.h: a node whose four quadrants are refined, in a
  // tree of shared-exponent values) may lie from its quadrant's mean, in units of half its
  // word's step: at least 1. Every other value lies within half its step.
  float derived_rounding() const { return derived_rounding_; }
  bool is_derived_node(int n) const { return shape_.shared_values() && (link(n) & 15u) == 15u; }
  const std::uint32_t* node(int n) const {
    return words_.data() + packed_node_offset(shape_, std::size_t(texel_start_), std::size_t(n));
  }
  // The node's values: after its link, or from its first word in a texel node (halves unless
  // the tree's values are shared-exponent words).
  const std::uint16_t* halves(int n) const {
    return reinterpret_cast<const std::uint16_t*>(node(n) + (is_texel_node(n) ? 0 : 1));
  }

  std::uint32_t link(int n) const { return is_texel_node(n) ? 0 : node(n)[0]; }
  // Child node of quadrant q of node n, 0 for a leaf quadrant.
  std::int32_t child(int n, int q) const {
    const std::uint32_t l = link(n);
    if (!(l >> q & 1)) return 0;
    return std::int32_t((l >> 4) + std::uint32_t(std::popcount(l & ((1u << q) - 1))));
  }
  // Value of group g, channel c over quadrant q of node n.
  float value(int n, int g, int c, int q) const {
    if (shape_.shared_values())
      return shared_exponent_channel(node(n)[(is_texel_node(n) ? 0 : 1) + q], c) *
             scales_.value_scale;
    return half_to_float(halves(n)[(g * shape_.channels + c) * 4 + q]) * scales_.value_scale;
  }
  // How far value(n, g, c, q) may lie from the mean of its quadrant's texels: half an ulp of
  // its half (plus half the subnormal spacing), or half its shared-exponent word's step (times
  // derived_rounding() for a derived node); times the value scale.
  double rounding(int n, int g, int c, int q) const {
    if (shape_.shared_values())
      return 0.5 * double(shared_exponent_step(node(n)[(is_texel_node(n) ? 0 : 1) + q])) *
             double(scales_.value_scale) * (is_derived_node(n) ? double(derived_rounding_) : 1.0);
    return kHalfRounding * std::abs(double(value(n, g, c, q))) +
           kHalfSubnormalRounding * double(scales_.value_scale);
  }
  // The magnitude whose product with the other tree's, times 2 kHalfRounding, bounds both
  // rounding terms of a convolution, |a| db + |b| da: |value| for halves, (|value| + rounding /
  // kHalfRounding) / 2 for a shared-exponent value (for two of them the product's cross terms
  // make up the difference, a value being at most 511 steps).
  double rounding_share(int n, int g, int c, int q) const {
    const double v = std::abs(double(value(n, g, c, q)));
    if (!shape_.shared_values()) return v;
    return (v + rounding(n, g, c, q) / kHalfRounding) / 2;
  }
  // A magnitude at least |value| and at least rounding / kHalfRounding: |value| for halves,
  // so that kHalfRounding times it bounds the rounding (the largest-deviation alternatives).
  double rounding_magnitude(int n, int g, int c, int q) const {
    const double v = std::abs(double(value(n, g, c, q)));
    if (!shape_.shared_values()) return v;
    return std::max(v, rounding(n, g, c, q) / kHalfRounding);
  }
  // Bound code and bound of group g (< bounded_groups), channel c over quadrant q of node n
  // (see BoundKind); without a group, group 0's. A texel node of exact texels has no codes: its
  // bound is its value's rounding.
  std::uint8_t bound_code(int n, int g, int c, int q) const {
    return reinterpret_cast<const std::uint8_t*>(
        node(n) + 1 + shape_.value_words())[(g * shape_.channels + c) * 4 + q];
  }
  std::uint8_t bound_code(int n, int c, int q) const { return bound_code(n, 0, c, q); }
  float bound(int n, int g, int c, int q) const {
    if (shape_.exact_texels && is_texel_node(n)) return float(rounding(n, g, c, q) * (1 + 0x1p-20));
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
  float derived_rounding_ = 1;
  int texel_start_ = 0, node_count_ = 0;
};

// An owning packed tree.
struct PackedTree {
  PackedShape shape;
  TreeScales scales;
  std::vector<std::uint32_t> words;
  std::size_t texel_start = 0;  // its first texel node (its node count when there are none)
  // PackedTreeView::derived_rounding (set by derive_refined_values).
  float derived_rounding = 1;

  PackedTreeView view() const { return {shape, scales, words, texel_start, derived_rounding}; }
  int node_count() const { return view().node_count(); }
};

// The packed form of a tree: nodes breadth first, values rounded to the nearest half after
// scaling, and bounds rounded up after adding what that rounding moved each value, so that
// they hold for the packed values: l2 from tree.deviations (tree.errors when there are none),
// linf from tree.errors. Bounds are kept for the first bounded_groups groups (at most the
// tree's bounded groups; std::invalid_argument otherwise).
PackedTree pack(const Quadtree& tree, BoundKind bounds = BoundKind::l2, int bounded_groups = 1);

// The packed form of a tree whose texels are exact (a capture's: every single-texel quadrant's
// bound is 0 in its source, std::invalid_argument otherwise): texel nodes hold values alone.
// An RGB tree of one group holds its values as shared-exponent words (they must then be >= 0,
// std::invalid_argument otherwise); other trees, or when asked, as halves.
PackedTree pack_exact_texels(const Quadtree& tree, BoundKind bounds = BoundKind::l2,
                             ValueEncoding encoding = ValueEncoding::shared_exponent);

}  // namespace basis
