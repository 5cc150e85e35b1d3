#include "basis/io/image.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "basis/core/file_error.h"

namespace basis {

Image::Image(int width_, int height_, int channels_)
    : width(width_), height(height_), channels(channels_) {
  if (width < 0 || height < 0 || channels < 1) throw std::invalid_argument("bad image size");
  pixels.assign(std::size_t(width) * height * channels, 0.0f);
}

Grid image_to_grid(const Image& image, const std::string& name) {
  if (image.width != image.height || !is_valid_resolution(image.width))
    throw FileError(name +
                    ": a capture image is square with a power-of-two side from 2 to 512, got " +
                    std::to_string(image.width) + " x " + std::to_string(image.height));
  Grid grid(image.width, 3);
  long long bad = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c) {
        const float v = image.at(x, y, image.channels >= 3 ? c : 0);
        bad += !(v >= 0 && v < INFINITY);
        grid.at(0, c, x, y) = v;
      }
  if (bad)
    throw FileError(name + ": " + std::to_string(bad) +
                    " texel values are NaN, infinite or negative");
  return grid;
}

Image grid_to_image(const Grid& grid) {
  Image image(grid.resolution, grid.resolution, 3);
  for (int y = 0; y < grid.resolution; ++y)
    for (int x = 0; x < grid.resolution; ++x)
      for (int c = 0; c < 3; ++c)
        image.at(x, y, c) = grid.at(0, std::min(c, grid.channels - 1), x, y);
  return image;
}

float tone_map(float value, float average, float key) {
  const float scaled = average > 0 ? std::max(0.0f, value) * key / average : 0.0f;
  const float mapped = scaled / (1 + scaled);
  return mapped <= 0.0031308f ? 12.92f * mapped : 1.055f * std::pow(mapped, 1 / 2.4f) - 0.055f;
}

}  // namespace basis
