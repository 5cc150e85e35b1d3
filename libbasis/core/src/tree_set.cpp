#include "basis/core/tree_set.h"

#include <stdexcept>

namespace basis {

void TreeSet::append(const PackedTreeView& tree) {
  if (!(tree.shape() == shape_))
    throw std::invalid_argument(
        "tree shape differs from the set's (resolution, channels, groups, bounds, exact texels)");
  if (words_.size() + tree.words().size() > UINT32_MAX)
    throw std::length_error("tree set exceeds 2^32 words");
  // Room first, so that a failure to allocate leaves the set as it was (an insertion at the end
  // that throws has no effect) and the extents and factors never fall out of step.
  auto room_for_one = [](auto& v) {
    if (v.size() == v.capacity()) v.reserve(2 * v.size() + 1);  // growing as push_back would
  };
  room_for_one(extents_);
  room_for_one(derived_roundings_);
  const std::size_t first_word = words_.size();
  words_.insert(words_.end(), tree.words().begin(), tree.words().end());
  extents_.push_back({std::uint32_t(first_word), std::uint32_t(tree.node_count()),
                      std::uint32_t(tree.texel_start()), tree.scales()});
  derived_roundings_.push_back(tree.derived_rounding());
  total_nodes_ += std::size_t(tree.node_count());
}

}  // namespace basis
