#include "basis/core/dense.h"

#include <Eigen/Core>
#include <stdexcept>

namespace basis {

namespace {

int check_compatible(const Grid& a, const Grid& b) {
  if (a.resolution != b.resolution)
    throw std::invalid_argument("dense convolution needs grids of equal resolution");
  if (a.channels != b.channels && a.channels != 1 && b.channels != 1)
    throw std::invalid_argument("dense convolution needs equal channel counts or a grey grid");
  return std::max(a.channels, b.channels);
}

}  // namespace

Rgb dense_convolve_naive(const Grid& a, const Grid& b) {
  const int channels = check_compatible(a, b);
  const int n = a.resolution;
  double sum[3] = {};
  for (int c = 0; c < channels; ++c)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        sum[c] +=
            double(a.at(0, a.channels == 1 ? 0 : c, x, y)) * b.at(0, b.channels == 1 ? 0 : c, x, y);
  for (double& s : sum)
    s /= double(n) * n;
  return channels_to_rgb(sum, channels);
}

Rgb dense_convolve_simd(const Grid& a, const Grid& b) {
  const int channels = check_compatible(a, b);
  const auto size = Eigen::Index(a.plane_size());
  double sum[3] = {};
  for (int c = 0; c < channels; ++c) {
    const auto pa = a.plane(0, a.channels == 1 ? 0 : c);
    const auto pb = b.plane(0, b.channels == 1 ? 0 : c);
    Eigen::Map<const Eigen::VectorXf> va(pa.data(), size), vb(pb.data(), size);
    sum[c] = va.dot(vb) / float(size);
  }
  return channels_to_rgb(sum, channels);
}

}  // namespace basis
