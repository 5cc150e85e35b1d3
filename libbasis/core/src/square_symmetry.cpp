#include "basis/core/square_symmetry.h"

#include <stdexcept>

namespace basis {

std::array<SquareSymmetry, 8> SquareSymmetry::all() {
  return {SquareSymmetry{{{{1, 0}, {0, 1}}}},   SquareSymmetry{{{{0, -1}, {1, 0}}}},
          SquareSymmetry{{{{-1, 0}, {0, -1}}}}, SquareSymmetry{{{{0, 1}, {-1, 0}}}},
          SquareSymmetry{{{{-1, 0}, {0, 1}}}},  SquareSymmetry{{{{1, 0}, {0, -1}}}},
          SquareSymmetry{{{{0, 1}, {1, 0}}}},   SquareSymmetry{{{{0, -1}, {-1, 0}}}}};
}

SquareSymmetry SquareSymmetry::inverse() const {
  return {{{{m[0][0], m[1][0]}, {m[0][1], m[1][1]}}}};
}

int SquareSymmetry::determinant() const {
  return m[0][0] * m[1][1] - m[0][1] * m[1][0];
}

Vec3 SquareSymmetry::apply(const Vec3& w) const {
  return {m[0][0] * w.x() + m[0][1] * w.y(), m[1][0] * w.x() + m[1][1] * w.y(), w.z()};
}

std::array<int, 2> SquareSymmetry::apply(int i, int j, int n) const {
  // Twice the offsets from the centre, to stay in integers for even n.
  const int di = 2 * i - (n - 1), dj = 2 * j - (n - 1);
  return {(m[0][0] * di + m[0][1] * dj + (n - 1)) / 2, (m[1][0] * di + m[1][1] * dj + (n - 1)) / 2};
}

Grid transform_grid(const Grid& grid, const SquareSymmetry& symmetry, GridVector vector) {
  if (vector.first_group >= 0 && vector.first_group + 1 >= grid.groups)
    throw std::invalid_argument("transform_grid: the vector's groups are not in the grid");
  const int n = grid.resolution;
  Grid out(n, grid.channels, grid.groups);
  for (int g = 0; g < grid.groups; ++g)
    for (int c = 0; c < grid.channels; ++c)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const auto [tx, ty] = symmetry.apply(x, y, n);
          out.at(g, c, tx, ty) = grid.at(g, c, x, y);
        }
  if (vector.first_group < 0) return out;
  const int sign = vector.axial ? symmetry.determinant() : 1;
  const auto& m = symmetry.m;
  for (int c = 0; c < grid.channels; ++c) {
    const std::span<float> a = out.plane(vector.first_group, c);
    const std::span<float> b = out.plane(vector.first_group + 1, c);
    for (std::size_t k = 0; k < a.size(); ++k) {
      const float va = a[k], vb = b[k];
      a[k] = float(sign * (m[0][0] * va + m[0][1] * vb));
      b[k] = float(sign * (m[1][0] * va + m[1][1] * vb));
    }
  }
  return out;
}

}  // namespace basis
