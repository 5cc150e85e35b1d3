// Texel averages of a function over the unit square by adaptive stratified supersampling, so
// that a feature narrower than a texel (a sharp lobe) is averaged, not point-sampled.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "basis/grid.h"

namespace basis {

struct SupersampleOptions {
  // A texel is done when two successive estimates (s and 2s samples per axis) of every group-0
  // channel differ by at most relative_tolerance * max(|estimate|, absolute_floor).
  double relative_tolerance = 1e-3;
  double absolute_floor = 1e-6;
  int max_samples_per_axis = 64;  // a power of two >= 2
};

// Fills every group and channel of `grid` with the average over each texel of
// f(u, v, out), where f writes groups * channels values (group-major) into out. The first
// estimate takes 2 x 2 midpoints and is kept if those samples agree to the tolerance; otherwise
// the samples per axis double until successive estimates agree or the maximum is reached.
// Deterministic. Returns the number of evaluations of f.
template <typename F>
long long average_over_texels(Grid& grid, const F& f, const SupersampleOptions& options,
                              int row_begin = 0, int row_end = -1) {
  const int n = grid.resolution;
  const int values = grid.channels * grid.groups;
  const int checked = grid.channels;  // group 0 decides convergence
  if (row_end < 0) row_end = n;
  std::vector<double> sample(values), sum(values), previous(values), lo(values), hi(values);
  long long evaluations = 0;
  auto estimate = [&](int x, int y, int s) {
    std::fill(sum.begin(), sum.end(), 0.0);
    std::fill(lo.begin(), lo.end(), INFINITY);
    std::fill(hi.begin(), hi.end(), -INFINITY);
    for (int j = 0; j < s; ++j)
      for (int i = 0; i < s; ++i) {
        f((x + (i + 0.5) / s) / n, (y + (j + 0.5) / s) / n, sample.data());
        for (int k = 0; k < values; ++k) {
          sum[k] += sample[k];
          lo[k] = std::min(lo[k], sample[k]);
          hi[k] = std::max(hi[k], sample[k]);
        }
      }
    evaluations += s * s;
    for (double& v : sum)
      v /= s * s;
  };
  auto tolerance = [&](double v) {
    return options.relative_tolerance * std::max(std::abs(v), options.absolute_floor);
  };
  for (int y = row_begin; y < row_end; ++y)
    for (int x = 0; x < n; ++x) {
      int s = 2;
      estimate(x, y, s);
      bool done = true;
      for (int k = 0; k < checked; ++k)
        done &= hi[k] - lo[k] <= tolerance(sum[k]);
      while (!done && s < options.max_samples_per_axis) {
        previous = sum;
        s *= 2;
        estimate(x, y, s);
        done = true;
        for (int k = 0; k < checked; ++k)
          done &= std::abs(sum[k] - previous[k]) <= tolerance(sum[k]);
      }
      for (int g = 0; g < grid.groups; ++g)
        for (int c = 0; c < grid.channels; ++c)
          grid.at(g, c, x, y) = float(sum[g * grid.channels + c]);
    }
  return evaluations;
}

}  // namespace basis
