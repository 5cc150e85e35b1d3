// Collections of packed quadtrees that share one shape, stored back to back: the layout of BRDF
// tables and capture sets in memory and in .qt files (so loaded files convolve in place).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "basis/core/packed_tree.h"

namespace basis {

// Where a tree's nodes sit in its set, nodes [first_node, first_node + node_count) with child
// links relative to first_node, and its scales. 16 bytes, the layout of .qt files.
struct TreeExtent {
  std::uint32_t first_node = 0;
  std::uint32_t node_count = 0;
  TreeScales scales;
};

// A non-owning view of a tree set.
class TreeSetView {
 public:
  TreeSetView() = default;
  TreeSetView(PackedShape shape, std::span<const TreeExtent> extents,
              std::span<const std::uint32_t> words)
      : shape_(shape), extents_(extents), words_(words) {}

  const PackedShape& shape() const { return shape_; }
  std::size_t size() const { return extents_.size(); }
  PackedTreeView tree(std::size_t i) const {
    const TreeExtent& e = extents_[i];
    const std::size_t w = std::size_t(shape_.words_per_node());
    return {shape_, e.scales, words_.subspan(std::size_t(e.first_node) * w, e.node_count * w)};
  }
  // Trees [first, first + count) of the set, over the same nodes (whose total_nodes() and
  // bytes() still count all of them).
  TreeSetView slice(std::size_t first, std::size_t count) const {
    return {shape_, extents_.subspan(first, count), words_};
  }
  std::span<const TreeExtent> extents() const { return extents_; }
  std::span<const std::uint32_t> words() const { return words_; }
  std::size_t total_nodes() const { return words_.size() / std::size_t(shape_.words_per_node()); }
  std::size_t bytes() const { return words_.size_bytes() + extents_.size_bytes(); }

 private:
  PackedShape shape_;
  std::span<const TreeExtent> extents_;
  std::span<const std::uint32_t> words_;
};

// An owning tree set; trees are appended in order.
class TreeSet {
 public:
  TreeSet() = default;
  explicit TreeSet(PackedShape shape) : shape_(shape) {}

  // Appends a packed tree of the set's shape (throws std::invalid_argument otherwise).
  void append(const PackedTreeView& tree);
  std::size_t size() const { return extents_.size(); }
  const PackedShape& shape() const { return shape_; }
  TreeSetView view() const { return {shape_, extents_, words_}; }
  PackedTreeView tree(std::size_t i) const { return view().tree(i); }

 private:
  PackedShape shape_;
  std::vector<TreeExtent> extents_;
  std::vector<std::uint32_t> words_;
};

}  // namespace basis
