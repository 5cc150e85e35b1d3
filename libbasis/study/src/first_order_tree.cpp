#include "basis/study/first_order_tree.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "basis/core/half.h"
#include "float_rounding.h"

namespace basis {

namespace {

// A node's sums over its texels, in texel units about the node's centre: the function, its
// first moments in u and v, and its square.
struct Moments {
  double sum = 0, sum_u = 0, sum_v = 0, sum_squares = 0;
};

// A function's texels row by row, three channels each (a grey function's one repeated).
using Texels = std::vector<std::array<double, 3>>;

// One level of the function's pyramid: per node and channel its moments, and whether the
// function is constant on it (with that constant). For a tree built from packed trees, also per
// node and channel what FirstOrderData is made of, each summed over the live terms: the RMS of
// the data's difference D from them, the RMS of their leaves' rounding, the mean of their
// leaves' bounds times the leaves' side over the node's, and the mean of their leaves' rounding;
// and the charge, the bounds of the terms whose leaf the node is (charged only where the function
// goes on).
struct Level {
  int side = 0;  // nodes per row
  std::vector<std::array<Moments, 3>> moments;
  std::vector<std::array<double, 3>> constant_value;
  std::vector<char> constant;
  std::vector<std::array<double, 3>> data_rms, data_rounding_rms, data_moment, data_rounding,
      charge;
  int terms = 0;                       // packed trees summed (0: built from a grid)
  std::vector<char> within_tolerance;  // for a cut tree: the node is a leaf (empty: none)
};

// RMS over a quadrant of f - p, f a function and p a plane over it, given the RMS r of the
// function's own piecewise-constant part about the plane, the RMS e of D = f - that part, and
// bounds on their cross term: with one packed tree, the part is constant on each of its leaves
// L, so that the integral of (part - p) D over L is (value_L - p's mean over L) times the
// integral of D (which the leaf's rounding bounds) plus the integral of (p's mean - p) D (which
// the plane's variation across L bounds): in all, at most area x (r x rounding_rms + g x
// moment), g = sqrt(slope_u^2 + slope_v^2), the RMS of p minus its mean. With several trees the
// part is not constant on one tree's leaves: r + e.
double residual_with_data(double r, double e, double rounding_rms, double g, double moment,
                          int terms) {
  if (terms != 1) return r + e;
  return std::sqrt(r * r + e * e + 2 * (r * rounding_rms + g * moment));
}

// The largest texel a tree takes: products of coefficients stay far from float overflow, and
// what float underflow loses stays within the descent's allowance for it.
constexpr float kLargestValue = 0x1p60f;

// A node's plane, from its moments over `texels` texels a side: mean and slopes as FirstOrderBlock
// holds them.
struct Plane {
  double mean = 0, slope_u = 0, slope_v = 0;
};
Plane plane_of(const Moments& m, int texels) {
  const double count = double(texels) * texels;
  const double slope_scale = std::sqrt(12.0) / (texels * count);
  return {m.sum / count, m.sum_u * slope_scale, m.sum_v * slope_scale};
}

// Throws unless every texel is finite and within +-kLargestValue.
void check_texels(const Texels& texels) {
  for (const std::array<double, 3>& texel : texels)
    for (const double f : texel)
      if (!std::isfinite(f) || std::abs(f) > double(kLargestValue))
        throw std::invalid_argument(
            "first-order tree of a value that is not finite or beyond "
            "2^60: " +
            std::to_string(f));
}

// The pyramid of a function of n x n texels, texels first.
std::vector<Level> pyramid(int n, const Texels& values) {
  std::vector<Level> levels(1);
  Level& texels = levels[0];
  texels.side = n;
  texels.moments.resize(std::size_t(n) * n);
  texels.constant_value.resize(texels.moments.size());
  texels.constant.assign(texels.moments.size(), 1);
  for (std::size_t i = 0; i < values.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      const double f = values[i][std::size_t(c)];
      texels.moments[i][std::size_t(c)] = {f, 0, 0, f * f};
      texels.constant_value[i][std::size_t(c)] = f;
    }
  for (int side = n / 2, child_side = 1; side >= 1; side /= 2, child_side *= 2) {
    const Level& below = levels.back();
    Level level;
    level.side = side;
    level.moments.resize(std::size_t(side) * side);
    level.constant_value.resize(level.moments.size());
    level.constant.assign(level.moments.size(), 1);
    const double offset = child_side / 2.0;  // a child's centre from its parent's, in texels
    for (int y = 0; y < side; ++y)
      for (int x = 0; x < side; ++x) {
        const std::size_t i = std::size_t(y) * side + x;
        for (int q = 0; q < 4; ++q) {
          const std::size_t j = std::size_t(2 * y + (q >> 1)) * below.side + 2 * x + (q & 1);
          const double du = (q & 1) ? offset : -offset, dv = (q >> 1) ? offset : -offset;
          for (int c = 0; c < 3; ++c) {
            const Moments& m = below.moments[j][c];
            Moments& sum = level.moments[i][c];
            sum.sum += m.sum;
            sum.sum_u += m.sum_u + du * m.sum;
            sum.sum_v += m.sum_v + dv * m.sum;
            sum.sum_squares += m.sum_squares;
          }
          if (!below.constant[j] ||
              below.constant_value[j] != below.constant_value[2 * y * below.side + 2 * x])
            level.constant[i] = 0;
        }
        level.constant_value[i] = below.constant_value[2 * y * below.side + 2 * x];
      }
    levels.push_back(std::move(level));
  }
  return levels;
}

// Quadrant q of a block (and of its data, for a tree built from packed trees) from node i of a
// level whose nodes are `texels` texels wide.
void set_quadrant(FirstOrderBlock& block, FirstOrderData* data, int q, const Level& level,
                  std::size_t i, int texels) {
  const double count = double(texels) * texels;
  for (int c = 0; c < 3; ++c) {
    const int lane = 3 * q + c;
    double residual = 0, slopes = 0;
    if (level.constant[i]) {
      block.mean[lane] = float(level.constant_value[i][c]);  // exact: slopes and residual 0
    } else {
      const Moments& m = level.moments[i][c];
      const Plane p = plane_of(m, texels);
      const double mean_square = m.sum_squares / count;
      // The sums' rounding moves the difference by a few 2^-40 of the mean square at most.
      const double residual_square =
          std::max(0.0,
                   mean_square - p.mean * p.mean - p.slope_u * p.slope_u - p.slope_v * p.slope_v) +
          0x1p-34 * mean_square;
      residual = std::sqrt(residual_square) * (1 + 0x1p-50);
      slopes = std::sqrt(p.slope_u * p.slope_u + p.slope_v * p.slope_v);
      block.mean[lane] = float(p.mean);
      block.slope_u[lane] = float(p.slope_u);
      block.slope_v[lane] = float(p.slope_v);
      block.residual[lane] = round_up(residual);
    }
    if (!data) continue;
    // Sums of a few terms' products in doubles: 2^-40 covers their rounding.
    const auto round_up_sum = [](double x) { return round_up(x * (1 + 0x1p-40)); };
    const std::array<double, 3>& e = level.data_rms[i];
    const std::array<double, 3>& moment = level.data_moment[i];
    const std::array<double, 3>& rounding_rms = level.data_rounding_rms[i];
    data->residual[lane] = round_up_sum(residual_with_data(
        double(block.residual[lane]), e[c], rounding_rms[c], slopes, moment[c], level.terms));
    data->rms[lane] = round_up_sum(e[c]);
    data->rounding_rms[lane] = round_up_sum(rounding_rms[c]);
    data->moment[lane] = round_up_sum(moment[c] + std::sqrt(3.0) * level.data_rounding[i][c]);
    data->rounding[lane] = round_up_sum(level.data_rounding[i][c]);
    if (!level.constant[i]) data->charge[lane] = round_up_sum(level.charge[i][c]);
  }
}

// Appends the block of node (x, y) of levels[level]'s quadrants, then theirs; returns its index.
// With data (a tree built from packed trees), appends their data beside them.
std::int32_t append_block(const std::vector<Level>& levels, int level, int x, int y,
                          std::vector<FirstOrderBlock>& blocks, std::vector<FirstOrderData>* data) {
  const std::int32_t index = std::int32_t(blocks.size());
  blocks.emplace_back();
  if (data) data->emplace_back();
  const Level& below = levels[level - 1];
  const int texels = 1 << (level - 1);
  for (int q = 0; q < 4; ++q) {
    const int cx = 2 * x + (q & 1), cy = 2 * y + (q >> 1);
    const std::size_t j = std::size_t(cy) * below.side + cx;
    set_quadrant(blocks[index], data ? &(*data)[index] : nullptr, q, below, j, texels);
  }
  for (int q = 0; q < 4; ++q) {
    const int cx = 2 * x + (q & 1), cy = 2 * y + (q >> 1);
    const std::size_t j = std::size_t(cy) * below.side + cx;
    const bool leaf =
        below.constant[j] || (!below.within_tolerance.empty() && below.within_tolerance[j]);
    if (level - 1 > 0 && !leaf) {
      const std::int32_t child = append_block(levels, level - 1, cx, cy, blocks, data);
      blocks[index].child[q] = child;
    }
  }
  return index;
}

// One term's leaves, texel by texel: each leaf's side in texels, its bound, and how far its
// values' rounding may move them from the data's mean over it, the weighted groups' summed by
// |weight|.
struct TermLeaves {
  std::vector<int> side;
  Texels bound, rounding;
};

// Adds the term's weighted values to `values` (n x n texels) and returns its leaves.
TermLeaves add_term(const WeightedTerm& term, Texels& values) {
  const PackedTreeView& tree = term.tree;
  const int n = tree.shape().resolution, channels = tree.shape().channels;
  const double average_rounding = (2 * std::countr_zero(unsigned(n)) + 1) * 0x1p-24;
  TermLeaves leaves;
  leaves.side.assign(values.size(), 0);
  leaves.bound.assign(values.size(), {});
  leaves.rounding.assign(values.size(), {});
  for_each_leaf(tree, [&](int node, int q, int level, int x, int y) {
    const int size = n >> level;
    std::array<double, 3> value{}, bound{}, rounding{};
    for (int c = 0; c < 3; ++c) {
      const int channel = std::min(c, channels - 1);
      for (int g = 0; g < term.groups; ++g) {
        const double weight = term.weights[std::size_t(g)];
        const double v = tree.value(node, g, channel, q);
        const double leaf_bound = tree.bound(node, g, channel, q);
        value[std::size_t(c)] += weight * v;
        bound[std::size_t(c)] += std::abs(weight) * leaf_bound;
        if (!(bound[std::size_t(c)] <= kLargestValue))
          throw std::invalid_argument("first-order tree of a term whose weighted bound is " +
                                      std::to_string(bound[std::size_t(c)]) +
                                      " (not finite or beyond 2^60)");
        // The half's rounding, and the average's own arithmetic in floats: a few 2^-24 a
        // level of the mean |texel|, which is at most |value| + its RMS deviation.
        rounding[std::size_t(c)] +=
            std::abs(weight) *
            (tree.rounding(node, g, channel, q) + average_rounding * (std::abs(v) + leaf_bound));
      }
    }
    for (int ty = y * size; ty < (y + 1) * size; ++ty)
      for (int tx = x * size; tx < (x + 1) * size; ++tx) {
        const std::size_t i = std::size_t(ty) * std::size_t(n) + std::size_t(tx);
        for (std::size_t c = 0; c < 3; ++c)
          values[i][c] += value[c];
        leaves.side[i] = size;
        leaves.bound[i] = bound;
        leaves.rounding[i] = rounding;
      }
  });
  return leaves;
}

// Adds one term's data to every level of the pyramid. On a node that lies inside one of the
// term's leaves the term is not live (its leaf's bound is charged where the descent passes it);
// on a node made of its leaves, it adds the RMS of their bounds; the mean of their bounds times
// the side of their leaf over the node's (a plane's slopes vary that much less across a smaller
// leaf); and the mean and the RMS of their rounding. On a node that is one of its leaves, it
// adds its bound to the node's charge, charged if the function goes on.
void add_term_data(std::vector<Level>& levels, const TermLeaves& leaves) {
  // Per node of the current level and channel, sums over its texels, in texel units.
  struct Sums {
    std::array<double, 3> squared_bound{}, bound_times_side{}, rounding{}, squared_rounding{};
    void add(const Sums& other) {
      for (std::size_t c = 0; c < 3; ++c) {
        squared_bound[c] += other.squared_bound[c];
        bound_times_side[c] += other.bound_times_side[c];
        rounding[c] += other.rounding[c];
        squared_rounding[c] += other.squared_rounding[c];
      }
    }
  };
  const int n = levels[0].side;
  std::vector<Sums> sums(std::size_t(n) * std::size_t(n));
  for (std::size_t i = 0; i < sums.size(); ++i)
    for (std::size_t c = 0; c < 3; ++c) {
      const double bound = leaves.bound[i][c], rounding = leaves.rounding[i][c];
      sums[i].squared_bound[c] = bound * bound;
      sums[i].bound_times_side[c] = bound * leaves.side[i];
      sums[i].rounding[c] = rounding;
      sums[i].squared_rounding[c] = rounding * rounding;
    }
  for (std::size_t k = 0; k < levels.size(); ++k) {
    Level& level = levels[k];
    const int side = level.side, texels = 1 << k;
    if (k > 0) {
      std::vector<Sums> above(std::size_t(side) * std::size_t(side));
      for (int y = 0; y < side; ++y)
        for (int x = 0; x < side; ++x)
          for (int q = 0; q < 4; ++q)
            above[std::size_t(y) * std::size_t(side) + std::size_t(x)].add(
                sums[std::size_t(2 * y + (q >> 1)) * std::size_t(2 * side) +
                     std::size_t(2 * x + (q & 1))]);
      sums = std::move(above);
    }
    if (level.data_rms.empty()) {
      level.data_rms.assign(sums.size(), {});
      level.data_rounding_rms.assign(sums.size(), {});
      level.data_moment.assign(sums.size(), {});
      level.data_rounding.assign(sums.size(), {});
      level.charge.assign(sums.size(), {});
    }
    const double area = double(texels) * texels;
    for (int y = 0; y < side; ++y)
      for (int x = 0; x < side; ++x) {
        const std::size_t i = std::size_t(y) * std::size_t(side) + std::size_t(x);
        const std::size_t first = std::size_t(y) * std::size_t(texels) * std::size_t(n) +
                                  std::size_t(x) * std::size_t(texels);
        const int leaf_side = leaves.side[first];
        if (leaf_side > texels) continue;  // inside one of the term's leaves
        const Sums& sum = sums[i];
        for (std::size_t c = 0; c < 3; ++c) {
          level.data_rms[i][c] += std::sqrt(sum.squared_bound[c] / area);
          level.data_moment[i][c] += sum.bound_times_side[c] / (area * texels);
          level.data_rounding[i][c] += sum.rounding[c] / area;
          level.data_rounding_rms[i][c] += std::sqrt(sum.squared_rounding[c] / area);
          if (leaf_side == texels) level.charge[i][c] += leaves.bound[first][c];
        }
      }
  }
}

// Marks the nodes of every level above the texels on which, in every channel, the texels lie
// within tolerances[c] of the node's plane (or mean).
void mark_within_tolerance(std::vector<Level>& levels, const Texels& texels,
                           const std::array<double, 3>& tolerances, FirstOrderCut cut) {
  const int n = levels[0].side;
  for (std::size_t k = 1; k < levels.size(); ++k) {
    Level& level = levels[k];
    const int side = level.side, size = 1 << k;
    level.within_tolerance.assign(std::size_t(side) * std::size_t(side), 1);
    for (int y = 0; y < side; ++y)
      for (int x = 0; x < side; ++x) {
        const std::size_t i = std::size_t(y) * std::size_t(side) + std::size_t(x);
        for (std::size_t c = 0; c < 3 && level.within_tolerance[i]; ++c) {
          Plane p = plane_of(level.moments[i][c], size);
          if (cut == FirstOrderCut::means) p.slope_u = p.slope_v = 0;
          for (int ty = 0; ty < size && level.within_tolerance[i]; ++ty)
            for (int tx = 0; tx < size; ++tx) {
              // The texel's centre about the node's, as psi_u and psi_v measure it.
              const double pu = std::sqrt(12.0) * (tx + 0.5 - size / 2.0) / size,
                           pv = std::sqrt(12.0) * (ty + 0.5 - size / 2.0) / size;
              const double f = texels[std::size_t(y * size + ty) * std::size_t(n) +
                                      std::size_t(x * size + tx)][c];
              if (std::abs(f - (p.mean + p.slope_u * pu + p.slope_v * pv)) > tolerances[c]) {
                level.within_tolerance[i] = 0;
                break;
              }
            }
        }
      }
  }
}

// The first-order tree of a pyramid, breadth first, with its data if the pyramid has them.
FirstOrderTree tree_of(const std::vector<Level>& levels) {
  const bool with_data = !levels[0].data_rms.empty();
  std::vector<FirstOrderBlock> depth_first;
  std::vector<FirstOrderData> data_depth_first;
  append_block(levels, int(levels.size()) - 1, 0, 0, depth_first,
               with_data ? &data_depth_first : nullptr);
  // Breadth first, as packed trees lie: a level's blocks next to each other, the top levels in
  // the first few lines.
  std::vector<std::int32_t> order{0}, renumbered(depth_first.size(), -1);
  renumbered[0] = 0;
  for (std::size_t i = 0; i < order.size(); ++i)
    for (const std::int32_t child : depth_first[std::size_t(order[i])].child)
      if (child >= 0) {
        renumbered[std::size_t(child)] = std::int32_t(order.size());
        order.push_back(child);
      }
  FirstOrderTree tree;
  tree.resolution = levels[0].side;
  tree.terms = levels[0].terms;
  tree.blocks.reserve(depth_first.size());
  for (const std::int32_t k : order) {
    tree.blocks.push_back(depth_first[std::size_t(k)]);
    for (std::int32_t& child : tree.blocks.back().child)
      if (child >= 0) child = renumbered[std::size_t(child)];
    if (with_data) tree.data.push_back(data_depth_first[std::size_t(k)]);
  }
  return tree;
}

// Group 0 of a grid as texels (a grey grid's channel repeated): std::invalid_argument unless its
// resolution is a power of two from 2, its channels 1 or 3, and every texel finite and within
// +-2^60.
Texels texels_of(const Grid& grid) {
  const int n = grid.resolution;
  if (n < 2 || (n & (n - 1)) != 0)
    throw std::invalid_argument("first-order tree of a grid of resolution " + std::to_string(n) +
                                " (a power of two from 2)");
  if (grid.channels != 1 && grid.channels != 3)
    throw std::invalid_argument("first-order tree of a grid of " + std::to_string(grid.channels) +
                                " channels (1 or 3)");
  Texels texels(std::size_t(n) * std::size_t(n));
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x)
      for (int c = 0; c < 3; ++c)
        texels[std::size_t(y) * std::size_t(n) + std::size_t(x)][std::size_t(c)] =
            grid.at(0, std::min(c, grid.channels - 1), x, y);
  check_texels(texels);
  return texels;
}

}  // namespace

FirstOrderTree first_order_tree(const Grid& grid) {
  return tree_of(pyramid(grid.resolution, texels_of(grid)));
}

FirstOrderTree first_order_tree(const Grid& grid, const std::array<double, 3>& tolerances,
                                FirstOrderCut cut) {
  for (const double t : tolerances)
    if (!(t >= 0) || !std::isfinite(t))
      throw std::invalid_argument("first-order tree cut at a tolerance of " + std::to_string(t));
  const Texels texels = texels_of(grid);
  std::vector<Level> levels = pyramid(grid.resolution, texels);
  mark_within_tolerance(levels, texels, tolerances, cut);
  return tree_of(levels);
}

FirstOrderTree first_order_tree(std::span<const WeightedTerm> terms) {
  if (terms.empty() || terms.size() > kMaxFoldedTerms)
    throw std::invalid_argument("first-order tree of " + std::to_string(terms.size()) +
                                " terms (1 to " + std::to_string(kMaxFoldedTerms) + ")");
  const int n = terms.front().tree.shape().resolution;
  for (const WeightedTerm& term : terms) {
    const PackedShape& shape = term.tree.shape();
    if (shape.resolution != n || n < 2 || (n & (n - 1)) != 0 || term.tree.node_count() == 0)
      throw std::invalid_argument("first-order tree of terms of resolutions " + std::to_string(n) +
                                  " and " + std::to_string(shape.resolution) +
                                  " (one, a power of two from 2)");
    if (term.groups < 1 || term.groups > shape.bounded_groups)
      throw std::invalid_argument("first-order tree of " + std::to_string(term.groups) +
                                  " groups of a tree with bounds on " +
                                  std::to_string(shape.bounded_groups));
    for (int g = 0; g < term.groups; ++g)
      if (!std::isfinite(term.weights[std::size_t(g)]))
        throw std::invalid_argument("first-order tree of a term weighted by " +
                                    std::to_string(term.weights[std::size_t(g)]));
  }
  Texels values(std::size_t(n) * std::size_t(n));
  std::vector<TermLeaves> leaves;
  for (const WeightedTerm& term : terms)
    leaves.push_back(add_term(term, values));
  check_texels(values);
  std::vector<Level> levels = pyramid(n, values);
  for (const TermLeaves& term : leaves)
    add_term_data(levels, term);
  for (Level& level : levels)
    level.terms = int(terms.size());
  return tree_of(levels);
}

FirstOrderTree first_order_tree(const PackedTreeView& tree) {
  const WeightedTerm term{tree, {1, 0, 0}, 1};
  return first_order_tree(std::span<const WeightedTerm>(&term, 1));
}

FirstOrderTree without_slopes(const FirstOrderTree& tree) {
  FirstOrderTree flat = tree;
  flat.slopes = false;
  for (std::size_t k = 0; k < flat.blocks.size(); ++k) {
    FirstOrderBlock& block = flat.blocks[k];
    for (std::size_t i = 0; i < 12; ++i) {
      const double residual = block.residual[i], u = block.slope_u[i], v = block.slope_v[i];
      // The slopes were rounded to nearest floats: up by 2^-22 for that.
      block.residual[i] = round_up(std::sqrt(residual * residual + u * u + v * v) * (1 + 0x1p-22));
      block.slope_u[i] = block.slope_v[i] = 0;
      if (flat.data.empty()) continue;
      // The data's residual about the mean: a plane without slopes.
      FirstOrderData& data = flat.data[k];
      data.residual[i] = round_up(residual_with_data(block.residual[i], data.rms[i],
                                                     data.rounding_rms[i], 0, 0, flat.terms) *
                                  (1 + 0x1p-40));
    }
  }
  return flat;
}

namespace {

// The smallest half at least x (x >= 0, within the half range).
std::uint16_t half_at_least(float x) {
  std::uint16_t h = float_to_half(x);
  if (half_to_float(h) < x) ++h;
  return h;
}

}  // namespace

CompactFirstOrderTree compact(const FirstOrderTree& tree) {
  const bool with_data = !tree.data.empty();
  // Per block, the residuals with the data's RMS added, rounded up; and per quadrant the largest
  // data moment and rounding of its channels.
  std::vector<std::array<float, 12>> residuals(tree.blocks.size());
  std::vector<std::array<float, 4>> moments(tree.blocks.size()), roundings(tree.blocks.size());
  float largest = 0;
  for (std::size_t k = 0; k < tree.blocks.size(); ++k) {
    const FirstOrderBlock& block = tree.blocks[k];
    for (std::size_t i = 0; i < 12; ++i) {
      double residual = block.residual[i];
      if (with_data) {
        const FirstOrderData& data = tree.data[k];
        if (data.charge[i] > 0)
          throw std::invalid_argument(
              "compact form of a first-order tree with charges (a sum of terms)");
        residual = data.residual[i];
        moments[k][i / 3] = std::max(moments[k][i / 3], data.moment[i]);
        roundings[k][i / 3] = std::max(roundings[k][i / 3], data.rounding[i]);
      }
      residuals[k][i] = round_up(residual);
      largest = std::max({largest, std::abs(block.mean[i]), std::abs(block.slope_u[i]),
                          std::abs(block.slope_v[i]), residuals[k][i], moments[k][i / 3],
                          roundings[k][i / 3]});
    }
  }
  CompactFirstOrderTree out;
  out.resolution = tree.resolution;
  out.with_data = with_data;
  out.slopes = tree.slopes;
  // The largest coefficient below 2^15 in units of the scale, and so below the largest half
  // (65504) after rounding up; the scale a normal float, so that halves times it are exact.
  out.scale = largest > 0 ? std::ldexp(1.0f, std::max(std::ilogb(largest) - 14, -126)) : 1;
  out.blocks.resize(tree.blocks.size());
  for (std::size_t k = 0; k < tree.blocks.size(); ++k) {
    const FirstOrderBlock& from = tree.blocks[k];
    CompactFirstOrderBlock& to = out.blocks[k];
    // Breadth first, a block's children follow one another in quadrant order.
    for (int q = 0; q < 4; ++q) {
      const std::int32_t child = from.child[std::size_t(q)];
      if (child < 0) continue;
      if (to.children == 0) to.first_child = child;
      to.children = std::uint8_t(to.children | 1u << q);
      if (to.child_block(q) != child)
        throw std::logic_error("first-order tree whose blocks' children are not consecutive");
    }
    for (std::size_t i = 0; i < 12; ++i) {
      to.halves[i] = float_to_half(from.mean[i] / out.scale);
      to.halves[12 + i] = float_to_half(from.slope_u[i] / out.scale);
      to.halves[24 + i] = float_to_half(from.slope_v[i] / out.scale);
      to.halves[36 + i] = half_at_least(residuals[k][i] / out.scale);
    }
    for (std::size_t q = 0; q < 4; ++q) {
      to.halves[48 + q] = half_at_least(moments[k][q] / out.scale);
      to.halves[52 + q] = half_at_least(roundings[k][q] / out.scale);
    }
  }
  return out;
}

}  // namespace basis
