// Texel averages of a function over the unit square by adaptive stratified supersampling, so
// that a feature narrower than a texel (a sharp lobe) is averaged, not point-sampled.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "basis/core/grid.h"

namespace basis {

struct SupersampleOptions {
  // Adaptive quadrature per texel: a cell's estimate from its centre sample is compared with
  // the mean of its four quadrants' centre samples; when the two differ by more than
  // relative_tolerance * max(|estimate|, floor) in some group-0 channel, each quadrant is
  // refined the same way, down to max_depth levels below the texel (4^max_depth cells).
  double relative_tolerance = 1e-3;
  double absolute_floor = 1e-6;
  // When positive, the floor of each group-0 channel is at least this fraction of the channel's
  // mean over the grid (estimated from the texels' centre samples): texels much darker than
  // the function's mean need no more relative precision than its mean does.
  double floor_fraction_of_mean = 0;
  int max_depth = 6;
  // Groups other than 0 ride along: they are evaluated at cells down to this depth only and
  // deeper cells inherit their ancestors' estimate.
  int max_group_depth = 6;
  // Groups whose channels decide convergence, from group 0 (1: group 0 alone). A further
  // group's floor is floor_fraction_of_mean times the mean of its |values| (signed functions,
  // such as derivatives, may average to zero).
  int checked_groups = 1;
  // Texels flagged by the caller (a feature may hide between samples there) are subdivided
  // unconditionally down to this depth.
  int forced_depth = 3;
  // Texels on the square's edge are sampled in a variable graded quadratically towards it
  // (boundary_graded), so that a function with an integrable singularity of order
  // 1/sqrt(distance) there converges: a BRDF over the cosine-weighted disk whose f cos stays
  // finite at the horizon, where f grows as 1/cos. An exact change of variables otherwise.
  bool graded_boundary = false;
};

// Where the sample at u lies once graded towards the square's edge, and the change of
// variables' Jacobian: within an edge texel of an n-texel side, its offset s from the texel's
// inner side becomes 1 - (1 - s)^2 (s^2 on the low side; 3 s^2 - 2 s^3 when n = 1), so that
// the samples crowd towards the edge; other texels keep u (Jacobian 1).
struct GradedCoordinate {
  double u = 0;
  double jacobian = 1;
};
inline GradedCoordinate boundary_graded(double u, int n) {
  const double scaled = u * n;
  const double texel = std::clamp(std::floor(scaled), 0.0, double(n - 1));
  const double s = scaled - texel;
  if (n == 1) return {s * s * (3 - 2 * s), 6 * s * (1 - s)};
  if (texel == 0) return {s * s / n, 2 * s};
  if (texel == n - 1) return {(texel + 1 - (1 - s) * (1 - s)) / n, 2 * (1 - s)};
  return {u, 1};
}

namespace detail {

// Adaptive refinement of one cell of a texel; see SupersampleOptions.
template <typename F>
class CellRefiner {
 public:
  CellRefiner(const F& f, const SupersampleOptions& options, int resolution, int values,
              int checked, const std::vector<double>& floor)
      : f_(f),
        o_(options),
        n_(resolution),
        values_(values),
        checked_(checked),
        floor_(floor),
        scratch_(std::size_t(options.max_depth + 2) * 10 * values) {}

  // Writes into `out` the average over the cell (x0, y0, size, in texel units, at `depth`)
  // whose centre sample is `centre`; returns the evaluations made.
  long long refine(double x0, double y0, double size, int depth, const double* centre, bool forced,
                   double* out) const {
    // Per depth: four children, their mean, and the running sum of refined children.
    double* children = &scratch_[std::size_t(depth) * 10 * values_];
    double* mean = children + 4 * values_;
    double* part = children + 5 * values_;
    // Groups that decide convergence are evaluated at every depth.
    const bool groups = checked_ == values_ || depth + 1 <= o_.max_group_depth;
    const int count = groups ? values_ : checked_;
    const double half = size / 2;
    for (int q = 0; q < 4; ++q) {
      double* c = children + q * values_;
      f_((x0 + (q & 1) * half + half / 2) / n_, (y0 + (q >> 1) * half + half / 2) / n_, c, groups);
      if (!groups) std::copy(centre + checked_, centre + values_, c + checked_);
    }
    long long evaluations = 4;
    for (int k = 0; k < count; ++k)
      mean[k] = (children[k] + children[values_ + k] + children[2 * values_ + k] +
                 children[3 * values_ + k]) /
                4;
    if (!groups) std::copy(centre + checked_, centre + values_, mean + checked_);
    bool converged = !forced || depth + 1 >= o_.forced_depth;
    for (int k = 0; k < checked_ && converged; ++k)
      converged = std::abs(mean[k] - centre[k]) <=
                  o_.relative_tolerance * std::max(std::abs(mean[k]), floor_[k]);
    if (converged || depth + 1 >= o_.max_depth) {
      std::copy(mean, mean + values_, out);
      return evaluations;
    }
    // The children's samples are their centres; deeper calls use the next depth's scratch.
    double* sum = part + values_;
    std::fill(sum, sum + values_, 0.0);
    for (int q = 0; q < 4; ++q) {
      evaluations += refine(x0 + (q & 1) * half, y0 + (q >> 1) * half, half, depth + 1,
                            children + q * values_, forced, part);
      for (int k = 0; k < values_; ++k)
        sum[k] += part[k] / 4;
    }
    std::copy(sum, sum + values_, out);
    return evaluations;
  }

 private:
  const F& f_;
  const SupersampleOptions& o_;
  int n_, values_, checked_;
  const std::vector<double>& floor_;
  mutable std::vector<double> scratch_;
};

}  // namespace detail

// Fills every group and channel of `grid` with the average over each texel of
// f(u, v, out, all_groups), where f writes group 0's channels into out and, when all_groups is
// true, the other groups' after them (group-major). Each texel is refined adaptively (see
// SupersampleOptions); texels for which force(x, y) is true are subdivided to forced_depth
// first. Deterministic. Returns the number of evaluations of f.
template <typename F, typename Force>
long long average_over_texels(Grid& grid, const F& f, const SupersampleOptions& options,
                              const Force& force) {
  const int n = grid.resolution;
  const int values = grid.channels * grid.groups;
  const int checked = grid.channels * std::clamp(options.checked_groups, 1, grid.groups);
  // f at graded coordinates, times the Jacobian, has the same texel averages.
  const auto sample = [&](double u, double v, double* out, bool all_groups) {
    if (!options.graded_boundary) return f(u, v, out, all_groups);
    const GradedCoordinate gu = boundary_graded(u, n), gv = boundary_graded(v, n);
    f(gu.u, gv.u, out, all_groups);
    const double jacobian = gu.jacobian * gv.jacobian;
    if (jacobian == 1) return;
    for (int k = 0; k < (all_groups ? values : checked); ++k)
      out[k] *= jacobian;
  };
  // Pass 1: centre samples, for the channels' means.
  std::vector<double> centres(std::size_t(n) * n * values);
  std::vector<double> mean(checked, 0.0), floor(checked);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      double* c = &centres[(std::size_t(y) * n + x) * values];
      sample((x + 0.5) / n, (y + 0.5) / n, c, true);
      for (int k = 0; k < checked; ++k)
        mean[k] += (k < grid.channels ? c[k] : std::abs(c[k])) / (double(n) * n);
    }
  for (int k = 0; k < checked; ++k)
    floor[k] = std::max(options.absolute_floor, options.floor_fraction_of_mean * std::abs(mean[k]));
  // Pass 2: refine every texel.
  const detail::CellRefiner<decltype(sample)> refiner(sample, options, n, values, checked, floor);
  std::vector<double> average(values);
  long long evaluations = std::size_t(n) * n;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      evaluations += refiner.refine(x, y, 1, 0, &centres[(std::size_t(y) * n + x) * values],
                                    force(x, y), average.data());
      for (int g = 0; g < grid.groups; ++g)
        for (int c = 0; c < grid.channels; ++c)
          grid.at(g, c, x, y) = float(average[g * grid.channels + c]);
    }
  return evaluations;
}

// Same with no texel forced.
template <typename F>
long long average_over_texels(Grid& grid, const F& f, const SupersampleOptions& options) {
  return average_over_texels(grid, f, options, [](int, int) { return false; });
}

}  // namespace basis
