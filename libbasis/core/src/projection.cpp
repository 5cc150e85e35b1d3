#include "basis/core/projection.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

#include "basis/core/number_text.h"

namespace basis {

namespace {

int log2_of(int n) {
  return std::countr_zero(unsigned(n));
}

// A float at least x (x >= 0, computed in double): the nearest float to x raised by 2^-50 (a
// margin for x's own double rounding), or the next float up when that lies below; 0 stays 0.
// So bounds rise by at most one float step, and a quadrant whose bound equals the tolerance
// exactly is refined.
float float_at_least(double x) {
  const double safe = x + x * 0x1p-50;
  const float nearest = float(safe);
  if (double(nearest) >= safe) return nearest;
  return std::bit_cast<float>(std::bit_cast<std::uint32_t>(nearest) + 1);
}

// The paper's error bound of level k-1 from level k (side `fine`): max - min of the 2 x 2
// children plus the largest child error (child errors absent at the texel level), rounded up.
void build_level(const float* __restrict src, const float* __restrict src_error, int fine,
                 float* __restrict dst_error) {
  const int coarse = fine / 2;
  for (int y = 0; y < coarse; ++y) {
    const float* __restrict r0 = src + std::size_t(2 * y) * fine;
    const float* __restrict r1 = r0 + fine;
    const float* __restrict e0 = src_error ? src_error + std::size_t(2 * y) * fine : nullptr;
    const float* __restrict e1 = src_error ? e0 + fine : nullptr;
    float* __restrict de = dst_error + std::size_t(y) * coarse;
    for (int x = 0; x < coarse; ++x) {
      const float a = r0[2 * x], b = r0[2 * x + 1], c = r1[2 * x], e = r1[2 * x + 1];
      double bound = double(std::max(std::max(a, b), std::max(c, e))) -
                     double(std::min(std::min(a, b), std::min(c, e)));
      if (src_error)
        bound += double(
            std::max(std::max(e0[2 * x], e0[2 * x + 1]), std::max(e1[2 * x], e1[2 * x + 1])));
      de[x] = float_at_least(bound);
    }
  }
}

// Level k-1 from level k for a bounded plane with exact bounds, its averages `average` given:
// the smallest and largest texel under each cell (from the children's, or the texels themselves
// at the finest level where lo and hi are null), and the error max(hi - average, average - lo),
// rounded up.
void build_level_exact(const float* src_lo, const float* src_hi, int fine,
                       const float* __restrict average, float* __restrict dst_lo,
                       float* __restrict dst_hi, float* __restrict dst_error) {
  const int coarse = fine / 2;
  for (int y = 0; y < coarse; ++y) {
    const std::size_t r0 = std::size_t(2 * y) * fine, r1 = r0 + fine, o = std::size_t(y) * coarse;
    const float* l0 = src_lo + r0;
    const float* l1 = src_lo + r1;
    const float* h0 = src_hi + r0;
    const float* h1 = src_hi + r1;
    float* __restrict lo = dst_lo + o;
    float* __restrict hi = dst_hi + o;
    float* __restrict error = dst_error + o;
    for (int x = 0; x < coarse; ++x)
      lo[x] = std::min(std::min(l0[2 * x], l0[2 * x + 1]), std::min(l1[2 * x], l1[2 * x + 1]));
    for (int x = 0; x < coarse; ++x)
      hi[x] = std::max(std::max(h0[2 * x], h0[2 * x + 1]), std::max(h1[2 * x], h1[2 * x + 1]));
    for (int x = 0; x < coarse; ++x)
      error[x] = float_at_least(
          std::max(double(hi[x]) - double(average[o + x]), double(average[o + x]) - double(lo[x])));
  }
}

}  // namespace

void check_projection_options(const ProjectionOptions& options) {
  if (!(options.tolerance >= 0) || !std::isfinite(options.tolerance))
    throw std::invalid_argument("tolerance must be a finite number >= 0, got " +
                                number_text(options.tolerance));
  if (!(options.local_floor >= 0) || !std::isfinite(options.local_floor))
    throw std::invalid_argument("tolerance floor must be a finite number >= 0, got " +
                                number_text(options.local_floor));
}

std::vector<float> absolute_tolerances(const ProjectionOptions& options,
                                       std::span<const double> channel_means) {
  check_projection_options(options);
  std::vector<float> tol;
  for (double mean : channel_means)
    tol.push_back(float(options.mode == ProjectionOptions::Mode::relative
                            ? options.tolerance * std::abs(mean)
                            : options.tolerance));
  return tol;
}

Quadtree QuadtreeProjector::project(const Grid& grid, const ProjectionOptions& options) {
  Quadtree tree;
  project(grid, options, tree);
  return tree;
}

void QuadtreeProjector::project(const Grid& grid, const ProjectionOptions& options, Quadtree& out) {
  const int n = grid.resolution;
  if (!is_valid_resolution(n))
    throw std::invalid_argument("resolution must be a power of two from 2 to 512, got " +
                                std::to_string(n));
  if (grid.channels != 1 && grid.channels != 3)
    throw std::invalid_argument("a quadtree holds 1 or 3 channels, got " +
                                std::to_string(grid.channels));
  if (grid.groups < 1 || grid.groups > 3)
    throw std::invalid_argument("a quadtree holds 1 to 3 channel groups, got " +
                                std::to_string(grid.groups));
  if (grid.texels.size() != grid.plane_size() * grid.channels * grid.groups)
    throw std::invalid_argument("grid storage does not match its size");
  if (!all_finite(grid.texels)) throw std::invalid_argument("grid holds NaN or Inf texels");
  const int levels = log2_of(n);  // texels are level `levels`
  const int max_depth = options.max_depth == 0 ? levels : options.max_depth;
  if (max_depth < 1 || max_depth > levels)
    throw std::invalid_argument("max depth must be 1.." + std::to_string(levels) + ", got " +
                                std::to_string(options.max_depth));

  const int channels = grid.channels;
  const int bounded = options.cut_on_all_groups ? channels * grid.groups : channels;
  build_levels(grid, options, bounded);

  // Tolerances: group 0's per channel; further groups' a multiple of their channel's.
  std::vector<double> means(channels);
  for (int c = 0; c < channels; ++c)
    means[c] = values(grid, 0, c)[0] + options.extra_mean[std::size_t(c)];
  std::vector<float> tolerances = absolute_tolerances(options, means);
  for (int p = channels; p < bounded; ++p)
    tolerances.push_back(float(options.group_tolerance_scale * tolerances[p % channels]));
  // Locally relative: tolerance x max(|quadrant value|, floor x |mean|) per plane.
  local_tolerance_.clear();
  if (options.local_floor > 0 && options.mode == ProjectionOptions::Mode::relative) {
    for (int p = 0; p < bounded; ++p) {
      const double scale = p < channels ? 1 : options.group_tolerance_scale;
      local_tolerance_.push_back(float(scale * options.tolerance));
      tolerances[p] = float(tolerances[p] * options.local_floor);
    }
  }
  cut(grid, tolerances, max_depth, out);
}

const float* QuadtreeProjector::values(const Grid& grid, int k, int p) const {
  if (k == levels_) return grid.plane(p / grid.channels, p % grid.channels).data();
  return value_planes_[std::size_t(k) * planes_ + p];
}

void QuadtreeProjector::build_levels(const Grid& grid, const ProjectionOptions& options,
                                     int bounded) {
  levels_ = log2_of(grid.resolution);
  planes_ = grid.channels * grid.groups;
  bounded_ = bounded;
  channels_ = grid.channels;
  const bool exact = options.bound == ProjectionOptions::Bound::exact;

  // Scratch levels 0 .. levels-1, each plane contiguous: values for all planes, errors (and,
  // for exact bounds, the extremes) for the bounded ones.
  std::size_t total = 0;
  for (int k = 0; k < levels_; ++k)
    total += std::size_t(1) << (2 * k);
  value_storage_.resize(total * planes_);
  error_storage_.resize(total * bounded_ * (exact ? 3 : 1));
  value_planes_.assign(std::size_t(levels_) * planes_, nullptr);
  error_planes_.assign(std::size_t(levels_) * bounded_, nullptr);
  extreme_planes_.assign(exact ? std::size_t(levels_) * bounded_ * 2 : 0, nullptr);
  std::size_t offset = 0;
  for (int k = 0; k < levels_; ++k) {
    const std::size_t cells = std::size_t(1) << (2 * k);
    for (int p = 0; p < planes_; ++p)
      value_planes_[std::size_t(k) * planes_ + p] =
          value_storage_.data() + (offset * planes_ + p * cells);
    for (int p = 0; p < bounded_; ++p) {
      error_planes_[std::size_t(k) * bounded_ + p] =
          error_storage_.data() + (offset * bounded_ + p * cells);
      if (!exact) continue;
      float* lo = error_storage_.data() + total * bounded_ + 2 * (offset * bounded_ + p * cells);
      extreme_planes_[2 * (std::size_t(k) * bounded_ + p)] = lo;
      extreme_planes_[2 * (std::size_t(k) * bounded_ + p) + 1] = lo + cells;
    }
    offset += cells;
  }

  // Averages first (the bounded planes' with their deviations, in one pass), then the bounds.
  build_deviations(grid);
  build_means(grid);
  for (int k = levels_; k >= 1; --k)
    for (int p = 0; p < bounded_; ++p) {
      const bool texels = k == levels_;
      if (exact)
        build_level_exact(texels ? values(grid, k, p) : extremes(k, p, 0),
                          texels ? values(grid, k, p) : extremes(k, p, 1), 1 << k,
                          values(grid, k - 1, p), extremes(k - 1, p, 0), extremes(k - 1, p, 1),
                          errors(k - 1, p));
      else
        build_level(values(grid, k, p), texels ? nullptr : errors(k, p), 1 << k, errors(k - 1, p));
    }
  // Bounds of texels near the float range can overflow it (averages cannot; checked all the same).
  if (!all_finite(value_storage_) || !all_finite(error_storage_) || !all_finite(deviation_storage_))
    throw std::overflow_error("error bounds of texels overflow float (largest 3.4e38)");
}

void QuadtreeProjector::build_means(const Grid& grid) {
  // Bottom-up in double, so that texels of either sign that cancel lose nothing to the float
  // sums of each level; each cell's mean is then rounded once to the nearest float.
  std::vector<double>& fine = moments_[0];
  std::vector<double>& coarse = moments_[2];
  for (int p = bounded_; p < planes_; ++p) {
    const std::span<const float> texels = grid.plane(p / channels_, p % channels_);
    fine.assign(texels.begin(), texels.end());
    for (int k = levels_; k >= 1; --k) {
      const int side = 1 << k, half = side / 2;
      coarse.resize(std::size_t(half) * std::size_t(half));
      float* stored = scratch_values(k - 1, p);
      for (int y = 0; y < half; ++y) {
        const double* r0 = fine.data() + std::size_t(2 * y) * side;
        const double* r1 = r0 + side;
        const std::size_t row = std::size_t(y) * half;
        for (int x = 0; x < half; ++x) {
          const double mean = ((r0[2 * x] + r0[2 * x + 1]) + (r1[2 * x] + r1[2 * x + 1])) * 0.25;
          coarse[row + x] = mean;
          stored[row + x] = float(mean);
        }
      }
      fine.swap(coarse);
    }
  }
}

void QuadtreeProjector::build_deviations(const Grid& grid) {
  std::size_t total = 0;
  for (int k = 0; k < levels_; ++k)
    total += std::size_t(1) << (2 * k);
  deviation_storage_.resize(total * bounded_);
  deviation_planes_.assign(std::size_t(levels_) * bounded_, nullptr);
  std::size_t offset = 0;
  for (int k = 0; k < levels_; ++k) {
    const std::size_t cells = std::size_t(1) << (2 * k);
    for (int p = 0; p < bounded_; ++p)
      deviation_planes_[std::size_t(k) * bounded_ + p] =
          deviation_storage_.data() + offset * bounded_ + p * cells;
    offset += cells;
  }
  // Bottom-up in double, per bounded plane: each cell's mean and sum of squared deviations of
  // its texels (Chan et al.'s pairwise update, free of cancellation), the mean stored as the
  // nearest float (the cell's average), then the RMS deviation from that average, rounded up.
  // Levels alternate between two pairs of arrays so that the loop over a row has no aliasing and
  // vectorises.
  for (int p = 0; p < bounded_; ++p) {
    const std::span<const float> texels = grid.plane(p / channels_, p % channels_);
    moments_[0].assign(texels.begin(), texels.end());
    moments_[1].assign(texels.size(), 0.0);
    moments_[2].resize(texels.size() / 4);
    moments_[3].resize(texels.size() / 4);
    int from = 0;
    double texels_per_child = 1;
    for (int k = levels_; k >= 1; --k) {
      const int fine = 1 << k, coarse = fine / 2;
      const double* fine_mean = moments_[from].data();
      const double* fine_squares = moments_[from + 1].data();
      double* coarse_mean = moments_[2 - from].data();
      double* coarse_squares = moments_[3 - from].data();
      float* stored = scratch_values(k - 1, p);
      float* deviation = deviations(k - 1, p);
      const double inverse_texels = 1 / (4 * texels_per_child);
      for (int y = 0; y < coarse; ++y) {
        const double* m0 = fine_mean + std::size_t(2 * y) * fine;
        const double* m1 = m0 + fine;
        const double* s0 = fine_squares + std::size_t(2 * y) * fine;
        const double* s1 = s0 + fine;
        const std::size_t row = std::size_t(y) * coarse;
        for (int x = 0; x < coarse; ++x) {
          const double a = m0[2 * x], b = m0[2 * x + 1], d = m1[2 * x], e = m1[2 * x + 1];
          const double m = (a + b + d + e) / 4;
          const double m2 = s0[2 * x] + s0[2 * x + 1] + s1[2 * x] + s1[2 * x + 1] +
                            texels_per_child * ((a - m) * (a - m) + (b - m) * (b - m) +
                                                (d - m) * (d - m) + (e - m) * (e - m));
          coarse_mean[row + x] = m;
          coarse_squares[row + x] = m2;
          stored[row + x] = float(m);
          const double offset_from_stored = m - double(stored[row + x]);
          const double rms =
              std::sqrt(m2 * inverse_texels + offset_from_stored * offset_from_stored);
          // A margin far above double rounding, then rounded up to a float.
          deviation[row + x] = float_at_least(rms + 1e-12 * (std::abs(m) + rms));
        }
      }
      from = 2 - from;
      texels_per_child *= 4;
    }
  }
}

void QuadtreeProjector::cut(const Grid& grid, std::span<const float> tolerances, int max_depth,
                            Quadtree& out) {
  const int channels = grid.channels;
  out.shape = QuadtreeShape{grid.resolution, channels, grid.groups, bounded_ / channels};
  const auto group0 = std::span(grid.texels).first(grid.plane_size() * std::size_t(channels));
  out.non_negative = std::ranges::all_of(group0, [](float t) { return t >= 0; });
  const std::size_t stride = out.shape.stride();
  std::size_t count = 0;
  pending_.clear();
  pending_.push_back({0, 0, 0, -1, 0});
  while (!pending_.empty()) {
    const PendingCell cell = pending_.back();
    pending_.pop_back();
    const auto node = std::int32_t(count++);
    if (count * stride > out.nodes.size()) {
      out.nodes.resize(std::max<std::size_t>(2 * out.nodes.size(), 16 * stride));
      out.errors.resize(out.nodes.size() / stride * bounded_);
      out.deviations.resize(out.errors.size());
    }
    Quad* quads = &out.nodes[node * stride];
    Quad* errors_out = &out.errors[node * bounded_];
    Quad* deviations_out = &out.deviations[node * bounded_];
    if (cell.parent >= 0) {
      std::int32_t* parent_links =
          reinterpret_cast<std::int32_t*>(&out.nodes[cell.parent * stride]);
      std::memcpy(parent_links + cell.quadrant, &node, sizeof node);
    }
    // Quadrants are the 2 x 2 cells (2x .. 2x+1, 2y .. 2y+1) of the next level.
    const int k = cell.level + 1, side = 1 << k;
    const std::size_t row0 = std::size_t(2 * cell.y) * side + 2 * cell.x, row1 = row0 + side;
    for (int p = 0; p < planes_; ++p) {
      const float* src = values(grid, k, p);
      std::memcpy(quads[1 + p].lane, src + row0, 2 * sizeof(float));
      std::memcpy(quads[1 + p].lane + 2, src + row1, 2 * sizeof(float));
    }
    int refine = 0;
    for (int p = 0; p < bounded_; ++p) {
      Quad error{};
      if (k < levels_) {
        const float* src = errors(k, p);
        std::memcpy(error.lane, src + row0, 2 * sizeof(float));
        std::memcpy(error.lane + 2, src + row1, 2 * sizeof(float));
      }
      errors_out[p] = error;
      if (local_tolerance_.empty()) {
        for (int q = 0; q < 4; ++q)
          refine |= int(error.lane[q] > tolerances[p]) << q;
      } else {
        // Relative to the quadrant's own value of group 0 (never below the floor).
        const Quad& v = quads[1 + p % channels];
        for (int q = 0; q < 4; ++q)
          refine |= int(error.lane[q] >
                        std::max(tolerances[p], local_tolerance_[p] * std::abs(v.lane[q])))
                    << q;
      }
      if (k < levels_) {
        const float* src = deviations(k, p);
        std::memcpy(deviations_out[p].lane, src + row0, 2 * sizeof(float));
        std::memcpy(deviations_out[p].lane + 2, src + row1, 2 * sizeof(float));
      } else {
        deviations_out[p] = Quad{};
      }
    }
    if (k >= max_depth) refine = 0;
    const std::int32_t no_children[4] = {0, 0, 0, 0};
    std::memcpy(&quads[0], no_children, sizeof no_children);
    // Push in reverse so that quadrant 0's subtree is emitted first.
    for (int q = 3; q >= 0; --q)
      if (refine >> q & 1)
        pending_.push_back({k, 2 * cell.x + (q & 1), 2 * cell.y + (q >> 1), node, q});
  }
  out.nodes.resize(count * stride);
  out.errors.resize(count * bounded_);
  out.deviations.resize(count * bounded_);
}

Quadtree project(const Grid& grid, const ProjectionOptions& options) {
  return QuadtreeProjector().project(grid, options);
}

}  // namespace basis
