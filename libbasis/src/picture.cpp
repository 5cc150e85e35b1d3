#include "basis/picture.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace basis {

Image draw_tree(const QuadtreeView& tree, const PictureOptions& options) {
  const QuadtreeShape& shape = tree.shape();
  if (options.size < 2 || options.size > 8192)
    throw std::invalid_argument("picture size must be 2..8192 pixels");
  if (options.group < 0 || options.group >= shape.groups)
    throw std::invalid_argument("the tree has no channel group " + std::to_string(options.group));
  const int size = options.size;
  Image image(size, size, 3);
  const bool is_signed = options.group > 0;

  // Scale: the mean for functions, the largest magnitude for signed groups.
  double scale = 0;
  if (is_signed) {
    const Grid grid = reconstruct(tree);
    for (int c = 0; c < shape.channels; ++c)
      for (float v : grid.plane(options.group, c))
        scale = std::max(scale, double(std::abs(v)));
  } else {
    for (int c = 0; c < shape.channels; ++c)
      scale += integrate(tree, 0, c) / shape.channels;
  }

  auto paint = [&](auto&& self, int node, double u0, double v0, double cell) -> void {
    const double half = cell / 2;
    for (int q = 0; q < 4; ++q) {
      const double qu = u0 + (q & 1) * half, qv = v0 + (q >> 1) * half;
      if (const int child = tree.child(node, q)) {
        self(self, child, qu, qv, half);
        continue;
      }
      const int x0 = int(std::lround(qu * size)), x1 = int(std::lround((qu + half) * size));
      const int y0 = int(std::lround(qv * size)), y1 = int(std::lround((qv + half) * size));
      float rgb[3];
      for (int c = 0; c < 3; ++c) {
        const float v = tree.value(node, options.group, shape.channels == 1 ? 0 : c, q);
        rgb[c] = is_signed ? float(v / (scale > 0 ? scale : 1)) : tone_map(v, float(scale));
      }
      if (is_signed) {  // red positive, blue negative, by the mean over channels
        const float s = (rgb[0] + rgb[1] + rgb[2]) / 3;
        const float m = std::pow(std::min(1.0f, std::abs(s)), 0.5f);
        rgb[0] = s > 0 ? m : 0;
        rgb[1] = 0.1f * m;
        rgb[2] = s < 0 ? m : 0;
      }
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x)
          for (int c = 0; c < 3; ++c)
            image.at(x, y, c) = rgb[c];
      if (!options.outline_cells || x1 - x0 < 3) continue;
      for (int x = x0; x < x1; ++x)
        for (int c = 0; c < 3; ++c)
          image.at(x, y0, c) = image.at(x, y1 - 1, c) = 0.25f;
      for (int y = y0; y < y1; ++y)
        for (int c = 0; c < 3; ++c)
          image.at(x0, y, c) = image.at(x1 - 1, y, c) = 0.25f;
    }
  };
  paint(paint, 0, 0, 0, 1);
  return image;
}

}  // namespace basis
