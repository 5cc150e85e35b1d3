// Collections of packed quadtrees that share one shape, stored back to back: the layout of BRDF
// tables and capture sets in memory and in .qt files (so loaded files convolve in place).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "basis/core/packed_tree.h"

namespace basis {

// Where a tree's nodes sit in its set: node_count nodes from word first_word on, with child
// links relative to its first node, its first texel node (node_count when it has none; see
// PackedTreeView), and its scales. 20 bytes, the layout of .qt files.
struct TreeExtent {
  std::uint32_t first_word = 0;
  std::uint32_t node_count = 0;
  std::uint32_t texel_start = 0;
  TreeScales scales;

  // The words it spans in a set of that shape.
  std::size_t word_count(const PackedShape& shape) const {
    return packed_node_offset(shape, texel_start, node_count);
  }
};

// A non-owning view of a tree set. Trees with derived values (refined_values.h) have their
// PackedTreeView::derived_rounding beside their extents (none: 1 for every tree).
class TreeSetView {
 public:
  TreeSetView() = default;
  TreeSetView(PackedShape shape, std::span<const TreeExtent> extents,
              std::span<const std::uint32_t> words, std::size_t total_nodes,
              std::span<const float> derived_roundings = {})
      : shape_(shape),
        extents_(extents),
        words_(words),
        derived_roundings_(derived_roundings),
        total_nodes_(total_nodes) {}
  // The set of those extents (their node counts summed).
  TreeSetView(PackedShape shape, std::span<const TreeExtent> extents,
              std::span<const std::uint32_t> words, std::span<const float> derived_roundings = {})
      : TreeSetView(shape, extents, words, 0, derived_roundings) {
    for (const TreeExtent& e : extents)
      total_nodes_ += e.node_count;
  }

  const PackedShape& shape() const { return shape_; }
  std::size_t size() const { return extents_.size(); }
  PackedTreeView tree(std::size_t i) const {
    const TreeExtent& e = extents_[i];
    return {shape_, e.scales, words_.subspan(e.first_word, e.word_count(shape_)), e.texel_start,
            derived_roundings_.empty() ? 1.0f : derived_roundings_[i]};
  }
  // Trees [first, first + count) of the set, over the same nodes (whose total_nodes() and
  // bytes() still count all of them).
  TreeSetView slice(std::size_t first, std::size_t count) const {
    return {
        shape_, extents_.subspan(first, count), words_, total_nodes_,
        derived_roundings_.empty() ? derived_roundings_ : derived_roundings_.subspan(first, count)};
  }
  std::span<const TreeExtent> extents() const { return extents_; }
  std::span<const std::uint32_t> words() const { return words_; }
  // Nodes of every tree (of the whole set, for a slice).
  std::size_t total_nodes() const { return total_nodes_; }
  std::size_t bytes() const { return words_.size_bytes() + extents_.size_bytes(); }

 private:
  PackedShape shape_;
  std::span<const TreeExtent> extents_;
  std::span<const std::uint32_t> words_;
  std::span<const float> derived_roundings_;
  std::size_t total_nodes_ = 0;
};

// An owning tree set; trees are appended in order.
class TreeSet {
 public:
  TreeSet() = default;
  explicit TreeSet(PackedShape shape) : shape_(shape) {}

  // Appends a packed tree of the set's shape (throws std::invalid_argument otherwise).
  void append(const PackedTreeView& tree);
  // Room for that many more trees and words, so that appending them allocates once.
  void reserve(std::size_t trees, std::size_t words) {
    extents_.reserve(extents_.size() + trees);
    derived_roundings_.reserve(derived_roundings_.size() + trees);
    words_.reserve(words_.size() + words);
  }
  std::size_t size() const { return extents_.size(); }
  const PackedShape& shape() const { return shape_; }
  TreeSetView view() const { return {shape_, extents_, words_, total_nodes_, derived_roundings_}; }
  PackedTreeView tree(std::size_t i) const { return view().tree(i); }

 private:
  PackedShape shape_;
  std::vector<TreeExtent> extents_;
  std::vector<std::uint32_t> words_;
  std::vector<float> derived_roundings_;  // one per tree
  std::size_t total_nodes_ = 0;
};

}  // namespace basis
