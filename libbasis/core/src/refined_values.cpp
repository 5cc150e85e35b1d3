#include "basis/core/refined_values.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <span>
#include <stdexcept>
#include <string>

#include "basis/core/shared_exponent.h"

namespace basis {
namespace {

constexpr std::uint32_t kAllQuadrants = 15;
constexpr std::size_t kBoundsPerNode = 3 * 4;  // channels x quadrants of a shared-value node

// Per channel and quadrant of each derived node, what the pass knows of the mean M of its
// texels: an estimate, a bound on |M - estimate|, and a bound on |M - value| (the offset).
struct Means {
  std::span<double> estimate, estimate_error, offset;
};

// Not cleared: a derived node's entries are written before its parent reads them (children
// come later in the tree, and the pass goes backwards), and no other entry is read; a scratch
// reused from tree to tree is then not filled again (it was 0.3 MiB a capture).
Means means_in(std::vector<double>& scratch, std::size_t nodes) {
  const std::size_t size = nodes * kBoundsPerNode;
  if (scratch.size() < 3 * size) scratch.resize(3 * size);
  const std::span<double> all(scratch);
  return {all.subspan(0, size), all.subspan(size, size), all.subspan(2 * size, size)};
}

// One pass over the tree, children before parents; sets the tree's derived_rounding. Returns
// whether every derived bound fits the tree's bound scale (a bound that does not gets code 255,
// which does not hold).
bool derive_pass(PackedTree& tree, std::vector<double>& scratch) {
  const PackedShape& shape = tree.shape;
  const std::size_t texel_start = tree.texel_start;
  const std::size_t count = std::size_t(tree.node_count());
  const std::size_t full_words = std::size_t(shape.words_per_node());
  const double value_scale = tree.scales.value_scale;
  // Codes' values as PackedTreeView::bound computes them: the float product.
  auto code_value = [&](std::uint8_t code) {
    return double(bound_code_value(code) * tree.scales.bound_scale);
  };
  auto half_step = [&](std::uint32_t word) {
    return 0.5 * double(shared_exponent_step(word)) * value_scale;
  };
  // The largest bound a code reaches both as the float product and as the exact one (the
  // packed descents'), as bound_code_at_least chooses codes.
  const double largest_codable =
      std::min(code_value(255), double(bound_code_value(255)) * double(tree.scales.bound_scale));
  const Means means = means_in(scratch, texel_start);
  double largest_offset = 1;  // in half steps of the derived word
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
      const bool derived_child = !texel && (child[0] & kAllQuadrants) == kAllQuadrants;
      // Per channel and child quadrant i: its value v, bound s, a bound e on |M_i - v_i|, the
      // estimate of M_i and a bound on that estimate's error. A value the file stores (a
      // texel's, or a node's that is not derived) is within half its word's step of M_i, as
      // every descent takes it. Each is written below before it is read, so they are not
      // cleared first (five short fills for every derived quadrant, each slow to start).
      std::array<std::array<double, 4>, 3> v, s, e, estimate, estimate_error;
      std::array<double, 3> mean{}, mean_error{};
      std::array<float, 3> scaled_mean{};
      for (int c = 0; c < 3; ++c) {
        for (std::size_t i = 0; i < 4; ++i) {
          v[c][i] = double(shared_exponent_channel(child_values[i], c)) * value_scale;
          // A stored node's value is a float average of its texels, rounded to a word: within
          // half its step of their mean, and the float average's own error (about 2^-24 of the
          // largest channel per level, below 2^-19 of it over a tree's levels, where half a step
          // is at least 2^-10 of it) within 2^-9 of that half step.
          const double rounding = half_step(child_values[i]) * (texel ? 1 : 1 + 0x1p-9);
          const std::size_t at = std::size_t(c) * 4 + i;
          if (texel) {  // as PackedTreeView::bound: half the word's step
            s[c][i] = rounding * (1 + 0x1p-20);
            e[c][i] = rounding;
          } else {
            s[c][i] = code_value(child_codes[at]);
            const double offset = derived_child ? means.offset[k * kBoundsPerNode + at] : rounding;
            e[c][i] = std::min(s[c][i], offset);
          }
          estimate[c][i] = derived_child ? means.estimate[k * kBoundsPerNode + at] : v[c][i];
          estimate_error[c][i] =
              derived_child ? means.estimate_error[k * kBoundsPerNode + at] : rounding;
          mean[c] += estimate[c][i];
          mean_error[c] += estimate_error[c][i];
        }
        mean[c] /= 4;
        // The mean's own rounding in double arithmetic, padded.
        mean_error[c] = (mean_error[c] / 4 + 0x1p-50 * mean[c]) * (1 + 0x1p-40);
        // Below 2^15, which words cannot hold: texels just under it may round up to it (the
        // bound is taken from the word's value, so it still holds).
        scaled_mean[c] = std::min(float(mean[c] / value_scale), std::nextafter(0x1p15f, 0.0f));
      }
      const std::uint32_t word = encode_shared_exponent(scaled_mean);
      node[1 + q] = word;
      const double rounding = half_step(word);
      for (int c = 0; c < 3; ++c) {
        const double value = double(shared_exponent_channel(word, c)) * value_scale;
        double squares = 0, largest = 0;
        for (std::size_t i = 0; i < 4; ++i) {
          const double d = std::abs(v[c][i] - value);
          squares += s[c][i] * s[c][i] + d * d + 2 * d * e[c][i];
          largest = std::max(largest, s[c][i] + d);
        }
        const std::size_t at = n * kBoundsPerNode + std::size_t(c) * 4 + q;
        means.estimate[at] = mean[c];
        means.estimate_error[at] = mean_error[c];
        means.offset[at] = (mean_error[c] + std::abs(mean[c] - value)) * (1 + 0x1p-40);
        largest_offset = std::max(largest_offset, means.offset[at] / rounding);
        const double bound =
            (shape.bounds == BoundKind::l2 ? std::sqrt(squares / 4) : largest) * (1 + 0x1p-40);
        if (bound > largest_codable) fits = false;
        codes[std::size_t(c) * 4 + q] = bound_code_at_least(bound, tree.scales.bound_scale);
      }
    }
  }
  // Rounded up: a float within 2^-24 of the padded ratio.
  tree.derived_rounding = float(largest_offset * (1 + 0x1p-20));
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
