#include "basis/core/packed_tree.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "basis/core/refined_values.h"

namespace basis {

float PackedTreeView::largest_deviation_bound(int n, int g, int c, int q, int level) const {
  const float b = bound(n, g, c, q);
  if (shape_.bounds == BoundKind::linf) return b;
  // RMS x sqrt(texels): no texel deviates more than the RMS of all of them allows.
  const double texels_per_side = double(shape_.resolution) / double(1 << level);
  return float(double(b) * std::max(1.0, texels_per_side) * (1 + 1e-6));
}

float half_value_scale(double largest) {
  return largest > 0 ? std::ldexp(1.0f, std::max(std::ilogb(largest) - 14, -126)) : 1.0f;
}

std::uint8_t bound_code_at_least(double bound, float bound_scale) {
  // Both products reach it: the float one (PackedTreeView::bound) and the exact one (the packed
  // descents scale their sums by bound_scale in double), which rounding may leave below it.
  auto reaches = [&](int code) {
    const float value = bound_code_value(std::uint8_t(code));
    return double(value * bound_scale) >= bound && double(value) * double(bound_scale) >= bound;
  };
  // Estimated from the bound's float bits, then settled against the decoded values.
  const auto bits = std::bit_cast<std::uint32_t>(float(bound / bound_scale));
  int code = bits <= kBoundCodeBias ? 0 : int(std::min((bits - kBoundCodeBias) >> 20, 255u));
  while (code < 255 && !reaches(code))
    ++code;
  while (code > 0 && reaches(code - 1))
    --code;
  return std::uint8_t(code);
}

namespace {

PackedTree pack_tree(const Quadtree& tree, BoundKind bounds, int bounded_groups, bool exact_texels,
                     ValueEncoding encoding) {
  const QuadtreeView source = tree.view();
  const QuadtreeShape& s = tree.shape;
  if (bounded_groups < 1 || bounded_groups > s.bounded_groups)
    throw std::invalid_argument("cannot keep bounds of " + std::to_string(bounded_groups) +
                                " groups of a tree that has them for " +
                                std::to_string(s.bounded_groups));
  PackedTree out;
  out.shape = {s.resolution, s.channels, s.groups, bounds, bounded_groups, exact_texels};
  if (exact_texels && s.channels == 3 && s.groups == 1) out.shape.value_encoding = encoding;
  const int count = source.node_count();
  const bool have_deviations = !tree.deviations.empty();
  auto source_bound = [&](int node, int g, int c, int q) -> double {
    if (bounds == BoundKind::l2 && have_deviations)
      return tree.deviations[std::size_t(node) * s.error_stride() + g * s.channels + c].lane[q];
    return source.error(node, g, c, q);
  };

  // Scales: the largest value a little below the largest half; bounds up to the largest.
  double largest = 0;
  for (int n = 0; n < count; ++n)
    for (int g = 0; g < s.groups; ++g)
      for (int c = 0; c < s.channels; ++c)
        for (int q = 0; q < 4; ++q)
          largest = std::max(largest, double(std::abs(source.value(n, g, c, q))));
  if (largest >= kPackedValueLimit)
    throw std::overflow_error("values of 2^125 (4.3e37) or more cannot be packed");
  out.scales.value_scale = half_value_scale(largest);
  const double value_scale = out.scales.value_scale;
  // Every node's value words, once (halves, or a shared-exponent word per quadrant); bounds for
  // the packed values: the source's plus how far each value moved.
  const bool shared = out.shape.shared_values();
  const std::size_t value_words = std::size_t(out.shape.value_words());
  std::vector<std::uint32_t> values(std::size_t(count) * value_words);
  const std::size_t bounds_per_node = std::size_t(bounded_groups) * s.channels * 4;
  std::vector<double> moved_bounds(std::size_t(count) * bounds_per_node);
  double largest_bound = 0;
  for (int n = 0; n < count; ++n) {
    std::uint32_t* w = values.data() + std::size_t(n) * value_words;
    std::array<std::uint16_t, 4 * 3 * 3> h{};  // halves: at most 3 groups of 3 channels
    if (shared)
      for (int q = 0; q < 4; ++q) {
        std::array<float, 3> rgb;
        for (int c = 0; c < 3; ++c)
          rgb[std::size_t(c)] = float(double(source.value(n, 0, c, q)) / value_scale);
        if (!(rgb[0] >= 0 && rgb[1] >= 0 && rgb[2] >= 0))
          throw std::invalid_argument("shared-exponent values must be >= 0, a quadrant holds (" +
                                      std::to_string(rgb[0]) + ", " + std::to_string(rgb[1]) +
                                      ", " + std::to_string(rgb[2]) + ")");
        w[q] = encode_shared_exponent(rgb);
      }
    for (int g = 0; g < s.groups; ++g)
      for (int c = 0; c < s.channels; ++c)
        for (int q = 0; q < 4; ++q) {
          const float v = source.value(n, g, c, q);
          float packed;
          if (shared) {
            packed = shared_exponent_channel(w[q], c);
          } else {
            const std::uint16_t half = float_to_half(float(double(v) / value_scale));
            h[(g * s.channels + c) * 4 + q] = half;
            packed = half_to_float(half);
          }
          if (g >= bounded_groups) continue;
          const double moved = std::abs(double(packed) * value_scale - double(v));
          const double b = source_bound(n, g, c, q) + moved;
          moved_bounds[std::size_t(n) * bounds_per_node + (g * s.channels + c) * 4 + q] = b;
          largest_bound = std::max(largest_bound, b);
        }
    if (!shared) std::memcpy(w, h.data(), value_words * sizeof(std::uint32_t));
  }
  if (largest_bound >= kPackedValueLimit)
    throw std::overflow_error("error bounds of 2^125 (4.3e37) or more cannot be packed");
  float bound_scale = float(largest_bound);
  if (double(bound_scale) < largest_bound) bound_scale = std::nextafter(bound_scale, INFINITY);
  out.scales.bound_scale = bound_scale > 0 ? bound_scale : 1.0f;
  const float scale = out.scales.bound_scale;
  auto code_for = [scale](double b) { return bound_code_at_least(b, scale); };

  // Breadth-first order: node i's children get the next indices, in quadrant order; texel
  // nodes, the last level, hold values alone with exact texels.
  std::vector<int> order{0}, depth(std::size_t(count), 0);
  order.reserve(count);
  for (std::size_t i = 0; i < order.size(); ++i)
    for (int q = 0; q < 4; ++q)
      if (const int child = source.child(order[i], q)) {
        depth[std::size_t(child)] = depth[std::size_t(order[i])] + 1;
        order.push_back(child);
      }
  out.texel_start = std::size_t(count);
  if (exact_texels) {
    const int texel_depth = out.shape.texel_depth();
    for (std::size_t i = 0; i < order.size(); ++i)
      if (depth[std::size_t(order[i])] == texel_depth) {
        out.texel_start = i;
        break;
      }
    for (std::size_t i = out.texel_start; i < order.size(); ++i)
      for (int g = 0; g < bounded_groups; ++g)
        for (int c = 0; c < s.channels; ++c)
          for (int q = 0; q < 4; ++q)
            if (source_bound(order[i], g, c, q) != 0)
              throw std::invalid_argument(
                  "texels are not exact: a single-texel quadrant has a bound of " +
                  std::to_string(source_bound(order[i], g, c, q)));
  }
  out.words.assign(packed_node_offset(out.shape, out.texel_start, std::size_t(count)), 0);
  order.assign(1, 0);
  for (std::size_t i = 0; i < order.size(); ++i) {
    const int n = order[i];
    std::uint32_t* w = out.words.data() + packed_node_offset(out.shape, out.texel_start, i);
    const std::uint32_t* node_values = values.data() + std::size_t(n) * value_words;
    if (i >= out.texel_start) {  // a texel node: values alone
      std::copy_n(node_values, value_words, w);
      continue;
    }
    std::uint32_t mask = 0;
    const auto first = std::uint32_t(order.size());
    for (int q = 0; q < 4; ++q)
      if (const int child = source.child(n, q)) {
        mask |= 1u << q;
        order.push_back(child);
      }
    w[0] = mask ? first << 4 | mask : 0;
    std::copy_n(node_values, value_words, w + 1);
    auto* codes = reinterpret_cast<std::uint8_t*>(w + 1 + value_words);
    for (std::size_t k = 0; k < bounds_per_node; ++k)
      codes[k] = code_for(moved_bounds[std::size_t(n) * bounds_per_node + k]);
  }
  // Nodes refined over all four quadrants: the values and bounds their children determine, so
  // that files may leave them out (refined_values.h).
  derive_refined_values(out);
  // Deriving may double the bound scale until the derived bounds code.
  if (out.scales.bound_scale > kLargestBoundScale)
    throw std::overflow_error("error bounds of 2^125 (4.3e37) or more cannot be packed");
  return out;
}

}  // namespace

PackedTree pack(const Quadtree& tree, BoundKind bounds, int bounded_groups) {
  return pack_tree(tree, bounds, bounded_groups, false, ValueEncoding::halves);
}

PackedTree pack_exact_texels(const Quadtree& tree, BoundKind bounds, ValueEncoding encoding) {
  return pack_tree(tree, bounds, 1, true, encoding);
}

}  // namespace basis
