// Errors of a rendered image against a reference over the pixels that hit geometry.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "basis/io/image.h"

namespace basis {

struct ImageErrors {
  // Mean over covered pixels and RGB channels of (I - R)^2 / (R^2 + eps), eps = 0.01 m^2 with
  // m the reference's mean over those pixels and channels (relative MSE, scale-free).
  double relative_mse = 0;
  double rmse = 0;  // square root of the mean of (I - R)^2 over the same values
  // The 99th percentile over covered pixels of the pixel's relative error, the square root of
  // its channels' mean (I - R)^2 / (R^2 + eps): where an image fails locally.
  double p99_relative_error = 0;
  std::size_t pixels = 0;
};

// How many of the image's red, green and blue values are NaN or infinite (a reference must
// have none: its errors would be NaN).
std::size_t non_finite_rgb_values(const Image& image);

// Throws std::invalid_argument unless the images have one size, three channels or more and the
// mask one entry per pixel.
ImageErrors compare_images(const Image& image, const Image& reference,
                           std::span<const std::uint8_t> covered);

}  // namespace basis
