// Derived values of fully refined nodes against the texels they stand for: each quadrant's value
// near the texels' mean, its l2 bound at least their RMS deviation from it and its linf bound
// their largest; the layout without those values read back word for word; truncated words and
// bad links refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "basis/core/projection.h"
#include "basis/core/refined_values.h"
#include "support/test_functions.h"

namespace basis {
namespace {

struct QuadrantCheck {
  int derived_quadrants = 0;
  double worst_excess = 0;       // largest (deviation - bound) / bound; must stay <= 0
  double worst_mean_offset = 0;  // largest |value - mean| / the quadrant's largest mean
  // Largest (|value - mean| - rounding) / rounding, the rounding a descent allows the value
  // (PackedTreeView::rounding); must stay <= 0.
  double worst_rounding_excess = 0;
  std::vector<double> bound_ratios;  // bound / the texels' deviation, where it is not 0
};

// Every quadrant of every node whose four quadrants are refined, against the grid's texels.
QuadrantCheck check_derived(const PackedTreeView& tree, const Grid& grid) {
  QuadrantCheck check;
  const int n = grid.resolution;
  const bool l2 = tree.shape().bounds == BoundKind::l2;
  auto visit = [&](auto&& self, int node, int level, int x, int y) -> void {
    if (tree.is_texel_node(node)) return;
    const bool derived = (tree.link(node) & 15u) == 15u;
    for (int q = 0; q < 4; ++q) {
      const int qx = 2 * x + (q & 1), qy = 2 * y + (q >> 1), size = n >> (level + 1);
      if (derived) {
        ++check.derived_quadrants;
        double largest_mean = 0;
        std::vector<double> means(3);
        for (int c = 0; c < 3; ++c) {
          double sum = 0;
          for (int ty = qy * size; ty < (qy + 1) * size; ++ty)
            for (int tx = qx * size; tx < (qx + 1) * size; ++tx)
              sum += grid.at(0, c, tx, ty);
          means[std::size_t(c)] = sum / (double(size) * size);
          largest_mean = std::max(largest_mean, means[std::size_t(c)]);
        }
        for (int c = 0; c < 3; ++c) {
          const double value = tree.value(node, 0, c, q), bound = tree.bound(node, c, q);
          double squares = 0, largest = 0;
          for (int ty = qy * size; ty < (qy + 1) * size; ++ty)
            for (int tx = qx * size; tx < (qx + 1) * size; ++tx) {
              const double d = grid.at(0, c, tx, ty) - value;
              squares += d * d;
              largest = std::max(largest, std::abs(d));
            }
          const double deviation = l2 ? std::sqrt(squares / (double(size) * size)) : largest;
          check.worst_excess = std::max(check.worst_excess, (deviation - bound) / bound);
          if (deviation > 0) check.bound_ratios.push_back(bound / deviation);
          const double rounding = tree.rounding(node, 0, c, q);
          check.worst_rounding_excess =
              std::max(check.worst_rounding_excess,
                       (std::abs(value - means[std::size_t(c)]) - rounding) / rounding);
          if (largest_mean > 0)
            check.worst_mean_offset = std::max(
                check.worst_mean_offset, std::abs(value - means[std::size_t(c)]) / largest_mean);
        }
      }
      if (const int child = tree.child(node, q)) self(self, child, level + 1, qx, qy);
    }
  };
  visit(visit, 0, 0, 0, 0);
  return check;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

std::vector<testing::NamedGrid> grids_to_check() {
  std::vector<testing::NamedGrid> grids = testing::test_functions(64, 3, 5);
  // A sky with a sun and sharp edges, in a capture's range of values.
  grids.push_back({"sky", testing::sample_grid(128, 3, [](double u, double v, int c) {
                     const double sun =
                         std::exp(-4000 * ((u - 0.62) * (u - 0.62) + (v - 0.41) * (v - 0.41)));
                     const double wall = (u + 0.3 * v > 0.8 && v < 0.7) ? 0.05 : 1.0;
                     return wall * (0.3 + 0.2 * c + 2e3 * sun);
                   })});
  grids.push_back({"one_way_rounding", testing::one_way_rounding_grid(64)});
  return grids;
}

TEST(RefinedValues, DerivedBoundsHoldForTheTexels) {
  for (const testing::NamedGrid& g : grids_to_check())
    for (const double tolerance : {0.0, 0.05, 0.3})
      for (const BoundKind kind : {BoundKind::l2, BoundKind::linf}) {
        SCOPED_TRACE(g.name + " at tolerance " + std::to_string(tolerance) +
                     (kind == BoundKind::l2 ? ", l2" : ", linf"));
        const PackedTree tree = pack_exact_texels(project(g.grid, {.tolerance = tolerance}), kind);
        ASSERT_TRUE(has_derived_values(tree.shape));
        const QuadrantCheck check = check_derived(tree.view(), g.grid);
        // Steps and the spike refine no node over all four quadrants: nothing is derived in
        // them. The other three grids have such nodes at every tolerance (measured 28 to 1,364).
        if (g.name == "random" || g.name == "smooth" || g.name == "sky") {
          EXPECT_GE(check.derived_quadrants, 28);
        }
        if (tolerance == 0 && (g.name == "random" || g.name == "sky")) {
          EXPECT_GT(check.derived_quadrants, 100);
        }
        if (tolerance == 0 && g.name == "one_way_rounding") {
          EXPECT_EQ(check.derived_quadrants, 4 * (tree.node_count() - 32 * 32));
        }
        EXPECT_LE(check.worst_excess, 0);
        // Every derived value within the rounding a descent allows it (tree.derived_rounding
        // times half its step), and that factor at most 7: half a step of its own, and the mean
        // of the half steps of the stored values below. A word's step is 1/512 to 1/256 of its
        // largest channel, and a mean's largest channel at least a third of the mean of the
        // largest channels below it, so that mean is at most 6 of the derived value's half
        // steps. Measured 2.75-3.1 on traced captures.
        EXPECT_LE(check.worst_rounding_excess, 0);
        EXPECT_GE(tree.derived_rounding, 1.0f);
        EXPECT_LE(tree.derived_rounding, 7.0f);
        // A word rounds to 1/512 of its largest channel; the derived means add a child's each.
        EXPECT_LE(check.worst_mean_offset, 0x1p-7);
        // Not much looser than the texels' own deviation (l2: the codes' rounding up and the
        // children's offsets from their means).
        if (!check.bound_ratios.empty()) {
          EXPECT_LE(median(check.bound_ratios), 1.25);
        }
      }
}

TEST(RefinedValues, ElidedWordsReadBackToTheSameTree) {
  for (const testing::NamedGrid& g : grids_to_check()) {
    SCOPED_TRACE(g.name);
    const PackedTree tree = pack_exact_texels(project(g.grid, {.tolerance = 0.02}));
    int derived_nodes = 0;
    for (int n = 0; n < int(tree.texel_start); ++n)
      derived_nodes += (tree.view().link(n) & 15u) == 15u;
    const std::vector<std::uint32_t> elided = elide_refined_values(tree.view());
    EXPECT_EQ(elided.size(),
              tree.words.size() - std::size_t(derived_nodes) * (tree.shape.words_per_node() - 1));
    // With a word past it, as in a set: only the tree's own are read.
    std::vector<std::uint32_t> in_set = elided;
    in_set.push_back(0xdeadbeef);
    PackedTree read;
    EXPECT_EQ(read_elided_tree(tree.shape, tree.scales, in_set, std::size_t(tree.node_count()),
                               tree.texel_start, read),
              elided.size());
    derive_refined_values(read, DerivedBoundRange::refuse);
    EXPECT_EQ(read.scales, tree.scales);
    EXPECT_EQ(read.words, tree.words);
    EXPECT_EQ(read.derived_rounding, tree.derived_rounding);
    // Whatever a fully refined node held before (values of a tree packed otherwise, or noise),
    // deriving gives the same tree.
    PackedTree scrambled = tree;
    for (int n = 0; n < int(tree.texel_start); ++n)
      if ((tree.view().link(n) & 15u) == 15u)
        for (int w = 1; w < tree.shape.words_per_node(); ++w)
          scrambled.words[std::size_t(n * tree.shape.words_per_node() + w)] ^= 0x5a5a5a5au;
    derive_refined_values(scrambled, DerivedBoundRange::refuse);
    EXPECT_EQ(scrambled.words, tree.words);
    // Every shorter run of words is refused by name, none read past.
    for (std::size_t size = 0; size < elided.size(); size += 1 + size / 7)
      EXPECT_THROW(read_elided_tree(tree.shape, tree.scales, {elided.data(), size},
                                    std::size_t(tree.node_count()), tree.texel_start, read),
                   std::invalid_argument);
  }
}

// Texels that round up to the top of the words' range (2^15 times the value scale): their mean
// cannot be a word, so it is rounded down to one, and the bound still holds.
TEST(RefinedValues, MeansAtTheTopOfTheRangeStayWords) {
  Grid grid = testing::random_grid(16, 3, 4);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x)
      grid.at(0, 0, x, y) = 65504 - float((x + y) % 3);  // red near the largest value
  const PackedTree tree = pack_exact_texels(project(grid, {.tolerance = 0.0}));
  ASSERT_EQ(tree.view().link(0) & 15u, 15u);
  EXPECT_LE(check_derived(tree.view(), grid).worst_excess, 0);
}

TEST(RefinedValues, LinksBackwardsAndUncodableBoundsAreRefused) {
  const Grid grid = testing::random_grid(32, 3, 9);
  const PackedTree tree = pack_exact_texels(project(grid, {.tolerance = 0.0}));
  ASSERT_EQ(tree.view().link(0) & 15u, 15u);
  // A fully refined node whose children would come before it.
  PackedTree backwards = tree;
  const std::size_t node = tree.texel_start - 1;
  backwards.words[node * std::size_t(tree.shape.words_per_node())] = std::uint32_t(node) << 4 | 15u;
  EXPECT_THROW(derive_refined_values(backwards), std::invalid_argument);
  // A bound scale far too small for the values' spread: refused, or doubled until it codes.
  PackedTree small = tree;
  small.scales.bound_scale = tree.scales.bound_scale * 0x1p-12f;
  EXPECT_THROW(derive_refined_values(small, DerivedBoundRange::refuse), std::invalid_argument);
  derive_refined_values(small);
  EXPECT_GT(small.scales.bound_scale, tree.scales.bound_scale * 0x1p-12f);
  EXPECT_LE(check_derived(small.view(), grid).worst_excess, 0);
  // Once derived, deriving again changes nothing.
  PackedTree again = small;
  derive_refined_values(again, DerivedBoundRange::refuse);
  EXPECT_EQ(again.words, small.words);
}

}  // namespace
}  // namespace basis
