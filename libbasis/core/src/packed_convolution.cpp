// Convolution of packed trees: the SIMD descent (SSE4.1 and F16C) and its scalar reference.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "basis/core/convolution.h"
#include "basis/core/folded_tree.h"
#include "basis/core/gradual_underflow.h"
#include "basis/core/number_text.h"
#include "scalar_descent.h"

// The SIMD descent needs SSE4.1 and F16C; an AVX-512 (F, BW, VL) build takes RGB pairs twelve
// lanes at a time in one register, an AVX2 build in two.
#if defined(__SSE4_1__) && defined(__F16C__)
#include <immintrin.h>

#include "packed_lanes.h"
#endif

namespace basis {

namespace {

void check_compatible(const PackedShape& a, const PackedShape& b) {
  if (a.channels != b.channels && a.channels != 1 && b.channels != 1)
    throw std::invalid_argument("cannot convolve trees of " + std::to_string(a.channels) + " and " +
                                std::to_string(b.channels) + " channels");
}

// How far a half-rounded value may lie from the average it stands for: kHalfRounding and
// kHalfSubnormalRounding (packed_tree.h).
// Summed over the stopped pairs, the rounding terms |a| db + |b| da are at most
// kRoundingPerMagnitude x (the sum of area |a b|) + kRoundingFloor, in units of the value scales:
// values in those units lie below 2^15, so |a| 2^-25 <= 2^-10 and the areas add up to 1. The
// averages that were rounded are themselves floats, within half a float step (2^-24) of their
// texels' mean (projection.h): the factor 1 + 2^-10 covers that on both sides.
constexpr double kRoundingPerMagnitude = 2 * kHalfRounding * (1 + 0x1p-10), kRoundingFloor = 0x1p-9;

// A descent's own sums lie within gamma (detail::summation_gamma) of the sum of the magnitudes
// its rounding terms take (each at least |a b|: a shared word's share at least its value, which
// lies below 512 of its steps).

// The additions a SIMD descent's product term goes through, at most: a pair's two nodes cover
// one place, so no node of either tree is in two pairs, and a lane takes fewer terms than the
// smaller tree has nodes; then up to four a level (a level's sums into the descent's, a nested
// descent's into its parent's, generously) and, with the lanes' sum and the few roundings each
// term was computed in, 16 more.
double simd_additions(const PackedTreeView& a, const PackedTreeView& b) {
  return double(std::min(a.node_count(), b.node_count())) + 4.0 * kMaxTreeLevels + 16;
}

// The certified bound of a descent whose bound terms (the values' rounding included) summed to
// `terms` and whose magnitudes to `magnitudes` (in the scales' units), each sum possibly below
// exact by the factor 1 - gamma, and whose value's sum may lie gamma times the magnitudes from
// exact; then the rounding floor. The last factor covers this line's own.
double descent_bound(double terms, double magnitudes, double gamma, double floor) {
  return ((terms + gamma * magnitudes) / (1 - gamma) + floor) * (1 + 0x1p-40);
}

// Tree a as the scalar descent reads it: one group, or several combined with weights into one
// function, whose value is sum_g w_g a_g, whose bounds are sum_g |w_g| times the groups' (the
// RMS and the largest deviation are norms), and whose halves' rounding scales with
// sum_g |w_g a_g| and the total weight.
class WeightedTree {
 public:
  WeightedTree(const PackedTreeView& tree, std::span<const float> weights) : tree_(tree) {
    count_ = weights.empty() ? 1 : std::min(3, int(weights.size()));
    for (int g = 0; g < count_; ++g) {
      weight_[g] = weights.empty() ? 1.0 : double(weights[g]);
      total_weight_ += std::abs(weight_[g]);
    }
  }
  const PackedShape& shape() const { return tree_.shape(); }
  std::int32_t child(int n, int q) const { return tree_.child(n, q); }
  // Group 0 is the weighted combination; other groups (unweighted descents) are the tree's.
  double value(int n, int g, int c, int q) const {
    if (g > 0) return tree_.value(n, g, c, q);
    double v = 0;
    for (int k = 0; k < count_; ++k)
      v += weight_[k] * tree_.value(n, k, c, q);
    return v;
  }
  double bound(int n, int c, int q) const {
    double b = 0;
    for (int k = 0; k < count_; ++k)
      b += std::abs(weight_[k]) * tree_.bound(n, k, c, q);
    return b;
  }
  double magnitude(int n, int c, int q) const {
    double m = 0;
    for (int k = 0; k < count_; ++k)
      m += std::abs(weight_[k]) * tree_.rounding_magnitude(n, k, c, q);
    return m;
  }
  // The groups' rounding share (PackedTreeView::rounding_share), weighted.
  double rounding_share(int n, int c, int q) const {
    double m = 0;
    for (int k = 0; k < count_; ++k)
      m += std::abs(weight_[k]) * tree_.rounding_share(n, k, c, q);
    return m;
  }
  double total_weight() const { return total_weight_; }
  // Whether groups are combined: the function may then be negative.
  bool combined() const { return count_ > 1; }
  // Whether the function may be negative: combined groups, or values in halves (a tree of any
  // signed grid); only shared-exponent words (captures' radiance) are known to be >= 0.
  bool may_be_negative() const { return combined() || !tree_.shape().shared_values(); }

 private:
  const PackedTreeView& tree_;
  double weight_[3] = {1, 0, 0};
  int count_ = 1;
  double total_weight_ = 0;
};

// The bound of a stopped pair of packed quadrants with values a, b, which stand for true
// averages a + da, b + db (|da|, |db| at most half an ulp):
//   |integral of AB - area a b| <= area (|integral of (A - a)(B - b)| / area + |a| db + |b| da),
// the first term at most min(sa sb, [a linf] ea (|b| + db) + |b| da, [b linf] likewise; the
// largest-deviation terms hold for B >= 0 and A >= 0 respectively: where that side may be
// negative they would add sa sb, the mean of |B| being at most |b| plus its RMS deviation, and
// never be smaller than sa sb, so they are taken only where it is known to be >= 0),
// the
// rounding terms kRoundingPerMagnitude |a b| here and kRoundingFloor (times the value scales)
// once for the whole descent. For weighted groups |a| is their magnitude (WeightedTree); for
// shared-exponent values the rounding terms take their rounding shares, and the
// largest-deviation terms their rounding magnitudes, in place of |a| and |b| (PackedTreeView).
auto packed_pair_bound(const WeightedTree& a, const PackedTreeView& b, double value_scale_a) {
  const bool linf_a = a.shape().bounds == BoundKind::linf;
  const bool linf_b = b.shape().bounds == BoundKind::linf;
  const double floor_a = kHalfSubnormalRounding * value_scale_a * a.total_weight();
  return [&a, &b, linf_a, linf_b, floor_a](int na, int nb, int ca, int cb, int q, double, double) {
    const double sa = a.bound(na, ca, q), sb = b.bound(nb, cb, q);
    const double abs_a = a.magnitude(na, ca, q);
    const double abs_b = b.rounding_magnitude(nb, 0, cb, q);  // |vb|, for halves
    const double da = kHalfRounding * abs_a + floor_a;
    const double db = kHalfRounding * abs_b + kHalfSubnormalRounding * b.scales().value_scale;
    double product = sa * sb;
    // Each alternative only where the other side is known to be >= 0: elsewhere it would add
    // sa sb, and could not be smaller than the product term.
    if (linf_a && b.shape().shared_values())
      product = std::min(product, sa * (abs_b + db) + abs_b * da);
    if (linf_b && !a.may_be_negative()) product = std::min(product, sb * (abs_a + da) + abs_a * db);
    return product +
           kRoundingPerMagnitude * a.rounding_share(na, ca, q) * b.rounding_share(nb, 0, cb, q);
  };
}

GroupConvolution scalar(const PackedTreeView& a, const PackedTreeView& b, int groups,
                        double accuracy, std::span<const float> weights = {}) {
  check_compatible(a.shape(), b.shape());
  const WeightedTree weighted(a, weights);
  const int channels = std::max(a.shape().channels, b.shape().channels);
  detail::AccuracyTarget target{accuracy, {}};
  for (int c = 0; c < channels; ++c)
    for (int q = 0; q < 4; ++q)
      target.estimate[c] += std::abs(weighted.value(0, 0, std::min(c, a.shape().channels - 1), q) *
                                     b.value(0, 0, std::min(c, b.shape().channels - 1), q)) /
                            4;
  detail::ScalarSums sums;
  detail::descend_scalar(weighted, b, 0, 0, 0.25, channels, groups, target,
                         packed_pair_bound(weighted, b, a.scales().value_scale), sums);
  const double floor = kRoundingFloor * weighted.total_weight() * double(a.scales().value_scale) *
                       double(b.scales().value_scale);
  // One accumulator a channel takes every stopped quadrant, in double. Its terms' magnitudes,
  // groups' included (sum_g |w_g a_g| |b|, which their double sums round against), are at most
  // the rounding terms of the bound over kRoundingPerMagnitude.
  const double gamma = detail::summation_gamma(double(sums.stops) + 16, 0x1p-53);
  GroupConvolution result;
  for (int c = 0; c < 3; ++c) {
    const int lane = channels == 1 ? 0 : c;
    const CertifiedFloat group0 = certified_float(
        sums.value[0][lane],
        descent_bound(sums.bound[lane], sums.bound[lane] / kRoundingPerMagnitude, gamma, floor));
    result.value[0][c] = group0.value;
    result.bound[c] = group0.bound;
    for (int g = 1; g < groups; ++g)
      result.value[g][c] = certified_float(sums.value[g][lane], 0).value;
  }
  return result;
}

#if defined(__SSE4_1__) && defined(__F16C__)

// kChildOffsets[mask][q]: the rank of quadrant q's child among the refined quadrants of mask.
alignas(16) constexpr std::uint32_t kChildOffsets[16][4] = {
    {0, 0, 0, 0}, {0, 1, 1, 1}, {0, 0, 1, 1}, {0, 1, 2, 2}, {0, 0, 0, 1}, {0, 1, 1, 2},
    {0, 0, 1, 2}, {0, 1, 2, 3}, {0, 0, 0, 0}, {0, 1, 1, 1}, {0, 0, 1, 1}, {0, 1, 2, 2},
    {0, 0, 0, 1}, {0, 1, 1, 2}, {0, 0, 1, 2}, {0, 1, 2, 3}};

// Lanes of the quadrants whose bit is set in a 4-bit mask.
alignas(16) constexpr std::uint32_t kLaneMasks[16][4] = {
    {0, 0, 0, 0},     {~0u, 0, 0, 0},     {0, ~0u, 0, 0},     {~0u, ~0u, 0, 0},
    {0, 0, ~0u, 0},   {~0u, 0, ~0u, 0},   {0, ~0u, ~0u, 0},   {~0u, ~0u, ~0u, 0},
    {0, 0, 0, ~0u},   {~0u, 0, 0, ~0u},   {0, ~0u, 0, ~0u},   {~0u, ~0u, 0, ~0u},
    {0, 0, ~0u, ~0u}, {~0u, 0, ~0u, ~0u}, {0, ~0u, ~0u, ~0u}, {~0u, ~0u, ~0u, ~0u}};

#if defined(__AVX2__) && !(defined(__AVX512F__) && defined(__AVX512VL__))
// kQueuedLanes[mask]: for each quadrant q whose bit is set in a 4-bit mask, in order, the lanes
// q and 4 + q (its children's nodes of a and of b, in a register holding a's four and then b's);
// lanes past them repeat lane 0.
struct QueuedLanes {
  alignas(32) std::int32_t lanes[16][8];
  constexpr QueuedLanes() : lanes{} {
    for (int mask = 0; mask < 16; ++mask) {
      int n = 0;
      for (int q = 0; q < 4; ++q)
        if (mask >> q & 1) {
          lanes[mask][n++] = q;
          lanes[mask][n++] = 4 + q;
        }
    }
  }
};
inline constexpr QueuedLanes kQueuedLanes;
#endif

inline __m128 lanes_of(unsigned mask) {
  return _mm_load_ps(reinterpret_cast<const float*>(kLaneMasks[mask]));
}

// The ranks of the four quadrants' children among the refined quadrants of a link's mask.
inline __m128i child_offsets(std::uint32_t link) {
  return _mm_load_si128(reinterpret_cast<const __m128i*>(kChildOffsets[link & 15u]));
}

using detail::abs_ps;
using detail::load_bound_codes;
using detail::load_halves;

// Four floats at p (FoldedTree::descent_nodes(): float bits in words).
inline __m128 load_floats(const std::uint32_t* p) {
  return _mm_loadu_ps(reinterpret_cast<const float*>(p));
}

// The steps of four shared-exponent words (shared_exponent.h): 2^(exponent - 24) each.
inline __m128 shared_steps(__m128i words) {
  const __m128i exponents = _mm_srli_epi32(words, 27);
  return _mm_castsi128_ps(
      _mm_slli_epi32(_mm_add_epi32(exponents, _mm_set1_epi32(127 - kSharedExponentBias)), 23));
}

// Channel c of four shared-exponent words whose steps are given.
inline __m128 shared_channel(__m128i words, int c, __m128 steps) {
  const __m128i mantissas = _mm_and_si128(
      _mm_srl_epi32(words, _mm_cvtsi32_si128(kSharedMantissaBits * c)), _mm_set1_epi32(511));
  return _mm_mul_ps(_mm_cvtepi32_ps(mantissas), steps);
}

// A shared-exponent value's rounding magnitude (PackedTreeView::rounding_magnitude),
// max(value, step kSharedStepMagnitude), and its rounding share (rounding_share),
// (value + step kSharedStepMagnitude) / 2: half the step over kHalfRounding is the step's
// share.
constexpr float kSharedStepMagnitude = float(0.5 / kHalfRounding);

// What the steps of the shared-exponent words of the node at w are multiplied by for their
// rounding magnitude: step_magnitudes[1] in a derived node (its four quadrants refined: its
// link's mask full), step_magnitudes[0] (kSharedStepMagnitude) elsewhere; texel nodes (kTexel)
// have no link. Chosen by index, without a branch on the data (which no predictor learns).
template <bool kTexel>
inline float step_magnitude(const std::uint32_t* w, const float* step_magnitudes) {
  if constexpr (kTexel) return kSharedStepMagnitude;
  return step_magnitudes[((w[0] & 15u) + 1u) >> 4];
}

inline float lane_sum(__m128 v) {
  const __m128 pairs = _mm_add_ps(v, _mm_movehl_ps(v, v));
  return _mm_cvtss_f32(_mm_add_ss(pairs, _mm_shuffle_ps(pairs, pairs, 1)));
}

// What a descent needs to know of its two trees: node words, where the bound codes sit, the
// weights of a's groups when they are combined, and the constants that bring sums to the trees'
// scales and an accuracy target to unscaled units.
template <int CA, int CB>
struct DescentConstants {
  static constexpr int C = CA > CB ? CA : CB;
  // Words of a node of FoldedTree::descent_nodes(): its link, then values, shares, bounds and
  // stopping bounds, CA x 4 floats each.
  static constexpr std::size_t kDecodedFoldWords = FoldedTree::descent_words(CA);
  // Words of a node of shared-exponent words (RGB, one group and its bounds: packed_tree.h),
  // full and texel, and where a full one's bound codes start.
  static constexpr std::size_t kSharedNodeWords = 1 + 4 + 3, kSharedTexelWords = 4,
                               kSharedCodes = 1 + 4;
  const std::uint32_t* a;
  const std::uint32_t* b;
  std::size_t words_a, words_b;
  // Word offset of the bound codes in a node (a folded a's decoded nodes have none: their
  // policies read floats, and codes_a is not used for them).
  std::size_t codes_a, codes_b;
  // Texel nodes of exact texels (values alone, nodes from texel_start on, all of the last level
  // and only it): their depth (-1 for a tree without them), the words of one, where node n of
  // them lies (texels_a + n x texel_words_a), and the factor that brings their halves' rounding
  // to bound units (value scale / bound scale, rounded up).
  std::uint32_t texel_start_a, texel_start_b;
  int texel_depth_a, texel_depth_b;
  std::size_t texel_words_a, texel_words_b;
  const std::uint32_t* texels_a;
  const std::uint32_t* texels_b;
  float texel_bound_a, texel_bound_b;
  // Whether a tree's nodes hold shared-exponent words (RGB, one group, exact texels), and the
  // factor that brings a texel word's step to its bound, half the step, in bound units.
  bool shared_a, shared_b;
  float shared_bound_a, shared_bound_b;
  // What a node's word steps are multiplied by for their rounding magnitude (step_magnitude):
  // kSharedStepMagnitude, and in a derived node that times the tree's derived_rounding
  // (PackedTreeView).
  float step_magnitudes_a[2], step_magnitudes_b[2];
  // In double: two trees' scales multiply beyond the floats' range (2^-252 to 2^235).
  double value_scale, bound_scale;
  float values_in_bound_units, linf_a_scale, linf_b_scale;
  // Weighted descents: a stands for sum_g weight[g] a_g; total_weight = sum_g |weight[g]|.
  float weight[3] = {1, 0, 0}, abs_weight[3] = {1, 0, 0};
  float total_weight = 1;
  bool combined = false;
  bool targeted;
  // A pair stops in a channel when its product term <= per_product |a b| + allowed[c] (bound
  // units): term + kRoundingPerMagnitude |a b| <= accuracy / 2 (|a b| + E), E the roots' product.
  float per_product;
  // Weighted descents and shared-exponent values: term <= per_value |a b| - per_magnitude
  // |a|' |b|' + allowed[c], |a|' and |b|' the magnitudes the rounding scales with (sum_g
  // |w_g a_g|, or a shared word's rounding share).
  float per_value, per_magnitude;
  float allowed[C];

  // folded_nodes: a's nodes decoded (FoldedTree::descent_nodes()), read in place of its words.
  DescentConstants(const PackedTreeView& ta, const PackedTreeView& tb, double accuracy,
                   std::span<const float> weights = {},
                   std::span<const std::uint32_t> folded_nodes = {})
      : a(ta.words().data()),
        b(tb.words().data()),
        words_a(ta.shape().words_per_node()),
        words_b(tb.shape().words_per_node()),
        codes_a(1 + std::size_t(ta.shape().value_words())),
        codes_b(1 + std::size_t(tb.shape().value_words())),
        texel_start_a(std::uint32_t(ta.texel_start())),
        texel_start_b(std::uint32_t(tb.texel_start())),
        texel_depth_a(ta.texel_start() < ta.node_count() ? ta.shape().texel_depth() : -1),
        texel_depth_b(tb.texel_start() < tb.node_count() ? tb.shape().texel_depth() : -1),
        texel_words_a(std::size_t(ta.shape().words_per_texel_node())),
        texel_words_b(std::size_t(tb.shape().words_per_texel_node())),
        texels_a(a + std::size_t(texel_start_a) * (words_a - texel_words_a)),
        texels_b(b + std::size_t(texel_start_b) * (words_b - texel_words_b)),
        texel_bound_a(
            float(double(ta.scales().value_scale) / ta.scales().bound_scale * (1 + 0x1p-20))),
        texel_bound_b(
            float(double(tb.scales().value_scale) / tb.scales().bound_scale * (1 + 0x1p-20))),
        shared_a(CA == 3 && ta.shape().shared_values()),
        shared_b(CB == 3 && tb.shape().shared_values()),
        shared_bound_a(texel_bound_a * 0.5f),
        shared_bound_b(texel_bound_b * 0.5f),
        step_magnitudes_a{kSharedStepMagnitude, kSharedStepMagnitude * ta.derived_rounding()},
        step_magnitudes_b{kSharedStepMagnitude, kSharedStepMagnitude * tb.derived_rounding()},
        targeted(accuracy > 0) {
    if (!folded_nodes.empty()) {  // a folded tree has no texel nodes
      a = texels_a = folded_nodes.data();
      words_a = texel_words_a = kDecodedFoldWords;
    }
    if (!weights.empty()) {
      combined = weights.size() > 1;
      total_weight = 0;
      for (std::size_t g = 0; g < 3; ++g) {
        weight[g] = g < weights.size() ? weights[g] : 0;
        abs_weight[g] = std::abs(weight[g]);
        total_weight += abs_weight[g];
      }
    }
    // Sums are kept without the trees' scales: values and rounding terms in units of
    // value_scale_a value_scale_b, bound products in units of bound_scale_a bound_scale_b; the
    // largest-deviation alternatives are brought to the latter's units.
    const TreeScales& sa = ta.scales();
    const TreeScales& sb = tb.scales();
    bound_scale = double(sa.bound_scale) * sb.bound_scale;
    value_scale = double(sa.value_scale) * sb.value_scale;
    values_in_bound_units = float(value_scale / bound_scale);
    linf_a_scale = sb.value_scale / sb.bound_scale;
    linf_b_scale = sa.value_scale / sa.bound_scale;
    per_product = float((accuracy / 2 - kRoundingPerMagnitude) * values_in_bound_units);
    per_value = float(accuracy / 2 * values_in_bound_units);
    per_magnitude = float(kRoundingPerMagnitude * values_in_bound_units);
    // The roots' product E, from their values (without the scales, as the sums); a full
    // descent never reads it.
    for (int c = 0; c < C; ++c)
      allowed[c] = 0;
    if (!targeted) return;
    const int groups_a = weights.empty() ? 1 : int(weights.size());
    for (int c = 0; c < C; ++c) {
      __m128 root_a = _mm_setzero_ps();
      for (int g = 0; g < groups_a; ++g)
        root_a = _mm_add_ps(
            root_a, _mm_mul_ps(_mm_set1_ps(weight[g]), root_quadrants(ta, g, CA == 1 ? 0 : c)));
      const float product =
          lane_sum(abs_ps(_mm_mul_ps(root_a, root_quadrants(tb, 0, CB == 1 ? 0 : c))));
      allowed[c] = float(accuracy / 2 * (double(product) / 4) * values_in_bound_units);
    }
  }

  // Channel c of group g of the root's four quadrants, without the value scale (shared-exponent
  // trees have one group).
  static __m128 root_quadrants(const PackedTreeView& t, int g, int c) {
    const std::uint32_t* values = t.node(0) + (t.is_texel_node(0) ? 0 : 1);
    if (!t.shape().shared_values()) return load_halves(values + 2 * (g * t.shape().channels + c));
    const __m128i words = _mm_loadu_si128(reinterpret_cast<const __m128i*>(values));
    return shared_channel(words, c, shared_steps(words));
  }
};

// Where the nodes of one level of a descent lie: node n of a at a + n x stride_a, of b likewise;
// texel levels address the texel nodes.
struct LevelNodes {
  const std::uint32_t* a;
  const std::uint32_t* b;
  std::size_t stride_a, stride_b;
};

// The largest-deviation alternatives to the product term sa sb, in its units (see
// packed_pair_bound), for trees with linf bounds: on SSE registers, and on AVX-512 below.
// abs_a bounds |a| and the magnitude its halves' rounding scales with (for weighted groups,
// sum_g |weight_g a_g|); vb is b's value.
template <bool kLinfA, bool kLinfB, int CA, int CB>
__m128 linf_terms(const DescentConstants<CA, CB>& k, __m128 term, __m128 sa, __m128 sb,
                  __m128 abs_a, __m128 vb) {
  const __m128 abs_b = abs_ps(vb);
  const __m128 ulp = _mm_set1_ps(float(kHalfRounding));
  const __m128 floor = _mm_set1_ps(float(kHalfSubnormalRounding));
  const __m128 da =
      _mm_add_ps(_mm_mul_ps(abs_a, ulp), _mm_mul_ps(floor, _mm_set1_ps(k.total_weight)));
  const __m128 db = _mm_add_ps(_mm_mul_ps(abs_b, ulp), floor);
  const __m128 values = _mm_set1_ps(k.values_in_bound_units);
  // Each alternative only where the other side is known to be >= 0 (see packed_pair_bound).
  if constexpr (kLinfA)
    if (k.shared_b)
      term = _mm_min_ps(term, _mm_add_ps(_mm_mul_ps(_mm_mul_ps(sa, _mm_add_ps(abs_b, db)),
                                                    _mm_set1_ps(k.linf_a_scale)),
                                         _mm_mul_ps(_mm_mul_ps(abs_b, da), values)));
  if constexpr (kLinfB)
    if (!k.combined && k.shared_a)
      term = _mm_min_ps(term, _mm_add_ps(_mm_mul_ps(_mm_mul_ps(sb, _mm_add_ps(abs_a, da)),
                                                    _mm_set1_ps(k.linf_b_scale)),
                                         _mm_mul_ps(_mm_mul_ps(abs_a, db), values)));
  return term;
}

// Per-pair arithmetic on SSE registers: four quadrants of one channel in each. GA groups of a
// are summed apart (GA > 1: convolve_groups), or GW groups of a are combined with weights into
// one function (GW > 1: weighted convolutions). kFolded: a is a folded tree (folded_tree.h):
// group 0 its values and live bounds, group 1 half the magnitudes its rounding scales with and
// the bounds of the terms that stop where the sum goes on, added on internal quadrants.
// kBound: the bound is summed; without it a pair adds its values alone (the same sums), and
// the bound's arithmetic is left out.
template <int CA, int CB, int GA, int GW, bool kLinfA, bool kLinfB, bool kFolded = false,
          bool kBound = true>
struct NarrowPairs {
  static constexpr int C = CA > CB ? CA : CB;
  // A folded a is read from its decoded nodes (FoldedTree::descent_nodes()).
  static constexpr bool kDecodedFold = true;
  // The flags PackedDescent reads: a is folded; b holds shared-exponent words.
  static constexpr bool kFoldedA = kFolded, kSharedB = false;
  struct Sums {
    __m128 value[GA][C];
    __m128 bound[C];      // product terms, in units of the bound scales
    __m128 magnitude[C];  // |a b| (times area, once a level is done), for the halves' rounding,
                          // in units of the value scales
    Sums() {
      for (int c = 0; c < C; ++c) {
        for (int g = 0; g < GA; ++g)
          value[g][c] = _mm_setzero_ps();
        bound[c] = magnitude[c] = _mm_setzero_ps();
      }
    }
    // Adds o times scale (a level's sums times its area, a power of two: exact).
    void add(const Sums& o, float scale = 1) {
      const __m128 s = _mm_set1_ps(scale);
      for (int c = 0; c < C; ++c) {
        for (int g = 0; g < GA; ++g)
          value[g][c] = _mm_add_ps(value[g][c], _mm_mul_ps(o.value[g][c], s));
        bound[c] = _mm_add_ps(bound[c], _mm_mul_ps(o.bound[c], s));
        magnitude[c] = _mm_add_ps(magnitude[c], _mm_mul_ps(o.magnitude[c], s));
      }
    }
    float value_of(int g, int c) const { return lane_sum(value[g][c]); }
    float bound_of(int c) const { return lane_sum(bound[c]); }
    float magnitude_of(int c) const { return lane_sum(magnitude[c]); }
  };

  // The bound of exact texels of magnitude m (sum_g |w_g v_g| for weighted groups) whose
  // weights add up to total_weight, in bound units given by `scale`.
  static __m128 texel_bounds(__m128 m, float total_weight, float scale) {
    return _mm_mul_ps(_mm_add_ps(_mm_mul_ps(m, _mm_set1_ps(float(kHalfRounding))),
                                 _mm_set1_ps(float(kHalfSubnormalRounding) * total_weight)),
                      _mm_set1_ps(scale));
  }

  // One channel of one group of a side of a pair, four quadrants: its values, the magnitude the
  // largest-deviation terms take (|v|, or a shared word's rounding magnitude), the rounding
  // share, how far rounding may have moved the value in units of kHalfRounding (|v| for halves, a
  // shared word's step share), and its bounds (codes, or an exact texel's rounding).
  struct Side {
    __m128 value, magnitude, share, rounding_units, bound;
  };
  // Channel c of the node at w (a texel node with kTexel), from its shared-exponent words and
  // their steps (loaded once per node) when shared, else from its halves. step_magnitudes: the
  // steps' factors (DescentConstants).
  template <bool kTexel>
  static Side one_channel(const std::uint32_t* w, int c, bool shared, __m128i words, __m128 steps,
                          std::size_t codes, float texel_bound, float shared_bound,
                          const float* step_magnitudes) {
    Side s;
    if (shared) {
      s.value = shared_channel(words, c, steps);
      const __m128 step_share =
          _mm_mul_ps(steps, _mm_set1_ps(step_magnitude<kTexel>(w, step_magnitudes)));
      s.magnitude = _mm_max_ps(s.value, step_share);
      s.share = _mm_mul_ps(_mm_add_ps(s.value, step_share), _mm_set1_ps(0.5f));
      s.rounding_units = step_share;
      if constexpr (kTexel)
        s.bound = _mm_mul_ps(steps, _mm_set1_ps(shared_bound));
      else
        s.bound = load_bound_codes(w + codes + c);
      return s;
    }
    s.value = load_halves(w + (kTexel ? 0 : 1) + 2 * c);
    s.rounding_units = s.share = s.magnitude = abs_ps(s.value);
    if constexpr (kTexel)
      s.bound = texel_bounds(s.magnitude, 1, texel_bound);
    else
      s.bound = load_bound_codes(w + codes + c);
    return s;
  }

  // The magnitude whose kRoundingPerMagnitude-fold bounds the rounding terms of a folded pair,
  // |f| db + |b| df: db is kHalfRounding times b's rounding units (Side::rounding_units: |b| for
  // halves, a shared word's step share); df, the terms' and f's own rounding, kHalfRounding
  // times rounding_f = 2 X + |f|, X the folded tree's half magnitude (the folded side's share).
  static __m128 folded_magnitude(__m128 abs_f, __m128 rounding_f, __m128 rounding_b, __m128 abs_b) {
    return _mm_mul_ps(_mm_add_ps(_mm_mul_ps(abs_f, rounding_b), _mm_mul_ps(rounding_f, abs_b)),
                      _mm_set1_ps(0.5f));
  }

  // Adds the pair's quadrants that stop (leaves, or within the accuracy target), without their
  // area (the level's, applied once per level), and returns the internal quadrants that go on.
  // kTexelA, kTexelB: the node of a, of b, is a texel node of exact texels, values alone.
  template <bool kTexelA, bool kTexelB>
  static unsigned visit(const DescentConstants<CA, CB>& k, const std::uint32_t* wa,
                        const std::uint32_t* wb, unsigned internal, Sums& sums) {
    const std::uint32_t* values_a = wa + (kTexelA ? 0 : 1);
    const std::uint32_t* values_b = wb + (kTexelB ? 0 : 1);
    // Shared-exponent values: a word per quadrant, the channels unpacked below.
    const bool shared_a = CA == 3 && GW == 1 && k.shared_a;
    const bool shared_b = CB == 3 && k.shared_b;
    __m128i words_a = _mm_setzero_si128(), words_b = _mm_setzero_si128();
    __m128 steps_a = _mm_setzero_ps(), steps_b = _mm_setzero_ps();
    if (shared_a) {
      words_a = _mm_loadu_si128(reinterpret_cast<const __m128i*>(values_a));
      steps_a = shared_steps(words_a);
    }
    if (shared_b) {
      words_b = _mm_loadu_si128(reinterpret_cast<const __m128i*>(values_b));
      steps_b = shared_steps(words_b);
    }
    __m128 vb[C], product[C], magnitude[C], term[C], term_on[C];
    for (int c = 0; c < C; ++c) {
      const int ca = CA == 1 ? 0 : c;
      Side a;
      __m128 stopping_bound = _mm_setzero_ps();
      if constexpr (kFolded) {  // decoded: values, shares, bounds, stopping bounds
        const auto at = [&](FoldedTree::DescentBlock block) {
          return load_floats(wa + FoldedTree::descent_offset(CA, block, ca));
        };
        a.value = at(FoldedTree::values);
        a.share = a.magnitude = at(FoldedTree::shares);
        a.bound = at(FoldedTree::bounds);
        stopping_bound = at(FoldedTree::stopping_bounds);
      } else if constexpr (GW == 1) {
        a = one_channel<kTexelA>(wa, ca, shared_a, words_a, steps_a, k.codes_a, k.texel_bound_a,
                                 k.shared_bound_a, k.step_magnitudes_a);
      } else {
        a.value = a.magnitude = a.bound = _mm_setzero_ps();
        for (int g = 0; g < GW; ++g) {
          const __m128 v = load_halves(values_a + 2 * (g * CA + ca));
          a.value = _mm_add_ps(a.value, _mm_mul_ps(_mm_set1_ps(k.weight[g]), v));
          a.magnitude =
              _mm_add_ps(a.magnitude, _mm_mul_ps(_mm_set1_ps(k.abs_weight[g]), abs_ps(v)));
          if constexpr (!kTexelA)
            a.bound =
                _mm_add_ps(a.bound, _mm_mul_ps(_mm_set1_ps(k.abs_weight[g]),
                                               load_bound_codes(wa + k.codes_a + g * CA + ca)));
        }
        if constexpr (kTexelA) a.bound = texel_bounds(a.magnitude, k.total_weight, k.texel_bound_a);
        a.share = a.magnitude;
      }
      const Side b =
          one_channel<kTexelB>(wb, CB == 1 ? 0 : c, shared_b, words_b, steps_b, k.codes_b,
                               k.texel_bound_b, k.shared_bound_b, k.step_magnitudes_b);
      vb[c] = b.value;
      product[c] = _mm_mul_ps(a.value, b.value);
      if constexpr (kFolded)
        magnitude[c] =
            folded_magnitude(abs_ps(a.value), a.share, b.rounding_units, abs_ps(b.value));
      else
        magnitude[c] = _mm_mul_ps(a.share, b.share);
      term[c] = _mm_mul_ps(a.bound, b.bound);
      if constexpr (kFolded) term_on[c] = _mm_mul_ps(stopping_bound, b.bound);
      if constexpr (kLinfA || kLinfB)
        term[c] =
            linf_terms<kLinfA, kLinfB>(k, term[c], a.bound, b.bound, a.magnitude, b.magnitude);
    }
    if (kBound && k.targeted) {
      __m128 enough = _mm_castsi128_ps(_mm_set1_epi32(-1));
      for (int c = 0; c < C; ++c) {
        __m128 allowed;
        if (GW == 1 && !kFolded && !k.shared_a && !k.shared_b)
          allowed = _mm_add_ps(_mm_mul_ps(_mm_set1_ps(k.per_product), abs_ps(product[c])),
                               _mm_set1_ps(k.allowed[c]));
        else  // the rounding scales with the magnitudes (groups', or shared words'), not |a b|
          allowed = _mm_add_ps(_mm_sub_ps(_mm_mul_ps(_mm_set1_ps(k.per_value), abs_ps(product[c])),
                                          _mm_mul_ps(_mm_set1_ps(k.per_magnitude), magnitude[c])),
                               _mm_set1_ps(k.allowed[c]));
        enough = _mm_and_ps(enough, _mm_cmple_ps(term[c], allowed));
      }
      internal &= ~unsigned(_mm_movemask_ps(enough));
    }
    // At a texel node every quadrant stops (run_level passes internal as 0, and this relies on
    // it): the sums take the lanes unmasked, and no quadrant goes on to charge its stopping
    // bound (the same sums, without the masks).
    constexpr bool kAllStop = kTexelA || kTexelB;
    const __m128 internal_lanes = lanes_of(internal);
    const auto stopped = [&](__m128 x) {
      if constexpr (kAllStop)
        return x;
      else
        return _mm_andnot_ps(internal_lanes, x);
    };
    if constexpr (kFolded && kBound && !kAllStop)
      for (int c = 0; c < C; ++c)
        sums.bound[c] = _mm_add_ps(sums.bound[c], _mm_and_ps(internal_lanes, term_on[c]));
    for (int c = 0; c < C; ++c) {
      sums.value[0][c] = _mm_add_ps(sums.value[0][c], stopped(product[c]));
      for (int g = 1; g < GA; ++g) {
        const __m128 vg = load_halves(values_a + 2 * (g * CA + (CA == 1 ? 0 : c)));
        sums.value[g][c] = _mm_add_ps(sums.value[g][c], stopped(_mm_mul_ps(vg, vb[c])));
      }
      if constexpr (!kBound) continue;
      sums.bound[c] = _mm_add_ps(sums.bound[c], stopped(term[c]));
      sums.magnitude[c] = _mm_add_ps(sums.magnitude[c], stopped(magnitude[c]));
    }
    return internal;
  }
};

#if defined(__AVX2__) && !(defined(__AVX512F__) && defined(__AVX512BW__) && defined(__AVX512VL__))

// Twelve lanes on AVX2 registers: channels 0 and 1 of four quadrants in `low` (lanes 4c .. 4c +
// 3 hold channel c), channel 2 in `high`. Each lane goes through the operations NarrowPairs'
// lane of the same channel and quadrant goes through, in the same order.
struct Lanes12 {
  __m256 low;
  __m128 high;
};

inline Lanes12 operator+(Lanes12 x, Lanes12 y) {
  return {_mm256_add_ps(x.low, y.low), _mm_add_ps(x.high, y.high)};
}
inline Lanes12 operator-(Lanes12 x, Lanes12 y) {
  return {_mm256_sub_ps(x.low, y.low), _mm_sub_ps(x.high, y.high)};
}
inline Lanes12 operator*(Lanes12 x, Lanes12 y) {
  return {_mm256_mul_ps(x.low, y.low), _mm_mul_ps(x.high, y.high)};
}
inline Lanes12 lanes12(float v) {
  return {_mm256_set1_ps(v), _mm_set1_ps(v)};
}
// v[c] in channel c's four lanes.
inline Lanes12 lanes12_per_channel(const float* v) {
  return {_mm256_setr_ps(v[0], v[0], v[0], v[0], v[1], v[1], v[1], v[1]), _mm_set1_ps(v[2])};
}
// One channel's four lanes in all three channels.
inline Lanes12 lanes12_grey(__m128 v) {
  return {_mm256_set_m128(v, v), v};
}
inline Lanes12 abs12(Lanes12 x) {
  return {_mm256_andnot_ps(_mm256_set1_ps(-0.0f), x.low), abs_ps(x.high)};
}
inline Lanes12 max12(Lanes12 x, Lanes12 y) {
  return {_mm256_max_ps(x.low, y.low), _mm_max_ps(x.high, y.high)};
}
inline Lanes12 min12(Lanes12 x, Lanes12 y) {
  return {_mm256_min_ps(x.low, y.low), _mm_min_ps(x.high, y.high)};
}
// x where the 4-lane mask (kLaneMasks) is set, in every channel, and 0 elsewhere; or where it
// is clear (andnot12).
inline Lanes12 and12(__m128 mask, Lanes12 x) {
  return {_mm256_and_ps(_mm256_set_m128(mask, mask), x.low), _mm_and_ps(mask, x.high)};
}
inline Lanes12 andnot12(__m128 mask, Lanes12 x) {
  return {_mm256_andnot_ps(_mm256_set_m128(mask, mask), x.low), _mm_andnot_ps(mask, x.high)};
}
// The quadrants where x <= y in every channel, as a 4-bit mask.
inline unsigned all_channels_at_most(Lanes12 x, Lanes12 y) {
  const __m256 low = _mm256_cmp_ps(x.low, y.low, _CMP_LE_OQ);
  const __m128 both = _mm_and_ps(_mm256_castps256_ps128(low), _mm256_extractf128_ps(low, 1));
  return unsigned(_mm_movemask_ps(_mm_and_ps(both, _mm_cmple_ps(x.high, y.high))));
}

// Per-pair arithmetic on AVX2 registers for RGB pairs: NarrowPairs' on twelve lanes (Lanes12),
// two registers an operation where NarrowPairs takes three, and six accumulators where it takes
// nine; each lane's sums are NarrowPairs', in the same order. A grey side is repeated in all
// three channels. kSharedWordsB: b's values are known to be shared-exponent words (else the
// tree says). kBound: as NarrowPairs'.
template <int CA, int CB, int GA, int GW, bool kLinfA, bool kLinfB, bool kFolded = false,
          bool kSharedWordsB = false, bool kBound = true>
struct MidPairs {
  static constexpr int C = 3;
  // A folded a is read from its decoded nodes (FoldedTree::descent_nodes()).
  static constexpr bool kDecodedFold = true;
  // The flags PackedDescent reads: a is folded; b holds shared-exponent words.
  static constexpr bool kFoldedA = kFolded, kSharedB = kSharedWordsB;
  struct Sums {
    Lanes12 value[GA];
    Lanes12 bound = lanes12(0);
    Lanes12 magnitude = lanes12(0);
    Sums() {
      for (int g = 0; g < GA; ++g)
        value[g] = lanes12(0);
    }
    // Adds o times scale (a level's sums times its area, a power of two: exact).
    void add(const Sums& o, float scale = 1) {
      const Lanes12 s = lanes12(scale);
      for (int g = 0; g < GA; ++g)
        value[g] = value[g] + o.value[g] * s;
      bound = bound + o.bound * s;
      magnitude = magnitude + o.magnitude * s;
    }
    static float lanes(Lanes12 v, int c) {
      if (c == 2) return lane_sum(v.high);
      return lane_sum(c == 0 ? _mm256_castps256_ps128(v.low) : _mm256_extractf128_ps(v.low, 1));
    }
    float value_of(int g, int c) const { return lanes(value[g], c); }
    float bound_of(int c) const { return lanes(bound, c); }
    float magnitude_of(int c) const { return lanes(magnitude, c); }
  };

  // The halves of group g of a node of `channels` channels whose values start at w.
  static Lanes12 values(const std::uint32_t* w, int channels, int g) {
    const std::uint32_t* p = w + 2 * g * channels;
    if (channels == 1) return lanes12_grey(load_halves(p));
    return {_mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p))),
            load_halves(p + 4)};
  }
  // The floats of a node of `channels` channels at p (FoldedTree::descent_nodes()).
  static Lanes12 floats(const std::uint32_t* p, int channels) {
    if (channels == 1) return lanes12_grey(load_floats(p));
    return {_mm256_loadu_ps(reinterpret_cast<const float*>(p)), load_floats(p + 8)};
  }
  // The bound codes of a node of `channels` channels at word offset `codes`.
  static Lanes12 bounds(const std::uint32_t* w, int channels, std::size_t codes) {
    if (channels == 1) return lanes12_grey(load_bound_codes(w + codes));
    const __m256i low =
        _mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(w + codes)));
    return {_mm256_castsi256_ps(_mm256_add_epi32(_mm256_slli_epi32(low, 20),
                                                 _mm256_set1_epi32(int(kBoundCodeBias)))),
            load_bound_codes(w + codes + 2)};
  }

  // Four shared-exponent words at w (channel c of word q in lane 4c + q), and their steps in the
  // same lanes.
  static Lanes12 shared_values(const std::uint32_t* w, Lanes12& steps) {
    const __m128i words = _mm_loadu_si128(reinterpret_cast<const __m128i*>(w));
    const __m128 step = shared_steps(words);
    steps = lanes12_grey(step);
    const int m = kSharedMantissaBits;
    const __m256i shifted = _mm256_srlv_epi32(_mm256_broadcastsi128_si256(words),
                                              _mm256_setr_epi32(0, 0, 0, 0, m, m, m, m));
    const __m256i mantissas = _mm256_and_si256(shifted, _mm256_set1_epi32(511));
    return {_mm256_mul_ps(_mm256_cvtepi32_ps(mantissas), steps.low),
            shared_channel(words, 2, step)};
  }

  // The bound of exact texels of magnitude m (see NarrowPairs::texel_bounds).
  static Lanes12 texel_bounds(Lanes12 m, float total_weight, float scale) {
    return (m * lanes12(float(kHalfRounding)) +
            lanes12(float(kHalfSubnormalRounding) * total_weight)) *
           lanes12(scale);
  }

  // The largest-deviation alternatives to the product term (see linf_terms on SSE registers).
  static Lanes12 linf_terms(const DescentConstants<CA, CB>& k, Lanes12 term, Lanes12 sa, Lanes12 sb,
                            Lanes12 abs_a, Lanes12 vb) {
    const Lanes12 abs_b = abs12(vb);
    const Lanes12 ulp = lanes12(float(kHalfRounding));
    const Lanes12 floor = lanes12(float(kHalfSubnormalRounding));
    const Lanes12 da = abs_a * ulp + floor * lanes12(k.total_weight);
    const Lanes12 db = abs_b * ulp + floor;
    const Lanes12 values = lanes12(k.values_in_bound_units);
    if constexpr (kLinfA)
      if (k.shared_b)
        term = min12(term, sa * (abs_b + db) * lanes12(k.linf_a_scale) + abs_b * da * values);
    if constexpr (kLinfB)
      if (!k.combined && k.shared_a)
        term = min12(term, sb * (abs_a + da) * lanes12(k.linf_b_scale) + abs_a * db * values);
    return term;
  }

  // One group of a side of a pair (see NarrowPairs::Side).
  struct Side {
    Lanes12 value, magnitude, share, rounding_units, bound;
  };
  template <bool kTexel>
  static Side one_group(const std::uint32_t* w, int channels, bool shared, std::size_t codes,
                        float texel_bound, float shared_bound, const float* step_magnitudes) {
    const std::uint32_t* values_at = w + (kTexel ? 0 : 1);
    Side s;
    if (shared) {
      Lanes12 steps;
      s.value = shared_values(values_at, steps);
      const Lanes12 step_share = steps * lanes12(step_magnitude<kTexel>(w, step_magnitudes));
      s.magnitude = max12(s.value, step_share);
      s.share = (s.value + step_share) * lanes12(0.5f);
      s.rounding_units = step_share;
      if constexpr (kTexel)
        s.bound = steps * lanes12(shared_bound);
      else
        s.bound = bounds(w, channels, codes);
      return s;
    }
    s.value = values(values_at, channels, 0);
    s.rounding_units = s.share = s.magnitude = abs12(s.value);
    if constexpr (kTexel)
      s.bound = texel_bounds(s.magnitude, 1, texel_bound);
    else
      s.bound = bounds(w, channels, codes);
    return s;
  }

  template <bool kTexelA, bool kTexelB>
  static unsigned visit(const DescentConstants<CA, CB>& k, const std::uint32_t* wa,
                        const std::uint32_t* wb, unsigned internal, Sums& sums) {
    const std::uint32_t* values_a = wa + (kTexelA ? 0 : 1);
    Side a;
    Lanes12 stopping_bound = lanes12(0);
    if constexpr (kFolded) {  // decoded: values, shares, bounds, stopping bounds
      const auto at = [&](FoldedTree::DescentBlock block) {
        return floats(wa + FoldedTree::descent_offset(CA, block, 0), CA);
      };
      a.value = at(FoldedTree::values);
      a.share = a.magnitude = at(FoldedTree::shares);
      a.bound = at(FoldedTree::bounds);
      stopping_bound = at(FoldedTree::stopping_bounds);
    } else if constexpr (GW == 1) {
      a = one_group<kTexelA>(wa, CA, CA == 3 && k.shared_a, k.codes_a, k.texel_bound_a,
                             k.shared_bound_a, k.step_magnitudes_a);
    } else {
      a.value = a.magnitude = a.bound = lanes12(0);
      for (int g = 0; g < GW; ++g) {
        const Lanes12 v = values(values_a, CA, g);
        a.value = a.value + lanes12(k.weight[g]) * v;
        a.magnitude = a.magnitude + lanes12(k.abs_weight[g]) * abs12(v);
        if constexpr (!kTexelA)
          a.bound = a.bound + lanes12(k.abs_weight[g]) * bounds(wa, CA, k.codes_a + g * CA);
      }
      if constexpr (kTexelA) a.bound = texel_bounds(a.magnitude, k.total_weight, k.texel_bound_a);
      a.share = a.magnitude;
    }
    const Side b = one_group<kTexelB>(wb, CB, kSharedWordsB || (CB == 3 && k.shared_b),
                                      kSharedWordsB ? k.kSharedCodes : k.codes_b, k.texel_bound_b,
                                      k.shared_bound_b, k.step_magnitudes_b);
    const Lanes12 product = a.value * b.value;
    Lanes12 magnitude;
    if constexpr (kFolded) {  // see NarrowPairs::folded_magnitude
      // Shared-exponent values are >= 0 (+0 included): their magnitude is themselves.
      const Lanes12 abs_b = kSharedWordsB ? b.value : abs12(b.value);
      magnitude = (abs12(a.value) * b.rounding_units + a.share * abs_b) * lanes12(0.5f);
    } else
      magnitude = a.share * b.share;
    Lanes12 term = a.bound * b.bound;
    if constexpr (kLinfA || kLinfB)
      term = linf_terms(k, term, a.bound, b.bound, a.magnitude, b.magnitude);
    if (kBound && k.targeted) {
      Lanes12 allowed;
      if (GW == 1 && !kFolded && !k.shared_a && !k.shared_b)
        allowed = lanes12(k.per_product) * abs12(product) + lanes12_per_channel(k.allowed);
      else  // the rounding scales with the magnitudes (groups', or shared words'), not |a b|
        allowed = (lanes12(k.per_value) * abs12(product) - lanes12(k.per_magnitude) * magnitude) +
                  lanes12_per_channel(k.allowed);
      internal &= ~all_channels_at_most(term, allowed);
    }
    // At a texel node every quadrant stops (run_level passes internal as 0, and this relies on
    // it): the sums take the lanes unmasked, and no quadrant goes on to charge its stopping
    // bound (the same sums, without the masks).
    constexpr bool kAllStop = kTexelA || kTexelB;
    const __m128 internal_lanes = lanes_of(internal);
    const auto stopped = [&](Lanes12 x) {
      if constexpr (kAllStop)
        return x;
      else
        return andnot12(internal_lanes, x);
    };
    if constexpr (kFolded && kBound && !kAllStop)
      sums.bound = sums.bound + and12(internal_lanes, stopping_bound * b.bound);
    sums.value[0] = sums.value[0] + stopped(product);
    for (int g = 1; g < GA; ++g)
      sums.value[g] = sums.value[g] + stopped(values(values_a, CA, g) * b.value);
    if constexpr (!kBound) return internal;
    sums.bound = sums.bound + stopped(term);
    sums.magnitude = sums.magnitude + stopped(magnitude);
    return internal;
  }
};

#endif  // AVX2 without AVX-512

#if defined(__AVX512F__) && defined(__AVX512BW__) && defined(__AVX512VL__)

inline __m512 abs512(__m512 x) {
  return _mm512_castsi512_ps(
      _mm512_and_si512(_mm512_castps_si512(x), _mm512_set1_epi32(0x7fffffff)));
}

template <bool kLinfA, bool kLinfB, int CA, int CB>
__m512 linf_terms(const DescentConstants<CA, CB>& k, __m512 term, __m512 sa, __m512 sb,
                  __m512 abs_a, __m512 vb) {
  const __m512 abs_b = abs512(vb);
  const __m512 ulp = _mm512_set1_ps(float(kHalfRounding));
  const __m512 floor = _mm512_set1_ps(float(kHalfSubnormalRounding));
  const __m512 da = _mm512_add_ps(_mm512_mul_ps(abs_a, ulp),
                                  _mm512_mul_ps(floor, _mm512_set1_ps(k.total_weight)));
  const __m512 db = _mm512_add_ps(_mm512_mul_ps(abs_b, ulp), floor);
  const __m512 values = _mm512_set1_ps(k.values_in_bound_units);
  // Each alternative only where the other side is known to be >= 0 (see packed_pair_bound).
  if constexpr (kLinfA)
    if (k.shared_b)
      term = _mm512_maskz_min_ps(
          0xffff, term,
          _mm512_add_ps(_mm512_mul_ps(_mm512_mul_ps(sa, _mm512_add_ps(abs_b, db)),
                                      _mm512_set1_ps(k.linf_a_scale)),
                        _mm512_mul_ps(_mm512_mul_ps(abs_b, da), values)));
  if constexpr (kLinfB)
    if (!k.combined && k.shared_a)
      term = _mm512_maskz_min_ps(
          0xffff, term,
          _mm512_add_ps(_mm512_mul_ps(_mm512_mul_ps(sb, _mm512_add_ps(abs_a, da)),
                                      _mm512_set1_ps(k.linf_b_scale)),
                        _mm512_mul_ps(_mm512_mul_ps(abs_a, db), values)));
  return term;
}

// Per-pair arithmetic on AVX-512 registers: the four quadrants of all three channels in one
// register (lanes 4c .. 4c + 3 hold channel c), a grey side repeated in all three.
// kSharedWordsB: b's values are known to be shared-exponent words (else the tree says). kBound:
// as NarrowPairs'.
template <int CA, int CB, int GA, int GW, bool kLinfA, bool kLinfB, bool kFolded = false,
          bool kSharedWordsB = false, bool kBound = true>
struct WidePairs {
  static constexpr int C = 3;
  // A folded a is read from its packed words (halves and bound codes).
  static constexpr bool kDecodedFold = false;
  // The flags PackedDescent reads: a is folded; b holds shared-exponent words.
  static constexpr bool kFoldedA = kFolded, kSharedB = kSharedWordsB;
  static constexpr __mmask16 kLanes = 0x0fff;
  struct Sums {
    __m512 value[GA];
    __m512 bound = _mm512_setzero_ps();
    __m512 magnitude = _mm512_setzero_ps();
    Sums() {
      for (int g = 0; g < GA; ++g)
        value[g] = _mm512_setzero_ps();
    }
    // Adds o times scale (a level's sums times its area, a power of two: exact).
    void add(const Sums& o, float scale = 1) {
      const __m512 s = _mm512_set1_ps(scale);
      for (int g = 0; g < GA; ++g)
        value[g] = _mm512_fmadd_ps(o.value[g], s, value[g]);
      bound = _mm512_fmadd_ps(o.bound, s, bound);
      magnitude = _mm512_fmadd_ps(o.magnitude, s, magnitude);
    }
    static float lanes(__m512 v, int c) {
      alignas(64) float lane[16];
      _mm512_store_ps(lane, v);
      return (lane[4 * c] + lane[4 * c + 1]) + (lane[4 * c + 2] + lane[4 * c + 3]);
    }
    float value_of(int g, int c) const { return lanes(value[g], c); }
    float bound_of(int c) const { return lanes(bound, c); }
    float magnitude_of(int c) const { return lanes(magnitude, c); }
  };

  // The halves of group g of a node of `channels` channels whose values start at w, as 12 lanes.
  static __m512 values(const std::uint32_t* w, int channels, int g) {
    const std::uint32_t* p = w + 2 * g * channels;
    if (channels == 1) return _mm512_maskz_broadcast_f32x4(0xffff, load_halves(p));
    return _mm512_maskz_cvtph_ps(0xffff, _mm256_maskz_loadu_epi16(kLanes, p));
  }
  // The bound codes of a node of `channels` channels at word offset `codes`, as 12 lanes.
  static __m512 bounds(const std::uint32_t* w, int channels, std::size_t codes) {
    const __m128i bytes =
        channels == 1 ? _mm_set1_epi32(int(w[codes])) : _mm_maskz_loadu_epi8(kLanes, w + codes);
    return _mm512_castsi512_ps(_mm512_add_epi32(
        _mm512_maskz_slli_epi32(0xffff, _mm512_maskz_cvtepu8_epi32(0xffff, bytes), 20),
        _mm512_set1_epi32(int(kBoundCodeBias))));
  }

  // Four shared-exponent words at w as 12 lanes (channel c of word q in lane 4c + q), and their
  // steps in the same lanes. (Masked forms throughout: the unmasked ones start from undefined
  // registers, which GCC 12 warns of.)
  static __m512 shared_values(const std::uint32_t* w, __m512& steps) {
    const __m512i words =
        _mm512_maskz_broadcast_i32x4(0xffff, _mm_loadu_si128(reinterpret_cast<const __m128i*>(w)));
    const __m512i exponents = _mm512_maskz_srli_epi32(0xffff, words, 27);
    steps = _mm512_castsi512_ps(_mm512_maskz_slli_epi32(
        0xffff, _mm512_add_epi32(exponents, _mm512_set1_epi32(127 - kSharedExponentBias)), 23));
    const int m = kSharedMantissaBits;
    const __m512i shifts =
        _mm512_setr_epi32(0, 0, 0, 0, m, m, m, m, 2 * m, 2 * m, 2 * m, 2 * m, 0, 0, 0, 0);
    const __m512i mantissas = _mm512_maskz_and_epi32(
        kLanes, _mm512_maskz_srlv_epi32(0xffff, words, shifts), _mm512_set1_epi32(511));
    return _mm512_mul_ps(_mm512_maskz_cvtepi32_ps(0xffff, mantissas), steps);
  }

  // The bound of exact texels of magnitude m (see NarrowPairs::texel_bounds).
  static __m512 texel_bounds(__m512 m, float total_weight, float scale) {
    return _mm512_mul_ps(
        _mm512_fmadd_ps(m, _mm512_set1_ps(float(kHalfRounding)),
                        _mm512_set1_ps(float(kHalfSubnormalRounding) * total_weight)),
        _mm512_set1_ps(scale));
  }

  // One group of a side of a pair, all channels in 12 lanes: its values, the magnitude the
  // largest-deviation terms take (|v|, or a shared word's rounding magnitude), the rounding
  // share, how far rounding may have moved the value (NarrowPairs::Side), and its bounds (codes,
  // or an exact texel's rounding).
  struct Side {
    __m512 value, magnitude, share, rounding_units, bound;
  };
  // Group 0 of the node at w (a texel node with kTexel), from its shared-exponent words when
  // shared, else from its halves.
  template <bool kTexel>
  static Side one_group(const std::uint32_t* w, int channels, bool shared, std::size_t codes,
                        float texel_bound, float shared_bound, const float* step_magnitudes) {
    const std::uint32_t* values_at = w + (kTexel ? 0 : 1);
    Side s;
    if (shared) {
      __m512 steps;
      s.value = shared_values(values_at, steps);
      const __m512 step_share =
          _mm512_mul_ps(steps, _mm512_set1_ps(step_magnitude<kTexel>(w, step_magnitudes)));
      s.magnitude = _mm512_maskz_max_ps(0xffff, s.value, step_share);
      s.share = _mm512_mul_ps(_mm512_add_ps(s.value, step_share), _mm512_set1_ps(0.5f));
      s.rounding_units = step_share;
      if constexpr (kTexel)
        s.bound = _mm512_mul_ps(steps, _mm512_set1_ps(shared_bound));
      else
        s.bound = bounds(w, channels, codes);
      return s;
    }
    s.value = values(values_at, channels, 0);
    s.rounding_units = s.share = s.magnitude = abs512(s.value);
    if constexpr (kTexel)
      s.bound = texel_bounds(s.magnitude, 1, texel_bound);
    else
      s.bound = bounds(w, channels, codes);
    return s;
  }

  template <bool kTexelA, bool kTexelB>
  static unsigned visit(const DescentConstants<CA, CB>& k, const std::uint32_t* wa,
                        const std::uint32_t* wb, unsigned internal, Sums& sums) {
    const std::uint32_t* values_a = wa + (kTexelA ? 0 : 1);
    Side a;
    __m512 stopping_bound = _mm512_setzero_ps(), half_magnitude = _mm512_setzero_ps();
    if constexpr (kFolded) {
      a.value = values(values_a, CA, 0);
      half_magnitude = values(values_a, CA, 1);
      a.share = a.magnitude =
          _mm512_add_ps(abs512(a.value), _mm512_add_ps(half_magnitude, half_magnitude));
      a.bound = bounds(wa, CA, k.codes_a);
      stopping_bound = bounds(wa, CA, k.codes_a + CA);
    } else if constexpr (GW == 1) {
      a = one_group<kTexelA>(wa, CA, CA == 3 && k.shared_a, k.codes_a, k.texel_bound_a,
                             k.shared_bound_a, k.step_magnitudes_a);
    } else {
      a.value = a.magnitude = a.bound = _mm512_setzero_ps();
      for (int g = 0; g < GW; ++g) {
        const __m512 v = values(values_a, CA, g);
        a.value = _mm512_fmadd_ps(_mm512_set1_ps(k.weight[g]), v, a.value);
        a.magnitude = _mm512_fmadd_ps(_mm512_set1_ps(k.abs_weight[g]), abs512(v), a.magnitude);
        if constexpr (!kTexelA)
          a.bound = _mm512_fmadd_ps(_mm512_set1_ps(k.abs_weight[g]),
                                    bounds(wa, CA, k.codes_a + g * CA), a.bound);
      }
      if constexpr (kTexelA) a.bound = texel_bounds(a.magnitude, k.total_weight, k.texel_bound_a);
      a.share = a.magnitude;
    }
    const Side b = one_group<kTexelB>(wb, CB, kSharedWordsB || (CB == 3 && k.shared_b),
                                      kSharedWordsB ? k.kSharedCodes : k.codes_b, k.texel_bound_b,
                                      k.shared_bound_b, k.step_magnitudes_b);
    const __m512 product = _mm512_mul_ps(a.value, b.value);
    __m512 magnitude;
    if constexpr (kFolded) {  // see NarrowPairs::folded_magnitude
      const __m512 abs_f = abs512(a.value), abs_b = abs512(b.value);
      magnitude =
          _mm512_mul_ps(_mm512_fmadd_ps(abs_f, b.rounding_units, _mm512_mul_ps(a.share, abs_b)),
                        _mm512_set1_ps(0.5f));
    } else {
      magnitude = _mm512_mul_ps(a.share, b.share);
    }
    __m512 term = _mm512_mul_ps(a.bound, b.bound);
    if constexpr (kLinfA || kLinfB)
      term = linf_terms<kLinfA, kLinfB>(k, term, a.bound, b.bound, a.magnitude, b.magnitude);
    if (kBound && k.targeted) {
      __m512 per_pair;
      if (GW == 1 && !kFolded && !k.shared_a && !k.shared_b)
        per_pair = _mm512_mul_ps(_mm512_set1_ps(k.per_product), abs512(product));
      else  // the rounding scales with the magnitudes (groups', or shared words'), not |a b|
        per_pair = _mm512_sub_ps(_mm512_mul_ps(_mm512_set1_ps(k.per_value), abs512(product)),
                                 _mm512_mul_ps(_mm512_set1_ps(k.per_magnitude), magnitude));
      const __m512 allowed = _mm512_add_ps(
          per_pair,
          _mm512_setr_ps(k.allowed[0], k.allowed[0], k.allowed[0], k.allowed[0], k.allowed[1],
                         k.allowed[1], k.allowed[1], k.allowed[1], k.allowed[2], k.allowed[2],
                         k.allowed[2], k.allowed[2], 0, 0, 0, 0));
      const unsigned within = _mm512_cmp_ps_mask(term, allowed, _CMP_LE_OQ);
      internal &= ~(within & within >> 4 & within >> 8 & 15u);
    }
    const unsigned leaves = ~internal & 15u;
    const __mmask16 stop = __mmask16(leaves | leaves << 4 | leaves << 8);
    sums.value[0] = _mm512_mask_add_ps(sums.value[0], stop, sums.value[0], product);
    for (int g = 1; g < GA; ++g)
      sums.value[g] = _mm512_mask_add_ps(sums.value[g], stop, sums.value[g],
                                         _mm512_mul_ps(values(values_a, CA, g), b.value));
    if constexpr (!kBound) return internal;
    sums.bound = _mm512_mask_add_ps(sums.bound, stop, sums.bound, term);
    if constexpr (kFolded && !(kTexelA || kTexelB))  // no quadrant of a texel node goes on
      sums.bound =
          _mm512_mask_add_ps(sums.bound, __mmask16(internal | internal << 4 | internal << 8),
                             sums.bound, _mm512_mul_ps(stopping_bound, b.bound));
    sums.magnitude = _mm512_mask_add_ps(sums.magnitude, stop, sums.magnitude, magnitude);
    return internal;
  }
};

#endif  // AVX-512

// Breadth-first simultaneous descent of packed trees a (groups 0..GA-1) and b (group 0): a
// level's pairs are visited in the order they were queued, and the pairs of their internal
// quadrants queued for the next level, so that consecutive pairs do not depend on each other and,
// nodes lying breadth first, each level's nodes are read in increasing address order. Each
// pair's arithmetic is the policy's (SSE, or AVX-512 or AVX2 for RGB); sums are kept without the
// trees' scales, applied once at the end, and a level's without its quadrants' area, applied once
// per level.
template <typename Pairs, int CA, int CB>
class PackedDescent {
 public:
  using Sums = typename Pairs::Sums;

  PackedDescent(const PackedTreeView& a, const PackedTreeView& b, double accuracy,
                std::span<const float> weights, std::span<const std::uint32_t> folded_nodes = {})
      : k_(a, b, accuracy, weights, folded_nodes) {}

  Sums run(std::uint32_t root_a, std::uint32_t root_b, float quadrant_area, int depth) const {
    if (depth > kMaxTreeLevels) throw std::runtime_error("quadtree deeper than its resolution");
    Sums sums;
    Levels levels;
    levels.pairs[depth & 1][0] = {root_a, root_b};
    unsigned count = 1;
    // Level by level: the texel nodes of exact texels (values alone, no children) are the last
    // level's, so which kind of node a pair holds is known per level, not per pair.
    for (float area = quadrant_area; count > 0; area *= 0.25f, ++depth) {
      const Pair* pairs = levels.pairs[depth & 1];
      Pair* next = levels.pairs[~depth & 1];
      const bool texel_a = depth == k_.texel_depth_a, texel_b = depth == k_.texel_depth_b;
      if (!texel_a && !texel_b) [[likely]]
        count = run_level<false, false>(pairs, count, next, area, depth, sums);
      else if (!texel_a)
        count = run_level<false, true>(pairs, count, next, area, depth, sums);
      else if (!texel_b)
        count = run_level<true, false>(pairs, count, next, area, depth, sums);
      else
        count = run_level<true, true>(pairs, count, next, area, depth, sums);
    }
    return sums;
  }

  const DescentConstants<CA, CB>& constants() const { return k_; }
  // For a folded tree a: its values may be negative (a combination), and its terms' rounding
  // floor is floor_weight (FoldedTree).
  void fold(float floor_weight) {
    k_.combined = true;
    k_.total_weight = floor_weight;
  }

 private:
  // Room for a real lookup's widest level (at 128^2, on average about 300 pairs for the main
  // job's GGX entries, 600-800 against the forest's captures): a pair whose children find the
  // next level full descends apart, in nested calls, and at 256 pairs that cost a GGX lookup a
  // fifth of its time.
  static constexpr unsigned kLevelPairs = 2048;

  // A pair of nodes, of a and of b.
  struct Pair {
    std::uint32_t a, b;
  };
  // The pairs of the level being visited and of the next, alternately (level d in pairs[d & 1]).
  struct Levels {
    alignas(32) Pair pairs[2][kLevelPairs];
  };

  // Words of a folded a's decoded node where the policy reads them (0 otherwise), and of b's
  // shared-exponent nodes, full and texel.
  static constexpr std::size_t kDecodedStrideA =
      Pairs::kFoldedA && Pairs::kDecodedFold ? DescentConstants<CA, CB>::kDecodedFoldWords : 0;
  static constexpr std::size_t kSharedWords[2] = {DescentConstants<CA, CB>::kSharedNodeWords,
                                                  DescentConstants<CA, CB>::kSharedTexelWords};

  LevelNodes level_nodes(int depth) const {
    const bool texel_a = depth == k_.texel_depth_a, texel_b = depth == k_.texel_depth_b;
    return {texel_a ? k_.texels_a : k_.a, texel_b ? k_.texels_b : k_.b,
            texel_a ? k_.texel_words_a : k_.words_a, texel_b ? k_.texel_words_b : k_.words_b};
  }

  // Visits the `count` pairs of one level, writes the pairs of their internal quadrants to
  // `next` and returns how many. kTexelA, kTexelB: the level's nodes of a, of b, are texel nodes.
  template <bool kTexelA, bool kTexelB>
  unsigned run_level(const Pair* pairs, unsigned count, Pair* next, float area, int depth,
                     Sums& sums) const {
    // The level works on a copy of the constants and sums of its own: SIMD stores may alias
    // anything, so that every pair's stores into the next level would otherwise send the sums
    // and constants through memory (a chain of stores and reloads from one pair to the next).
    // The level's sums are kept without its area, a power of two applied once at the end
    // (exactly, so that only the order of the additions changes).
    const DescentConstants<CA, CB> k = k_;
    Sums level_sums, nested;
    unsigned queued = 0;
    // Pairs whose children found the next level full (index << 4 | internal quadrants): they
    // descend after the loop, which then makes no call and keeps more of the level's sums in
    // registers (fewer instructions a pair); in the same order, so the same sums.
    static_assert(((kLevelPairs - 1) << 4 | 15u) <= 0xFFFFu, "an entry fits 16 bits");
    std::uint16_t overflow[kLevelPairs];
    unsigned overflowed = 0;
    const LevelNodes nodes = level_nodes(depth), children_nodes = level_nodes(depth + 1);
    // Strides the policy fixes (a folded a's decoded nodes, b's shared-exponent nodes) are
    // constants, so that a pair's addresses take no multiplication by a value held in memory.
    const std::size_t stride_a = kDecodedStrideA ? kDecodedStrideA : nodes.stride_a;
    const std::size_t stride_b = Pairs::kSharedB ? kSharedWords[kTexelB] : nodes.stride_b;
    for (unsigned i = 0; i < count; ++i) {
      const std::uint32_t* wa = nodes.a + std::size_t(pairs[i].a) * stride_a;
      const std::uint32_t* wb = nodes.b + std::size_t(pairs[i].b) * stride_b;
      if constexpr (kTexelA || kTexelB) {
        // A texel node has no children: nothing goes on.
        Pairs::template visit<kTexelA, kTexelB>(k, wa, wb, 0, level_sums);
        continue;
      }
      const std::uint32_t la = wa[0], lb = wb[0];
      const unsigned internal =
          Pairs::template visit<false, false>(k, wa, wb, la & lb & 0xFu, level_sums);
      if (queued > kLevelPairs - 4) [[unlikely]] {
        // No room: this pair's internal quadrants descend after the loop, in nested calls.
        overflow[overflowed++] = std::uint16_t(i << 4 | internal);
        continue;
      }
      // The children are read when their level comes: ask for them now, so that memory
      // latency overlaps the rest of this level. A node's children lie next to each other:
      // their first two cache lines (all four of a capture's full nodes, 128 bytes, when the
      // first starts a line), whichever quadrants go on (prefetches never fault, and a branch
      // per quadrant cost more than they do).
      const char* children_b = reinterpret_cast<const char*>(
          children_nodes.b + std::size_t(lb >> 4) * children_nodes.stride_b);
      _mm_prefetch(children_b, _MM_HINT_T0);
      _mm_prefetch(children_b + 64, _MM_HINT_T0);
      // Without a branch on the data (which no predictor learns): the pairs of the internal
      // quadrants are written one after the other, with room for all four.
      const __m128i ca = _mm_add_epi32(_mm_set1_epi32(int(la >> 4)), child_offsets(la));
      const __m128i cb = _mm_add_epi32(_mm_set1_epi32(int(lb >> 4)), child_offsets(lb));
      Pair* slot = next + queued;
#if defined(__AVX512F__) && defined(__AVX512VL__)
      const __m128i low = _mm_unpacklo_epi32(ca, cb), high = _mm_unpackhi_epi32(ca, cb);
      const __m256i four = _mm256_inserti128_si256(_mm256_castsi128_si256(low), high, 1);
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(slot),
                          _mm256_maskz_compress_epi64(__mmask8(internal), four));
      queued += unsigned(std::popcount(internal));
#elif defined(__AVX2__)
      // The children of a's quadrants in the low half, b's in the high: quadrant q's pair is
      // lanes q and 4 + q, gathered in order for the internal quadrants.
      const __m256i both = _mm256_inserti128_si256(_mm256_castsi128_si256(ca), cb, 1);
      _mm256_storeu_si256(
          reinterpret_cast<__m256i*>(slot),
          _mm256_permutevar8x32_epi32(both, _mm256_load_si256(reinterpret_cast<const __m256i*>(
                                                kQueuedLanes.lanes[internal]))));
      queued += unsigned(std::popcount(internal));
#else
      const __m128i low = _mm_unpacklo_epi32(ca, cb), high = _mm_unpackhi_epi32(ca, cb);
      _mm_storel_epi64(reinterpret_cast<__m128i*>(slot), low);
      slot += internal & 1;
      _mm_storel_epi64(reinterpret_cast<__m128i*>(slot), _mm_srli_si128(low, 8));
      slot += internal >> 1 & 1;
      _mm_storel_epi64(reinterpret_cast<__m128i*>(slot), high);
      slot += internal >> 2 & 1;
      _mm_storel_epi64(reinterpret_cast<__m128i*>(slot), _mm_srli_si128(high, 8));
      slot += internal >> 3 & 1;
      queued = unsigned(slot - next);
#endif
    }
    for (unsigned j = 0; j < overflowed; ++j) {
      const unsigned i = overflow[j] >> 4, internal = overflow[j] & 15u;
      const std::uint32_t la = nodes.a[std::size_t(pairs[i].a) * stride_a];
      const std::uint32_t lb = nodes.b[std::size_t(pairs[i].b) * stride_b];
      for (unsigned q = 0; q < 4; ++q)
        if (internal >> q & 1)
          nested.add(run(first_child(la, q), first_child(lb, q), area * 0.25f, depth + 1));
    }
    sums.add(level_sums, area);
    sums.add(nested);
    return queued;
  }

  static std::uint32_t first_child(std::uint32_t link, unsigned q) {
    return (link >> 4) + kChildOffsets[link & 15u][q];
  }

  DescentConstants<CA, CB> k_;
};

// kFolded: a is folded->tree() (folded_tree.h), whose terms' rounding folded->floor_weight()
// covers, read from its decoded nodes where the policy takes them (kDecodedFold). kSharedWordsB:
// b's values are shared-exponent words (WidePairs, MidPairs). Without kBound, the values alone (the
// same sums) and a bound of +infinity.
template <int CA, int CB, int GA, int GW, bool kLinfA, bool kLinfB, bool kFolded = false,
          bool kSharedWordsB = false, bool kBound = true>
GroupConvolution descend_simd(const PackedTreeView& a, const PackedTreeView& b, double accuracy,
                              std::span<const float> weights, const FoldedTree* folded = nullptr) {
  constexpr int C = CA > CB ? CA : CB;
#if defined(__AVX512F__) && defined(__AVX512BW__) && defined(__AVX512VL__)
  using Pairs =
      std::conditional_t<C == 3,
                         WidePairs<CA, CB, GA, GW, kLinfA, kLinfB, kFolded, kSharedWordsB, kBound>,
                         NarrowPairs<CA, CB, GA, GW, kLinfA, kLinfB, kFolded, kBound>>;
#elif defined(__AVX2__)
  using Pairs =
      std::conditional_t<C == 3,
                         MidPairs<CA, CB, GA, GW, kLinfA, kLinfB, kFolded, kSharedWordsB, kBound>,
                         NarrowPairs<CA, CB, GA, GW, kLinfA, kLinfB, kFolded, kBound>>;
#else
  using Pairs = NarrowPairs<CA, CB, GA, GW, kLinfA, kLinfB, kFolded, kBound>;
#endif
  std::span<const std::uint32_t> folded_nodes;
  if constexpr (kFolded && Pairs::kDecodedFold) folded_nodes = folded->descent_nodes();
  if constexpr (kSharedWordsB) {
    using K = DescentConstants<CA, CB>;
    if (std::size_t(b.shape().words_per_node()) != K::kSharedNodeWords ||
        std::size_t(b.shape().words_per_texel_node()) != K::kSharedTexelWords ||
        std::size_t(1 + b.shape().value_words()) != K::kSharedCodes)
      throw std::logic_error("a tree of shared-exponent words laid out otherwise");
  }
  PackedDescent<Pairs, CA, CB> descent(a, b, accuracy, weights, folded_nodes);
  if constexpr (kFolded) descent.fold(folded->floor_weight());
  const typename Pairs::Sums sums = descent.run(0, 0, 0.25f, 0);
  const DescentConstants<CA, CB>& k = descent.constants();
  // Results below the normal floats lose up to 2^-150 an operation, in the units they are
  // computed in: fewer than 2^7 n operations reach a channel's value in the sums' units, as many
  // its magnitudes and its bound; and a weighted group's products (tiny weights) lose it in a's
  // units, two operations each, before they are multiplied by b's value (below 2^16 in its
  // units) and an area (the areas summing to 1): at most 3 x 2^-133 a channel for the values,
  // and as much for the magnitudes beside them.
  const double additions = simd_additions(a, b);
  const double gamma = detail::summation_gamma(additions, 0x1p-24);
  const double floor = kRoundingFloor * k.total_weight * k.value_scale +
                       (additions * 0x1p-142 + 3 * 0x1p-132) * k.value_scale +
                       additions * 0x1p-143 * k.bound_scale;
  GroupConvolution result;
  for (int c = 0; c < 3; ++c) {
    const int lane = C == 1 ? 0 : c;
    double bound = std::numeric_limits<double>::infinity();
    if constexpr (kBound) {
      const double magnitudes = double(sums.magnitude_of(lane)) * k.value_scale;
      bound = descent_bound(
          double(sums.bound_of(lane)) * k.bound_scale + kRoundingPerMagnitude * magnitudes,
          magnitudes, gamma, floor);
    }
    const CertifiedFloat group0 =
        certified_float(double(sums.value_of(0, lane)) * k.value_scale, bound);
    result.value[0][c] = group0.value;
    result.bound[c] = group0.bound;
    for (int g = 1; g < GA; ++g)
      result.value[g][c] = certified_float(double(sums.value_of(g, lane)) * k.value_scale, 0).value;
  }
  return result;
}

// kFolded: a is folded->tree (see descend_simd). kBound: see descend_simd.
template <int GA, int GW, bool kFolded = false, bool kBound = true>
GroupConvolution dispatch_simd(const PackedTreeView& a, const PackedTreeView& b, double accuracy,
                               std::span<const float> weights, const FoldedTree* folded = nullptr) {
  const int ca = a.shape().channels, cb = b.shape().channels;
  const bool la = a.shape().bounds == BoundKind::linf, lb = b.shape().bounds == BoundKind::linf;
  auto by_kinds = [&]<int CA, int CB>() {
    if constexpr (!kFolded) {
      if (la && lb)
        return descend_simd<CA, CB, GA, GW, true, true, false, false, kBound>(a, b, accuracy,
                                                                              weights);
      if (la)
        return descend_simd<CA, CB, GA, GW, true, false, false, false, kBound>(a, b, accuracy,
                                                                               weights);
    }
    if (lb)
      return descend_simd<CA, CB, GA, GW, false, true, kFolded, false, kBound>(a, b, accuracy,
                                                                               weights, folded);
    // Lookups against captures (shared-exponent words, RGB), a batch's folded ones and single
    // entries: the encoding known at compile time spares every pair a branch and the merge of
    // its two sides, and the node strides become constants.
    if constexpr ((kFolded || (GA == 1 && GW == 1)) && CB == 3)
      if (b.shape().shared_values())
        return descend_simd<CA, CB, GA, GW, false, false, kFolded, true, kBound>(a, b, accuracy,
                                                                                 weights, folded);
    return descend_simd<CA, CB, GA, GW, false, false, kFolded, false, kBound>(a, b, accuracy,
                                                                              weights, folded);
  };
  if (ca == 1 && cb == 1) return by_kinds.template operator()<1, 1>();
  if (ca == 1) return by_kinds.template operator()<1, 3>();
  if (cb == 1) return by_kinds.template operator()<3, 1>();
  return by_kinds.template operator()<3, 3>();
}

// dispatch_simd with the bound, or without it (the values alone) when `bound` is false.
template <int GA, int GW, bool kFolded = false>
GroupConvolution dispatch_simd_bound_if(bool bound, const PackedTreeView& a,
                                        const PackedTreeView& b, double accuracy,
                                        std::span<const float> weights,
                                        const FoldedTree* folded = nullptr) {
  if (bound) return dispatch_simd<GA, GW, kFolded>(a, b, accuracy, weights, folded);
  return dispatch_simd<GA, GW, kFolded, false>(a, b, accuracy, weights, folded);
}

#endif  // SSE4.1 and F16C

// One group weighted by w: the value times w, the bound times |w|.
// The products of two floats are exact in double: the float results keep a bound that holds.
[[maybe_unused]] GroupConvolution scalar_weight_of(GroupConvolution g, float w) {
  for (int c = 0; c < 3; ++c) {
    const CertifiedFloat f =
        certified_float(double(g.value[0][c]) * w, double(g.bound[c]) * std::abs(w));
    g.value[0][c] = f.value;
    g.bound[c] = f.bound;
  }
  return g;
}

// With `bound` false, one group's value alone (the same sums) and a bound of +infinity.
GroupConvolution dispatch(const PackedTreeView& a, const PackedTreeView& b, int groups,
                          double accuracy, bool bound = true) {
#if defined(__SSE4_1__) && defined(__F16C__)
  check_compatible(a.shape(), b.shape());
  switch (groups) {
    case 1:
      return dispatch_simd_bound_if<1, 1>(bound, a, b, accuracy, {});
    case 2:
      return dispatch_simd<2, 1>(a, b, accuracy, {});
    default:
      return dispatch_simd<3, 1>(a, b, accuracy, {});
  }
#else
  (void)bound;  // the scalar descent computes the bound; result_of drops it
  return scalar(a, b, groups, accuracy);
#endif
}

void check_weights(const PackedTreeView& a, std::span<const float> weights) {
  if (weights.empty() || weights.size() > 3 || int(weights.size()) > a.shape().bounded_groups)
    throw std::invalid_argument("weights for " + std::to_string(weights.size()) +
                                " groups of a tree with bounds for " +
                                std::to_string(a.shape().bounded_groups));
  for (const float w : weights)
    if (!std::isfinite(w)) throw std::invalid_argument("a group weight is not finite");
}

// An accuracy target is a fraction from 0 to 1, and stops on the bound: it cannot go without one.
void check_options(const ConvolutionOptions& options) {
  if (!(options.accuracy >= 0 && options.accuracy <= 1))
    throw std::invalid_argument("an accuracy target must be from 0 to 1, got " +
                                number_text(options.accuracy));
  if (!options.bound && options.accuracy > 0)
    throw std::invalid_argument("an accuracy target needs the certified bound it stops on");
}

// Group 0 of g; its bound +infinity without options.bound (for the paths that computed it).
Convolution result_of(const GroupConvolution& g, const ConvolutionOptions& options) {
  constexpr float kNone = std::numeric_limits<float>::infinity();
  if (!options.bound) return {g.value[0], {kNone, kNone, kNone}};
  return {g.value[0], g.bound};
}

}  // namespace

Convolution convolve(const PackedTreeView& a, const PackedTreeView& b,
                     const ConvolutionOptions& options) {
  const GradualUnderflow gradual_underflow;
  check_options(options);
  return result_of(dispatch(a, b, 1, options.accuracy, options.bound), options);
}

Convolution convolve(const FoldedTree& a, const PackedTreeView& b,
                     const ConvolutionOptions& options) {
  const GradualUnderflow gradual_underflow;
  check_compatible(a.tree().shape, b.shape());
  check_options(options);
#if defined(__SSE4_1__) && defined(__F16C__)
  if (a.descent_nodes().empty()) throw std::invalid_argument("a folded tree moved from");
  return result_of(dispatch_simd_bound_if<1, 1, true>(options.bound, a.tree().view(), b,
                                                      options.accuracy, {}, &a),
                   options);
#else
  (void)options;
  throw std::logic_error("convolving a folded tree needs SSE4.1 and F16C (folding_available())");
#endif
}

Convolution convolve_scalar(const PackedTreeView& a, const PackedTreeView& b,
                            const ConvolutionOptions& options) {
  const GradualUnderflow gradual_underflow;
  check_options(options);
  return result_of(scalar(a, b, 1, options.accuracy), options);
}

Convolution convolve_weighted(const PackedTreeView& a, std::span<const float> weights,
                              const PackedTreeView& b, const ConvolutionOptions& options) {
  const GradualUnderflow gradual_underflow;
  check_weights(a, weights);
  check_options(options);
#if defined(__SSE4_1__) && defined(__F16C__)
  check_compatible(a.shape(), b.shape());
  const double accuracy = options.accuracy;
  GroupConvolution g;
  switch (weights.size()) {
    case 1:
      g = scalar_weight_of(dispatch_simd_bound_if<1, 1>(options.bound, a, b, accuracy, {}),
                           weights[0]);
      break;
    case 2:
      g = dispatch_simd_bound_if<1, 2>(options.bound, a, b, accuracy, weights);
      break;
    default:
      g = dispatch_simd_bound_if<1, 3>(options.bound, a, b, accuracy, weights);
  }
#else
  const GroupConvolution g = scalar(a, b, 1, options.accuracy, weights);
#endif
  return result_of(g, options);
}

Convolution convolve_weighted_scalar(const PackedTreeView& a, std::span<const float> weights,
                                     const PackedTreeView& b, const ConvolutionOptions& options) {
  const GradualUnderflow gradual_underflow;
  check_weights(a, weights);
  check_options(options);
  return result_of(scalar(a, b, 1, options.accuracy, weights), options);
}

GroupConvolution convolve_groups(const PackedTreeView& a, const PackedTreeView& b) {
  const GradualUnderflow gradual_underflow;
  return dispatch(a, b, std::min(a.shape().groups, 3), 0);
}

GroupConvolution convolve_groups_scalar(const PackedTreeView& a, const PackedTreeView& b) {
  const GradualUnderflow gradual_underflow;
  return scalar(a, b, std::min(a.shape().groups, 3), 0);
}

}  // namespace basis
