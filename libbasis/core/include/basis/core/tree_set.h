// Collections of quadtrees that share one shape, stored back to back: the layout of BRDF
// tables and capture sets in memory and in .qt files (so loaded files convolve in place).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "basis/core/quadtree.h"

namespace basis {

// Where a tree's nodes sit in its set: nodes [first_node, first_node + node_count), with child
// links relative to first_node.
struct TreeExtent {
  std::uint32_t first_node = 0;
  std::uint32_t node_count = 0;
};

// A non-owning view of a tree set.
class TreeSetView {
 public:
  TreeSetView() = default;
  TreeSetView(QuadtreeShape shape, std::span<const TreeExtent> extents, std::span<const Quad> nodes,
              std::span<const Quad> errors)
      : shape_(shape), extents_(extents), nodes_(nodes), errors_(errors) {}

  const QuadtreeShape& shape() const { return shape_; }
  std::size_t size() const { return extents_.size(); }
  QuadtreeView tree(std::size_t i) const {
    const TreeExtent& e = extents_[i];
    return {shape_,
            nodes_.subspan(std::size_t(e.first_node) * shape_.stride(),
                           std::size_t(e.node_count) * shape_.stride()),
            errors_.subspan(std::size_t(e.first_node) * shape_.channels,
                            std::size_t(e.node_count) * shape_.channels)};
  }
  std::span<const TreeExtent> extents() const { return extents_; }
  std::span<const Quad> nodes() const { return nodes_; }
  std::span<const Quad> errors() const { return errors_; }
  std::size_t total_nodes() const { return nodes_.size() / shape_.stride(); }

 private:
  QuadtreeShape shape_;
  std::span<const TreeExtent> extents_;
  std::span<const Quad> nodes_;
  std::span<const Quad> errors_;
};

// An owning tree set; trees are appended in order.
class TreeSet {
 public:
  TreeSet() = default;
  explicit TreeSet(QuadtreeShape shape) : shape_(shape) {}

  // Appends a tree of the set's shape (throws std::invalid_argument otherwise).
  void append(const QuadtreeView& tree);
  std::size_t size() const { return extents_.size(); }
  const QuadtreeShape& shape() const { return shape_; }
  TreeSetView view() const { return {shape_, extents_, nodes_, errors_}; }
  QuadtreeView tree(std::size_t i) const { return view().tree(i); }

 private:
  QuadtreeShape shape_;
  std::vector<TreeExtent> extents_;
  std::vector<Quad> nodes_;
  std::vector<Quad> errors_;
};

}  // namespace basis
