// Float images in memory (interleaved channels, row 0 at the top), their conversion to and from
// grids of texels, and tone mapping for pictures. Files are read and written by image_file.h.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "basis/core/grid.h"

namespace basis {

struct Image {
  int width = 0;
  int height = 0;
  int channels = 3;
  std::vector<float> pixels;  // pixels[(y * width + x) * channels + c]

  Image() = default;
  Image(int width, int height, int channels);
  float& at(int x, int y, int c) { return pixels[(std::size_t(y) * width + x) * channels + c]; }
  float at(int x, int y, int c) const {
    return pixels[(std::size_t(y) * width + x) * channels + c];
  }
};

// The texels of a capture image as an RGB grid: texel (x, y) at column x, row y, a grey image
// standing for all three channels. Throws FileError naming `name` unless the image is square
// with a power-of-two side from 2 to 512 and every texel is finite and at least 0.
Grid image_to_grid(const Image& image, const std::string& name);

// Group 0 of a grid as an RGB image, texel (x, y) at column x, row y (a grey grid in all three
// channels): the layout image_to_grid reads.
Image grid_to_image(const Grid& grid);

// Maps a linear HDR value to a display value in [0,1]: a Reinhard curve x / (1 + x) of the
// value exposed by `key / average`, then the sRGB curve. `average` is usually the image's mean
// luminance; values at the average map to key / (1 + key) before the sRGB curve.
float tone_map(float value, float average, float key = 0.5f);

}  // namespace basis
