// Folded trees: a weighted sum of trees folded into one convolves to the dense product of the
// terms' texels within its bound, to the terms' own descents' values and, up to the rounding up
// of the folded bound codes, their summed bounds; accuracy targets keep the bound; values alone
// are the certified descent's; what cannot fold is refused.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include "basis/core/folded_tree.h"
#include "basis/core/half.h"
#include "basis/core/projection.h"
#include "support/test_functions.h"

namespace basis {
namespace {

using testing::test_functions;
using testing::three_groups;

struct Term {
  Grid grid;  // three groups
  PackedTree tree;
  std::array<float, 3> weights;
  int groups;
};

// Terms over different test functions, with weights as Hermite interpolation gives them (some
// negative) and one, two or three groups.
std::vector<Term> make_terms(int channels, std::size_t count) {
  const std::vector<std::array<float, 3>> weights = {
      {0.5f, 0.12f, -0.05f}, {0.3f, -0.1f, 0.04f}, {0.15f, 0.08f, 0}, {0.05f, 0, 0}};
  const std::vector<testing::NamedGrid> functions = test_functions(32, channels, 51);
  std::vector<Term> terms;
  for (std::size_t t = 0; t < count; ++t) {
    Grid grid = three_groups(functions[(2 * t + 1) % functions.size()].grid, 52 + unsigned(t));
    const Quadtree tree =
        project(grid, {.tolerance = 0.1, .cut_on_all_groups = true, .group_tolerance_scale = 1});
    const std::array<float, 3> w = weights[t];
    const int groups = w[2] != 0 ? 3 : w[1] != 0 ? 2 : 1;
    terms.push_back({std::move(grid), pack(tree, BoundKind::l2, 3), w, groups});
  }
  return terms;
}

TEST(FoldedTree, WithinTheBoundOfTheTexelsAndAtMostTheTermsBounds) {
  for (const auto& [channels_a, channels_b] : {std::pair{1, 1}, {3, 3}, {1, 3}, {3, 1}})
    for (const std::size_t count : {1, 2, 4}) {
      const std::vector<Term> terms = make_terms(channels_a, count);
      std::vector<WeightedTerm> weighted;
      for (const Term& t : terms)
        weighted.push_back({t.tree.view(), t.weights, t.groups});
      const FoldedTree folded = fold(weighted);
      for (const auto& [name_b, grid_b] : test_functions(64, channels_b, 53))
        for (const BoundKind kind_b : {BoundKind::l2, BoundKind::linf}) {
          // Captures: RGB with exact texels in shared-exponent words; grey in halves; RMS or
          // largest-deviation bounds.
          const Quadtree tree_b = project(grid_b, {.tolerance = 0.1});
          const PackedTree b =
              channels_b == 3 ? pack_exact_texels(tree_b, kind_b) : pack(tree_b, kind_b);
          for (const double accuracy : {0.0, 0.02, 0.1}) {
            const std::string what =
                std::to_string(count) + " terms of " + std::to_string(channels_a) + " channels x " +
                name_b + " (" + std::to_string(channels_b) + ", bounds " +
                std::to_string(int(kind_b)) + ") accuracy " + std::to_string(accuracy);
            const Convolution result = convolve(folded, b.view(), {accuracy});
            Convolution separate;
            for (const Term& t : terms) {
              const Convolution c = convolve_weighted(
                  t.tree.view(), std::span(t.weights.data(), std::size_t(t.groups)), b.view(),
                  {accuracy});
              for (int ch = 0; ch < 3; ++ch) {
                separate.value[ch] += c.value[ch];
                separate.bound[ch] += c.bound[ch];
              }
            }
            for (int c = 0; c < 3; ++c) {
              const int ca = channels_a == 1 ? 0 : c, cb = channels_b == 1 ? 0 : c;
              // The dense product of the terms' texels (32^2, each over 2 x 2 texels of b).
              double texels = 0, magnitude = 0;
              for (int y = 0; y < 64; ++y)
                for (int x = 0; x < 64; ++x) {
                  double f = 0, f_magnitude = 0;
                  for (const Term& t : terms)
                    for (int g = 0; g < t.groups; ++g) {
                      f += t.weights[g] * t.grid.at(g, ca, x / 2, y / 2);
                      f_magnitude += std::abs(t.weights[g] * t.grid.at(g, ca, x / 2, y / 2));
                    }
                  texels += f * grid_b.at(0, cb, x, y);
                  magnitude += f_magnitude * std::abs(grid_b.at(0, cb, x, y));
                }
              texels /= 64.0 * 64;
              magnitude /= 64.0 * 64;
              EXPECT_LE(std::abs(result.value[c] - texels),
                        result.bound[c] * (1 + 1e-4) + 1e-6 * magnitude)
                  << what << " channel " << c << " bound " << result.bound[c];
              if (accuracy != 0) continue;
              // Values alone: the same descent's value, to the bit, and nothing certified.
              const Convolution alone = convolve(folded, b.view(), {.bound = false});
              EXPECT_EQ(alone.value[c], result.value[c]) << what << " channel " << c;
              EXPECT_EQ(alone.bound[c], std::numeric_limits<float>::infinity()) << what;
              // The terms' own descents: the same value up to halves' rounding (the folded sum's,
              // and shared-exponent quadrants read at other levels), and a bound at most theirs
              // but for the folded codes' rounding up (1/8 at most) and the folded sum's own
              // rounding (kHalfRounding of the magnitude).
              EXPECT_LE(std::abs(result.value[c] - separate.value[c]), 4e-3 * magnitude) << what;
              // (Against largest-deviation bounds the terms' descents take that alternative on
              // every stopped pair, the folded descent only where the sum stops.)
              if (kind_b == BoundKind::l2) {
                EXPECT_LE(result.bound[c], 1.125 * separate.bound[c] + 0x1p-10 * magnitude)
                    << what << " channel " << c;
              }
            }
          }
        }
    }
}

// A term that stops while the sum goes on adds its bound where it stops: without that, a
// coarse term against a fine one would lose its bound entirely. A constant-in-value but
// varying term (its texels a checkerboard, its tree one node) against a light that matches
// the checkerboard: the value misses the product by the texels' correlation, which the bound
// must carry.
TEST(FoldedTree, ATermThatStopsEarlyKeepsItsBound) {
  const int n = 32;
  Grid checker(n, 1), fine(n, 1, 3), light(n * 2, 1);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      checker.at(0, 0, x, y) = (x + y) % 2 ? 1.5f : 0.5f;
      fine.at(0, 0, x, y) = x < n / 2 ? 0.1f * float(x) : 2.0f;
    }
  for (int y = 0; y < 2 * n; ++y)
    for (int x = 0; x < 2 * n; ++x)
      light.at(0, 0, x, y) = (x / 2 + y / 2) % 2 ? 3.0f : 1.0f;
  // The checkerboard is cut at the root (tolerance far above its deviation); the other term
  // and the light are refined to their texels.
  const PackedTree coarse = pack(project(checker, {.tolerance = 10}));
  ASSERT_EQ(coarse.node_count(), 1);
  const PackedTree refined = pack(project(fine, {.tolerance = 0}), BoundKind::l2, 1);
  const PackedTree b = pack(project(light, {.tolerance = 0}));
  const std::vector<WeightedTerm> terms = {{coarse.view(), {0.7f, 0, 0}, 1},
                                           {refined.view(), {0.3f, 0, 0}, 1}};
  const FoldedTree folded = fold(terms);
  ASSERT_GT(folded.tree().node_count(), 1);
  const Convolution result = convolve(folded, b.view());
  double texels = 0;
  for (int y = 0; y < 2 * n; ++y)
    for (int x = 0; x < 2 * n; ++x)
      texels += (0.7 * checker.at(0, 0, x / 2, y / 2) + 0.3 * fine.at(0, 0, x / 2, y / 2)) *
                light.at(0, 0, x, y);
  texels /= 4.0 * n * n;
  // The product differs from the trees' by the checkerboard's correlation with the light.
  EXPECT_GT(std::abs(result.value[0] - texels), 0.05 * texels);
  EXPECT_LE(std::abs(result.value[0] - texels), result.bound[0]);
}

// The decoded nodes the descents read are the packed tree's values, shares and bounds, bit for
// bit, decoded one by one here through the view (half_to_float, bound_code_value), not by the
// fold's SIMD, one for each of its nodes; a folded tree moved from, which holds none, is refused,
// not read out of bounds.
TEST(FoldedTree, DecodedNodesAreThePackedTrees) {
  for (const int channels : {1, 3}) {
    const std::vector<Term> made = make_terms(channels, 2);
    std::vector<WeightedTerm> terms;
    for (const Term& t : made)
      terms.push_back({t.tree.view(), t.weights, t.groups});
    const FoldedTree folded = fold(terms);
    const PackedTreeView view = folded.tree().view();
    const int folded_channels = view.shape().channels;
    ASSERT_EQ(folded_channels, channels);
    const std::size_t stride = 1 + 16 * std::size_t(folded_channels);  // written out: the layout
    ASSERT_EQ(FoldedTree::descent_words(folded_channels), stride);
    ASSERT_EQ(folded.descent_nodes().size(), std::size_t(view.node_count()) * stride);
    for (int n = 0; n < view.node_count(); ++n) {
      const std::uint32_t* node = folded.descent_nodes().data() + std::size_t(n) * stride;
      ASSERT_EQ(node[0], view.link(n));
      // Block b, channel c, quadrant q: its bits, to compare exactly (signed zeros included).
      const auto at = [&](int block, int c, int q) {
        return node[1 + std::size_t(block * 4 * folded_channels + 4 * c + q)];
      };
      const auto bits = [](float f) { return std::bit_cast<std::uint32_t>(f); };
      for (int c = 0; c < folded_channels; ++c)
        for (int q = 0; q < 4; ++q) {
          const float value = half_to_float(view.halves(n)[4 * c + q]);
          const float half_magnitude = half_to_float(view.halves(n)[4 * (folded_channels + c) + q]);
          EXPECT_EQ(at(0, c, q), bits(value));
          EXPECT_EQ(at(1, c, q), bits(std::abs(value) + (half_magnitude + half_magnitude)));
          EXPECT_EQ(at(2, c, q), bits(bound_code_value(view.bound_code(n, 0, c, q))));
          EXPECT_EQ(at(3, c, q), bits(bound_code_value(view.bound_code(n, 1, c, q))));
        }
    }
    FoldedTree moved_from = folded;
    const FoldedTree moved_to = std::move(moved_from);
    EXPECT_EQ(convolve(moved_to, made[0].tree.view()).value,
              convolve(folded, made[0].tree.view()).value);
    EXPECT_THROW(convolve(moved_from, made[0].tree.view()), std::invalid_argument);
  }
}

// Rounding at its worst: each term's half, the folded sum's own half and the light's half all
// round by (nearly) half an ulp the same way, so that the value misses the product by about
// three half-ulps, all of which the bound's rounding terms must carry.
TEST(FoldedTree, RoundingOfTermsSumAndLightStaysWithinTheBound) {
  const float ulp = 0x1p-10f;  // of a half in [1, 2)
  auto constant = [](int n, float v) {
    Grid g(n, 1);
    for (float& t : g.texels)
      t = v;
    return g;
  };
  // Term 1 rounds down to 1, term 2 down to 1 + ulp; their mean, 1 + ulp / 2, down to 1 (ties
  // to even); the light down to 1.
  const float a1 = 1 + 0.49f * ulp, a2 = 1 + 1.49f * ulp, light = 1 + 0.49f * ulp;
  const PackedTree t1 = pack(project(constant(4, a1), {.tolerance = 0}));
  const PackedTree t2 = pack(project(constant(4, a2), {.tolerance = 0}));
  const PackedTree b = pack(project(constant(4, light), {.tolerance = 0}));
  const std::vector<WeightedTerm> terms = {{t1.view(), {0.5f, 0, 0}, 1},
                                           {t2.view(), {0.5f, 0, 0}, 1}};
  const Convolution result = convolve(fold(terms), b.view());
  const double truth = (0.5 * a1 + 0.5 * a2) * double(light);
  const double error = std::abs(double(result.value[0]) - truth);
  EXPECT_GT(error, 1.4 * ulp);  // the test is one the bound could fail
  EXPECT_LE(error, result.bound[0]);
}

// Weights and trees so small that the fold's float products fall below the normal floats, where
// they lose bits that no relative rounding term covers: one weight, 1.5 x 2^-23, times a value
// scale of 2^-126 lies halfway between two subnormals and rounds up by a third, and every value
// with it. The folded convolution stays within its bound of the texels' product, for weights
// from 2^-149 to 0.7 against terms from 2^-120 to 1: one term of one group, and two terms, one
// of two groups, whose losses add up and one of which stops where the other goes on.
TEST(FoldedTree, WeightsAndScalesBelowTheNormalFloatsKeepTheBound) {
  const int n = 8;
  std::mt19937 rng(61);
  std::uniform_real_distribution<float> unit(1, 2);
  Grid light(n, 1);
  for (float& t : light.texels)
    t = unit(rng);
  const PackedTree b = pack(project(light, {.tolerance = 0}));
  const ProjectionOptions both_groups{.tolerance = 0.1f, .cut_on_all_groups = true};
  int cases = 0;
  for (const float scale : {1.0f, 0x1p-112f, 0x1p-120f})
    for (const bool constant : {true, false}) {
      Grid grid(n, 1, 2), other(n, 1);
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          grid.at(0, 0, x, y) = constant ? 1.5f * scale : unit(rng) * scale;
          grid.at(1, 0, x, y) = unit(rng) * scale;
          // Constant but for one quadrant: a term that stops where the other goes on.
          other.at(0, 0, x, y) = (x < n / 2 && y < n / 2 ? unit(rng) : 1.25f) * scale;
        }
      for (const float tolerance : {0.0f, 0.1f}) {
        const PackedTree a = pack(
            project(grid, {.tolerance = tolerance, .cut_on_all_groups = true}), BoundKind::l2, 2);
        const PackedTree a2 = pack(project(other, both_groups), BoundKind::l2);
        for (const float w : {1.5f * 0x1p-23f, 0.7f, 1.3f * 0x1p-100f, 1.7f * 0x1p-130f,
                              1.1f * 0x1p-143f, 0x1p-149f})
          for (const bool two_terms : {false, true}) {
            const float w1 = two_terms ? w / 3 : 0, w2 = 0.6f * w;
            long double exact = 0;
            for (int y = 0; y < n; ++y)
              for (int x = 0; x < n; ++x) {
                long double f = (long double)w * grid.at(0, 0, x, y);
                if (two_terms)
                  f += (long double)w1 * grid.at(1, 0, x, y) +
                       (long double)w2 * other.at(0, 0, x, y);
                exact += f * light.at(0, 0, x, y);
              }
            exact /= n * n;
            std::vector<WeightedTerm> terms = {{a.view(), {w, w1, 0}, two_terms ? 2 : 1}};
            if (two_terms) terms.push_back({a2.view(), {w2, 0, 0}, 1});
            const Convolution r = convolve(fold(terms), b.view());
            EXPECT_LE(std::abs((long double)r.value[0] - exact), (long double)r.bound[0])
                << "terms of 2^" << std::ilogb(scale) << (constant ? " (constant)" : "")
                << ", tolerance " << tolerance << ", weight " << w
                << (two_terms ? ", two terms" : "") << ": value " << r.value[0] << ", exact "
                << double(exact);
            ++cases;
          }
      }
    }
  EXPECT_EQ(cases, 144);
  // The loss the bound now counts: the folded value a third above the product.
  Grid grid(n, 1);
  for (float& t : grid.texels)
    t = 1.5f * 0x1p-112f;
  const PackedTree a = pack(project(grid, {.tolerance = 0}), BoundKind::l2);
  const std::vector<WeightedTerm> terms = {{a.view(), {1.5f * 0x1p-23f, 0, 0}, 1}};
  long double exact = 0;
  for (const float t : light.texels)
    exact += (long double)(1.5f * 0x1p-23f) * (1.5f * 0x1p-112f) * t;
  exact /= n * n;
  EXPECT_GT(std::abs((long double)convolve(fold(terms), b.view()).value[0] - exact), exact / 4);
}

// The smallest trees that fill a fold's queue at once: four terms of two nodes each (the root and
// one refined quadrant, a different one per term), whose fold refines all four quadrants of its
// root; their sum convolves to the dense product within the bound.
TEST(FoldedTree, TwoNodeTermsRefiningEveryQuadrantFold) {
  const int n = 4;
  std::vector<Grid> grids;
  std::vector<PackedTree> trees;
  std::vector<WeightedTerm> terms;
  for (int t = 0; t < 4; ++t) {
    Grid grid(n, 1);
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const bool inside = x / 2 == (t & 1) && y / 2 == (t >> 1);
        grid.at(0, 0, x, y) = inside ? 1.0f + 0.5f * float((x + y) % 2) + 0.1f * float(t) : 1.0f;
      }
    trees.push_back(pack(project(grid, {.tolerance = 0}), BoundKind::l2, 1));
    ASSERT_EQ(trees.back().node_count(), 2);
    grids.push_back(std::move(grid));
  }
  for (int t = 0; t < 4; ++t)
    terms.push_back({trees[std::size_t(t)].view(), {0.25f + 0.1f * float(t), 0, 0}, 1});
  const FoldedTree folded = fold(terms);
  EXPECT_EQ(folded.tree().node_count(), 5);
  Grid light(n, 1);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x)
      light.at(0, 0, x, y) = 1.0f + float(x) + 0.5f * float(y);
  const PackedTree b = pack(project(light, {.tolerance = 0}));
  const Convolution result = convolve(folded, b.view());
  double texels = 0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x)
      for (int t = 0; t < 4; ++t)
        texels += double(terms[std::size_t(t)].weights[0]) * grids[std::size_t(t)].at(0, 0, x, y) *
                  light.at(0, 0, x, y);
  texels /= n * n;
  EXPECT_LE(std::abs(result.value[0] - texels), result.bound[0]);
  EXPECT_LE(result.bound[0], 1e-2 * texels);  // texel-exact terms: only rounding remains
}

TEST(FoldedTree, RefusesWhatCannotFold) {
  const Grid grid = three_groups(test_functions(16, 1, 54)[1].grid, 55);
  const Quadtree tree = project(grid, {.tolerance = 0.1, .cut_on_all_groups = true});
  const PackedTree l2 = pack(tree, BoundKind::l2, 3), linf = pack(tree, BoundKind::linf, 3);
  const PackedTree one_bounded = pack(tree, BoundKind::l2, 1);
  const PackedTree exact = pack_exact_texels(project(test_functions(16, 3, 56)[0].grid, {}));
  const PackedTree other_resolution = pack(project(test_functions(32, 1, 57)[0].grid, {}));
  auto folds = [](std::vector<WeightedTerm> terms) { return fold(terms).tree().node_count() > 0; };
  EXPECT_TRUE(folds({{l2.view(), {1, 0.5f, 0.25f}, 3}}));
  EXPECT_THROW(folds({}), std::invalid_argument);
  EXPECT_THROW(folds({{linf.view(), {1, 0, 0}, 1}}), std::invalid_argument);
  EXPECT_THROW(folds({{one_bounded.view(), {1, 1, 0}, 2}}), std::invalid_argument);
  EXPECT_THROW(folds({{exact.view(), {1, 0, 0}, 1}}), std::invalid_argument);
  EXPECT_THROW(folds({{l2.view(), {1, 0, 0}, 1}, {other_resolution.view(), {1, 0, 0}, 1}}),
               std::invalid_argument);
  EXPECT_THROW(folds({{l2.view(), {NAN, 0, 0}, 1}}), std::invalid_argument);
  // An accuracy target stops on the bound: not without one.
  const FoldedTree folded = fold(std::vector<WeightedTerm>{{l2.view(), {1, 0.5f, 0.25f}, 3}});
  const PackedTree capture = pack(project(test_functions(16, 1, 58)[1].grid, {}));
  EXPECT_THROW(convolve(folded, capture.view(), {.accuracy = 0.1, .bound = false}),
               std::invalid_argument);
  EXPECT_NO_THROW(convolve(folded, capture.view(), {.accuracy = 0.1}));
  EXPECT_NO_THROW(convolve(folded, capture.view(), {.bound = false}));
}

}  // namespace
}  // namespace basis
