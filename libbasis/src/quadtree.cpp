#include "basis/quadtree.h"

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
  // Exponent bits all set means Inf or NaN; an integer OR-reduction vectorises.
  std::uint32_t bad = 0;
  for (float v : values) {
    const auto bits = std::bit_cast<std::uint32_t>(v);
    bad |= (bits & 0x7f800000u) == 0x7f800000u;
  }
  return bad == 0;
}

void set_links(Quad& quad, const std::int32_t (&links)[4]) {
  std::memcpy(&quad, links, sizeof links);
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

  // Scratch levels 0 .. levels-1; level `levels` is the grid itself (error 0).
  level_offset_.assign(levels + 1, 0);
  std::size_t total = 0;
  for (int k = 0; k < levels; ++k) {
    level_offset_[k] = total;
    total += std::size_t(1) << (2 * k);
  }
  values_.resize(total * planes);
  errors_.resize(total * channels);
  auto value_plane = [&](int k, int p) -> const float* {
    if (k == levels) return grid.texels.data() + std::size_t(p) * grid.plane_size();
    return values_.data() + level_offset_[k] * planes + (std::size_t(p) << (2 * k));
  };
  auto error_plane = [&](int k, int c) -> const float* {
    return errors_.data() + level_offset_[k] * channels + (std::size_t(c) << (2 * k));
  };

  // Bottom-up: averages of the four children, and the error bound of section 2.2.
  for (int k = levels; k >= 1; --k) {
    const int fine = 1 << k, coarse = fine / 2;
    for (int p = 0; p < planes; ++p) {
      const float* src = value_plane(k, p);
      float* dst = const_cast<float*>(value_plane(k - 1, p));
      const bool bounded = p < channels;  // group 0
      const float* src_err = bounded && k < levels ? error_plane(k, p) : nullptr;
      float* dst_err = bounded ? const_cast<float*>(error_plane(k - 1, p)) : nullptr;
      for (int y = 0; y < coarse; ++y) {
        const float* r0 = src + std::size_t(2 * y) * fine;
        const float* r1 = r0 + fine;
        float* d = dst + std::size_t(y) * coarse;
        for (int x = 0; x < coarse; ++x) {
          const float a = r0[2 * x], b = r0[2 * x + 1], c = r1[2 * x], e = r1[2 * x + 1];
          d[x] = ((a + b) + (c + e)) * 0.25f;
        }
        if (!bounded) continue;
        float* de = dst_err + std::size_t(y) * coarse;
        for (int x = 0; x < coarse; ++x) {
          const float a = r0[2 * x], b = r0[2 * x + 1], c = r1[2 * x], e = r1[2 * x + 1];
          de[x] =
              std::max(std::max(a, b), std::max(c, e)) - std::min(std::min(a, b), std::min(c, e));
        }
        if (!src_err) continue;
        const float* e0 = src_err + std::size_t(2 * y) * fine;
        const float* e1 = e0 + fine;
        for (int x = 0; x < coarse; ++x)
          de[x] += std::max(std::max(e0[2 * x], e0[2 * x + 1]), std::max(e1[2 * x], e1[2 * x + 1]));
      }
    }
  }

  std::vector<double> means(channels);
  for (int c = 0; c < channels; ++c)
    means[c] = value_plane(0, c)[0];
  const std::vector<float> tol = absolute_tolerances(options, means);

  // Top-down cut, emitting nodes in depth-first pre-order.
  out.shape = QuadtreeShape{n, channels, grid.groups};
  const int stride = out.shape.stride();
  out.nodes.clear();
  out.errors.clear();

  auto emit = [&](auto&& self, int k, int x, int y) -> std::int32_t {
    const auto node = std::int32_t(out.nodes.size() / stride);
    out.nodes.resize(out.nodes.size() + stride);
    out.errors.resize(out.errors.size() + channels);
    const int side = 1 << (k + 1);
    const bool texel_level = k + 1 == levels;
    bool refine[4] = {};
    for (int q = 0; q < 4; ++q) {
      const std::size_t cell = std::size_t(2 * y + (q >> 1)) * side + (2 * x + (q & 1));
      for (int p = 0; p < planes; ++p)
        out.nodes[std::size_t(node) * stride + 1 + p].lane[q] = value_plane(k + 1, p)[cell];
      for (int c = 0; c < channels; ++c) {
        const float err = texel_level ? 0.0f : error_plane(k + 1, c)[cell];
        out.errors[std::size_t(node) * channels + c].lane[q] = err;
        refine[q] |= err > tol[c];
      }
      refine[q] &= k + 1 < max_depth;
    }
    std::int32_t links[4] = {};
    for (int q = 0; q < 4; ++q)
      if (refine[q]) links[q] = self(self, k + 1, 2 * x + (q & 1), 2 * y + (q >> 1));
    set_links(out.nodes[std::size_t(node) * stride], links);
    return node;
  };
  emit(emit, 0, 0, 0);
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

float evaluate(const QuadtreeView& tree, double u, double v, int group, int channel) {
  int node = 0;
  double u0 = 0, v0 = 0, size = 1;
  for (;;) {
    size /= 2;
    const int qx = u >= u0 + size, qy = v >= v0 + size;
    const int q = qx + 2 * qy;
    const int child = tree.child(node, q);
    if (!child) return tree.value(node, group, channel, q);
    u0 += qx * size;
    v0 += qy * size;
    node = child;
  }
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
