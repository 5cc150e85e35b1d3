#include "basis/core/tree_set.h"

#include <stdexcept>
#include <utility>

namespace basis {

TreeSet::TreeSet(PackedShape shape, std::vector<TreeExtent> extents,
                 std::vector<std::uint32_t> words)
    : shape_(shape), extents_(std::move(extents)), words_(std::move(words)) {
  for (const TreeExtent& e : extents_)
    total_nodes_ += e.node_count;
  derived_roundings_.assign(extents_.size(), 1.0f);
}

void TreeSet::append(const PackedTreeView& tree) {
  if (!(tree.shape() == shape_))
    throw std::invalid_argument(
        "tree shape differs from the set's (resolution, channels, groups, bounds, exact texels)");
  if (words_.size() + tree.words().size() > UINT32_MAX)
    throw std::length_error("tree set exceeds 2^32 words");
  extents_.push_back({std::uint32_t(words_.size()), std::uint32_t(tree.node_count()),
                      std::uint32_t(tree.texel_start()), tree.scales()});
  words_.insert(words_.end(), tree.words().begin(), tree.words().end());
  derived_roundings_.push_back(tree.derived_rounding());
  total_nodes_ += std::size_t(tree.node_count());
}

}  // namespace basis
