// Dense grids of texel averages over the unit square [0,1]^2: the input of quadtree projection
// and the full-resolution reference for convolution.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

namespace basis {

// An N x N grid of texel averages with C channels (1 or 3) in G channel groups. Group 0 is the
// function; further groups (for example derivatives) ride along and are averaged alike.
// Texel (x, y) covers u in [x/N, (x+1)/N) and v in [y/N, (y+1)/N). Storage is planar.
struct Grid {
  int resolution = 0;
  int channels = 1;
  int groups = 1;
  std::vector<float> texels;

  Grid() = default;
  Grid(int resolution, int channels, int groups = 1);

  std::size_t plane_size() const { return std::size_t(resolution) * resolution; }
  std::span<float> plane(int group, int channel);
  std::span<const float> plane(int group, int channel) const;
  float& at(int group, int channel, int x, int y) {
    return texels[(std::size_t(group * channels + channel) * resolution + y) * resolution + x];
  }
  float at(int group, int channel, int x, int y) const {
    return texels[(std::size_t(group * channels + channel) * resolution + y) * resolution + x];
  }
  // Mean over the unit square of one channel: the integral of the function over [0,1]^2.
  double mean(int group, int channel) const;
};

// The grid averaged down to a coarser resolution that divides its own (box filter of texel
// averages, all groups). Throws std::invalid_argument otherwise.
Grid downsample(const Grid& grid, int resolution);

// The grid at a finer resolution that its own divides, each texel repeated over the texels it
// covers: the same piecewise-constant function (all groups). Throws std::invalid_argument
// otherwise.
Grid upsample(const Grid& grid, int resolution);

// The grid's groups combined into one: sum over g < weights.size() of weights[g] times group g
// (trailing zero weights ignored; std::invalid_argument when a nonzero weight has no group).
Grid combine_groups(const Grid& grid, std::span<const double> weights);

// True when no value is NaN or infinite.
bool all_finite(std::span<const float> values);

// True when n is a power of two in [2, 512], the resolutions a quadtree accepts.
bool is_valid_resolution(int n);

}  // namespace basis
