#include "basis/core/grid.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

namespace basis {

Grid::Grid(int resolution_, int channels_, int groups_)
    : resolution(resolution_), channels(channels_), groups(groups_) {
  if (resolution < 1 || channels < 1 || groups < 1)
    throw std::invalid_argument("grid: resolution, channels and groups must be positive");
  texels.assign(plane_size() * channels * groups, 0.0f);
}

std::span<float> Grid::plane(int group, int channel) {
  return {texels.data() + std::size_t(group * channels + channel) * plane_size(), plane_size()};
}

std::span<const float> Grid::plane(int group, int channel) const {
  return {texels.data() + std::size_t(group * channels + channel) * plane_size(), plane_size()};
}

double Grid::mean(int group, int channel) const {
  double sum = 0;
  for (float t : plane(group, channel))
    sum += t;
  return sum / double(plane_size());
}

Grid downsample(const Grid& grid, int resolution) {
  const int n = grid.resolution;
  if (resolution > n || n % resolution != 0) throw std::invalid_argument("cannot downsample");
  if (resolution == n) return grid;
  const int f = n / resolution;
  Grid out(resolution, grid.channels, grid.groups);
  for (int g = 0; g < grid.groups; ++g)
    for (int c = 0; c < grid.channels; ++c)
      for (int y = 0; y < resolution; ++y)
        for (int x = 0; x < resolution; ++x) {
          double sum = 0;
          for (int j = 0; j < f; ++j)
            for (int i = 0; i < f; ++i)
              sum += grid.at(g, c, x * f + i, y * f + j);
          out.at(g, c, x, y) = float(sum / (f * f));
        }
  return out;
}

Grid upsample(const Grid& grid, int resolution) {
  const int n = grid.resolution;
  if (resolution < n || resolution % n != 0) throw std::invalid_argument("cannot upsample");
  if (resolution == n) return grid;
  const int f = resolution / n;
  Grid out(resolution, grid.channels, grid.groups);
  for (int g = 0; g < grid.groups; ++g)
    for (int c = 0; c < grid.channels; ++c)
      for (int y = 0; y < resolution; ++y)
        for (int x = 0; x < resolution; ++x)
          out.at(g, c, x, y) = grid.at(g, c, x / f, y / f);
  return out;
}

Grid combine_groups(const Grid& grid, std::span<const double> weights) {
  std::size_t used = weights.size();
  while (used > 0 && weights[used - 1] == 0)
    --used;
  if (int(used) > grid.groups)
    throw std::invalid_argument("weights for " + std::to_string(used) + " groups of a grid of " +
                                std::to_string(grid.groups));
  Grid out(grid.resolution, grid.channels, 1);
  for (int c = 0; c < grid.channels; ++c) {
    const std::span<float> to = out.plane(0, c);
    for (std::size_t i = 0; i < to.size(); ++i) {
      double v = 0;
      for (std::size_t g = 0; g < used; ++g)
        v += weights[g] * grid.plane(int(g), c)[i];
      to[i] = float(v);
    }
  }
  return out;
}

bool all_finite(std::span<const float> values) {
  // A float is Inf or NaN exactly when its magnitude bits exceed those of FLT_MAX; an unsigned
  // max-reduction vectorises.
  std::uint32_t largest = 0;
  for (const float v : values) {
    std::uint32_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    largest = std::max(largest, bits & 0x7fffffffu);
  }
  return largest <= 0x7f7fffffu;
}

bool is_valid_resolution(int n) {
  return n >= 2 && n <= 512 && (n & (n - 1)) == 0;
}

}  // namespace basis
