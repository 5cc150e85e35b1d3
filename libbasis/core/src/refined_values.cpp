#include "basis/core/refined_values.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "basis/core/shared_exponent.h"

namespace basis {
namespace {

constexpr std::uint32_t kAllQuadrants = 15;
constexpr std::size_t kBoundsPerNode = 3 * 4;  // channels x quadrants of a shared-value node

// One pass over the tree, children before parents. Returns whether every derived bound fits the
// tree's bound scale (a bound that does not gets code 255, which does not hold).
bool derive_pass(PackedTree& tree, std::vector<double>& offsets) {
  const PackedShape& shape = tree.shape;
  const std::size_t texel_start = tree.texel_start;
  const std::size_t count = std::size_t(tree.node_count());
  const std::size_t full_words = std::size_t(shape.words_per_node());
  const double value_scale = tree.scales.value_scale;
  // Codes' values as PackedTreeView::bound computes them: the float product.
  auto code_value = [&](std::uint8_t code) {
    return double(bound_code_value(code) * tree.scales.bound_scale);
  };
  const double largest_codable = code_value(255);
  // Bounds on |mean of a quadrant's texels - its value|, per channel and quadrant of the
  // derived nodes (negative for the others).
  offsets.assign(texel_start * kBoundsPerNode, -1);
  bool fits = true;
  for (std::size_t n = texel_start; n-- > 0;) {
    std::uint32_t* node = tree.words.data() + n * full_words;
    const std::uint32_t link = node[0];
    if ((link & kAllQuadrants) != kAllQuadrants) continue;
    const std::size_t first = link >> 4;
    if (first <= n || first + 4 > count)
      throw std::invalid_argument("node " + std::to_string(n) + " links to nodes " +
                                  std::to_string(first) + ".." + std::to_string(first + 3) +
                                  ", not after it among the tree's " + std::to_string(count));
    auto* codes = reinterpret_cast<std::uint8_t*>(node + 1 + shape.value_words());
    for (std::size_t q = 0; q < 4; ++q) {
      const std::size_t k = first + q;
      const bool texel = k >= texel_start;
      const std::uint32_t* child = tree.words.data() + packed_node_offset(shape, texel_start, k);
      const std::uint32_t* child_values = texel ? child : child + 1;
      const auto* child_codes =
          texel ? nullptr : reinterpret_cast<const std::uint8_t*>(child_values + 4);
      std::array<std::array<double, 4>, 3> v{};
      std::array<double, 3> mean{};
      std::array<float, 3> scaled_mean{};
      for (int c = 0; c < 3; ++c) {
        for (std::size_t i = 0; i < 4; ++i) {
          v[c][i] = double(shared_exponent_channel(child_values[i], c)) * value_scale;
          mean[c] += v[c][i];
        }
        mean[c] /= 4;
        // Below 2^15, which words cannot hold: texels just under it may round up to it (the
        // bound is taken from the word's value, so it still holds).
        scaled_mean[c] = std::min(float(mean[c] / value_scale), std::nextafter(0x1p15f, 0.0f));
      }
      const std::uint32_t word = encode_shared_exponent(scaled_mean);
      node[1 + q] = word;
      for (int c = 0; c < 3; ++c) {
        const double value = double(shared_exponent_channel(word, c)) * value_scale;
        double squares = 0, largest = 0, offset = 0;
        for (std::size_t i = 0; i < 4; ++i) {
          double s, e;
          if (texel) {  // as PackedTreeView::bound: half the word's step
            e = 0.5 * double(shared_exponent_step(child_values[i])) * value_scale;
            s = e * (1 + 0x1p-20);
          } else {
            const std::size_t at = std::size_t(c) * 4 + i;
            s = code_value(child_codes[at]);
            const double derived = offsets[k * kBoundsPerNode + at];
            e = derived >= 0 ? std::min(s, derived) : s;
          }
          const double d = std::abs(v[c][i] - value);
          squares += s * s + d * d + 2 * d * e;
          largest = std::max(largest, s + d);
          offset += e / 4;
        }
        // The mean's own rounding in double arithmetic, and the bound's, padded.
        offsets[n * kBoundsPerNode + std::size_t(c) * 4 + q] =
            (offset + std::abs(mean[c] - value) + 0x1p-48 * mean[c]) * (1 + 0x1p-40);
        const double bound =
            (shape.bounds == BoundKind::l2 ? std::sqrt(squares / 4) : largest) * (1 + 0x1p-40);
        if (bound > largest_codable) fits = false;
        codes[std::size_t(c) * 4 + q] = bound_code_at_least(bound, tree.scales.bound_scale);
      }
    }
  }
  return fits;
}

}  // namespace

void derive_refined_values(PackedTree& tree, DerivedBoundRange range) {
  std::vector<double> scratch;
  derive_refined_values(tree, range, scratch);
}

void derive_refined_values(PackedTree& tree, DerivedBoundRange range,
                           std::vector<double>& scratch) {
  if (!has_derived_values(tree.shape)) return;
  const std::size_t full_words = std::size_t(tree.shape.words_per_node());
  for (int doublings = 0; !derive_pass(tree, scratch); ++doublings) {
    if (range == DerivedBoundRange::refuse || doublings == 64)
      throw std::invalid_argument("a derived bound exceeds what the tree's bound scale codes");
    // Twice the scale: the other nodes' codes recoded, rounded up, and the derived ones again.
    const float old_scale = tree.scales.bound_scale;
    tree.scales.bound_scale = 2 * old_scale;
    for (std::size_t n = 0; n < tree.texel_start; ++n) {
      std::uint32_t* node = tree.words.data() + n * full_words;
      if ((node[0] & kAllQuadrants) == kAllQuadrants) continue;
      auto* codes = reinterpret_cast<std::uint8_t*>(node + 1 + tree.shape.value_words());
      for (std::size_t i = 0; i < kBoundsPerNode; ++i)
        codes[i] = bound_code_at_least(double(bound_code_value(codes[i])) * double(old_scale),
                                       tree.scales.bound_scale);
    }
  }
}

std::vector<std::uint32_t> elide_refined_values(const PackedTreeView& tree) {
  const std::span<const std::uint32_t> words = tree.words();
  if (!has_derived_values(tree.shape())) return {words.begin(), words.end()};
  std::vector<std::uint32_t> out;
  out.reserve(words.size());
  const std::size_t full_words = std::size_t(tree.shape().words_per_node());
  for (int n = 0; n < tree.texel_start(); ++n) {
    const std::uint32_t* node = tree.node(n);
    const bool derived = (node[0] & kAllQuadrants) == kAllQuadrants;
    out.insert(out.end(), node, node + (derived ? 1 : full_words));
  }
  if (tree.texel_start() < tree.node_count())
    out.insert(out.end(), tree.node(tree.texel_start()), words.data() + words.size());
  return out;
}

std::size_t read_elided_tree(const PackedShape& shape, const TreeScales& scales,
                             std::span<const std::uint32_t> words, std::size_t node_count,
                             std::size_t texel_start, PackedTree& tree) {
  if (texel_start > node_count)
    throw std::invalid_argument("first texel node " + std::to_string(texel_start) +
                                " past the tree's " + std::to_string(node_count) + " nodes");
  tree.shape = shape;
  tree.scales = scales;
  tree.texel_start = texel_start;
  const std::size_t full_words = std::size_t(shape.words_per_node());
  const std::size_t texel_words = (node_count - texel_start) * std::size_t(shape.value_words());
  auto run_out = [&] {
    return std::invalid_argument("its " + std::to_string(node_count) +
                                 " nodes need more words than the set holds");
  };
  if (!has_derived_values(shape)) {
    const std::size_t size = packed_node_offset(shape, texel_start, node_count);
    if (size > words.size()) throw run_out();
    tree.words.assign(words.begin(), words.begin() + std::ptrdiff_t(size));
    return size;
  }
  // At least a link word per full node: checked before anything is allocated.
  if (texel_start > words.size() || texel_words > words.size() - texel_start) throw run_out();
  tree.words.assign(packed_node_offset(shape, texel_start, node_count), 0);
  std::size_t at = 0;
  for (std::size_t n = 0; n < texel_start; ++n) {
    if (at >= words.size()) throw run_out();
    const bool derived = (words[at] & kAllQuadrants) == kAllQuadrants;
    const std::size_t size = derived ? 1 : full_words;
    if (size > words.size() - at) throw run_out();
    std::copy_n(words.data() + at, size, tree.words.data() + n * full_words);
    at += size;
  }
  if (texel_words > words.size() - at) throw run_out();
  std::copy_n(words.data() + at, texel_words, tree.words.data() + texel_start * full_words);
  return at + texel_words;
}

}  // namespace basis
