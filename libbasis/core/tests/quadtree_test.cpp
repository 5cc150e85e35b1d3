// Quadtree projection: reconstruction within tolerance, exact integrals, valid error bounds,
// tolerance and depth semantics.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <random>

#include "basis/core/projection.h"
#include "support/test_functions.h"

namespace basis {
namespace {

using testing::test_functions;

// Largest |texel - quadrant value| of the source grid over every quadrant of every node,
// compared with the stored error bound; calls check(max_deviation, stored_error).
template <typename Check>
void for_each_quadrant_deviation(const QuadtreeView& tree, const Grid& grid, Check check) {
  const int n = grid.resolution;
  auto visit = [&](auto&& self, int node, int x0, int y0, int size) -> void {
    const int half = size / 2;
    for (int q = 0; q < 4; ++q) {
      const int qx = x0 + (q & 1) * half, qy = y0 + (q >> 1) * half;
      for (int c = 0; c < grid.channels; ++c) {
        const float v = tree.value(node, 0, c, q);
        float deviation = 0;
        for (int y = qy; y < qy + half; ++y)
          for (int x = qx; x < qx + half; ++x)
            deviation = std::max(deviation, std::abs(grid.at(0, c, x, y) - v));
        check(deviation, tree.error(node, c, q), std::abs(v));
      }
      if (const int child = tree.child(node, q)) self(self, child, qx, qy, half);
    }
  };
  visit(visit, 0, 0, 0, n);
}

class QuadtreeProperties : public ::testing::TestWithParam<std::tuple<int, int>> {};

TEST_P(QuadtreeProperties, ReconstructionWithinToleranceAndIntegralExact) {
  const int n = std::get<0>(GetParam()), channels = std::get<1>(GetParam());
  for (const auto& [name, grid] : test_functions(n, channels, 11)) {
    for (double tolerance : {0.0, 0.01, 0.05, 0.5}) {
      const Quadtree tree = project(grid, {.tolerance = tolerance});
      const Grid recon = reconstruct(tree.view());
      for (int c = 0; c < channels; ++c) {
        const double mean = grid.mean(0, c);
        const double tol = tolerance * std::abs(mean);
        for (int y = 0; y < n; ++y)
          for (int x = 0; x < n; ++x) {
            const float input = grid.at(0, c, x, y);
            ASSERT_LE(std::abs(recon.at(0, c, x, y) - input), tol + 1e-6 * std::abs(input) + 1e-7)
                << name << " tol " << tolerance << " texel " << x << "," << y;
          }
        EXPECT_NEAR(integrate(tree.view(), 0, c), mean, 1e-6 * std::abs(mean) + 1e-9)
            << name << " tol " << tolerance;
      }
      if (tolerance == 0) {
        EXPECT_EQ(recon.texels, grid.texels) << name;
      }
    }
  }
}

// The locally relative cut (BRDF tables' default): every texel of the reconstruction lies
// within tolerance x max(|its quadrant's value|, floor x |mean|) of the input texel.
TEST_P(QuadtreeProperties, LocallyRelativeCutHoldsEveryTexelNearItsQuadrantOrTheFloor) {
  const int n = std::get<0>(GetParam()), channels = std::get<1>(GetParam());
  for (const auto& [name, grid] : test_functions(n, channels, 12))
    for (double tolerance : {0.01, 0.05, 0.3})
      for (double floor : {0.05, 0.2, 1.0}) {
        const Quadtree tree = project(grid, {.tolerance = tolerance, .local_floor = floor});
        const Grid recon = reconstruct(tree.view());
        for (int c = 0; c < channels; ++c) {
          const double mean = std::abs(grid.mean(0, c));
          for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x) {
              const double input = grid.at(0, c, x, y), value = recon.at(0, c, x, y);
              const double allowed = tolerance * std::max(std::abs(value), floor * mean);
              ASSERT_LE(std::abs(value - input), allowed * (1 + 1e-6) + 1e-6 * std::abs(input))
                  << name << " tolerance " << tolerance << " floor " << floor << " texel " << x
                  << "," << y;
            }
        }
      }
}

TEST_P(QuadtreeProperties, StoredErrorBoundsEveryTexel) {
  const int n = std::get<0>(GetParam()), channels = std::get<1>(GetParam());
  for (const auto bound : {ProjectionOptions::Bound::exact, ProjectionOptions::Bound::paper})
    for (const auto& function : test_functions(n, channels, 5)) {
      const std::string& name = function.name;
      const Quadtree tree = project(function.grid, {.tolerance = 0.05, .bound = bound});
      for_each_quadrant_deviation(
          tree.view(), function.grid, [&](float deviation, float error, float v) {
            ASSERT_LE(deviation, error + 1e-6f * (v + deviation) + 1e-7f) << name;
            // The exact bound is the largest deviation itself.
            if (bound == ProjectionOptions::Bound::exact) {
              ASSERT_LE(error, deviation + 1e-6f * (v + deviation) + 1e-7f) << name;
            }
          });
    }
}

// The stored RMS deviation of every quadrant, against the texels under it (in double): never
// below it, and above it only by float rounding; never above the error bound.
TEST_P(QuadtreeProperties, StoredDeviationsAreTheRmsOfEveryQuadrant) {
  const int n = std::get<0>(GetParam()), channels = std::get<1>(GetParam());
  for (const auto& function : test_functions(n, channels, 6)) {
    const Quadtree tree = project(function.grid, {.tolerance = 0.05});
    ASSERT_EQ(tree.deviations.size(), tree.errors.size());
    const QuadtreeView view = tree.view();
    auto visit = [&](auto&& self, int node, int x0, int y0, int size) -> void {
      const int half = size / 2;
      for (int q = 0; q < 4; ++q) {
        const int qx = x0 + (q & 1) * half, qy = y0 + (q >> 1) * half;
        for (int c = 0; c < channels; ++c) {
          const double v = view.value(node, 0, c, q);
          double squares = 0, magnitude = std::abs(v);
          for (int y = qy; y < qy + half; ++y)
            for (int x = qx; x < qx + half; ++x) {
              const double d = function.grid.at(0, c, x, y) - v;
              squares += d * d;
              magnitude = std::max(magnitude, double(std::abs(function.grid.at(0, c, x, y))));
            }
          const double rms = std::sqrt(squares / (double(half) * half));
          const float stored = tree.deviations[std::size_t(node) * channels + c].lane[q];
          ASSERT_GE(stored, rms * (1 - 1e-12)) << function.name;
          ASSERT_LE(stored, rms + 1e-6 * magnitude + 1e-30) << function.name;
          ASSERT_LE(stored, view.error(node, c, q) * (1 + 1e-6) + 1e-6 * magnitude)
              << function.name;
        }
        if (const int child = view.child(node, q)) self(self, child, qx, qy, half);
      }
    };
    visit(visit, 0, 0, 0, n);
  }
}

TEST_P(QuadtreeProperties, ExactBoundsNeverNeedMoreNodesThanThePapers) {
  const int n = std::get<0>(GetParam()), channels = std::get<1>(GetParam());
  for (const auto& [name, grid] : test_functions(n, channels, 6))
    for (double tolerance : {0.01, 0.05, 0.2}) {
      const int exact = project(grid, {.tolerance = tolerance}).node_count();
      const int paper =
          project(grid, {.tolerance = tolerance, .bound = ProjectionOptions::Bound::paper})
              .node_count();
      EXPECT_LE(exact, paper) << name << " " << tolerance;
    }
}

INSTANTIATE_TEST_SUITE_P(Resolutions, QuadtreeProperties,
                         ::testing::Combine(::testing::Values(2, 8, 32, 64),
                                            ::testing::Values(1, 3)));

// Texels of either sign whose magnitudes cancel (+-10^6 beside 0.3 in every 2 x 2 cell, and
// random mixtures from 10^-3 to 10^6): every stored average lies within half a float step of
// its texels' mean (summed here in long double; up to 2^-48 of the largest texel for the double
// sums of nine levels), and every stored error bound is at least the
// largest |texel - stored average| (exactly, in double), for both kinds of bound. Averages
// summed in floats level by level put the 2 x 2 cells' mean 0.15 at 0.15625.
TEST(Quadtree, AveragesOfTexelsThatCancelAreTheirMeans) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> exponent(-3, 6), unit(0, 1);
  for (int n : {2, 8, 64}) {
    const Grid cells = testing::cancelling_grid(n);
    Grid mixture(n, 3);
    for (float& t : mixture.texels)
      t = float((unit(rng) < 0.5 ? -1 : 1) * std::pow(10.0, exponent(rng)));
    for (const Grid* grid : std::array<const Grid*, 2>{&cells, &mixture})
      for (const auto bound : {ProjectionOptions::Bound::exact, ProjectionOptions::Bound::paper}) {
        const Quadtree tree = project(*grid, {.tolerance = 0, .bound = bound});
        const QuadtreeView view = tree.view();
        auto visit = [&](auto&& self, int node, int x0, int y0, int size) -> void {
          const int half = size / 2;
          for (int q = 0; q < 4; ++q) {
            const int qx = x0 + (q & 1) * half, qy = y0 + (q >> 1) * half;
            for (int c = 0; c < grid->channels; ++c) {
              const float v = view.value(node, 0, c, q);
              long double sum = 0;
              double largest = 0, deviation = 0;
              for (int y = qy; y < qy + half; ++y)
                for (int x = qx; x < qx + half; ++x) {
                  sum += grid->at(0, c, x, y);
                  largest = std::max(largest, double(std::abs(grid->at(0, c, x, y))));
                  deviation =
                      std::max(deviation, std::abs(double(grid->at(0, c, x, y)) - double(v)));
                }
              const double mean = double(sum / (double(half) * half));
              const double half_step =
                  0.5 * double(std::nextafter(std::abs(v), INFINITY) - std::abs(v));
              ASSERT_LE(std::abs(double(v) - mean), half_step + 0x1p-48 * largest)
                  << "n " << n << " node " << node << " quadrant " << q << ": " << v
                  << " against the mean " << mean;
              ASSERT_GE(double(view.error(node, c, q)), deviation)
                  << "n " << n << " node " << node << " quadrant " << q;
            }
            if (const int child = view.child(node, q)) self(self, child, qx, qy, half);
          }
        };
        visit(visit, 0, 0, 0, n);
      }
  }
}

TEST(Quadtree, ConstantFunctionIsASingleNode) {
  for (int n : {2, 32, 512}) {
    Grid g(n, 3);
    for (float& t : g.texels)
      t = 0.7f;
    const Quadtree tree = project(g, {.tolerance = 0});
    EXPECT_EQ(tree.node_count(), 1);
    EXPECT_FLOAT_EQ(integrate(tree.view(), 0, 2), 0.7f);
  }
  Grid black(64, 1);
  EXPECT_EQ(project(black).node_count(), 1);
}

TEST(Quadtree, AbsoluteAndRelativeToleranceAgreeWhenScaledByTheMean) {
  const Grid g = testing::test_functions(32, 1, 3)[1].grid;  // smooth
  const double mean = g.mean(0, 0);
  const Quadtree relative = project(g, {.tolerance = 0.2});
  const Quadtree absolute =
      project(g, {.tolerance = 0.2 * mean, .mode = ProjectionOptions::Mode::absolute});
  ASSERT_GT(relative.node_count(), 1);
  ASSERT_LT(relative.node_count(), 341);  // neither trivial nor complete
  EXPECT_EQ(relative.node_count(), absolute.node_count());
  // Scaling the function scales absolute tolerances' effect but not relative ones'.
  Grid scaled = g;
  for (float& t : scaled.texels)
    t *= 1000;
  EXPECT_EQ(project(scaled, {.tolerance = 0.2}).node_count(), relative.node_count());
  EXPECT_GT(project(scaled, {.tolerance = 0.2 * mean, .mode = ProjectionOptions::Mode::absolute})
                .node_count(),
            relative.node_count());
}

TEST(Quadtree, LooserToleranceNeverAddsNodes) {
  const Grid g = testing::test_functions(64, 3, 9)[1].grid;
  int previous = 1 << 30;
  for (double t : {0.0, 0.001, 0.01, 0.05, 0.1, 1.0, 100.0}) {
    const int nodes = project(g, {.tolerance = t}).node_count();
    EXPECT_LE(nodes, previous) << t;
    previous = nodes;
  }
  EXPECT_EQ(previous, 1);
}

TEST(Quadtree, MaxDepthLimitsLevels) {
  const Grid g = testing::random_grid(64, 1, 1);
  for (int depth = 1; depth <= 6; ++depth) {
    const Quadtree tree = project(g, {.tolerance = 0, .max_depth = depth});
    const auto histogram = depth_histogram(tree.view());
    EXPECT_EQ(int(histogram.size()), depth);
    EXPECT_EQ(histogram.back(), 1 << (2 * (depth - 1)));  // random data refines everywhere
    // Cut off above the tolerance, the stored bounds still cover every texel's deviation.
    int checked = 0;
    for_each_quadrant_deviation(tree.view(), g, [&](float deviation, float error, float v) {
      ASSERT_LE(deviation, error + 1e-6f * (v + deviation) + 1e-7f) << "depth " << depth;
      checked += deviation > 0;
    });
    EXPECT_GT(checked, 0) << "depth " << depth;
  }
}

TEST(Quadtree, ChildLinksPointForwardAndNodesAreReachableOnce) {
  for (const auto& [name, grid] : test_functions(128, 3, 2)) {
    const Quadtree tree = project(grid, {.tolerance = 0.02});
    const QuadtreeView v = tree.view();
    std::vector<int> parents(v.node_count(), 0);
    for (int node = 0; node < v.node_count(); ++node)
      for (int q = 0; q < 4; ++q)
        if (const int child = v.child(node, q)) {
          ASSERT_GT(child, node) << name;
          ASSERT_LT(child, v.node_count()) << name;
          ++parents[child];
        }
    EXPECT_EQ(parents[0], 0);
    for (int node = 1; node < v.node_count(); ++node)
      EXPECT_EQ(parents[node], 1) << name;
  }
}

TEST(Quadtree, EvaluateMatchesReconstruction) {
  const Grid g = testing::test_functions(32, 3, 4)[2].grid;
  const Quadtree tree = project(g, {.tolerance = 0.05});
  const Grid recon = reconstruct(tree.view());
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x)
      for (int c = 0; c < 3; ++c)
        EXPECT_EQ(evaluate(tree.view(), (x + 0.5) / 32, (y + 0.5) / 32, 0, c),
                  recon.at(0, c, x, y));
  EXPECT_EQ(evaluate(tree.view(), 1.0, 1.0), recon.at(0, 0, 31, 31));
}

TEST(Quadtree, ExtraGroupsRideAlongWithoutChangingTheCut) {
  Grid g(32, 3, 3);
  const Grid base = testing::test_functions(32, 3, 8)[1].grid;
  std::copy(base.texels.begin(), base.texels.end(), g.texels.begin());
  std::mt19937 rng(1);
  std::normal_distribution<float> noise;
  for (std::size_t i = base.texels.size(); i < g.texels.size(); ++i)
    g.texels[i] = noise(rng);
  const Quadtree with_groups = project(g, {.tolerance = 0.05});
  const Quadtree alone = project(base, {.tolerance = 0.05});
  ASSERT_EQ(with_groups.node_count(), alone.node_count());
  // Every group's leaves hold the exact average of that group over the leaf (in double).
  int leaves = 0;
  for_each_leaf(with_groups.view(), [&](int node, int q, int level, int x, int y) {
    const int size = 32 >> level;
    ++leaves;
    for (int group = 0; group < 3; ++group)
      for (int c = 0; c < 3; ++c) {
        double sum = 0, magnitude = 0;
        for (int ty = y * size; ty < (y + 1) * size; ++ty)
          for (int tx = x * size; tx < (x + 1) * size; ++tx) {
            sum += g.at(group, c, tx, ty);
            magnitude = std::max(magnitude, double(std::abs(g.at(group, c, tx, ty))));
          }
        ASSERT_NEAR(with_groups.view().value(node, group, c, q), sum / (size * size),
                    1e-6 * magnitude)
            << "group " << group << " channel " << c << " leaf at level " << level;
      }
  });
  EXPECT_GT(leaves, 4);
  for (int group = 1; group < 3; ++group)
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(integrate(with_groups.view(), group, c), g.mean(group, c), 1e-5);
}

// Cut on all groups: every group's texels lie within group_tolerance_scale times group 0's
// tolerance of the same channel, and the stored bounds of every group cover its deviations.
TEST(Quadtree, CuttingOnAllGroupsKeepsEveryGroupWithinItsTolerance) {
  const auto functions = testing::test_functions(64, 3, 9);
  Grid g(64, 3, 3);
  for (int group = 0; group < 3; ++group) {
    const Grid& source = functions[(group + 1) % functions.size()].grid;
    std::copy(source.texels.begin(), source.texels.end(),
              g.texels.begin() + std::ptrdiff_t(group) * std::ptrdiff_t(source.texels.size()));
  }
  for (const double scale : {1.0, 10.0}) {
    const ProjectionOptions options{
        .tolerance = 0.05, .cut_on_all_groups = true, .group_tolerance_scale = scale};
    const Quadtree tree = project(g, options);
    const QuadtreeView view = tree.view();
    ASSERT_EQ(view.shape().bounded_groups, 3);
    EXPECT_GT(tree.node_count(), project(g, {.tolerance = 0.05}).node_count()) << scale;
    const Grid recon = reconstruct(view);
    for (int group = 0; group < 3; ++group)
      for (int c = 0; c < 3; ++c) {
        const double allowed = (group == 0 ? 1 : scale) * 0.05 * std::abs(g.mean(0, c));
        for (int y = 0; y < 64; ++y)
          for (int x = 0; x < 64; ++x) {
            const double input = g.at(group, c, x, y);
            ASSERT_LE(std::abs(recon.at(group, c, x, y) - input),
                      allowed * (1 + 1e-6) + 1e-6 * std::abs(input))
                << "scale " << scale << " group " << group << " channel " << c;
          }
      }
    for_each_leaf(view, [&](int node, int q, int level, int x, int y) {
      const int size = 64 >> level;
      for (int group = 0; group < 3; ++group)
        for (int c = 0; c < 3; ++c) {
          const float v = view.value(node, group, c, q);
          float deviation = 0;
          for (int ty = y * size; ty < (y + 1) * size; ++ty)
            for (int tx = x * size; tx < (x + 1) * size; ++tx)
              deviation = std::max(deviation, std::abs(g.at(group, c, tx, ty) - v));
          ASSERT_LE(deviation, view.error(node, group, c, q) * (1 + 1e-6f) + 1e-6f * std::abs(v))
              << "group " << group << " channel " << c;
        }
    });
  }
}

TEST(Quadtree, RejectsInvalidInput) {
  EXPECT_THROW(project(Grid(3, 1)), std::invalid_argument);
  EXPECT_THROW(project(Grid(1024, 1)), std::invalid_argument);
  EXPECT_THROW(project(Grid(8, 2)), std::invalid_argument);
  Grid nan(8, 1);
  nan.at(0, 0, 3, 3) = std::nanf("");
  EXPECT_THROW(project(nan), std::invalid_argument);
  Grid inf(8, 1);
  inf.at(0, 0, 7, 0) = INFINITY;
  EXPECT_THROW(project(inf), std::invalid_argument);
  EXPECT_THROW(project(Grid(8, 1), {.tolerance = -1}), std::invalid_argument);
  EXPECT_THROW(project(Grid(8, 1), {.tolerance = NAN}), std::invalid_argument);
  EXPECT_THROW(project(Grid(8, 1), {.max_depth = 4}), std::invalid_argument);
}

}  // namespace
}  // namespace basis
