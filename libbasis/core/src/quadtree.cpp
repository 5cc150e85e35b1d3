#include "basis/core/quadtree.h"

#include <cstring>

namespace basis {

std::int32_t QuadtreeView::child(int node, int quadrant) const {
  std::int32_t links[4];
  std::memcpy(links, &nodes_[std::size_t(node) * shape_.stride()], sizeof links);
  return links[quadrant];
}

}  // namespace basis
