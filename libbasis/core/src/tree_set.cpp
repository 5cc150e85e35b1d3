#include "basis/core/tree_set.h"

#include <stdexcept>

namespace basis {

void TreeSet::append(const PackedTreeView& tree) {
  if (!(tree.shape() == shape_))
    throw std::invalid_argument(
        "tree shape differs from the set's (resolution, channels, groups, bounds)");
  const std::size_t first = words_.size() / std::size_t(shape_.words_per_node());
  if (first + std::size_t(tree.node_count()) > UINT32_MAX)
    throw std::length_error("tree set exceeds 2^32 nodes");
  extents_.push_back({std::uint32_t(first), std::uint32_t(tree.node_count()), tree.scales()});
  words_.insert(words_.end(), tree.words().begin(), tree.words().end());
}

}  // namespace basis
