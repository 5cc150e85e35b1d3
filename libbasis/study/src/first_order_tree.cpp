#include "basis/study/first_order_tree.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include "basis/core/half.h"

namespace basis {

namespace {

// A node's sums over its texels, in texel units about the node's centre: the function, its
// first moments in u and v, and its square.
struct Moments {
  double sum = 0, sum_u = 0, sum_v = 0, sum_squares = 0;
};

// One level of the grid's pyramid: per node and channel its moments, and whether the function
// is constant on it (with that constant).
struct Level {
  int side = 0;  // nodes per row
  std::vector<std::array<Moments, 3>> moments;
  std::vector<std::array<float, 3>> constant_value;
  std::vector<char> constant;
};

// Sixteen float lanes and eight double lanes, one vector each where the machine has them.
using Lanes = float __attribute__((vector_size(64)));
using Wide = double __attribute__((vector_size(64)));

using Ints = std::int32_t __attribute__((vector_size(64)));

// Bit i in lane i, for the twelve lanes in use.
constexpr Ints kLaneBits = {1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024, 2048, 0, 0, 0, 0};

// For each set of quadrants (bit q for quadrant q), 1 in their lanes and 0 elsewhere.
constexpr std::array<std::array<float, 16>, 16> quadrant_lanes() {
  std::array<std::array<float, 16>, 16> lanes{};
  for (unsigned set = 0; set < 16; ++set)
    for (int i = 0; i < 12; ++i)
      lanes[set][std::size_t(i)] = (set >> (i / 3)) & 1 ? 1.0f : 0.0f;
  return lanes;
}
constexpr std::array<std::array<float, 16>, 16> kQuadrantLanes = quadrant_lanes();

// Vectors pass by reference: where the machine lacks 64-byte registers, passing them by value
// would take an ABI that differs from one build to another.
unsigned horizontal_or(const Ints& lanes) {
  Ints x = lanes;
  x |= __builtin_shufflevector(x, x, 8, 9, 10, 11, 12, 13, 14, 15, 0, 1, 2, 3, 4, 5, 6, 7);
  x |= __builtin_shufflevector(x, x, 4, 5, 6, 7, 0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2, 3);
  x |= __builtin_shufflevector(x, x, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1);
  x |= __builtin_shufflevector(x, x, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0);
  return unsigned(x[0]);
}

void load(const std::array<float, 16>& values, Lanes& lanes) {
  std::memcpy(&lanes, values.data(), sizeof lanes);
}

// |x| lane by lane, into `magnitude`.
void absolute(const Lanes& x, Lanes& magnitude) {
  using Bits = std::uint32_t __attribute__((vector_size(64)));
  magnitude = Lanes(Bits(x) & 0x7fffffffu);
}

// Adds the sixteen lanes of x to two vectors of eight doubles.
void add_widened(const Lanes& x, Wide& low, Wide& high) {
  low += __builtin_convertvector(__builtin_shufflevector(x, x, 0, 1, 2, 3, 4, 5, 6, 7), Wide);
  high +=
      __builtin_convertvector(__builtin_shufflevector(x, x, 8, 9, 10, 11, 12, 13, 14, 15), Wide);
}

// |a| + |b| + |c| lane by lane.
void absolute_sum(const Lanes& a, const Lanes& b, const Lanes& c, Lanes& sum) {
  Lanes magnitude;
  absolute(a, sum);
  absolute(b, magnitude);
  sum += magnitude;
  absolute(c, magnitude);
  sum += magnitude;
}

// The largest texel a tree takes: products of coefficients stay far from float overflow, and
// what float underflow loses stays within kUnderflow (below).
constexpr float kLargestValue = 0x1p60f;

// A double rounded up to a float.
float round_up(double x) {
  float f = float(x);
  if (double(f) < x) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

// The pyramid of a grid's group 0, texels first.
std::vector<Level> pyramid(const Grid& grid) {
  const int n = grid.resolution;
  std::vector<Level> levels(1);
  Level& texels = levels[0];
  texels.side = n;
  texels.moments.resize(std::size_t(n) * n);
  texels.constant_value.resize(texels.moments.size());
  texels.constant.assign(texels.moments.size(), 1);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x)
      for (int c = 0; c < 3; ++c) {
        const float f = grid.at(0, std::min(c, grid.channels - 1), x, y);
        if (!std::isfinite(f) || std::abs(f) > kLargestValue)
          throw std::invalid_argument(
              "first-order tree of a value that is not finite or beyond "
              "2^60: " +
              std::to_string(f));
        const std::size_t i = std::size_t(y) * n + x;
        texels.moments[i][c] = {f, 0, 0, double(f) * f};
        texels.constant_value[i][c] = f;
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

// Quadrant q of a block from node i of a level whose nodes are `texels` texels wide.
void set_quadrant(FirstOrderBlock& block, int q, const Level& level, std::size_t i, int texels) {
  const double count = double(texels) * texels;
  const double slope_scale = std::sqrt(12.0) / (texels * count);
  for (int c = 0; c < 3; ++c) {
    const int lane = 3 * q + c;
    if (level.constant[i]) {
      block.mean[lane] = level.constant_value[i][c];
      continue;  // exact: slopes and residual 0
    }
    const Moments& m = level.moments[i][c];
    const double mean = m.sum / count, slope_u = m.sum_u * slope_scale,
                 slope_v = m.sum_v * slope_scale, mean_square = m.sum_squares / count;
    // The sums' rounding moves the difference by a few 2^-40 of the mean square at most.
    const double residual_square =
        std::max(0.0, mean_square - mean * mean - slope_u * slope_u - slope_v * slope_v) +
        0x1p-34 * mean_square;
    block.mean[lane] = float(mean);
    block.slope_u[lane] = float(slope_u);
    block.slope_v[lane] = float(slope_v);
    block.residual[lane] = round_up(std::sqrt(residual_square) * (1 + 0x1p-50));
  }
}

// Appends the block of node (x, y) of levels[level]'s quadrants, then theirs; returns its index.
std::int32_t append_block(const std::vector<Level>& levels, int level, int x, int y,
                          std::vector<FirstOrderBlock>& blocks) {
  const std::int32_t index = std::int32_t(blocks.size());
  blocks.emplace_back();
  const Level& below = levels[level - 1];
  const int texels = 1 << (level - 1);
  for (int q = 0; q < 4; ++q) {
    const int cx = 2 * x + (q & 1), cy = 2 * y + (q >> 1);
    const std::size_t j = std::size_t(cy) * below.side + cx;
    set_quadrant(blocks[index], q, below, j, texels);
  }
  for (int q = 0; q < 4; ++q) {
    const int cx = 2 * x + (q & 1), cy = 2 * y + (q >> 1);
    const std::size_t j = std::size_t(cy) * below.side + cx;
    if (level - 1 > 0 && !below.constant[j]) {
      const std::int32_t child = append_block(levels, level - 1, cx, cy, blocks);
      blocks[index].child[q] = child;
    }
  }
  return index;
}

}  // namespace

FirstOrderTree first_order_tree(const Grid& grid) {
  const int n = grid.resolution;
  if (n < 2 || (n & (n - 1)) != 0)
    throw std::invalid_argument("first-order tree of a grid of resolution " + std::to_string(n) +
                                " (a power of two from 2)");
  if (grid.channels != 1 && grid.channels != 3)
    throw std::invalid_argument("first-order tree of a grid of " + std::to_string(grid.channels) +
                                " channels (1 or 3)");
  const std::vector<Level> levels = pyramid(grid);
  std::vector<FirstOrderBlock> depth_first;
  append_block(levels, int(levels.size()) - 1, 0, 0, depth_first);
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
  tree.resolution = n;
  tree.blocks.reserve(depth_first.size());
  for (const std::int32_t k : order) {
    tree.blocks.push_back(depth_first[std::size_t(k)]);
    for (std::int32_t& child : tree.blocks.back().child)
      if (child >= 0) child = renumbered[std::size_t(child)];
  }
  return tree;
}

FirstOrderTree without_slopes(const FirstOrderTree& tree) {
  FirstOrderTree flat = tree;
  for (FirstOrderBlock& block : flat.blocks)
    for (std::size_t i = 0; i < 12; ++i) {
      const double residual = block.residual[i], u = block.slope_u[i], v = block.slope_v[i];
      // The slopes were rounded to nearest floats: up by 2^-22 for that.
      block.residual[i] = round_up(std::sqrt(residual * residual + u * u + v * v) * (1 + 0x1p-22));
      block.slope_u[i] = block.slope_v[i] = 0;
    }
  return flat;
}

namespace {

// The four groups of a block as sixteen lanes each, and per lane the most by which the block's
// coefficients may differ from the exact planes' beyond float rounding (0 for float blocks).
void load_block(const FirstOrderBlock& block, float, Lanes& mean, Lanes& slope_u, Lanes& slope_v,
                Lanes& residual, Lanes& rounding) {
  load(block.mean, mean);
  load(block.slope_u, slope_u);
  load(block.slope_v, slope_v);
  load(block.residual, residual);
  rounding = Lanes{};
}

// Twelve halves from `halves` on, times scale, in lanes 0..11; lanes 12..15 zero.
void load_halves(const std::uint16_t* halves, float scale, Lanes& lanes) {
#if defined(__AVX512F__)
  __m256i bits;
  std::memcpy(&bits, halves, sizeof bits);  // sixteen halves, the last four masked off
  const __m512 values = _mm512_maskz_cvtph_ps(0x0fff, bits);
  std::memcpy(&lanes, &values, sizeof lanes);
#else
  lanes = Lanes{};
  for (int i = 0; i < 12; ++i)
    lanes[i] = half_to_float(halves[i]);
#endif
  lanes *= scale;
}

void load_block(const CompactFirstOrderBlock& block, float scale, Lanes& mean, Lanes& slope_u,
                Lanes& slope_v, Lanes& residual, Lanes& rounding) {
  load_halves(&block.halves[0], scale, mean);
  load_halves(&block.halves[12], scale, slope_u);
  load_halves(&block.halves[24], scale, slope_v);
  load_halves(&block.halves[36], scale, residual);
  // Rounded to nearest halves from floats: within 2^-11 of the largest (and a float's 2^-24
  // before it), or half a subnormal step of scale.
  Lanes m, u, v;
  absolute(mean, m);
  absolute(slope_u, u);
  absolute(slope_v, v);
  const Lanes largest = m > u ? (m > v ? m : v) : (u > v ? u : v);
  rounding = 0x1.02p-11f * largest + 0x1p-24f * scale;
}

float scale_of(const FirstOrderTree&) {
  return 1;
}
float scale_of(const CompactFirstOrderTree& tree) {
  return tree.scale;
}

// Per pair of quadrants, what the coefficients' rounding to floats (at most 2^-24 of each) and
// the float arithmetic of the planes' product (a few 2^-24 more) may move it: within 2^-20 of the
// product of their absolute sums. The pairs' bounds, computed in floats, are scaled up by 2^-20
// for their own rounding at the end.
constexpr float kRounding = 0x1p-20f;
// What float underflow may lose per pair of quadrants, beyond that: subnormal coefficients and
// products lose at most a few 2^-149 each, times coefficients of at most 2^60 (kLargestValue).
constexpr float kUnderflow = 0x1p-80f;

// One descent of a against b, a level at a time: each level's pairs are queued, and their blocks
// fetched, while the level above is worked through, so that memory latency overlaps the
// arithmetic.
template <typename Tree>
class Descent {
 public:
  Descent(const FirstOrderTree& a, const Tree& b, double accuracy)
      : a_(&a), b_(&b), scale_(scale_of(b)), accuracy_(accuracy) {
    if (a.blocks.empty() || b.blocks.empty())
      throw std::invalid_argument("first-order convolution of an empty tree");
    if (a.resolution != b.resolution)
      throw std::invalid_argument("first-order trees of resolutions " +
                                  std::to_string(a.resolution) + " and " +
                                  std::to_string(b.resolution) + " do not convolve");
    if (!(accuracy >= 0) || !std::isfinite(accuracy))
      throw std::invalid_argument("first-order convolution to an accuracy of " +
                                  std::to_string(accuracy));
    std::array<double, 3> estimate{};
    Lanes ma, ua, va, ra, mb, ub, vb, rb, rounding;
    load_block(a.blocks[0], 1, ma, ua, va, ra, rounding);
    load_block(b.blocks[0], scale_, mb, ub, vb, rb, rounding);
    const Lanes product = ma * mb + ua * ub + va * vb;
    for (int i = 0; i < 12; ++i)
      estimate[std::size_t(i % 3)] += 0.25 * double(product[i]);
    half_accuracy_ = float(accuracy / 2);
    for (int i = 0; i < 12; ++i)
      budget_[i] = half_accuracy_ * float(std::abs(estimate[std::size_t(i % 3)]));
    level_.reserve(64);
    next_.reserve(64);
    level_.push_back({0, 0});
  }

  bool done() const { return level_.empty(); }

  // Descends one level.
  void step() {
    // The level's sums, scaled by its quadrants' area in doubles (no underflow) at its end.
    Wide value_low{}, value_high{}, bound_low{}, bound_high{};
    next_.resize(4 * level_.size());
    std::size_t count = 0;
    pairs_ += level_.size();
    for (const Pair& pair : level_) {
      const FirstOrderBlock& ba = a_->blocks[std::size_t(pair.a)];
      const auto& bb = b_->blocks[std::size_t(pair.b)];
      // In floats, twelve lanes at once: the rounding term covers the arithmetic's rounding.
      Lanes ma, ua, va, ra, mb, ub, vb, rb, rounding_a, rounding_b;
      load_block(ba, 1, ma, ua, va, ra, rounding_a);
      load_block(bb, scale_, mb, ub, vb, rb, rounding_b);
      const Lanes product = ma * mb + ua * ub + va * vb;
      Lanes sum_a, sum_b, magnitude;
      absolute_sum(ma, ua, va, sum_a);
      absolute_sum(mb, ub, vb, sum_b);
      absolute(product, magnitude);
      const Lanes pair_bound =
          ra * rb + sum_a * rounding_b + kRounding * sum_a * sum_b + kUnderflow;
      const Ints within_lanes = pair_bound <= half_accuracy_ * magnitude + budget_;
      const unsigned within = horizontal_or(within_lanes & kLaneBits);
      unsigned stops = 0;  // bit q: quadrant q stops
      for (int q = 0; q < 4; ++q) {
        const bool go_on = ba.child[q] >= 0 && bb.child[q] >= 0;
        if (go_on && (accuracy_ == 0 || ((within >> (3 * q)) & 7) != 7)) {
          next_[count++] = {ba.child[q], bb.child[q]};
          prefetch(a_->blocks[std::size_t(ba.child[q])]);
          prefetch(b_->blocks[std::size_t(bb.child[q])]);
        } else {
          stops |= 1u << q;
        }
      }
      Lanes stop;
      load(kQuadrantLanes[stops], stop);
      add_widened(stop * product, value_low, value_high);
      add_widened(stop * pair_bound, bound_low, bound_high);
    }
    const double area = std::ldexp(1.0, -2 * depth_);  // of the level's quadrants
    value_low_ += area * value_low;
    value_high_ += area * value_high;
    bound_low_ += area * bound_low;
    bound_high_ += area * bound_high;
    next_.resize(count);
    level_.swap(next_);
    ++depth_;
  }

  FirstOrderConvolution result() const {
    std::array<double, 16> value, bound;
    for (int i = 0; i < 8; ++i) {
      value[std::size_t(i)] = value_low_[i];
      value[std::size_t(8 + i)] = value_high_[i];
      bound[std::size_t(i)] = bound_low_[i];
      bound[std::size_t(8 + i)] = bound_high_[i];
    }
    Convolution out;
    for (std::size_t c = 0; c < 3; ++c) {
      const double v = value[c] + value[3 + c] + value[6 + c] + value[9 + c];
      const double e = bound[c] + bound[3 + c] + bound[6 + c] + bound[9 + c];
      out.value[c] = float(v);
      // The pairs' bounds' rounding in floats, the sums' (far below the pairs' rounding terms)
      // and the value's to float.
      out.bound[c] = round_up(e * (1 + 0x1p-20) + 0x1p-24 * std::abs(v));
    }
    return {out, pairs_};
  }

 private:
  struct Pair {
    std::int32_t a, b;
  };
  template <typename Block>
  static void prefetch(const Block& block) {
    const char* bytes = reinterpret_cast<const char*>(&block);
    for (std::size_t offset = 0; offset < sizeof block; offset += 64)
      __builtin_prefetch(bytes + offset);
  }

  const FirstOrderTree* a_;
  const Tree* b_;
  float scale_;
  double accuracy_;
  float half_accuracy_ = 0;
  Lanes budget_{};  // accuracy / 2 x E, lane by lane, E the roots' planes' estimate
  Wide value_low_{}, value_high_{}, bound_low_{}, bound_high_{};
  std::vector<Pair> level_, next_;
  int depth_ = 1;
  std::size_t pairs_ = 0;
};

template <typename Tree>
FirstOrderConvolution descend(const FirstOrderTree& a, const Tree& b, double accuracy) {
  Descent<Tree> descent(a, b, accuracy);
  while (!descent.done())
    descent.step();
  return descent.result();
}

}  // namespace

FirstOrderConvolution convolve_first_order(const FirstOrderTree& a, const FirstOrderTree& b,
                                           double accuracy) {
  return descend(a, b, accuracy);
}

FirstOrderConvolution convolve_first_order(const FirstOrderTree& a, const CompactFirstOrderTree& b,
                                           double accuracy) {
  return descend(a, b, accuracy);
}

CompactFirstOrderTree compact(const FirstOrderTree& tree) {
  float largest = 0;
  for (const FirstOrderBlock& block : tree.blocks)
    for (std::size_t i = 0; i < 12; ++i)
      largest = std::max({largest, std::abs(block.mean[i]), std::abs(block.slope_u[i]),
                          std::abs(block.slope_v[i]), block.residual[i]});
  CompactFirstOrderTree out;
  out.resolution = tree.resolution;
  // The largest coefficient below 2^15 in units of the scale, and so below the largest half
  // (65504) after rounding up; the scale a normal float, so that halves times it are exact.
  out.scale = largest > 0 ? std::ldexp(1.0f, std::max(std::ilogb(largest) - 14, -126)) : 1;
  out.blocks.resize(tree.blocks.size());
  for (std::size_t k = 0; k < tree.blocks.size(); ++k) {
    const FirstOrderBlock& from = tree.blocks[k];
    CompactFirstOrderBlock& to = out.blocks[k];
    to.child = from.child;
    for (std::size_t i = 0; i < 12; ++i) {
      to.halves[i] = float_to_half(from.mean[i] / out.scale);
      to.halves[12 + i] = float_to_half(from.slope_u[i] / out.scale);
      to.halves[24 + i] = float_to_half(from.slope_v[i] / out.scale);
      std::uint16_t residual = float_to_half(from.residual[i] / out.scale);
      if (half_to_float(residual) < from.residual[i] / out.scale) ++residual;  // round up
      to.halves[36 + i] = residual;
    }
  }
  return out;
}

}  // namespace basis
