#include "basis/io/image.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace basis {

Image::Image(int width_, int height_, int channels_)
    : width(width_), height(height_), channels(channels_) {
  if (width < 0 || height < 0 || channels < 1) throw std::invalid_argument("bad image size");
  pixels.assign(std::size_t(width) * height * channels, 0.0f);
}

float tone_map(float value, float average, float key) {
  const float scaled = average > 0 ? std::max(0.0f, value) * key / average : 0.0f;
  const float mapped = scaled / (1 + scaled);
  return mapped <= 0.0031308f ? 12.92f * mapped : 1.055f * std::pow(mapped, 1 / 2.4f) - 0.055f;
}

}  // namespace basis
