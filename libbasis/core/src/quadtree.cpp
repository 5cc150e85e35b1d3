#include "basis/core/quadtree.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

namespace basis {

std::int32_t QuadtreeView::child(int node, int quadrant) const {
  std::int32_t links[4];
  std::memcpy(links, &nodes_[std::size_t(node) * shape_.stride()], sizeof links);
  return links[quadrant];
}

namespace {

int log2_of(int n) {
  return std::countr_zero(unsigned(n));
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

// Level k-1 from level k (side `fine`): averages of 2 x 2 children, and for bounded planes the
// error bound max - min + max(child error) (child errors absent at the texel level).
void build_level(const float* __restrict src, const float* __restrict src_error, int fine,
                 float* __restrict dst, float* __restrict dst_error) {
  const int coarse = fine / 2;
  for (int y = 0; y < coarse; ++y) {
    const float* __restrict r0 = src + std::size_t(2 * y) * fine;
    const float* __restrict r1 = r0 + fine;
    float* __restrict d = dst + std::size_t(y) * coarse;
    for (int x = 0; x < coarse; ++x)
      d[x] = ((r0[2 * x] + r0[2 * x + 1]) + (r1[2 * x] + r1[2 * x + 1])) * 0.25f;
    if (!dst_error) continue;
    float* __restrict de = dst_error + std::size_t(y) * coarse;
    for (int x = 0; x < coarse; ++x) {
      const float a = r0[2 * x], b = r0[2 * x + 1], c = r1[2 * x], e = r1[2 * x + 1];
      de[x] = std::max(std::max(a, b), std::max(c, e)) - std::min(std::min(a, b), std::min(c, e));
    }
    if (!src_error) continue;
    const float* __restrict e0 = src_error + std::size_t(2 * y) * fine;
    const float* __restrict e1 = e0 + fine;
    for (int x = 0; x < coarse; ++x)
      de[x] += std::max(std::max(e0[2 * x], e0[2 * x + 1]), std::max(e1[2 * x], e1[2 * x + 1]));
  }
}

// Level k-1 from level k for a bounded plane with exact bounds: averages, the smallest and
// largest texel under each cell (from the children's, or the texels themselves at the finest
// level where lo and hi are null), and the error max(hi - average, average - lo).
void build_level_exact(const float* __restrict src, const float* src_lo, const float* src_hi,
                       int fine, float* __restrict dst, float* __restrict dst_lo,
                       float* __restrict dst_hi, float* __restrict dst_error) {
  if (!src_lo) src_lo = src_hi = src;
  const int coarse = fine / 2;
  if (coarse <= 8) {  // short rows: one fused scalar loop beats four vector loops' set-up
    for (int y = 0; y < coarse; ++y) {
      const std::size_t r0 = std::size_t(2 * y) * fine, r1 = r0 + fine;
      for (int x = 0; x < coarse; ++x) {
        const std::size_t i = r0 + 2 * x, j = r1 + 2 * x, o = std::size_t(y) * coarse + x;
        const float average = ((src[i] + src[i + 1]) + (src[j] + src[j + 1])) * 0.25f;
        const float lo =
            std::min(std::min(src_lo[i], src_lo[i + 1]), std::min(src_lo[j], src_lo[j + 1]));
        const float hi =
            std::max(std::max(src_hi[i], src_hi[i + 1]), std::max(src_hi[j], src_hi[j + 1]));
        dst[o] = average;
        dst_lo[o] = lo;
        dst_hi[o] = hi;
        dst_error[o] = std::max(hi - average, average - lo);
      }
    }
    return;
  }
  // Long rows: one quantity per loop, so that each vectorises.
  for (int y = 0; y < coarse; ++y) {
    const std::size_t r0 = std::size_t(2 * y) * fine, r1 = r0 + fine, o = std::size_t(y) * coarse;
    const float* __restrict a0 = src + r0;
    const float* __restrict a1 = src + r1;
    const float* l0 = src_lo + r0;
    const float* l1 = src_lo + r1;
    const float* h0 = src_hi + r0;
    const float* h1 = src_hi + r1;
    float* __restrict average = dst + o;
    float* __restrict lo = dst_lo + o;
    float* __restrict hi = dst_hi + o;
    float* __restrict error = dst_error + o;
    for (int x = 0; x < coarse; ++x)
      average[x] = ((a0[2 * x] + a0[2 * x + 1]) + (a1[2 * x] + a1[2 * x + 1])) * 0.25f;
    for (int x = 0; x < coarse; ++x)
      lo[x] = std::min(std::min(l0[2 * x], l0[2 * x + 1]), std::min(l1[2 * x], l1[2 * x + 1]));
    for (int x = 0; x < coarse; ++x)
      hi[x] = std::max(std::max(h0[2 * x], h0[2 * x + 1]), std::max(h1[2 * x], h1[2 * x + 1]));
    for (int x = 0; x < coarse; ++x)
      error[x] = std::max(hi[x] - average[x], average[x] - lo[x]);
  }
}

}  // namespace

std::vector<float> absolute_tolerances(const ProjectionOptions& options,
                                       std::span<const double> channel_means) {
  if (!(options.tolerance >= 0) || !std::isfinite(options.tolerance))
    throw std::invalid_argument("tolerance must be a finite number >= 0, got " +
                                std::to_string(options.tolerance));
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
  const int planes = channels * grid.groups;
  const int bounded = options.cut_on_all_groups ? planes : channels;  // planes with error bounds

  // Scratch levels 0 .. levels-1; level `levels` is the grid itself (error 0). Pointers to
  // every plane of every level, values for all planes, errors for the bounded ones.
  std::size_t total = 0;
  for (int k = 0; k < levels; ++k)
    total += std::size_t(1) << (2 * k);
  values_.resize(total * planes);
  const bool exact = options.bound == ProjectionOptions::Bound::exact;
  errors_.resize(total * bounded * (exact ? 3 : 1));  // exact bounds also keep lo and hi
  value_planes_.assign(std::size_t(levels + 1) * planes, nullptr);
  error_planes_.assign(std::size_t(levels + 1) * bounded, nullptr);
  extreme_planes_.assign(exact ? std::size_t(levels + 1) * bounded * 2 : 0, nullptr);
  std::size_t offset = 0;
  for (int k = 0; k < levels; ++k) {
    const std::size_t cells = std::size_t(1) << (2 * k);
    for (int p = 0; p < planes; ++p)
      value_planes_[k * planes + p] = values_.data() + (offset * planes + p * cells);
    for (int c = 0; c < bounded; ++c) {
      error_planes_[k * bounded + c] = errors_.data() + (offset * bounded + c * cells);
      if (!exact) continue;
      float* extremes = errors_.data() + total * bounded + 2 * (offset * bounded + c * cells);
      extreme_planes_[2 * (k * bounded + c)] = extremes;
      extreme_planes_[2 * (k * bounded + c) + 1] = extremes + cells;
    }
    offset += cells;
  }
  for (int p = 0; p < planes; ++p)
    value_planes_[levels * planes + p] =
        const_cast<float*>(grid.texels.data()) + p * grid.plane_size();

  // Bottom-up: averages of the four children, and the error bound of section 2.2.
  for (int k = levels; k >= 1; --k)
    for (int p = 0; p < planes; ++p)
      if (exact && p < bounded) {
        const bool texels = k == levels;
        build_level_exact(
            value_planes_[k * planes + p],
            texels ? nullptr : extreme_planes_[2 * (k * bounded + p)],
            texels ? nullptr : extreme_planes_[2 * (k * bounded + p) + 1], 1 << k,
            value_planes_[(k - 1) * planes + p], extreme_planes_[2 * ((k - 1) * bounded + p)],
            extreme_planes_[2 * ((k - 1) * bounded + p) + 1], error_planes_[(k - 1) * bounded + p]);
      } else
        build_level(value_planes_[k * planes + p],
                    p < bounded && k < levels ? error_planes_[k * bounded + p] : nullptr, 1 << k,
                    value_planes_[(k - 1) * planes + p],
                    p < bounded ? error_planes_[(k - 1) * bounded + p] : nullptr);

  // Tolerances: group 0's per channel; further groups' a multiple of their channel's.
  std::vector<double> means(channels);
  for (int c = 0; c < channels; ++c)
    means[c] = value_planes_[c][0] + options.extra_mean[std::size_t(c)];
  std::vector<float> tol = absolute_tolerances(options, means);
  for (int p = channels; p < bounded; ++p)
    tol.push_back(float(options.group_tolerance_scale * tol[p % channels]));

  // Top-down cut, emitting nodes in depth-first pre-order with an explicit stack of cells still
  // to emit and the parent link each one fills.
  out.shape = QuadtreeShape{n, channels, grid.groups};
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
      out.errors.resize(out.nodes.size() / stride * channels);
    }
    Quad* quads = &out.nodes[node * stride];
    Quad* errors = &out.errors[node * channels];
    if (cell.parent >= 0) {
      std::int32_t* parent_links =
          reinterpret_cast<std::int32_t*>(&out.nodes[cell.parent * stride]);
      std::memcpy(parent_links + cell.quadrant, &node, sizeof node);
    }
    // Quadrants are the 2 x 2 cells (2x .. 2x+1, 2y .. 2y+1) of the next level.
    const int k = cell.level + 1, side = 1 << k;
    const std::size_t row0 = std::size_t(2 * cell.y) * side + 2 * cell.x, row1 = row0 + side;
    for (int p = 0; p < planes; ++p) {
      const float* src = value_planes_[k * planes + p];
      std::memcpy(quads[1 + p].lane, src + row0, 2 * sizeof(float));
      std::memcpy(quads[1 + p].lane + 2, src + row1, 2 * sizeof(float));
    }
    int refine = 0;
    for (int p = 0; p < bounded; ++p) {
      Quad error{};
      if (k < levels) {
        const float* src = error_planes_[k * bounded + p];
        std::memcpy(error.lane, src + row0, 2 * sizeof(float));
        std::memcpy(error.lane + 2, src + row1, 2 * sizeof(float));
      }
      if (p < channels) errors[p] = error;  // stored bounds: group 0
      for (int q = 0; q < 4; ++q)
        refine |= int(error.lane[q] > tol[p]) << q;
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
  out.errors.resize(count * channels);
}

Quadtree project(const Grid& grid, const ProjectionOptions& options) {
  return QuadtreeProjector().project(grid, options);
}

Grid reconstruct(const QuadtreeView& tree) {
  const QuadtreeShape& s = tree.shape();
  Grid grid(s.resolution, s.channels, s.groups);
  auto fill = [&](auto&& self, int node, int x0, int y0, int size) -> void {
    const int half = size / 2;
    for (int q = 0; q < 4; ++q) {
      const int qx = x0 + (q & 1) * half, qy = y0 + (q >> 1) * half;
      if (const int child = tree.child(node, q)) {
        self(self, child, qx, qy, half);
        continue;
      }
      for (int g = 0; g < s.groups; ++g)
        for (int c = 0; c < s.channels; ++c) {
          const float v = tree.value(node, g, c, q);
          for (int y = qy; y < qy + half; ++y)
            for (int x = qx; x < qx + half; ++x)
              grid.at(g, c, x, y) = v;
        }
    }
  };
  fill(fill, 0, 0, 0, s.resolution);
  return grid;
}

LeafQuadrant find_leaf(const QuadtreeView& tree, double u, double v) {
  int node = 0;
  double u0 = 0, v0 = 0, size = 1;
  for (;;) {
    size /= 2;
    const int qx = u >= u0 + size, qy = v >= v0 + size;
    const int q = qx + 2 * qy;
    const int child = tree.child(node, q);
    if (!child) return {node, q};
    u0 += qx * size;
    v0 += qy * size;
    node = child;
  }
}

float evaluate(const QuadtreeView& tree, double u, double v, int group, int channel) {
  const LeafQuadrant leaf = find_leaf(tree, u, v);
  return tree.value(leaf.node, group, channel, leaf.quadrant);
}

double integrate(const QuadtreeView& tree, int group, int channel) {
  double sum = 0;
  for (int q = 0; q < 4; ++q)
    sum += tree.value(0, group, channel, q);
  return sum / 4;
}

std::vector<int> depth_histogram(const QuadtreeView& tree) {
  std::vector<int> histogram;
  auto visit = [&](auto&& self, int node, int level) -> void {
    if (int(histogram.size()) <= level) histogram.resize(level + 1, 0);
    ++histogram[level];
    for (int q = 0; q < 4; ++q)
      if (const int child = tree.child(node, q)) self(self, child, level + 1);
  };
  if (tree.node_count() > 0) visit(visit, 0, 0);
  return histogram;
}

}  // namespace basis
