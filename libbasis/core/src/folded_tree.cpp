#include "basis/core/folded_tree.h"
#include "basis/core/gradual_underflow.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#if defined(__SSE4_1__) && defined(__F16C__)
#include <immintrin.h>

#include "packed_lanes.h"
#endif

namespace basis {

bool folding_available() {
#if defined(__SSE4_1__) && defined(__F16C__)
  return true;
#else
  return false;
#endif
}

namespace {

void check_terms(std::span<const WeightedTerm> terms) {
  if (terms.empty()) throw std::invalid_argument("nothing to fold");
  if (terms.size() > kMaxFoldedTerms)
    throw std::invalid_argument("cannot fold more than " + std::to_string(kMaxFoldedTerms) +
                                " trees");
  const PackedShape& first = terms.front().tree.shape();
  for (const WeightedTerm& t : terms) {
    const PackedShape& s = t.tree.shape();
    if (s.resolution != first.resolution)
      throw std::invalid_argument("cannot fold trees of different resolutions");
    if (s.bounds != BoundKind::l2)
      throw std::invalid_argument("only trees with RMS (l2) bounds fold");
    if (s.exact_texels) throw std::invalid_argument("trees with exact texels do not fold");
    if (t.groups < 1 || t.groups > s.bounded_groups)
      throw std::invalid_argument("a term weights " + std::to_string(t.groups) +
                                  " groups of a tree with bounds for " +
                                  std::to_string(s.bounded_groups));
    for (int g = 0; g < t.groups; ++g)
      if (!std::isfinite(t.weights[std::size_t(g)]))
        throw std::invalid_argument("a term's weight is not finite");
    if (t.tree.node_count() == 0) throw std::invalid_argument("a term's tree is empty");
  }
}

#if defined(__SSE4_1__) && defined(__F16C__)

// Where a term stands on a node of the fold: on node `node` of its own tree, or, after its tree
// stopped above (node < 0), holding that quadrant's weighted values and magnitudes.
struct TermState {
  int node = 0;
  float value[3] = {}, magnitude[3] = {};
};
using TermStates = std::array<TermState, kMaxFoldedTerms>;

// A node of the fold before packing, per channel, four quadrants each: the sum's values, half
// the terms' magnitudes, the live terms' bounds and those of the terms that stop there.
struct FoldedNode {
  std::uint32_t link = 0;
  __m128 value[3], half_magnitude[3], live[3], stopped[3];
};

// One node of a term's tree, weighted, per channel: values sum_g w_g a_g, magnitudes
// sum_g |w_g a_g| and bounds sum_g |w_g| s_g.
struct WeightedNode {
  std::uint32_t link;
  __m128 value[3], magnitude[3], bound[3];
};

// A term with its weights in the units of its tree's values and bound codes, and what its
// weighted bounds may lose below the normal floats (added to each of them).
struct ScaledTerm {
  PackedTreeView tree;
  int groups = 1, tree_channels = 1;
  std::array<float, 3> value_weight{}, bound_weight{};
  float bound_slack = 0;
};

ScaledTerm scaled(const WeightedTerm& term) {
  ScaledTerm out{term.tree, term.groups, term.tree.shape().channels, {}, {}, 0};
  double lost = 0;
  for (int g = 0; g < term.groups; ++g) {
    const float w = term.weights[std::size_t(g)];
    out.value_weight[std::size_t(g)] = w * term.tree.scales().value_scale;
    const float bound_weight = std::abs(w) * term.tree.scales().bound_scale;
    out.bound_weight[std::size_t(g)] = bound_weight;
    if (w == 0) continue;  // its products are zeros, exactly
    // A subnormal weight is off by up to half its spacing, times a code of at most
    // bound_code_value(255); its products with codes (at least 2^-31) may be subnormal below a
    // weight of 2^-95, each off by up to 2^-150. In the normal floats the fold's 2^-20 margin
    // covers the relative rounding.
    if (bound_weight < 0x1p-126f)
      lost += double(bound_code_value(255)) *
              std::abs(double(bound_weight) -
                       std::abs(double(w)) * double(term.tree.scales().bound_scale));
    if (bound_weight < 0x1p-95f) lost += 0x1p-150;
  }
  if (lost > 0) out.bound_slack = std::nextafter(float(lost), INFINITY);
  return out;
}

// Node n of a term's tree, weighted, into `out` (written in place: a node built elsewhere and
// copied would be read back, wide, from the narrower stores that made it).
void read_node(const ScaledTerm& term, int n, int channels, WeightedNode& out) {
  const std::uint32_t* words = term.tree.node(n);
  const std::uint32_t* codes = words + 1 + term.tree.shape().value_words();
  out.link = words[0];
  for (int c = 0; c < 3; ++c)
    out.value[c] = out.magnitude[c] = out.bound[c] = _mm_setzero_ps();
  for (int c = 0; c < channels; ++c) {
    const int tc = term.tree_channels == 1 ? 0 : c;
    __m128 value = _mm_setzero_ps(), magnitude = _mm_setzero_ps(), bound = _mm_setzero_ps();
    for (int g = 0; g < term.groups; ++g) {
      const int at = g * term.tree_channels + tc;
      const __m128 v = _mm_mul_ps(detail::load_halves(words + 1 + 2 * at),
                                  _mm_set1_ps(term.value_weight[std::size_t(g)]));
      value = _mm_add_ps(value, v);
      magnitude = _mm_add_ps(magnitude, detail::abs_ps(v));
      bound = _mm_add_ps(bound, _mm_mul_ps(detail::load_bound_codes(codes + at),
                                           _mm_set1_ps(term.bound_weight[std::size_t(g)])));
    }
    out.value[c] = value;
    out.magnitude[c] = magnitude;
    out.bound[c] = _mm_add_ps(bound, _mm_set1_ps(term.bound_slack));
  }
}

// Lanes of the quadrants whose bit is clear in a 4-bit mask.
__m128 clear_lanes(std::uint32_t mask) {
  const __m128i bits = _mm_and_si128(_mm_set1_epi32(int(mask)), _mm_setr_epi32(1, 2, 4, 8));
  return _mm_castsi128_ps(_mm_cmpeq_epi32(bits, _mm_setzero_si128()));
}

float lane(__m128 v, int q) {
  alignas(16) float lanes[4];
  _mm_store_ps(lanes, v);
  return lanes[q];
}

// Four bound codes in one word (byte q for lane q), each the smallest whose value times
// bound_scale reaches its lane of `bound` as a float product (bound_code_at_least also asks it
// of the exact product; the fold's 2^-20 margin on its bounds covers the difference in the
// normal floats), for bounds up
// to bound_scale (the fold's scale is its largest bound; larger ones would take code 255, short
// of them): estimated from the float bits of bound / bound_scale, which never overshoot, then
// raised while short of it (once is enough; twice guards the float product's rounding).
std::uint32_t bound_codes_at_least(__m128 bound, float bound_scale) {
  // Below 2^-95 a code's product with the scale may be subnormal, where the float product can
  // round above the exact one by 2^-150: codes that reach the bound both ways, one by one.
  if (bound_scale < 0x1p-95f) {
    std::uint32_t codes = 0;
    for (int q = 0; q < 4; ++q)
      codes |= std::uint32_t(bound_code_at_least(double(lane(bound, q)), bound_scale)) << (8 * q);
    return codes;
  }
  const __m128 scale = _mm_set1_ps(bound_scale);
  const __m128i bias = _mm_set1_epi32(int(kBoundCodeBias)), largest = _mm_set1_epi32(255);
  const __m128i bits = _mm_max_epu32(_mm_castps_si128(_mm_div_ps(bound, scale)), bias);
  __m128i codes = _mm_min_epu32(_mm_srli_epi32(_mm_sub_epi32(bits, bias), 20), largest);
  for (int round = 0; round < 2; ++round) {
    const __m128 value =
        _mm_mul_ps(_mm_castsi128_ps(_mm_add_epi32(_mm_slli_epi32(codes, 20), bias)), scale);
    // Short lanes are all ones (-1): subtracting raises them by one code.
    const __m128i short_of = _mm_castps_si128(_mm_cmplt_ps(value, bound));
    codes = _mm_min_epu32(_mm_sub_epi32(codes, short_of), largest);
  }
  const __m128i bytes = _mm_packus_epi16(_mm_packus_epi32(codes, codes), _mm_setzero_si128());
  return std::uint32_t(_mm_cvtsi128_si32(bytes));
}

// The fold's nodes, breadth first with the children of a node consecutive (as packed trees lie).
std::vector<FoldedNode> fold_nodes(std::span<const WeightedTerm> weighted, int channels) {
  std::array<ScaledTerm, kMaxFoldedTerms> terms;
  const std::size_t count = weighted.size();
  std::size_t estimate = 0;
  for (std::size_t t = 0; t < count; ++t) {
    terms[t] = scaled(weighted[t]);
    estimate = std::max(estimate, std::size_t(weighted[t].tree.node_count()));
  }
  std::vector<FoldedNode> nodes;
  std::vector<TermStates> states;
  // The union of the terms' nodes: a little more than the largest term's (1.07-1.26 times for
  // the main job's tables' entries around a wo).
  nodes.reserve(estimate + estimate / 4);
  states.reserve(estimate + estimate / 4);
  states.emplace_back();  // every term at its root
  std::array<WeightedNode, kMaxFoldedTerms> term_nodes;
  for (std::size_t n = 0; n < states.size(); ++n) {
    // Room for this node's four children first, so that `here` stays where it is while they are
    // queued.
    if (states.capacity() - states.size() < 4)
      states.reserve(std::max(2 * states.capacity(), states.size() + 4));
    const TermStates& here = states[n];
    FoldedNode& out = nodes.emplace_back();
    std::uint32_t refined = 0;
    for (int c = 0; c < 3; ++c)
      out.value[c] = out.half_magnitude[c] = out.live[c] = out.stopped[c] = _mm_setzero_ps();
    for (std::size_t t = 0; t < count; ++t) {
      const TermState& s = here[t];
      if (s.node < 0) {
        for (int c = 0; c < channels; ++c) {
          out.value[c] = _mm_add_ps(out.value[c], _mm_set1_ps(s.value[c]));
          out.half_magnitude[c] = _mm_add_ps(out.half_magnitude[c], _mm_set1_ps(s.magnitude[c]));
        }
        continue;
      }
      WeightedNode& w = term_nodes[t];
      read_node(terms[t], s.node, channels, w);
      refined |= w.link & 15u;
      const __m128 stops = clear_lanes(w.link & 15u);
      for (int c = 0; c < channels; ++c) {
        out.value[c] = _mm_add_ps(out.value[c], w.value[c]);
        out.half_magnitude[c] = _mm_add_ps(out.half_magnitude[c], w.magnitude[c]);
        out.live[c] = _mm_add_ps(out.live[c], w.bound[c]);
        out.stopped[c] = _mm_add_ps(out.stopped[c], _mm_and_ps(stops, w.bound[c]));
      }
    }
    // Half the magnitudes, and 2^-8 more: for the float rounding of these sums, and for the
    // second-order part (about 2^-22 |w a b|) of a stopped term's rounding, which its quadrants
    // below carry through these magnitudes.
    for (int c = 0; c < channels; ++c)
      out.half_magnitude[c] = _mm_mul_ps(out.half_magnitude[c], _mm_set1_ps(0.5f + 0x1p-9f));
    if (refined) out.link = std::uint32_t(states.size()) << 4 | refined;
    for (int q = 0; q < 4; ++q) {
      if (!(refined >> q & 1)) continue;
      TermStates& below = states.emplace_back(here);
      for (std::size_t t = 0; t < count; ++t) {
        if (here[t].node < 0) continue;
        const std::uint32_t link = term_nodes[t].link;
        if (link >> q & 1) {
          below[t].node = int((link >> 4) + unsigned(std::popcount(link & ((1u << q) - 1))));
          continue;
        }
        below[t].node = -1;
        for (int c = 0; c < channels; ++c) {
          below[t].value[c] = lane(term_nodes[t].value[c], q);
          below[t].magnitude[c] = lane(term_nodes[t].magnitude[c], q);
        }
      }
    }
  }
  return nodes;
}

// The fold's nodes packed (packed_tree.h: two groups of halves, l2 bound codes for both): values
// to the nearest half, half magnitudes rounded up, the live bounds plus how far their value
// moved, every bound rounded up to its code.
PackedTree pack_folded(const std::vector<FoldedNode>& nodes, int resolution, int channels) {
  PackedTree out;
  out.shape = {resolution, channels, 2, BoundKind::l2, 2};
  out.texel_start = nodes.size();
  __m128 largest = _mm_setzero_ps();
  for (const FoldedNode& n : nodes)
    for (int c = 0; c < channels; ++c)
      largest = _mm_max_ps(largest, _mm_max_ps(detail::abs_ps(n.value[c]), n.half_magnitude[c]));
  float largest_value = 0;
  for (int q = 0; q < 4; ++q)
    largest_value = std::max(largest_value, lane(largest, q));
  out.scales.value_scale = half_value_scale(largest_value);
  const __m128 to_half = _mm_set1_ps(1 / out.scales.value_scale);
  const __m128 from_half = _mm_set1_ps(out.scales.value_scale);
  // Halves, and the live bounds with the value's rounding added (and 2^-20 of themselves for the
  // float sums), before the bound scale is known.
  std::vector<std::uint32_t> words(nodes.size() * std::size_t(out.shape.words_per_node()), 0);
  std::vector<std::array<float, 4>> bounds(nodes.size() * std::size_t(2 * channels));
  __m128 largest_bound = _mm_setzero_ps();
  const std::size_t stride = std::size_t(out.shape.words_per_node());
  for (std::size_t n = 0; n < nodes.size(); ++n) {
    std::uint32_t* w = words.data() + n * stride;
    w[0] = nodes[n].link;
    for (int c = 0; c < channels; ++c) {
      const __m128 scaled = _mm_mul_ps(nodes[n].value[c], to_half);
      const __m128i value = _mm_cvtps_ph(scaled, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
      const __m128i magnitude = _mm_cvtps_ph(_mm_mul_ps(nodes[n].half_magnitude[c], to_half),
                                             _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC);
      _mm_storel_epi64(reinterpret_cast<__m128i*>(w + 1 + 2 * c), value);
      _mm_storel_epi64(reinterpret_cast<__m128i*>(w + 1 + 2 * (channels + c)), magnitude);
      const __m128 moved =
          _mm_mul_ps(detail::abs_ps(_mm_sub_ps(_mm_cvtph_ps(value), scaled)), from_half);
      const __m128 live =
          _mm_mul_ps(_mm_add_ps(nodes[n].live[c], moved), _mm_set1_ps(1 + 0x1p-20f));
      const __m128 stopped = _mm_mul_ps(nodes[n].stopped[c], _mm_set1_ps(1 + 0x1p-20f));
      _mm_storeu_ps(bounds[n * std::size_t(2 * channels) + std::size_t(c)].data(), live);
      _mm_storeu_ps(bounds[n * std::size_t(2 * channels) + std::size_t(channels + c)].data(),
                    stopped);
      largest_bound = _mm_max_ps(largest_bound, _mm_max_ps(live, stopped));
    }
  }
  float bound_scale = 0;
  for (int q = 0; q < 4; ++q)
    bound_scale = std::max(bound_scale, lane(largest_bound, q));
  out.scales.bound_scale = bound_scale > 0 ? bound_scale : 1.0f;
  const std::size_t codes_at = 1 + std::size_t(out.shape.value_words());
  for (std::size_t n = 0; n < nodes.size(); ++n)
    for (std::size_t k = 0; k < std::size_t(2 * channels); ++k)
      words[n * stride + codes_at + k] = bound_codes_at_least(
          _mm_loadu_ps(bounds[n * std::size_t(2 * channels) + k].data()), out.scales.bound_scale);
  out.words = std::move(words);
  return out;
}

// FoldedTree::descent_nodes() of a packed folded tree: its values and bound codes decoded as the
// descents decode them, and the shares summed as they sum them.
std::vector<std::uint32_t> descent_nodes(const PackedTree& tree) {
  const PackedTreeView view = tree.view();
  const int channels = tree.shape.channels;
  const std::size_t stride = FoldedTree::descent_words(channels);
  const std::size_t codes_at = 1 + std::size_t(tree.shape.value_words());
  std::vector<std::uint32_t> out(std::size_t(view.node_count()) * stride);
  for (int n = 0; n < view.node_count(); ++n) {
    const std::uint32_t* w = view.node(n);
    std::uint32_t* node = out.data() + std::size_t(n) * stride;
    node[0] = w[0];
    const auto at = [&](FoldedTree::DescentBlock block, int c) {
      return reinterpret_cast<float*>(node + FoldedTree::descent_offset(channels, block, c));
    };
    for (int c = 0; c < channels; ++c) {
      const __m128 value = detail::load_halves(w + 1 + 2 * c);
      const __m128 half_magnitude = detail::load_halves(w + 1 + 2 * (channels + c));
      const __m128 share =
          _mm_add_ps(detail::abs_ps(value), _mm_add_ps(half_magnitude, half_magnitude));
      _mm_storeu_ps(at(FoldedTree::values, c), value);
      _mm_storeu_ps(at(FoldedTree::shares, c), share);
      _mm_storeu_ps(at(FoldedTree::bounds, c), detail::load_bound_codes(w + codes_at + c));
      _mm_storeu_ps(at(FoldedTree::stopping_bounds, c),
                    detail::load_bound_codes(w + codes_at + channels + c));
    }
  }
  return out;
}

#endif  // SSE4.1 and F16C

}  // namespace

FoldedTree fold(std::span<const WeightedTerm> terms) {
  const GradualUnderflow gradual_underflow;
  check_terms(terms);
#if defined(__SSE4_1__) && defined(__F16C__)
  int channels = 1;
  for (const WeightedTerm& t : terms)
    if (t.tree.shape().channels == 3) channels = 3;
  const int resolution = terms.front().tree.shape().resolution;
  // What read_node's float products lose below the normal floats, which no relative term
  // covers (the bounds' share is each term's bound_slack): a weight times the value scale that is
  // subnormal is off by up to 2^-150, times a half of at most 65504, and products that can be
  // subnormal (the weight under 2^-102, the smallest half 2^-24) by up to 2^-150 each. A weight
  // times a value scale (a power of two) that is normal is exact, and nothing is lost.
  double lost_values = 0;
  for (const WeightedTerm& t : terms)
    for (int g = 0; g < t.groups; ++g) {
      const float w = t.weights[std::size_t(g)];
      if (w == 0) continue;  // its products are zeros, exactly
      const double value_weight = double(w) * double(t.tree.scales().value_scale);
      // As scaled() rounds it.
      lost_values += 65504.0 * std::abs(double(w * t.tree.scales().value_scale) - value_weight) +
                     (std::abs(value_weight) < 0x1p-102 ? 0x1p-150 : 0);
    }
  FoldedTree folded;
  folded.tree_ = pack_folded(fold_nodes(terms, channels), resolution, channels);
  // The terms' subnormal rounding, in the folded tree's value units (2^-25 value_scale), and what
  // the products lost, twice (their magnitudes, which the rounding terms take, lost as much).
  const double value_scale = folded.tree_.scales.value_scale;
  for (const WeightedTerm& t : terms) {
    double weight = 0;
    for (int g = 0; g < t.groups; ++g)
      weight += std::abs(double(t.weights[std::size_t(g)]));
    folded.floor_weight_ += float(weight * double(t.tree.scales().value_scale) / value_scale);
  }
  folded.floor_weight_ += float(2 * lost_values / (kHalfSubnormalRounding * value_scale));
  folded.floor_weight_ = std::nextafter(folded.floor_weight_, INFINITY);
  folded.descent_nodes_ = descent_nodes(folded.tree_);
  return folded;
#else
  throw std::logic_error("folding trees needs SSE4.1 and F16C (folding_available())");
#endif
}

}  // namespace basis
