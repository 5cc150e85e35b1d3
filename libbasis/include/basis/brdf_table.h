// BRDF tables (DESIGN section 5): an M x M parabolic grid over the outgoing direction, each
// entry a quadtree over the incoming direction in the cosine-weighted concentric map.
#pragma once

#include <string>

#include "basis/tree_set.h"

namespace basis {

// Entry (i, j) sits at parabolic coordinates s_i = -1 + 2 i / (M - 1), t_j = -1 + 2 j / (M - 1)
// and is tree j * M + i. Group 0 of each tree is f(wi, wo); when the trees hold three groups,
// groups 1 and 2 are the derivatives used for rotation compensation (see rotation.h).
struct BrdfTableView {
  int wo_resolution = 0;
  TreeSetView trees;

  QuadtreeView entry(int i, int j) const { return trees.tree(std::size_t(j) * wo_resolution + i); }
};

// An owning BRDF table with the description of what it tabulates.
struct BrdfTable {
  int wo_resolution = 0;
  TreeSet trees;
  std::string model;  // model name (lambert, phong, ..., merl)
  std::string spec;   // the JSON spec it was tabulated from

  BrdfTableView view() const { return {wo_resolution, trees.view()}; }
};

}  // namespace basis
