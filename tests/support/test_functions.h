// Grids of test functions over the unit square for quadtree and convolution tests: random,
// smooth, steps (including along the square's diagonals) and a single bright spike.
#pragma once

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "basis/core/grid.h"

namespace basis::testing {

struct NamedGrid {
  std::string name;
  Grid grid;
};

// Fills every channel of group 0 with f(u, v, channel) sampled at texel centres.
template <typename F>
Grid sample_grid(int n, int channels, F f) {
  Grid g(n, channels);
  for (int c = 0; c < channels; ++c)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        g.at(0, c, x, y) = float(f((x + 0.5) / n, (y + 0.5) / n, c));
  return g;
}

inline Grid random_grid(int n, int channels, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0, 1);
  Grid g(n, channels);
  for (float& t : g.texels)
    t = unit(rng);
  return g;
}

// The functions every property test runs over, at resolution n.
inline std::vector<NamedGrid> test_functions(int n, int channels, unsigned seed) {
  std::vector<NamedGrid> out;
  out.push_back({"random", random_grid(n, channels, seed)});
  out.push_back({"smooth", sample_grid(n, channels, [](double u, double v, int c) {
                   return 1.5 + std::sin(6 * u + c) * std::cos(4 * v) +
                          20 * std::exp(-60 * ((u - 0.3) * (u - 0.3) + (v - 0.6) * (v - 0.6)));
                 })});
  out.push_back({"step", sample_grid(n, channels, [](double u, double v, int c) {
                   return (u > 0.37 ? 4.0 : 0.5) + (v < 0.81 ? 1.0 : 0.0) + c;
                 })});
  out.push_back({"diagonal_step", sample_grid(n, channels, [](double u, double v, int c) {
                   return u > v ? 3.0 + c : 0.25;
                 })});
  out.push_back({"antidiagonal_step", sample_grid(n, channels, [](double u, double v, int) {
                   return u + v > 1 ? 1.0 : 7.0;
                 })});
  Grid spike(n, channels);
  for (float& t : spike.texels)
    t = 0.5f;
  for (int c = 0; c < channels; ++c)
    spike.at(0, c, n / 3, n / 5) = 1e5f;
  out.push_back({"spike", std::move(spike)});
  return out;
}

// A three-group function: group 0 one of the test functions (non-negative), groups 1 and 2
// signed (a smooth wave and random noise), as table entries with derivatives hold them.
inline Grid three_groups(const Grid& base, unsigned seed) {
  Grid g(base.resolution, base.channels, 3);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> noise(-1, 1);
  const int n = base.resolution;
  for (int c = 0; c < base.channels; ++c)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        g.at(0, c, x, y) = base.at(0, c, x, y);
        g.at(1, c, x, y) = float(3 * std::sin(9.0 * x / n + c) * std::cos(5.0 * y / n));
        g.at(2, c, x, y) = noise(rng) * (x > n / 2 ? 4.0f : 0.5f);
      }
  return g;
}

// An RGB grid of n^2 texels whose roundings to shared-exponent words all go one way, so that
// means taken from rounded values drift from the texels' as far as they can. Values lie in
// [256, 512) (words of step 1). Each texel is a word plus 0.499 (it rounds down); each quadrant
// of 2 x 2 texels or more holds children of words k, k, k and k + 2 (k even), whose mean k + 0.5
// rounds down to k (ties go to even), at every level.
inline Grid one_way_rounding_grid(int n) {
  Grid g(n, 3);
  auto fill = [&](auto&& self, int x, int y, int size, int k) -> void {
    if (size == 1) {
      for (int c = 0; c < 3; ++c)
        g.at(0, c, x, y) = float(k + 20 * c) + 0.499f;
      return;
    }
    const int half = size / 2;
    for (int q = 0; q < 4; ++q)
      self(self, x + (q & 1) * half, y + (q >> 1) * half, half, q == 3 ? k + 2 : k);
  };
  for (int q = 0; q < 4; ++q)
    fill(fill, (q & 1) * n / 2, (q >> 1) * n / 2, n / 2, 300 + 20 * q);
  return g;
}

// A grey grid of n^2 texels that cancel: +10^6, 0.3, 0.3 and -10^6 in every 2 x 2 cell (mean
// 0.15), which float sums of the cells lose (10^6 + 0.3 rounds to 1000000.3125).
inline Grid cancelling_grid(int n) {
  Grid g(n, 1);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const int k = x % 2 + 2 * (y % 2);
      g.at(0, 0, x, y) = k == 0 ? 1e6f : k == 3 ? -1e6f : 0.3f;
    }
  return g;
}

}  // namespace basis::testing
