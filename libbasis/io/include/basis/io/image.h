// Float images in memory (interleaved channels, row 0 at the top) and tone mapping for
// pictures. Reading and writing files is in image_io.h (the image library).
#pragma once

#include <cstddef>
#include <vector>

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

// Maps linear HDR values to display values in [0,1]: scales so that `white` maps to 1 on a
// Reinhard curve x / (1 + x) with exposure `key / average`, then applies the sRGB curve.
// `average` is usually the image's mean luminance.
float tone_map(float value, float average, float key = 0.5f);

}  // namespace basis
