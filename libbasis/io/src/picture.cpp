#include "basis/io/picture.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace basis {

namespace {

template <typename Tree>
Image draw(const Tree& tree, const PictureOptions& options) {
  const auto& shape = tree.shape();
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

  for_each_leaf(tree, [&](int node, int q, int level, int cell_x, int cell_y) {
    const double cell = std::ldexp(1.0, -level), qu = cell_x * cell, qv = cell_y * cell;
    const int x0 = int(std::lround(qu * size)), x1 = int(std::lround((qu + cell) * size));
    const int y0 = int(std::lround(qv * size)), y1 = int(std::lround((qv + cell) * size));
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
    if (!options.outline_cells || x1 - x0 < 3) return;
    for (int x = x0; x < x1; ++x)
      for (int c = 0; c < 3; ++c)
        image.at(x, y0, c) = image.at(x, y1 - 1, c) = 0.25f;
    for (int y = y0; y < y1; ++y)
      for (int c = 0; c < 3; ++c)
        image.at(x0, y, c) = image.at(x1 - 1, y, c) = 0.25f;
  });
  // Markers: rings two pixels wide of radius size / 40.
  const double radius = std::max(3.0, size / 40.0);
  for (const auto& m : options.markers) {
    const double cx = m[0] * size, cy = m[1] * size;
    for (int y = std::max(0, int(cy - radius - 2)); y < std::min(size, int(cy + radius + 3)); ++y)
      for (int x = std::max(0, int(cx - radius - 2)); x < std::min(size, int(cx + radius + 3));
           ++x) {
        const double d = std::hypot(x + 0.5 - cx, y + 0.5 - cy);
        if (std::abs(d - radius) > 1) continue;
        image.at(x, y, 0) = image.at(x, y, 1) = 1.0f;
        image.at(x, y, 2) = 0.1f;
      }
  }
  return image;
}

}  // namespace

Image draw_tree(const QuadtreeView& tree, const PictureOptions& options) {
  return draw(tree, options);
}

Image draw_tree(const PackedTreeView& tree, const PictureOptions& options) {
  return draw(tree, options);
}

Image draw_points_from_above(std::span<const Vec3> positions, std::span<const Rgb> values,
                             int size) {
  if (positions.size() != values.size()) throw std::invalid_argument("one value per point");
  if (size < 16 || size > 8192) throw std::invalid_argument("picture size must be 16..8192");
  Image image(size, size, 3);
  for (float& p : image.pixels)
    p = 0.05f;
  if (positions.empty()) return image;
  double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY}, mean = 0;
  for (std::size_t i = 0; i < positions.size(); ++i) {
    for (int k = 0; k < 2; ++k) {
      lo[k] = std::min(lo[k], positions[i][k]);
      hi[k] = std::max(hi[k], positions[i][k]);
    }
    mean += (values[i][0] + values[i][1] + values[i][2]) / 3 / double(positions.size());
  }
  const double span = std::max({hi[0] - lo[0], hi[1] - lo[1], 1e-9});
  const int margin = size / 32;
  const double scale = (size - 2 * margin) / span;
  // Disc radius: points cover about the picture's area between them.
  const int radius =
      std::clamp(int(0.6 * (size - 2 * margin) / std::sqrt(double(positions.size()))), 1, size / 8);
  std::vector<std::size_t> order(positions.size());
  for (std::size_t i = 0; i < order.size(); ++i)
    order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return positions[a][2] < positions[b][2]; });
  for (const std::size_t i : order) {
    const int cx = margin + int((positions[i][0] - lo[0]) * scale);
    const int cy = size - 1 - margin - int((positions[i][1] - lo[1]) * scale);
    float rgb[3];
    for (int c = 0; c < 3; ++c)
      rgb[c] = tone_map(values[i][c], float(mean));
    for (int y = std::max(0, cy - radius); y <= std::min(size - 1, cy + radius); ++y)
      for (int x = std::max(0, cx - radius); x <= std::min(size - 1, cx + radius); ++x)
        if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= radius * radius)
          for (int c = 0; c < 3; ++c)
            image.at(x, y, c) = rgb[c];
  }
  return image;
}

}  // namespace basis
