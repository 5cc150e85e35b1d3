// The simultaneous descent of two first-order trees, level by level in SIMD lanes.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include "basis/core/half.h"
#include "basis/study/first_order_tree.h"
#include "float_rounding.h"

namespace basis {

namespace {

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

// Block k of a tree as sixteen lanes a group: its coefficients; its residual, the data's for a
// tree built from packed trees; what multiplies the other side's absolute slopes in a pair's
// bound (the data moment) and its absolute mean (the data's rounding); how far the coefficients
// may lie from the exact planes' beyond float rounding (compact blocks: their rounding to
// halves); and the charges.
struct BlockLanes {
  Lanes mean, slope_u, slope_v, residual, moment, rounding, coefficient_rounding, charge;
};

void load_block(const FirstOrderTree& tree, std::size_t k, float, BlockLanes& lanes) {
  const FirstOrderBlock& block = tree.blocks[k];
  load(block.mean, lanes.mean);
  load(block.slope_u, lanes.slope_u);
  load(block.slope_v, lanes.slope_v);
  load(block.residual, lanes.residual);
  lanes.coefficient_rounding = Lanes{};
  if (tree.data.empty()) {
    lanes.moment = lanes.rounding = lanes.charge = Lanes{};
    return;
  }
  const FirstOrderData& data = tree.data[k];
  load(data.residual, lanes.residual);
  load(data.moment, lanes.moment);
  load(data.rounding, lanes.rounding);
  load(data.charge, lanes.charge);
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

// Four halves, one per quadrant, times scale, each in its quadrant's three lanes.
void load_quadrant_halves(const std::uint16_t* halves, float scale, Lanes& lanes) {
  lanes = Lanes{};
  for (int i = 0; i < 12; ++i)
    lanes[i] = half_to_float(halves[i / 3]);
  lanes *= scale;
}

void load_block(const CompactFirstOrderTree& tree, std::size_t k, float scale, BlockLanes& lanes) {
  const CompactFirstOrderBlock& block = tree.blocks[k];
  load_halves(&block.halves[0], scale, lanes.mean);
  load_halves(&block.halves[12], scale, lanes.slope_u);
  load_halves(&block.halves[24], scale, lanes.slope_v);
  load_halves(&block.halves[36], scale, lanes.residual);
  // Rounded to nearest halves from floats: within 2^-11 of the largest (and a float's 2^-24
  // before it), or half a subnormal step of scale.
  Lanes m, u, v;
  absolute(lanes.mean, m);
  absolute(lanes.slope_u, u);
  absolute(lanes.slope_v, v);
  const Lanes largest = m > u ? (m > v ? m : v) : (u > v ? u : v);
  lanes.coefficient_rounding = 0x1.02p-11f * largest + 0x1p-24f * scale;
  lanes.charge = Lanes{};
  if (!tree.with_data) {
    lanes.moment = lanes.rounding = Lanes{};
    return;
  }
  // The data's moments and rounding, one per quadrant for its three channels.
  load_quadrant_halves(&block.halves[48], scale, lanes.moment);
  load_quadrant_halves(&block.halves[52], scale, lanes.rounding);
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
      : a_(&a),
        b_(&b),
        scale_(scale_of(b)),
        accuracy_(accuracy),
        charges_(has_charges(a) || has_charges(b)) {
    if (a.blocks.empty() || b.blocks.empty())
      throw std::invalid_argument("first-order convolution of an empty tree");
    if (a.resolution != b.resolution)
      throw std::invalid_argument("first-order trees of resolutions " +
                                  std::to_string(a.resolution) + " and " +
                                  std::to_string(b.resolution) + " do not convolve");
    if (a.slopes != b.slopes)
      throw std::invalid_argument(
          "a first-order tree of planes and one of means do not convolve (the product would "
          "leave out the slopes' cross term)");
    if (!(accuracy >= 0) || !std::isfinite(accuracy))
      throw std::invalid_argument("first-order convolution to an accuracy of " +
                                  std::to_string(accuracy));
    std::array<double, 3> estimate{};
    BlockLanes la, lb;
    load_block(a, 0, 1, la);
    load_block(*b_, 0, scale_, lb);
    const Lanes product = la.mean * lb.mean + la.slope_u * lb.slope_u + la.slope_v * lb.slope_v;
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
      BlockLanes la, lb;
      load_block(*a_, std::size_t(pair.a), 1, la);
      load_block(*b_, std::size_t(pair.b), scale_, lb);
      const Lanes product = la.mean * lb.mean + la.slope_u * lb.slope_u + la.slope_v * lb.slope_v;
      // Absolute slopes and means, raised by what their rounding may have lowered them.
      Lanes slopes_a, slopes_b, mean_a, mean_b, magnitude;
      absolute(la.slope_u, slopes_a);
      absolute(la.slope_v, magnitude);
      slopes_a += magnitude + 2.0f * la.coefficient_rounding;
      absolute(lb.slope_u, slopes_b);
      absolute(lb.slope_v, magnitude);
      slopes_b += magnitude + 2.0f * lb.coefficient_rounding;
      absolute(la.mean, mean_a);
      absolute(lb.mean, mean_b);
      mean_a += la.coefficient_rounding;
      mean_b += lb.coefficient_rounding;
      const Lanes sum_a = mean_a + slopes_a, sum_b = mean_b + slopes_b;
      absolute(product, magnitude);
      const Lanes pair_bound = la.residual * lb.residual + sum_a * lb.coefficient_rounding +
                               sum_b * la.coefficient_rounding + slopes_a * lb.moment +
                               slopes_b * la.moment + mean_a * lb.rounding + mean_b * la.rounding +
                               kRounding * sum_a * sum_b + kUnderflow;
      const Ints within_lanes = pair_bound <= half_accuracy_ * magnitude + budget_;
      const unsigned within = horizontal_or(within_lanes & kLaneBits);
      unsigned stops = 0;  // bit q: quadrant q stops
      for (int q = 0; q < 4; ++q) {
        const std::int32_t child_a = ba.child_block(q), child_b = bb.child_block(q);
        const bool go_on = child_a >= 0 && child_b >= 0;
        if (go_on && (accuracy_ == 0 || ((within >> (3 * q)) & 7) != 7)) {
          next_[count++] = {child_a, child_b};
          prefetch(a_->blocks[std::size_t(child_a)]);
          prefetch(b_->blocks[std::size_t(child_b)]);
          prefetch_data(*a_, child_a);
          prefetch_data(*b_, child_b);
        } else {
          stops |= 1u << q;
        }
      }
      Lanes stop;
      load(kQuadrantLanes[stops], stop);
      add_widened(stop * product, value_low, value_high);
      Lanes bound = stop * pair_bound;
      if (charges_) {
        // Where the descent goes on, the terms whose leaf the quadrant is, against the other
        // side's RMS over it (at most its absolute coefficients, its residual and what their
        // rounding moved): each term's bound charged once, as the terms' own descents would.
        Lanes going_on;
        load(kQuadrantLanes[~stops & 15u], going_on);
        bound += going_on * (la.charge * (sum_b + lb.residual) + lb.charge * (sum_a + la.residual));
      }
      add_widened(bound, bound_low, bound_high);
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
  static void prefetch_data(const FirstOrderTree& tree, std::int32_t k) {
    if (!tree.data.empty()) prefetch(tree.data[std::size_t(k)]);
  }
  static void prefetch_data(const CompactFirstOrderTree&, std::int32_t) {}
  static bool has_charges(const FirstOrderTree& tree) { return !tree.data.empty(); }
  static bool has_charges(const CompactFirstOrderTree&) { return false; }

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
  bool charges_;
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

}  // namespace basis
