// Half floats against the processor's own conversion; shared-exponent words against a search
// over every exponent; packed trees: the same topology, values
// within half precision, and bounds that still hold for every texel (linf) and every quadrant's
// RMS deviation (l2) after rounding.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <random>
#include <stdexcept>

#if defined(__F16C__)
#include <immintrin.h>
#endif

#include "basis/core/packed_tree.h"
#include "basis/core/projection.h"
#include "support/test_functions.h"

namespace basis {
namespace {

using testing::test_functions;

TEST(Half, EveryHalfRoundTripsThroughFloat) {
  for (std::uint32_t h = 0; h < 0x10000; ++h) {
    const float f = half_to_float(std::uint16_t(h));
    if (std::isnan(f)) {
      EXPECT_TRUE(std::isnan(half_to_float(float_to_half(f))));
      continue;
    }
    ASSERT_EQ(float_to_half(f), h) << h;
  }
  EXPECT_EQ(half_to_float(0x3c00), 1.0f);
  EXPECT_EQ(half_to_float(0x7bff), 65504.0f);
  EXPECT_EQ(half_to_float(0x0001), 0x1p-24f);
  EXPECT_EQ(half_to_float(0xc000), -2.0f);
}

// A second conversion by arithmetic in double: the value in units of its half spacing,
// rounded to nearest even by nearbyint (the default rounding mode).
std::uint16_t reference_float_to_half(float f) {
  const std::uint16_t sign = std::signbit(f) ? 0x8000 : 0;
  const double a = std::abs(double(f));
  if (std::isinf(f) || a >= 65520.0) return sign | 0x7c00;
  if (a < 0x1p-14) return sign | std::uint16_t(std::nearbyint(a * 0x1p24));  // subnormal units
  int exponent = std::ilogb(a);  // 2^exponent <= a < 2^(exponent + 1)
  const double units = std::nearbyint(std::ldexp(a, 10 - exponent));  // 1024 .. 2048
  const int e = exponent + 15 + (units == 2048 ? 1 : 0);
  const int mantissa = units == 2048 ? 0 : int(units) - 1024;
  if (e >= 31) return sign | 0x7c00;
  return sign | std::uint16_t(e << 10 | mantissa);
}

// Rounding to nearest even, against a second implementation (and the F16C instruction when the
// build has it) on floats drawn from every exponent and on the halfway points between halves.
TEST(Half, RoundsToNearestEven) {
  std::mt19937 rng(3);
  std::vector<float> floats = {0.0f,       -0.0f,    65504.0f, 65519.99f,   65520.0f,
                               1e30f,      -1e-30f,  0x1p-25f, 0x1.8p-25f,  0x1p-24f,
                               0x1.8p-24f, INFINITY, 0x1p-14f, 0x1.ffcp-15f};
  for (int i = 0; i < 2000000; ++i)
    floats.push_back(std::bit_cast<float>(std::uint32_t(rng())));
  for (std::uint32_t h = 0; h < 0x7c00; ++h)  // halfway above each half
    floats.push_back((half_to_float(std::uint16_t(h)) + half_to_float(std::uint16_t(h + 1))) / 2);
  for (const float f : floats) {
    if (std::isnan(f)) continue;
    ASSERT_EQ(float_to_half(f), reference_float_to_half(f)) << std::hexfloat << f;
#if defined(__F16C__)
    ASSERT_EQ(float_to_half(f), std::uint16_t(_mm_extract_epi16(
                                    _mm_cvtps_ph(_mm_set_ss(f), _MM_FROUND_TO_NEAREST_INT), 0)))
        << std::hexfloat << f;
#endif
  }
}

// Shared-exponent words against a search over every exponent, from the smallest, for the first
// whose step keeps each channel's nearest multiple (in exact double arithmetic) within 9 bits;
// decoded channels within half a step, and the step within 1 / 255.75 of the largest channel
// (2^-8 unless the largest rounds up to 512).
TEST(SharedExponent, TheSmallestExponentThatFitsAndTheNearestMantissas) {
  std::mt19937 rng(5);
  std::vector<std::array<float, 3>> colours = {
      {0, 0, 0},           {1, 1, 1},          {0x1.ffp14f, 0, 0}, {0, 0x1.fffp14f, 1e-20f},
      {511.5f, 255, 0},    {511.4f, 0, 3},     {0x1p-24f, 0, 0},   {0x1p-25f, 0x1.8p-25f, 0},
      {1e-30f, 2e-30f, 0}, {1000, 1e-3f, 0.5f}};
  std::uniform_real_distribution<float> exponent(-40.0f, 15.0f), unit(0.0f, 1.0f);
  for (int i = 0; i < 200000; ++i) {
    std::array<float, 3> c;
    for (float& v : c)
      v = unit(rng) < 0.1f ? 0.0f : std::min(std::exp2(exponent(rng)), 0x1.fffffep14f);
    colours.push_back(c);
  }
  for (const auto& c : colours) {
    int expected_exponent = 31;
    std::uint32_t expected = 0;
    for (int e = 0; e < 32; ++e) {
      const double step = std::ldexp(1.0, e - 24);
      std::array<double, 3> m;
      for (int k = 0; k < 3; ++k)
        m[std::size_t(k)] = std::nearbyint(double(c[std::size_t(k)]) / step);
      if (std::max({m[0], m[1], m[2]}) > 511) continue;
      expected_exponent = e;
      expected = std::uint32_t(e) << 27 | std::uint32_t(m[0]) | std::uint32_t(m[1]) << 9 |
                 std::uint32_t(m[2]) << 18;
      break;
    }
    const std::uint32_t word = encode_shared_exponent(c);
    ASSERT_EQ(word, expected) << c[0] << " " << c[1] << " " << c[2];
    const double step = shared_exponent_step(word);
    ASSERT_EQ(step, std::ldexp(1.0, expected_exponent - 24));
    const double largest = std::max({c[0], c[1], c[2]});
    ASSERT_LE(step, std::max(largest / 255.75, 0x1p-24));
    for (int k = 0; k < 3; ++k)
      ASSERT_LE(std::abs(double(shared_exponent_channel(word, k)) - c[std::size_t(k)]), step / 2);
  }
  for (const float bad : {-1e-30f, -1.0f, 0x1p15f, INFINITY, NAN})
    EXPECT_THROW(encode_shared_exponent({0.5f, bad, 0.5f}), std::invalid_argument) << bad;
}

// A bound's code is the smallest whose value times the scale reaches the bound both as the float
// product (what PackedTreeView::bound reads) and as the exact one (what the packed descents
// scale their sums by, in double): against a search over all 256 codes, for scales from the
// subnormal floats (where the float product rounds by up to 2^-150 either way) to 2^120, and
// bounds at, just above and just below either product of every code.
TEST(BoundCodes, ReachTheirBoundAsTheFloatAndTheExactProduct) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> mantissa(1.0, 2.0);
  std::vector<float> scales = {1.0f, 1.0f + 0x1p-23f, 0x1.fffffep0f, 0x1p-149f, 0x1.8p-140f};
  for (int e = -149; e <= 120; e += 3)
    for (int i = 0; i < 3; ++i)
      scales.push_back(float(std::ldexp(mantissa(rng), e)));
  int float_only = 0;
  for (const float scale : scales) {
    auto exact = [&](int c) { return double(bound_code_value(std::uint8_t(c))) * double(scale); };
    auto rounded = [&](int c) { return double(bound_code_value(std::uint8_t(c)) * scale); };
    for (int code = 0; code < 256; ++code)
      for (const double product : {exact(code), rounded(code)})
        for (const double bound :
             {product, std::nextafter(product, 0.0), std::nextafter(product, INFINITY)}) {
          if (!(bound > 0)) continue;
          int expected = 255;
          for (int c = 0; c < 256; ++c)
            if (exact(c) >= bound && rounded(c) >= bound) {
              expected = c;
              break;
            }
          float_only += rounded(code) >= bound && exact(code) < bound;
          ASSERT_EQ(int(bound_code_at_least(bound, scale)), expected)
              << "bound " << bound << " scale " << scale;
        }
  }
  // The cases this guards: the float product reaches where the exact one does not.
  EXPECT_GT(float_only, 0);
}

// Calls visit(node, depth) for every node of a packed tree, walking its links from the root.
template <typename Visit>
void for_each_node_depth(const PackedTreeView& p, Visit&& visit) {
  auto descend = [&](auto&& self, int node, int depth) -> void {
    visit(node, depth);
    for (int q = 0; q < 4; ++q)
      if (const int child = p.child(node, q)) self(self, child, depth + 1);
  };
  descend(descend, 0, 0);
}

class PackedTrees : public ::testing::TestWithParam<std::tuple<int, int>> {};

TEST_P(PackedTrees, KeepTopologyValuesAndCertifiedBounds) {
  const int n = std::get<0>(GetParam()), channels = std::get<1>(GetParam());
  for (const auto& function : test_functions(n, channels, 21)) {
    const Quadtree tree = project(function.grid, {.tolerance = 0.05});
    for (const BoundKind kind : {BoundKind::l2, BoundKind::linf})
      for (const int packing : {0, 1, 2}) {
        // With exact texels (a grid's texels are), texel nodes hold their values alone: in
        // halves (1), or, RGB, all values in shared-exponent words (2; halves for grey trees).
        const bool exact = packing > 0;
        const bool shared = packing == 2 && channels == 3;
        const PackedTree packed =
            exact ? pack_exact_texels(
                        tree, kind,
                        packing == 1 ? ValueEncoding::halves : ValueEncoding::shared_exponent)
                  : pack(tree, kind);
        const PackedTreeView p = packed.view();
        ASSERT_EQ(p.node_count(), tree.node_count());
        const PackedShape& shape = p.shape();
        int full_nodes = 0;
        for_each_node_depth(p, [&](int node, int depth) {
          ASSERT_EQ(p.is_texel_node(node), exact && depth == shape.texel_depth()) << node;
          full_nodes += !p.is_texel_node(node);
        });
        ASSERT_EQ(p.words().size(), std::size_t(full_nodes) * shape.words_per_node() +
                                        std::size_t(p.node_count() - full_nodes) *
                                            (shared  ? 4
                                             : exact ? 2 * channels
                                                     : shape.words_per_node()));
        // A full node: its link, its values (4 words shared, 2 x channels in halves), bounds.
        ASSERT_EQ(shape.words_per_node(), 1 + (shared ? 4 : 2 * channels) + channels);
        ASSERT_EQ(shape.shared_values(), shared);
        // The same cells, breadth first: every leaf of one is a leaf of the other.
        std::vector<std::array<int, 4>> cells_a, cells_b;
        for_each_leaf(tree.view(), [&](int, int q, int level, int x, int y) {
          cells_a.push_back({q, level, x, y});
        });
        std::vector<std::pair<int, int>> leaves;  // (node, quadrant) of p, in the same order
        for_each_leaf(p, [&](int node, int q, int level, int x, int y) {
          cells_b.push_back({q, level, x, y});
          leaves.push_back({node, q});
        });
        ASSERT_EQ(cells_a, cells_b) << function.name;
        // Breadth first: children follow their parent, blocks in order.
        std::uint32_t next = 1;
        for (int node = 0; node < p.node_count(); ++node) {
          const std::uint32_t link = p.link(node);
          if (link == 0) continue;
          ASSERT_EQ(link >> 4, next);
          next += std::uint32_t(std::popcount(link & 15u));
        }
        ASSERT_EQ(next, std::uint32_t(p.node_count()));
        // Values within half precision of the tree's (shared-exponent words within 1 / 511.5 of
        // their largest channel); bounds certified against the texels.
        std::size_t leaf = 0;
        for_each_leaf(tree.view(), [&](int node, int q, int level, int x, int y) {
          const auto [pn, pq] = leaves[leaf++];
          const int size = n >> level;
          double largest_channel = 0;
          for (int c = 0; c < channels; ++c)
            largest_channel =
                std::max(largest_channel, std::abs(double(tree.view().value(node, 0, c, q))));
          for (int c = 0; c < channels; ++c) {
            const float v = tree.view().value(node, 0, c, q), pv = p.value(pn, 0, c, pq);
            const double rounding = shared
                                        ? largest_channel / 511.5 + p.scales().value_scale * 0x1p-25
                                        : std::abs(v) * 0x1p-11 + p.scales().value_scale * 0x1p-24;
            ASSERT_LE(std::abs(pv - v), rounding * (1 + 1e-6)) << function.name;
            double squares = 0, largest = 0;
            for (int ty = y * size; ty < (y + 1) * size; ++ty)
              for (int tx = x * size; tx < (x + 1) * size; ++tx) {
                const double d = std::abs(double(function.grid.at(0, c, tx, ty)) - pv);
                squares += d * d;
                largest = std::max(largest, d);
              }
            const double rms = std::sqrt(squares / (double(size) * size));
            ASSERT_LE(rms, double(p.bound(pn, c, pq)) * (1 + 1e-6)) << function.name;
            ASSERT_LE(largest, double(p.largest_deviation_bound(pn, c, pq, level)) * (1 + 1e-6))
                << function.name;
            // Codes round up by at most one step of 2^-3 over the source bound and the move; an
            // exact texel's bound is the most its half (or its word) may have moved.
            if (p.is_texel_node(pn)) {
              EXPECT_LE(
                  p.bound(pn, c, pq),
                  (shared ? rounding : std::abs(pv) * 0x1p-11 + p.scales().value_scale * 0x1p-25) *
                      (1 + 1e-5));
              continue;
            }
            const double source = kind == BoundKind::l2
                                      ? tree.deviations[std::size_t(node) * channels + c].lane[q]
                                      : tree.view().error(node, c, q);
            EXPECT_LE(p.bound(pn, c, pq),
                      (source + std::abs(pv - v)) * 1.126 + p.scales().bound_scale * 0x1p-30)
                << function.name;
          }
        });
        // Shared words round each channel by up to 1 / 511.5 of the largest (at most the sum).
        double channel_sum = 0;
        for (int c = 0; c < channels; ++c)
          channel_sum += std::abs(integrate(tree.view(), 0, c));
        EXPECT_NEAR(
            integrate(p, 0, 0), integrate(tree.view(), 0, 0),
            (shared ? channel_sum / 511.5 : 1e-3 * std::abs(integrate(tree.view(), 0, 0))) + 1e-9);
      }
  }
}

// Texel nodes of values alone are only for texels that are exact: a tree whose single-texel
// quadrants carry a bound (a BRDF's variation inside a texel) is refused.
TEST(PackedTrees, ExactTexelsAreRefusedForTexelsWithBounds) {
  const auto functions = test_functions(8, 1, 22);
  Quadtree tree = project(functions[1].grid, {.tolerance = 0});
  EXPECT_NO_THROW(pack_exact_texels(tree));
  bool changed = false;
  for_each_leaf(tree.view(), [&](int node, int q, int level, int, int) {
    if (level != 3 || changed) return;
    tree.deviations[std::size_t(node) * tree.shape.error_stride()].lane[q] = 0.25f;
    tree.errors[std::size_t(node) * tree.shape.error_stride()].lane[q] = 0.25f;
    changed = true;
  });
  ASSERT_TRUE(changed);
  EXPECT_THROW(pack_exact_texels(tree), std::invalid_argument);
  EXPECT_THROW(pack_exact_texels(tree, BoundKind::linf), std::invalid_argument);
  EXPECT_NO_THROW(pack(tree));
}

INSTANTIATE_TEST_SUITE_P(Shapes, PackedTrees,
                         ::testing::Values(std::tuple{8, 1}, std::tuple{32, 3}, std::tuple{128, 3},
                                           std::tuple{64, 1}));

}  // namespace
}  // namespace basis
