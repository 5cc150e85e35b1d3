// Convolution of packed trees: the packed trees' product to half precision, the full-resolution
// product within the certified bound for every kind of bound, with and without texel nodes of
// values alone (exact texels), SIMD equal to scalar, values without the bound equal to the
// certified descents', accuracy-targeted descents within their bounds and no looser than the
// target allows, channel groups, and groups combined with weights (signed) within their bound.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include "basis/core/convolution.h"
#include "basis/core/dense.h"
#include "basis/core/folded_tree.h"
#include "basis/core/packed_tree.h"
#include "basis/core/projection.h"
#include "support/test_functions.h"

namespace basis {
namespace {

using testing::test_functions;
using testing::three_groups;

double relative_gap(double a, double b) {
  return std::abs(a - b) / std::max({std::abs(a), std::abs(b), 1e-30});
}

// Whether the SIMD descent's bound of channel c agrees with the scalar descent's, of trees a
// and b: the same terms to 1e-5 relative, once each has taken in its own value's rounding to a
// float (certified_float, at most 2^-24 of the value), and the SIMD bound above the scalar one by
// at most its float sums' share. That share is gamma = 2^-24 times the smaller tree's nodes plus
// 52 (the additions a float sum's term goes through) of the magnitudes and of the bound's own
// terms (their float sums, either way); the bound is at least 2^-10 of the magnitudes (its
// values' rounding), so the share is at most 2^10 + 2 times gamma of the bound. (The upper side is
// loose for trees of thousands of nodes: 25 % at 4,000; the lower side is not.)
bool bounds_agree(const Convolution& simd, const Convolution& scalar, int c,
                  const PackedTreeView& a, const PackedTreeView& b) {
  const double sums_share =
      (std::min(a.node_count(), b.node_count()) + 52) * 0x1p-24 * (0x1p10 + 2) * (1 + 1e-3);
  const double values =
      0x1p-24 * (std::abs(double(simd.value[c])) + std::abs(double(scalar.value[c])));
  const double x = simd.bound[c], y = scalar.bound[c];
  return x >= y - 1e-5 * std::max(x, y) - values &&
         x <= y * (1 + sums_share) + 1e-5 * std::max(x, y) + values;
}

// Channel c of the integral over [0,1]^2 of the product of group 0 of two grids (a grey grid
// counting for every channel), in double: at the finer resolution, each texel of the coarser
// repeated over the finer's texels it covers.
double grid_product(const Grid& a, const Grid& b, int c) {
  const int n = std::max(a.resolution, b.resolution);
  const int sa = n / a.resolution, sb = n / b.resolution;
  const int ca = a.channels == 1 ? 0 : c, cb = b.channels == 1 ? 0 : c;
  double sum = 0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x)
      sum += double(a.at(0, ca, x / sa, y / sa)) * b.at(0, cb, x / sb, y / sb);
  return sum / (double(n) * n);
}

struct Shapes {
  int res_a, res_b, channels_a, channels_b;
};

class PackedConvolution : public ::testing::TestWithParam<Shapes> {};

TEST_P(PackedConvolution, WithinTheBoundOfTheTexelsAndHalfPrecisionOfTheTrees) {
  const Shapes k = GetParam();
  const auto fa = test_functions(k.res_a, k.channels_a, 31);
  const auto fb = test_functions(k.res_b, k.channels_b, 32);
  // Variants: values in halves; in shared-exponent words (RGB trees with exact texels); the same
  // with the other arrangement of exact texels against bound kinds.
  for (const int variant : {0, 1, 2})
    for (const BoundKind kind_a : {BoundKind::l2, BoundKind::linf})
      for (const BoundKind kind_b : {BoundKind::l2, BoundKind::linf})
        for (const auto& [name_a, grid_a] : fa)
          for (const auto& [name_b, grid_b] : fb) {
            const std::string what = name_a + " x " + name_b + " kinds " +
                                     std::to_string(int(kind_a)) + std::to_string(int(kind_b)) +
                                     " variant " + std::to_string(variant);
            // Texel nodes of values alone (exact texels) on either side, or both, or neither,
            // one arrangement per pair of kinds and its opposite; in halves, or RGB in
            // shared-exponent words.
            const ValueEncoding encoding =
                variant == 0 ? ValueEncoding::halves : ValueEncoding::shared_exponent;
            const bool flip = variant == 2;
            const bool exact_a = (kind_a == BoundKind::linf) != flip;
            const bool exact_b = (kind_b == BoundKind::l2) != flip;
            const Quadtree tree_a = project(grid_a, {.tolerance = 0.1});
            const Quadtree tree_b = project(grid_b, {.tolerance = 0.1});
            const PackedTree a =
                exact_a ? pack_exact_texels(tree_a, kind_a, encoding) : pack(tree_a, kind_a);
            const PackedTree b =
                exact_b ? pack_exact_texels(tree_b, kind_b, encoding) : pack(tree_b, kind_b);
            // A shared-exponent texel rounds to 2^-9 of its largest channel, not of its own, and
            // a descent that stops at the other tree's leaf reads the parent's half instead.
            const double rounding_gap =
                a.shape.shared_values() || b.shape.shared_values() ? 4e-3 : 1e-3;
            const Convolution simd = convolve(a.view(), b.view());
            const Convolution scalar = convolve_scalar(a.view(), b.view());
            // Values alone: the same descent without the bound's arithmetic.
            const Convolution alone = convolve(a.view(), b.view(), {.bound = false});
            const Convolution scalar_alone = convolve_scalar(a.view(), b.view(), {.bound = false});
            // The dense product of the packed trees' reconstructions, to half precision: a
            // descent that stops at a leaf of one tree takes the other's quadrant value, rounded
            // to a half on its own rather than as the mean of its children's halves.
            const Grid ra = reconstruct(a.view()), rb = reconstruct(b.view());
            for (int c = 0; c < 3; ++c) {
              // The full-resolution product of the source texels.
              const double packed = grid_product(ra, rb, c),
                           texels = grid_product(grid_a, grid_b, c);
              EXPECT_LT(relative_gap(simd.value[c], packed), rounding_gap) << what;
              EXPECT_LE(std::abs(simd.value[c] - texels),
                        simd.bound[c] * (1 + 1e-4) + 1e-6 * texels)
                  << what << " bound " << simd.bound[c];
              // SIMD sums in float, the scalar descent in double: up to 16,384 pairs at 128^2.
              EXPECT_LT(relative_gap(simd.value[c], scalar.value[c]), 2e-6) << what;
              EXPECT_TRUE(bounds_agree(simd, scalar, c, a.view(), b.view())) << what;
              // The same value to the bit, and nothing certified (the scalar descent computes
              // its bound and drops it).
              EXPECT_EQ(alone.value[c], simd.value[c]) << what;
              EXPECT_EQ(alone.bound[c], std::numeric_limits<float>::infinity()) << what;
              EXPECT_EQ(scalar_alone.bound[c], std::numeric_limits<float>::infinity()) << what;
            }
          }
}

// A targeted descent stops early on its own terms: its value stays within its bound of the
// texels' product, and its bound within the target's share plus the full descent's bound.
TEST_P(PackedConvolution, AccuracyTargetsKeepTheirBounds) {
  const Shapes k = GetParam();
  const auto fa = test_functions(k.res_a, k.channels_a, 33);
  const auto fb = test_functions(k.res_b, k.channels_b, 34);
  for (const auto& [name_a, grid_a] : fa)
    for (const auto& [name_b, grid_b] : fb) {
      const PackedTree a = pack(project(grid_a, {.tolerance = 0.02}), BoundKind::l2);
      for (const bool exact_b : {false, true}) {
        const Quadtree tree_b = project(grid_b, {.tolerance = 0.02});
        const PackedTree b = exact_b ? pack_exact_texels(tree_b) : pack(tree_b);
        const Convolution full = convolve(a.view(), b.view());
        const int n = std::max(k.res_a, k.res_b), sa = n / k.res_a, sb = n / k.res_b;
        for (const double accuracy : {0.001, 0.01, 0.1}) {
          const Convolution simd = convolve(a.view(), b.view(), {.accuracy = accuracy});
          const Convolution scalar = convolve_scalar(a.view(), b.view(), {.accuracy = accuracy});
          for (int c = 0; c < 3; ++c) {
            const int ca = k.channels_a == 1 ? 0 : c, cb = k.channels_b == 1 ? 0 : c;
            double texels = 0;
            for (int y = 0; y < n; ++y)
              for (int x = 0; x < n; ++x)
                texels +=
                    double(grid_a.at(0, ca, x / sa, y / sa)) * grid_b.at(0, cb, x / sb, y / sb);
            texels /= double(n) * n;
            for (const Convolution& r : {simd, scalar}) {
              EXPECT_LE(std::abs(r.value[c] - texels), r.bound[c] * (1 + 1e-4) + 1e-6 * texels)
                  << name_a << " x " << name_b << " accuracy " << accuracy;
              EXPECT_LE(r.bound[c], accuracy * r.value[c] * (1 + 1e-4) + full.bound[c] * (1 + 1e-4))
                  << name_a << " x " << name_b << " accuracy " << accuracy << " exact " << exact_b;
            }
          }
        }
      }
    }
}

INSTANTIATE_TEST_SUITE_P(Shapes, PackedConvolution,
                         ::testing::Values(Shapes{32, 32, 1, 1}, Shapes{32, 32, 3, 3},
                                           Shapes{16, 64, 1, 3}, Shapes{64, 16, 3, 1},
                                           Shapes{128, 128, 3, 3}),
                         [](const auto& info) {
                           const Shapes& k = info.param;
                           return std::to_string(k.res_a) + "x" + std::to_string(k.res_b) + "_" +
                                  std::to_string(k.channels_a) + "ch_" +
                                  std::to_string(k.channels_b) + "ch";
                         });

TEST(PackedConvolution, GroupsEqualSeparateDenseProductsInSimdAndScalar) {
  Grid a(32, 3, 2);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> unit(-1, 2);
  for (float& t : a.texels)
    t = unit(rng);
  for (float& t : a.plane(0, 0))
    t = std::abs(t);
  const PackedTree ta = pack(project(a, {.tolerance = 0.1}), BoundKind::l2);
  for (const auto& [name, grid_b] : test_functions(32, 3, 35)) {
    const PackedTree tb = pack(project(grid_b, {.tolerance = 0.1}), BoundKind::l2);
    const Grid ra = reconstruct(ta.view()), rb = reconstruct(tb.view());
    const GroupConvolution simd = convolve_groups(ta.view(), tb.view());
    const GroupConvolution scalar = convolve_groups_scalar(ta.view(), tb.view());
    for (int g = 0; g < 2; ++g)
      for (int c = 0; c < 3; ++c) {
        double expected = 0;
        for (int i = 0; i < 32 * 32; ++i)
          expected += double(ra.plane(g, c)[i]) * rb.plane(0, c)[i];
        expected /= 32 * 32;
        EXPECT_NEAR(simd.value[g][c], expected, 1e-3 * std::abs(expected) + 1e-6) << name << g;
        EXPECT_NEAR(scalar.value[g][c], simd.value[g][c], 1e-6 * std::abs(expected) + 1e-6)
            << name << g;
      }
    EXPECT_EQ(simd.value[0], convolve(ta.view(), tb.view()).value);
    EXPECT_EQ(simd.bound, convolve(ta.view(), tb.view()).bound);
  }
}

TEST(PackedConvolution, WeightedGroupsLieWithinTheirBoundOfTheTexels) {
  const std::vector<std::array<float, 3>> weight_sets = {
      {1, 0, 0}, {0.6f, 0.3f, -0.2f}, {0.2f, -1.5f, 0.7f}, {0, 1, 0}, {-0.4f, 0, 2}};
  for (const auto& [channels_a, channels_b] : {std::pair{1, 1}, {3, 3}, {1, 3}, {3, 1}})
    for (const BoundKind kind_a : {BoundKind::l2, BoundKind::linf})
      for (const BoundKind kind_b : {BoundKind::l2, BoundKind::linf})
        for (const auto& [name_a, base] : test_functions(32, channels_a, 41)) {
          const Grid grid_a = three_groups(base, 42);
          const Quadtree tree_a = project(
              grid_a, {.tolerance = 0.1, .cut_on_all_groups = true, .group_tolerance_scale = 1});
          ASSERT_EQ(tree_a.shape.bounded_groups, 3);
          const PackedTree a = pack(tree_a, kind_a, 3);
          for (const auto& [name_b, grid_b] : test_functions(64, channels_b, 43)) {
            // Texel nodes of values alone for like channels with RMS bounds (as captures).
            const bool exact_b = channels_a == channels_b && kind_b == BoundKind::l2;
            const Quadtree tree_b = project(grid_b, {.tolerance = 0.1});
            const PackedTree b = exact_b ? pack_exact_texels(tree_b, kind_b) : pack(tree_b, kind_b);
            for (const auto& w : weight_sets)
              for (const double accuracy : {0.0, 0.01, 0.1}) {
                const std::string what = name_a + " x " + name_b + " kinds " +
                                         std::to_string(int(kind_a)) + std::to_string(int(kind_b)) +
                                         " weights " + std::to_string(w[0]) + "," +
                                         std::to_string(w[1]) + "," + std::to_string(w[2]) +
                                         " accuracy " + std::to_string(accuracy);
                const Convolution simd = convolve_weighted(a.view(), w, b.view(), {accuracy});
                const Convolution scalar =
                    convolve_weighted_scalar(a.view(), w, b.view(), {accuracy});
                // Values alone, the first one, two or three groups weighted: the same descents'
                // values to the bit (one group takes the plain descent, scaled).
                for (std::size_t groups = 1; accuracy == 0 && groups <= 3; ++groups) {
                  const std::span<const float> first(w.data(), groups);
                  const Convolution certified = convolve_weighted(a.view(), first, b.view());
                  const Convolution alone =
                      convolve_weighted(a.view(), first, b.view(), {.bound = false});
                  EXPECT_EQ(alone.value, certified.value) << what << " groups " << groups;
                  for (const float bound : alone.bound)
                    EXPECT_EQ(bound, std::numeric_limits<float>::infinity()) << what;
                }
                for (int c = 0; c < 3; ++c) {
                  const int ca = channels_a == 1 ? 0 : c, cb = channels_b == 1 ? 0 : c;
                  double texels = 0, magnitude = 0;
                  for (int y = 0; y < 64; ++y)
                    for (int x = 0; x < 64; ++x) {
                      double fa = 0;
                      for (int g = 0; g < 3; ++g)
                        fa += w[g] * grid_a.at(g, ca, x / 2, y / 2);
                      texels += fa * grid_b.at(0, cb, x, y);
                      magnitude += std::abs(fa * grid_b.at(0, cb, x, y));
                    }
                  texels /= 64.0 * 64;
                  magnitude /= 64.0 * 64;
                  for (const Convolution& r : {simd, scalar})
                    EXPECT_LE(std::abs(r.value[c] - texels),
                              r.bound[c] * (1 + 1e-4) + 1e-6 * magnitude)
                        << what << " bound " << r.bound[c];
                  if (accuracy == 0) {
                    EXPECT_LT(std::abs(simd.value[c] - scalar.value[c]), 1e-6 * magnitude) << what;
                    EXPECT_TRUE(bounds_agree(simd, scalar, c, a.view(), b.view())) << what;
                  }
                }
              }
          }
        }
}

TEST(PackedConvolution, WeightedGroupsOfOneGroupScaleThePlainConvolution) {
  const auto functions = test_functions(32, 3, 44);
  const PackedTree a = pack(project(functions[1].grid, {.tolerance = 0.05}));
  const PackedTree b = pack(project(functions[2].grid, {.tolerance = 0.05}));
  const Convolution plain = convolve(a.view(), b.view());
  const std::array<float, 1> half_weight = {-0.5f};
  const Convolution weighted = convolve_weighted(a.view(), half_weight, b.view());
  for (int c = 0; c < 3; ++c) {
    EXPECT_FLOAT_EQ(weighted.value[c], -0.5f * plain.value[c]);
    EXPECT_FLOAT_EQ(weighted.bound[c], 0.5f * plain.bound[c]);
  }
  // Weights for groups without bounds are refused: their bound would not hold.
  const std::array<float, 2> two = {1, 1};
  EXPECT_THROW(convolve_weighted(a.view(), two, b.view()), std::invalid_argument);
}

// Trees refined everywhere (noise at tolerance 0): a level of 128^2 or 256^2 pairs holds more
// pairs than the descent queues at once, and the pairs that do not fit are descended apart. The
// result is still the dense product of the texels, in SIMD and scalar.
TEST(PackedConvolution, LevelsLargerThanTheQueueAreDescendedInFull) {
  for (const int n : {128, 256}) {
    std::mt19937 rng{std::uint32_t(n)};
    std::uniform_real_distribution<float> unit(0.1f, 2);
    Grid grid_a(n, 3), grid_b(n, 3);
    for (float& t : grid_a.texels)
      t = unit(rng);
    for (float& t : grid_b.texels)
      t = unit(rng);
    const PackedTree a = pack(project(grid_a, {.tolerance = 0}), BoundKind::l2);
    const PackedTree b = pack_exact_texels(project(grid_b, {.tolerance = 0}), BoundKind::linf);
    ASSERT_EQ(a.view().node_count(), (n * n - 1) / 3) << n;
    const Convolution simd = convolve(a.view(), b.view());
    const Convolution scalar = convolve_scalar(a.view(), b.view());
    for (int c = 0; c < 3; ++c) {
      double texels = 0;
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
          texels += double(grid_a.at(0, c, x, y)) * grid_b.at(0, c, x, y);
      texels /= double(n) * n;
      EXPECT_LE(std::abs(simd.value[c] - texels), simd.bound[c] * (1 + 1e-4)) << n;
      EXPECT_LT(relative_gap(simd.value[c], texels), 1e-3) << n;
      // Float sums of up to 65,536 products against double ones.
      EXPECT_LT(relative_gap(simd.value[c], scalar.value[c]), 1e-5) << n;
      EXPECT_TRUE(bounds_agree(simd, scalar, c, a.view(), b.view())) << n;
    }
  }
}

// Shared-exponent words round every channel to a step of the quadrant's largest: a dim channel
// below half that step reads 0, all of it error. The bound must cover it through its rounding
// terms (here they decide, not the deviations), with the words on either side of the descent,
// in full nodes (a constant capture: its root) and in texel nodes (a checkerboard), in full and
// with an accuracy target. Ground truth: the product of the texels in double.
TEST(PackedConvolution, SharedExponentRoundingStaysWithinTheBound) {
  const int n = 32;
  const float dim = 0x1p-9f * 0.97f;  // half the step of a largest channel of 1 is 2^-9
  Grid constant(n, 3), checkerboard(n, 3), light(n, 1);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const float scale = (x + y) % 2 ? 1.0f : 0.5f;  // 0.5: half its step is 2^-10
      for (int c = 0; c < 3; ++c) {
        constant.at(0, c, x, y) = c == 0 ? 1.0f : c == 1 ? dim : 0.0f;
        checkerboard.at(0, c, x, y) = c == 0 ? scale : c == 1 ? dim * scale : 0.0f;
      }
      light.at(0, 0, x, y) = 1.0f + 0.5f * float(x) / n;
    }
  const PackedTree a = pack(project(light, {.tolerance = 0}));
  for (const Grid* capture : {&constant, &checkerboard}) {
    const PackedTree b = pack_exact_texels(project(*capture, {.tolerance = 0}));
    ASSERT_TRUE(b.shape.shared_values());
    double truth[3] = {};
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        for (int c = 0; c < 3; ++c)
          truth[c] += double(light.at(0, 0, x, y)) * capture->at(0, c, x, y) / (double(n) * n);
    for (const double accuracy : {0.0, 0.05})
      for (const bool swapped : {false, true}) {
        const PackedTreeView first = swapped ? b.view() : a.view();
        const PackedTreeView second = swapped ? a.view() : b.view();
        for (const Convolution& r : {convolve(first, second, {.accuracy = accuracy}),
                                     convolve_scalar(first, second, {.accuracy = accuracy})}) {
          // The dim channel is lost to the rounding: the test is one the bound could fail.
          EXPECT_GT(std::abs(r.value[1] - truth[1]), 0.5 * truth[1]);
          for (int c = 0; c < 3; ++c)
            EXPECT_LE(std::abs(r.value[c] - truth[c]), r.bound[c] * (1 + 1e-6) + 1e-12)
                << "channel " << c << " accuracy " << accuracy << " swapped " << swapped
                << " checkerboard " << (capture == &checkerboard);
        }
      }
  }
}

// The largest-deviation alternative eb |a| bounds the integral of A (B - b) only for A >= 0.
// A signed checkerboard (mean 0, RMS 1) against 1 + 0.5 of it (largest deviation 0.5), each a
// single leaf: their product's integral is 0.5 where the leaves give 0, and the bound must
// cover it (it gave 4e-7), whichever side comes first, in grey and in RGB, on every path.
TEST(PackedConvolution, LargestDeviationsAgainstASignedFunctionKeepTheirBound) {
  const int n = 16;
  for (const int channels : {1, 3}) {
    Grid signed_grid(n, channels), positive(n, channels);
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        for (int c = 0; c < channels; ++c) {
          const float sign = (x + y) % 2 ? 1.0f : -1.0f;
          signed_grid.at(0, c, x, y) = sign;
          positive.at(0, c, x, y) = 1.0f + 0.5f * sign;
        }
    // Tolerances that leave each tree a single leaf.
    const PackedTree a =
        pack(project(signed_grid, {.tolerance = 10, .mode = ProjectionOptions::Mode::absolute}),
             BoundKind::l2);
    const PackedTree b =
        pack(project(positive, {.tolerance = 10, .mode = ProjectionOptions::Mode::absolute}),
             BoundKind::linf);
    ASSERT_EQ(a.node_count(), 1);
    ASSERT_EQ(b.node_count(), 1);
    for (const bool swapped : {false, true}) {
      const PackedTreeView first = swapped ? b.view() : a.view();
      const PackedTreeView second = swapped ? a.view() : b.view();
      for (const Convolution& r : {convolve(first, second), convolve_scalar(first, second)})
        for (int c = 0; c < channels; ++c) {
          EXPECT_NEAR(r.value[c], 0.0, 1e-6);
          EXPECT_GE(r.bound[c], 0.5) << "channels " << channels << " swapped " << swapped;
        }
    }
  }
}

// Captures whose texels' roundings to words all go one way (one_way_rounding_grid), refined
// over every quadrant so that every node above the texels has values derived from its
// children's (refined_values.h), cut with l2 and linf bounds: against constants (in halves, and
// a capture's words), against themselves, with and without an accuracy target, SIMD and scalar,
// and against a weighted group and a folded sum, the texels' product lies within the bound. Derived
// level by level from rounded values, with the rounding of a stored value allowed them, a 16^2
// capture against a constant printed 61,122.83 +- 325.9 for a product of 60,720.91.
TEST(PackedConvolution, DerivedValuesKeepTheirBoundWhenEveryRoundingGoesOneWay) {
  for (const int n : {4, 16, 64})
    for (const BoundKind kind : {BoundKind::l2, BoundKind::linf}) {
      SCOPED_TRACE(std::to_string(n) + (kind == BoundKind::l2 ? " l2" : " linf"));
      const Grid grid = testing::one_way_rounding_grid(n);
      const PackedTree capture = pack_exact_texels(project(grid, {.tolerance = 0}), kind);
      ASSERT_TRUE(capture.shape.shared_values());
      ASSERT_EQ(capture.view().link(0) & 15u, 15u);
      EXPECT_GT(capture.derived_rounding, 1.0f);
      Grid grey(n, 1), rgb(n, 3);
      for (float& t : grey.texels)
        t = 1;
      for (float& t : rgb.texels)
        t = 1;
      const PackedTree halves = pack(project(grey, {.tolerance = 0.05}));
      const PackedTree constant = pack_exact_texels(project(rgb, {.tolerance = 0.05}));
      auto check = [&](const Convolution& r, const Grid& other, double weight,
                       const std::string& what) {
        for (int c = 0; c < 3; ++c) {
          const double exact = weight * grid_product(grid, other, c);
          EXPECT_LE(std::abs(double(r.value[c]) - exact), double(r.bound[c]))
              << what << ", channel " << c;
        }
      };
      const std::vector<std::pair<const PackedTree*, const Grid*>> others = {
          {&halves, &grey}, {&constant, &rgb}, {&capture, &grid}};
      for (const auto& [other, other_grid] : others)
        for (const bool swapped : {false, true})
          for (const double accuracy : {0.0, 0.05}) {
            const PackedTreeView a = swapped ? other->view() : capture.view();
            const PackedTreeView b = swapped ? capture.view() : other->view();
            const ConvolutionOptions options{.accuracy = accuracy};
            const std::string what = "against a tree of " + std::to_string(other->node_count()) +
                                     " nodes, swapped " + std::to_string(swapped) + ", accuracy " +
                                     std::to_string(accuracy);
            check(convolve(a, b, options), *other_grid, 1, what);
            check(convolve_scalar(a, b, options), *other_grid, 1, what + ", scalar");
          }
      // A weighted group and a folded sum of two terms (a table's lookups between entries)
      // against the capture.
      const float w[1] = {0.75f};
      check(convolve_weighted(halves.view(), w, capture.view()), grey, 0.75, "weighted");
      check(convolve_weighted_scalar(halves.view(), w, capture.view()), grey, 0.75,
            "weighted, scalar");
      if (folding_available()) {
        const std::vector<WeightedTerm> terms = {{halves.view(), {0.5f, 0, 0}, 1},
                                                 {halves.view(), {0.25f, 0, 0}, 1}};
        check(convolve(fold(terms), capture.view()), grey, 0.75, "folded");
      }
    }
}

// The descents add their products in floats. A texel whose value is a tie between two halves
// (16,392: 16,384 and 16,400) rounds to the even one, so that its product with itself takes the
// whole rounding its bound allows; after it, in the same lane, the small products of a
// checkerboard (3.75 and 3.875 squared, under half the float step of 2^28) are lost from the
// sum. The bound must cover the sums' rounding too: without it, this printed a value 259.8 from
// the texels' product, outside a bound of 256.3 that held only the values' rounding.
TEST(PackedConvolution, FloatSumsThatLoseTheirSmallTermsKeepTheirBound) {
  const int n = 32;
  bool folded = false;
  for (int corner = 0; corner < 4; ++corner) {
    Grid grey(n, 1), rgb(n, 3);
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const float small = (x + y) % 2 ? 3.75f : 3.875f;
        const bool big = x == corner % 2 && y == corner / 2;
        grey.at(0, 0, x, y) = big ? 16392.0f : small;
        for (int c = 0; c < 3; ++c)
          rgb.at(0, c, x, y) = big ? 16392.0f : small;
      }
    // Two groups of the same texels, weighted a half each: the weighted descent.
    Grid two_groups(n, 1, 2);
    for (int g = 0; g < 2; ++g)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
          two_groups.at(g, 0, x, y) = grey.at(0, 0, x, y);
    const PackedTree halves_twice =
        pack(project(two_groups,
                     {.tolerance = 0, .cut_on_all_groups = true, .group_tolerance_scale = 1}),
             BoundKind::l2, 2);
    const std::vector<std::pair<PackedTree, const Grid*>> trees = [&] {
      std::vector<std::pair<PackedTree, const Grid*>> t;
      t.emplace_back(pack(project(grey, {.tolerance = 0})), &grey);
      t.emplace_back(pack_exact_texels(project(grey, {.tolerance = 0})), &grey);
      t.emplace_back(pack(project(rgb, {.tolerance = 0})), &rgb);
      return t;
    }();
    for (const auto& [tree, grid] : trees) {
      const std::string what = "corner " + std::to_string(corner) + ", " +
                               std::to_string(grid->channels) + " channels, " +
                               std::to_string(tree.node_count()) + " nodes";
      const float halves[2] = {0.5f, 0.5f};
      for (const Convolution& r :
           {convolve(tree.view(), tree.view()), convolve_scalar(tree.view(), tree.view()),
            convolve_weighted(halves_twice.view(), halves, tree.view())})
        for (int c = 0; c < 3; ++c) {
          const double exact = grid_product(*grid, *grid, c);
          EXPECT_LE(std::abs(double(r.value[c]) - exact), double(r.bound[c]))
              << what << ", channel " << c;
        }
      // Folded: the tree as the sum of two halves of it (a lookup between two entries).
      if (folding_available() && grid->channels == 1 &&
          tree.view().texel_start() == tree.node_count()) {
        const std::vector<WeightedTerm> terms = {{tree.view(), {0.5f, 0, 0}, 1},
                                                 {tree.view(), {0.5f, 0, 0}, 1}};
        const Convolution r = convolve(fold(terms), tree.view());
        folded = true;
        for (int c = 0; c < 3; ++c)
          EXPECT_LE(std::abs(double(r.value[c]) - grid_product(*grid, *grid, c)),
                    double(r.bound[c]))
              << what << ", folded, channel " << c;
      }
    }
  }
  EXPECT_EQ(folded, folding_available());
}

// Weighted descents whose weights fall below the normal floats: trees a (two groups) and b, the
// weights, and the texels' product in long double. The weighted products and the sums of them
// lose bits to underflow (2^-150 an operation at worst), which no term relative to the
// magnitudes covers.
struct TinyWeights {
  PackedTree a, b;
  std::vector<float> w;
  long double exact;
  std::string what;
};

std::vector<TinyWeights> tiny_weight_cases() {
  std::vector<TinyWeights> cases;
  // Group 1 sets the tree's value scale (one texel of 30,000), so that group 0's texels, 2^-12
  // of that, times the weight, fall below the normal floats in the descent's units; b's texels of
  // 2^40 bring the result back into the normal floats, where the loss shows (0 for 5.4e-35,
  // with a bound of 1.2e-38, before the bound took underflow).
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> unit(1, 2);
  const int n = 16;
  Grid grid_a(n, 1, 2), grid_b(n, 1);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      grid_a.at(0, 0, x, y) = unit(rng) * 0x1p-12f;
      grid_a.at(1, 0, x, y) = x == 0 && y == 0 ? 30000.0f : unit(rng);
    }
  for (float& t : grid_b.texels)
    t = unit(rng) * 0x1p40f;
  const ProjectionOptions both_groups{
      .tolerance = 0, .cut_on_all_groups = true, .group_tolerance_scale = 1};
  const PackedTree a = pack(project(grid_a, both_groups), BoundKind::l2, 2);
  const PackedTree b = pack(project(grid_b, {.tolerance = 0}));
  for (const float scale : {0x1p-100f, 0x1p-130f, 0x1p-143f, 0x1p-149f}) {
    long double exact = 0;
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        exact += (long double)scale * grid_a.at(0, 0, x, y) * grid_b.at(0, 0, x, y);
    const std::string power = "2^" + std::to_string(std::ilogb(scale));
    cases.push_back({a, b, {scale, 0}, exact / (n * n), "random, weights " + power + " and 0"});
    // One weight: the plain descent, its result weighted after it.
    cases.push_back({a, b, {scale}, exact / (n * n), "random, one weight " + power});
  }
  // Constants: a weighted product of half the smallest subnormal (2^-149 x 0.5 in a's units of 1),
  // which rounds to 0, times b's largest half (65,504): 2^-135 of the result lost, where a term
  // growing with the trees' nodes allowed half that.
  Grid half(2, 1, 2), largest(2, 1);
  for (int k = 0; k < 4; ++k) {
    half.texels[std::size_t(k)] = 0.5f;
    half.texels[std::size_t(4 + k)] = 30000.0f;
    largest.texels[std::size_t(k)] = 65504.0f;
  }
  cases.push_back({pack(project(half, both_groups), BoundKind::l2, 2),
                   pack(project(largest, {.tolerance = 0})),
                   {0x1p-149f, 0},
                   (long double)0x1p-149f * 0.5L * 65504.0L,
                   "constants"});
  return cases;
}

// The SIMD and scalar weighted descents of a case.
std::vector<Convolution> tiny_weight_results(const TinyWeights& k) {
  return {convolve_weighted(k.a.view(), k.w, k.b.view()),
          convolve_weighted_scalar(k.a.view(), k.w, k.b.view())};
}

void expect_tiny_weights_within_their_bound(const TinyWeights& k,
                                            const std::vector<Convolution>& results) {
  for (const Convolution& r : results)
    for (int c = 0; c < 3; ++c) {
      EXPECT_GT(r.bound[c], 0) << k.what;
      EXPECT_LE(std::abs((long double)r.value[c] - k.exact), (long double)r.bound[c])
          << k.what << ", channel " << c << ", value " << r.value[c] << ", exact "
          << double(k.exact);
    }
}

TEST(PackedConvolution, WeightsBelowTheNormalFloatsKeepTheirBound) {
  for (const TinyWeights& k : tiny_weight_cases())
    expect_tiny_weights_within_their_bound(k, tiny_weight_results(k));
}

#if defined(__SSE2__)
// A caller that runs with flush-to-zero and denormals-are-zero set (as renderers often do): the
// descents keep subnormals while they run, so that their bounds hold, and the caller has its
// modes back afterwards. The trees are made first, in the default modes. Without the descents'
// own modes, the weights and the texels below the normal floats read as 0.
TEST(PackedConvolution, FlushToZeroInTheCallerKeepsTheBound) {
  const std::vector<TinyWeights> cases = tiny_weight_cases();
  // Float trees of texels below the normal floats against large ones: about 10^-10 each.
  Grid tiny(8, 1), large(8, 1);
  for (int k = 0; k < 64; ++k) {
    tiny.texels[std::size_t(k)] = 1e-40f * float(1 + k % 3);
    large.texels[std::size_t(k)] = 1e30f;
  }
  const Quadtree tiny_tree = project(tiny, {.tolerance = 0.05});
  const Quadtree large_tree = project(large, {.tolerance = 0.05});
  long double exact = 0;
  for (int k = 0; k < 64; ++k)
    exact += (long double)tiny.texels[std::size_t(k)] * large.texels[std::size_t(k)] / 64;
  constexpr unsigned kModes = _MM_FLUSH_ZERO_MASK | _MM_DENORMALS_ZERO_MASK;
  // The caller's modes for a scope, the test's own again after it (also if a call throws).
  struct CallerModes {
    unsigned saved = _mm_getcsr();
    CallerModes() { _mm_setcsr(saved | kModes); }
    ~CallerModes() { _mm_setcsr(saved); }
  };
  // Only the descents run in the caller's modes; the checks, which compare subnormals, after.
  std::vector<std::vector<Convolution>> results;
  Convolution floats, floats_scalar;
  unsigned after = 0;
  {
    const CallerModes caller;
    for (const TinyWeights& k : cases)
      results.push_back(tiny_weight_results(k));
    floats = convolve(tiny_tree.view(), large_tree.view());
    floats_scalar = convolve_scalar(tiny_tree.view(), large_tree.view());
    after = _mm_getcsr();
  }
  EXPECT_EQ(after & kModes, kModes);
  for (std::size_t i = 0; i < cases.size(); ++i)
    expect_tiny_weights_within_their_bound(cases[i], results[i]);
  for (const Convolution& r : {floats, floats_scalar})
    for (int c = 0; c < 3; ++c)
      EXPECT_LE(std::abs((long double)r.value[c] - exact), (long double)r.bound[c])
          << "float trees, channel " << c << ", value " << r.value[c];
}
#endif

// An accuracy target stops on the bound: asking for one without the bound is an error, on
// every path.
TEST(PackedConvolution, AnAccuracyTargetNeedsTheBound) {
  const auto functions = test_functions(16, 1, 37);
  const PackedTree a = pack(project(functions[1].grid, {.tolerance = 0.05}));
  const PackedTree b = pack(project(functions[2].grid, {.tolerance = 0.05}));
  const ConvolutionOptions both{.accuracy = 0.05, .bound = false};
  const float w[1] = {1};
  EXPECT_THROW(convolve(a.view(), b.view(), both), std::invalid_argument);
  EXPECT_THROW(convolve_scalar(a.view(), b.view(), both), std::invalid_argument);
  EXPECT_THROW(convolve_weighted(a.view(), w, b.view(), both), std::invalid_argument);
  EXPECT_THROW(convolve_weighted_scalar(a.view(), w, b.view(), both), std::invalid_argument);
  EXPECT_NO_THROW(convolve(a.view(), b.view(), {.accuracy = 0.05}));
  // Targets are fractions from 0 to 1.
  for (const double accuracy : {-0.1, 1.5, std::nan(""), double(INFINITY)}) {
    const ConvolutionOptions target{.accuracy = accuracy};
    EXPECT_THROW(convolve(a.view(), b.view(), target), std::invalid_argument) << accuracy;
    EXPECT_THROW(convolve_scalar(a.view(), b.view(), target), std::invalid_argument) << accuracy;
    EXPECT_THROW(convolve_weighted(a.view(), w, b.view(), target), std::invalid_argument);
  }
  EXPECT_NO_THROW(convolve(a.view(), b.view(), {.accuracy = 1}));
}

// Trees of values far from 1 whose products leave the normal floats: the value is what the
// double product of the grids gives, within a bound that is not zero and holds, in the SIMD and
// scalar paths; beyond the largest float, std::overflow_error rather than infinity.
TEST(PackedConvolution, ResultsBelowTheNormalFloatsKeepABoundThatHolds) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> unit(0, 1);
  for (const double scale : {1e-19, 1e-21, 1e-22}) {
    Grid ga(16, 3), gb(16, 3);
    for (float& t : ga.texels)
      t = float(unit(rng) * scale);
    for (float& t : gb.texels)
      t = float(unit(rng) * scale);
    const PackedTree a = pack(project(ga, {.tolerance = 0.05}));
    const PackedTree b = pack(project(gb, {.tolerance = 0.05}));
    const float w[1] = {0.3f};
    for (const Convolution& r : {convolve(a.view(), b.view()), convolve_scalar(a.view(), b.view())})
      for (int c = 0; c < 3; ++c) {
        const double exact = grid_product(ga, gb, c);
        EXPECT_GT(r.bound[c], 0) << scale;
        EXPECT_LE(std::abs(double(r.value[c]) - exact), double(r.bound[c])) << scale << " " << c;
      }
    // One weighted group (a table's off-grid tap), scaled after the descent.
    const Convolution weighted = convolve_weighted(a.view(), w, b.view());
    for (int c = 0; c < 3; ++c) {
      const double exact = 0.3 * grid_product(ga, gb, c);
      EXPECT_GT(weighted.bound[c], 0) << scale;
      EXPECT_LE(std::abs(double(weighted.value[c]) - exact), double(weighted.bound[c]))
          << scale << " " << c;
    }
  }
  Grid huge(16, 1);
  for (float& t : huge.texels)
    t = 1e20f * (1 + unit(rng));
  const PackedTree h = pack(project(huge, {.tolerance = 0.05}));
  EXPECT_THROW(convolve(h.view(), h.view()), std::overflow_error);
  EXPECT_THROW(convolve_scalar(h.view(), h.view()), std::overflow_error);
  EXPECT_THROW(convolve(h.view(), h.view(), {.bound = false}), std::overflow_error);
}

// Floats from doubles: the value rounds to nearest, the bound rounds up and covers it.
TEST(CertifiedFloat, RoundsTheBoundUpAndCoversTheValuesRounding) {
  for (const double value : {1.0 / 3, 2.455e-39, 7e-46, -1e-44, 3e38}) {
    const CertifiedFloat f = certified_float(value, 1e-50);
    EXPECT_LE(std::abs(double(f.value) - value), double(f.bound)) << value;
    EXPECT_GE(double(f.bound), 1e-50) << value;
  }
  EXPECT_EQ(certified_float(1, INFINITY).bound, INFINITY);
  EXPECT_THROW(certified_float(4e38, 0), std::overflow_error);
  // Values that round to the largest float are that float, with their rounding in the bound;
  // from half a step above it on (2^128 - 2^103), they round to infinity.
  const double largest = std::numeric_limits<float>::max();
  for (const double above : {0x1p90, 0x1p102, 0x1p103 - 0x1p76}) {
    const CertifiedFloat f = certified_float(-(largest + above), 1);
    EXPECT_EQ(f.value, -std::numeric_limits<float>::max()) << above;
    EXPECT_GE(double(f.bound), above + 1) << above;
  }
  EXPECT_THROW(certified_float(largest + 0x1p103, 0), std::overflow_error);
  EXPECT_THROW(certified_float(-0x1p128, 0), std::overflow_error);
  EXPECT_EQ(certified_float(1, 4e38).bound, INFINITY);
  EXPECT_THROW(certified_float(std::nan(""), 0), std::overflow_error);
}

}  // namespace
}  // namespace basis
