// The eight symmetries of the unit square (rotations by quarter turns and reflections about its
// axes and diagonals) and how they act on the hemisphere: the concentric and parabolic maps both
// commute with them, as (x, y, z) -> (A (x, y), z) with A a signed permutation matrix.
#pragma once

#include <array>

#include "basis/core/grid.h"
#include "basis/core/vector.h"

namespace basis {

struct SquareSymmetry {
  // A (x, y) = (m[0][0] x + m[0][1] y, m[1][0] x + m[1][1] y); entries are 0 or +-1.
  std::array<std::array<int, 2>, 2> m{{{1, 0}, {0, 1}}};

  // All eight, the identity first, then the other rotations, then the reflections.
  static std::array<SquareSymmetry, 8> all();
  SquareSymmetry inverse() const;  // the transpose
  int determinant() const;         // +1 for rotations, -1 for reflections
  bool is_identity() const { return m[0][0] == 1 && m[1][1] == 1; }
  // (A (x, y), z).
  Vec3 apply(const Vec3& w) const;
  // Index (i, j) of an n x n grid of points symmetric about its centre (texels, or a
  // parabolic grid of entries), moved to A ((i, j) - c) + c, c = ((n - 1) / 2, (n - 1) / 2).
  std::array<int, 2> apply(int i, int j, int n) const;
  bool operator==(const SquareSymmetry&) const = default;
};

// What the groups of a grid are, for transforming it: scalars, or a pair of groups that holds
// the two components of a vector in the square's frame (turned by A), or of an axial vector
// (a rotation vector in the tangent plane, turned by det(A) A).
struct GridVector {
  int first_group = -1;  // groups first_group and first_group + 1; -1 for none
  bool axial = false;
};

// The grid moved by the symmetry: texel A (x, y) of the result holds texel (x, y) of `grid`
// (the function g(w) = grid(A^-1 w) over the square), every group; the vector's pair of groups
// also turned.
Grid transform_grid(const Grid& grid, const SquareSymmetry& symmetry, GridVector vector = {});

}  // namespace basis
