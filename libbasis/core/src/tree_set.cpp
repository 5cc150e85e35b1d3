#include "basis/core/tree_set.h"

#include <stdexcept>

namespace basis {

void TreeSet::append(const QuadtreeView& tree) {
  if (!(tree.shape() == shape_))
    throw std::invalid_argument("tree shape differs from the set's (resolution, channels, groups)");
  const std::size_t first = nodes_.size() / shape_.stride();
  if (first + tree.node_count() > UINT32_MAX)
    throw std::length_error("tree set exceeds 2^32 nodes");
  extents_.push_back({std::uint32_t(first), std::uint32_t(tree.node_count())});
  nodes_.insert(nodes_.end(), tree.nodes().begin(), tree.nodes().end());
  errors_.insert(errors_.end(), tree.errors().begin(), tree.errors().end());
}

}  // namespace basis
