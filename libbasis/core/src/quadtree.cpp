#include "basis/core/quadtree.h"

#include <cstring>

namespace basis {

std::int32_t QuadtreeView::child(int node, int quadrant) const {
  std::int32_t links[4];
  std::memcpy(links, &nodes_[std::size_t(node) * shape_.stride()], sizeof links);
  return links[quadrant];
}

Grid reconstruct(const QuadtreeView& tree) {
  const QuadtreeShape& s = tree.shape();
  Grid grid(s.resolution, s.channels, s.groups);
  for_each_leaf(tree, [&](int node, int q, int level, int x, int y) {
    const int size = s.resolution >> level, x0 = x * size, y0 = y * size;
    for (int g = 0; g < s.groups; ++g)
      for (int c = 0; c < s.channels; ++c) {
        const float v = tree.value(node, g, c, q);
        for (int ty = y0; ty < y0 + size; ++ty)
          for (int tx = x0; tx < x0 + size; ++tx)
            grid.at(g, c, tx, ty) = v;
      }
  });
  return grid;
}

LeafQuadrant find_leaf(const QuadtreeView& tree, double u, double v) {
  int node = 0;
  double u0 = 0, v0 = 0, size = 1;
  for (;;) {
    size /= 2;
    const int qx = u >= u0 + size, qy = v >= v0 + size;
    const int q = qx + 2 * qy;
    const int child = tree.child(node, q);
    if (!child) return {node, q};
    u0 += qx * size;
    v0 += qy * size;
    node = child;
  }
}

float evaluate(const QuadtreeView& tree, double u, double v, int group, int channel) {
  const LeafQuadrant leaf = find_leaf(tree, u, v);
  return tree.value(leaf.node, group, channel, leaf.quadrant);
}

double integrate(const QuadtreeView& tree, int group, int channel) {
  double sum = 0;
  for (int q = 0; q < 4; ++q)
    sum += tree.value(0, group, channel, q);
  return sum / 4;
}

std::vector<int> depth_histogram(const QuadtreeView& tree) {
  std::vector<int> histogram;
  auto visit = [&](auto&& self, int node, int level) -> void {
    if (int(histogram.size()) <= level) histogram.resize(level + 1, 0);
    ++histogram[level];
    for (int q = 0; q < 4; ++q)
      if (const int child = tree.child(node, q)) self(self, child, level + 1);
  };
  if (tree.node_count() > 0) visit(visit, 0, 0);
  return histogram;
}

}  // namespace basis
