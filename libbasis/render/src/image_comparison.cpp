#include "basis/render/image_comparison.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace basis {

std::size_t non_finite_rgb_values(const Image& image) {
  std::size_t count = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < std::min(3, image.channels); ++c)
        count += !std::isfinite(image.at(x, y, c));
  return count;
}

ImageErrors compare_images(const Image& image, const Image& reference,
                           std::span<const std::uint8_t> covered) {
  if (image.width != reference.width || image.height != reference.height)
    throw std::invalid_argument("the reference is " + std::to_string(reference.width) + " x " +
                                std::to_string(reference.height) + " pixels, the image " +
                                std::to_string(image.width) + " x " + std::to_string(image.height));
  if (image.channels < 3 || reference.channels < 3)
    throw std::invalid_argument("images to compare need three channels");
  if (covered.size() != std::size_t(image.width) * image.height)
    throw std::invalid_argument("the mask does not match the image");
  ImageErrors e;
  double mean = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      if (!covered[std::size_t(y) * image.width + x]) continue;
      ++e.pixels;
      for (int c = 0; c < 3; ++c)
        mean += reference.at(x, y, c);
    }
  if (e.pixels == 0) return e;
  mean /= 3.0 * double(e.pixels);
  // A black reference has no scale: eps then keeps black pixels' error at 0, not 0 / 0.
  const double eps = mean > 0 ? 0.01 * mean * mean : 1e-30;
  double relative = 0, squared = 0;
  std::vector<double> per_pixel;
  per_pixel.reserve(e.pixels);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      if (!covered[std::size_t(y) * image.width + x]) continue;
      double pixel = 0;
      for (int c = 0; c < 3; ++c) {
        const double r = reference.at(x, y, c), d = image.at(x, y, c) - r;
        pixel += d * d / (r * r + eps);
        squared += d * d;
      }
      relative += pixel;
      per_pixel.push_back(std::sqrt(pixel / 3));
    }
  const auto p99 = per_pixel.begin() + std::ptrdiff_t(per_pixel.size() * 99 / 100);
  std::nth_element(per_pixel.begin(), p99, per_pixel.end());
  e.p99_relative_error = *p99;
  e.relative_mse = relative / (3.0 * double(e.pixels));
  e.rmse = std::sqrt(squared / (3.0 * double(e.pixels)));
  return e;
}

}  // namespace basis
