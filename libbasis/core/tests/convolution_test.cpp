// Convolution of quadtrees against dense references: exact for the trees, within the certified
// bound of the full-resolution product, SIMD equal to scalar, N-ary products, analytic lobes.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "basis/core/convolution.h"
#include "basis/core/dense.h"
#include "basis/core/hemisphere.h"
#include "basis/core/projection.h"
#include "support/test_functions.h"

namespace basis {
namespace {

using testing::test_functions;

// Dense integral of the product over [0,1]^2, written here independently of the library:
// grids are upsampled by replication to the finest resolution, channels broadcast; summed in
// long double (64 bits of mantissa), so that 2^40 + 2^-20 keeps its small part.
double dense_product(const std::vector<const Grid*>& grids, int group_of_first, int channel) {
  int n = 0;
  for (const Grid* g : grids)
    n = std::max(n, g->resolution);
  long double sum = 0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      double p = 1;
      for (std::size_t k = 0; k < grids.size(); ++k) {
        const Grid& g = *grids[k];
        const int scale = n / g.resolution;
        p *= g.at(k == 0 ? group_of_first : 0, g.channels == 1 ? 0 : channel, x / scale, y / scale);
      }
      sum += p;
    }
  return double(sum / (static_cast<long double>(n) * n));
}

// The grid of |texel|, for the magnitudes a float descent's sums may lose to rounding.
Grid absolute(const Grid& grid) {
  Grid out = grid;
  for (float& t : out.texels)
    t = std::abs(t);
  return out;
}

// The most a float descent's bound grows by rounding alone (convolution.h): its sums' share,
// (2 P + 8) 2^-24 of the magnitudes summed (P its pairs, at most the nodes of an n x n tree,
// (n^2 - 1) / 3), and the averages' own half float step on both sides of every pair (2^-24 each,
// and 2^-48 more of the largest texels); with Higham's 1 / (1 - n u) and the terms' own rounding,
// under 1.01 times (2 P + 13) 2^-24 of the magnitudes here.
double float_sums_cover(int n, double magnitude) {
  const double pairs = (double(n) * n - 1) / 3;
  return 1.01 * (2 * pairs + 13) * 0x1p-24 * magnitude;
}

// A SIMD bound against the scalar one (double sums): at least it, and above it by at most the
// float sums' cover.
void expect_simd_bound_covers_scalar(double simd, double scalar, int n, double magnitude,
                                     const std::string& what) {
  EXPECT_GE(simd, scalar * (1 - 1e-6)) << what;
  EXPECT_LE(simd, scalar * (1 + 1e-6) + float_sums_cover(n, magnitude)) << what;
}

double relative_gap(double a, double b) {
  return std::abs(a - b) / std::max({std::abs(a), std::abs(b), 1e-30});
}

struct Case {
  int res_a, res_b, channels_a, channels_b;
};

class ConvolutionProperties : public ::testing::TestWithParam<Case> {};

TEST_P(ConvolutionProperties, EqualsDenseProductOfReconstructions) {
  const Case k = GetParam();
  const auto fa = test_functions(k.res_a, k.channels_a, 1);
  const auto fb = test_functions(k.res_b, k.channels_b, 2);
  const int channels = std::max(k.channels_a, k.channels_b);
  for (double tolerance : {0.01, 0.05, 0.3})
    for (const auto& [name_a, grid_a] : fa)
      for (const auto& [name_b, grid_b] : fb) {
        const Quadtree a = project(grid_a, {.tolerance = tolerance});
        const Quadtree b = project(grid_b, {.tolerance = tolerance});
        const Grid ra = reconstruct(a.view()), rb = reconstruct(b.view());
        const Convolution conv = convolve(a.view(), b.view());
        const Rgb value = convolve_value(a.view(), b.view());
        for (int c = 0; c < channels; ++c) {
          const double expected = dense_product({&ra, &rb}, 0, c);
          EXPECT_LT(relative_gap(conv.value[c], expected), 2e-6)
              << name_a << " x " << name_b << " tol " << tolerance << " c " << c;
          EXPECT_EQ(value[c], conv.value[c]);
        }
      }
}

TEST_P(ConvolutionProperties, FullResolutionProductLiesWithinCertifiedBound) {
  const Case k = GetParam();
  const auto fa = test_functions(k.res_a, k.channels_a, 3);
  const auto fb = test_functions(k.res_b, k.channels_b, 4);
  const int channels = std::max(k.channels_a, k.channels_b);
  for (double tolerance : {0.01, 0.05, 0.3, 2.0})
    for (const auto& [name_a, grid_a] : fa)
      for (const auto& [name_b, grid_b] : fb) {
        const Quadtree a = project(grid_a, {.tolerance = tolerance});
        const Quadtree b = project(grid_b, {.tolerance = tolerance});
        const Convolution conv = convolve(a.view(), b.view());
        for (int c = 0; c < channels; ++c) {
          const double exact = dense_product({&grid_a, &grid_b}, 0, c);
          EXPECT_LE(std::abs(conv.value[c] - exact), conv.bound[c] + 2e-6 * std::abs(exact))
              << name_a << " x " << name_b << " tol " << tolerance << " c " << c << " bound "
              << conv.bound[c];
        }
      }
}

TEST_P(ConvolutionProperties, SimdAgreesWithScalar) {
  const Case k = GetParam();
  const auto fa = test_functions(k.res_a, k.channels_a, 5);
  const auto fb = test_functions(k.res_b, k.channels_b, 6);
  for (const auto& [name_a, grid_a] : fa)
    for (const auto& [name_b, grid_b] : fb) {
      const Quadtree a = project(grid_a, {.tolerance = 0.05});
      const Quadtree b = project(grid_b, {.tolerance = 0.05});
      const Convolution simd = convolve(a.view(), b.view());
      const Convolution scalar = convolve_scalar(a.view(), b.view());
      const Grid abs_a = absolute(reconstruct(a.view())), abs_b = absolute(reconstruct(b.view()));
      for (int c = 0; c < 3; ++c) {
        EXPECT_LT(relative_gap(simd.value[c], scalar.value[c]), 1e-6) << name_a << " x " << name_b;
        const int channel = std::min(c, std::max(k.channels_a, k.channels_b) - 1);
        expect_simd_bound_covers_scalar(simd.bound[c], scalar.bound[c], std::max(k.res_a, k.res_b),
                                        dense_product({&abs_a, &abs_b}, 0, channel),
                                        name_a + " x " + name_b);
      }
    }
}

// Functions of either sign: a quadrant's largest deviation times the other side's |mean|
// bounds the pair only where that side is >= 0 (the mean of |B| is |b| there, and can be far
// larger where B changes sign), so signed trees are certified by the product of the deviations.
// A checkerboard of +-1 (mean 0) against 1 + the same checkerboard, and smooth signed waves,
// cut coarse, against their dense product.
TEST(Convolution, SignedFunctionsStayWithinTheirBound) {
  const int n = 16;
  Grid checker(n, 1), shifted(n, 1), wave(n, 1), tilted_wave(n, 1);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const float sign = (x + y) % 2 == 0 ? 1.0f : -1.0f;
      checker.at(0, 0, x, y) = sign + 0.125f;
      shifted.at(0, 0, x, y) = 1.0f + sign;
      wave.at(0, 0, x, y) = float(std::sin(0.9 * x) * std::cos(0.7 * y));
      tilted_wave.at(0, 0, x, y) = float(0.2 + std::sin(0.9 * x + 0.3) * std::cos(0.7 * y));
    }
  const std::vector<const Grid*> grids = {&checker, &shifted, &wave, &tilted_wave};
  for (std::size_t i = 0; i < grids.size(); ++i)
    for (std::size_t j = 0; j < grids.size(); ++j)
      for (double tolerance : {0.25, 1.0, 2.5}) {
        const ProjectionOptions cut{.tolerance = tolerance,
                                    .mode = ProjectionOptions::Mode::absolute};
        const Quadtree a = project(*grids[i], cut), b = project(*grids[j], cut);
        const double exact = dense_product({grids[i], grids[j]}, 0, 0);
        for (const Convolution& conv :
             {convolve(a.view(), b.view()), convolve_scalar(a.view(), b.view())})
          EXPECT_LE(std::abs(conv.value[0] - exact), conv.bound[0] + 1e-6)
              << "grids " << i << ", " << j << " tolerance " << tolerance << ": value "
              << conv.value[0] << ", exact " << exact << ", bound " << conv.bound[0];
        const GroupConvolution groups = convolve_groups(a.view(), b.view());
        EXPECT_LE(std::abs(groups.value[0][0] - exact), groups.bound[0] + 1e-6)
            << "groups of grids " << i << ", " << j << " tolerance " << tolerance;
        // Packed with largest-deviation bounds, the same trees in halves.
        const PackedTree pa = pack(a, BoundKind::linf), pb = pack(b, BoundKind::linf);
        const Convolution packed = convolve(pa.view(), pb.view());
        EXPECT_LE(std::abs(packed.value[0] - exact), packed.bound[0] + 1e-6)
            << "packed grids " << i << ", " << j << " tolerance " << tolerance;
      }
  // Which trees take |value| in their bound: those made from texels that are all >= 0.
  EXPECT_FALSE(project(checker).non_negative);
  EXPECT_TRUE(project(shifted).non_negative);
  EXPECT_FALSE(project(wave).non_negative);
}

// Texels that cancel (+-10^6 beside 0.3 in every 2 x 2 cell, mean 0.15) against a constant:
// the descent stops at the constant's root, on the averages alone, so their rounding is all the
// error there is. Averages summed in floats put it at 0.15625, outside a bound of 1.5e-4 (packed)
// or 0 (float trees). At 2 x 2 the products are the texels themselves, +-2.5e5 beside 0.075, and
// float trees' sum of them cancels: their bound covers that too (the float sums' rounding).
TEST(Convolution, TexelsThatCancelKeepTheirBound) {
  for (int n : {2, 8, 64}) {
    const Grid cells = testing::cancelling_grid(n);
    Grid constant(n, 1);
    std::fill(constant.texels.begin(), constant.texels.end(), 1.0f);
    const double exact = dense_product({&cells, &constant}, 0, 0);
    const Quadtree a = project(cells, {.tolerance = 0}), b = project(constant, {.tolerance = 0});
    const Convolution unpacked = convolve(a.view(), b.view());
    EXPECT_LE(std::abs(unpacked.value[0] - exact), unpacked.bound[0])
        << "float trees at " << n << ": " << unpacked.value[0] << " +- " << unpacked.bound[0]
        << " against " << exact;
    for (const BoundKind kind : {BoundKind::l2, BoundKind::linf}) {
      const PackedTree pa = pack(a, kind), pb = pack(b, kind);
      for (const Convolution& packed :
           {convolve(pa.view(), pb.view()), convolve_scalar(pa.view(), pb.view())})
        EXPECT_LE(std::abs(packed.value[0] - exact), packed.bound[0])
            << "packed trees at " << n << ": " << packed.value[0] << " +- " << packed.bound[0]
            << " against " << exact;
    }
  }
}

// Float trees at the edges of their arithmetic, each against the dense product in double:
// averages whose double sums lose a texel (2^40 + 2^-20 - 2^40 averages to 0), averages
// rounded to the nearest float (1 + 2^-25 stored as 1), products below the floats (1e-23
// squared), and products beyond them that the integral is not (2e19 squared over 64 texels;
// two spikes of 4e20 that never meet, whose integral is 0). Each of the first four once printed
// a bound it broke, or threw.
TEST(Convolution, FloatTreesHoldTheirBoundAtTheEdgesOfTheirArithmetic) {
  struct Case {
    const char* name;
    Grid a, b;
  };
  std::vector<Case> cases;
  auto grid = [](int n, float fill) {
    Grid g(n, 1);
    std::fill(g.texels.begin(), g.texels.end(), fill);
    return g;
  };
  Case lost{"sums that lose a texel", grid(4, 0), grid(4, 1)};
  Case rounded{"averages rounded to floats", grid(4, 1), grid(4, 1)};
  for (int y = 0; y < 4; y += 2)
    for (int x = 0; x < 4; x += 2) {
      lost.a.at(0, 0, x, y) = 0x1p40f;
      lost.a.at(0, 0, x + 1, y) = 0x1p-20f;
      lost.a.at(0, 0, x, y + 1) = -0x1p40f;
      rounded.a.at(0, 0, x + 1, y + 1) = 1 + 0x1p-23f;
    }
  cases.push_back(lost);
  cases.push_back(rounded);
  cases.push_back({"products below the floats", grid(2, 1e-23f), grid(2, 1e-23f)});
  Case large{"products beyond the floats", grid(8, 0), grid(8, 0)};
  large.a.at(0, 0, 3, 5) = large.b.at(0, 0, 3, 5) = 2e19f;
  cases.push_back(large);
  Case apart{"spikes that never meet", grid(8, 0), grid(8, 0)};
  apart.a.at(0, 0, 1, 1) = apart.b.at(0, 0, 6, 6) = 4e20f;
  cases.push_back(apart);
  for (const Case& k : cases) {
    const Quadtree a = project(k.a, {.tolerance = 0}), b = project(k.b, {.tolerance = 0});
    const double exact = dense_product({&k.a, &k.b}, 0, 0);
    for (const Convolution& conv :
         {convolve(a.view(), b.view()), convolve_scalar(a.view(), b.view()),
          Convolution{convolve_groups(a.view(), b.view()).value[0],
                      convolve_groups(a.view(), b.view()).bound}})
      EXPECT_LE(std::abs(double(conv.value[0]) - exact), double(conv.bound[0]))
          << k.name << ": " << conv.value[0] << " +- " << conv.bound[0] << " against " << exact;
    // The value alone: the same descent's, to the bit (in double where floats overflow).
    EXPECT_EQ(convolve_value(a.view(), b.view())[0], convolve(a.view(), b.view()).value[0])
        << k.name;
  }
}

// Where a float descent's bound or another group's sums leave the floats but group 0's value
// does not, the value stays the descent's (the values alone give the same bits) and so does the
// bound of every entry point: a quadrant of +-1.5e38 (mean 0) beside small constants, cut at its
// root quadrants, whose bound overflows; and a second group of 1e30 against 1e10, whose
// products overflow.
TEST(Convolution, FloatTreesKeepTheirValueWhereOnlyTheirBoundOrOtherGroupsOverflow) {
  Grid spread(4, 1);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      const int q = (x >= 2 ? 1 : 0) + (y >= 2 ? 2 : 0);
      spread.at(0, 0, x, y) = q == 0   ? ((x + y) % 2 == 0 ? 1.5e38f : -1.5e38f)
                              : q == 1 ? 1.0f
                                       : 0x1p-12f;
    }
  const Quadtree a = project(spread, {.tolerance = 0, .max_depth = 1});
  const Convolution conv = convolve(a.view(), a.view());
  EXPECT_EQ(convolve_value(a.view(), a.view())[0], conv.value[0]);
  const double exact = dense_product({&spread, &spread}, 0, 0);
  EXPECT_FALSE(std::abs(double(conv.value[0]) - exact) > double(conv.bound[0]))
      << conv.value[0] << " +- " << conv.bound[0] << " against " << exact;

  Grid groups(2, 1, 2), light(2, 1);
  for (int k = 0; k < 4; ++k) {
    groups.texels[std::size_t(k)] = 1;
    groups.texels[std::size_t(4 + k)] = 1e30f;
    light.texels[std::size_t(k)] = 1e10f;
  }
  const Quadtree ga = project(groups, {.tolerance = 0}), gb = project(light, {.tolerance = 0});
  const GroupConvolution both = convolve_groups(ga.view(), gb.view());
  const Convolution first = convolve(ga.view(), gb.view());
  EXPECT_EQ(both.value[0], first.value);
  EXPECT_EQ(both.bound, first.bound);
  EXPECT_EQ(both.value[1][0], std::numeric_limits<float>::infinity());  // 1e40 is beyond floats
}

INSTANTIATE_TEST_SUITE_P(Shapes, ConvolutionProperties,
                         ::testing::Values(Case{32, 32, 1, 1}, Case{32, 32, 3, 3},
                                           Case{16, 16, 1, 3}, Case{64, 64, 3, 1},
                                           Case{8, 64, 3, 3}, Case{128, 32, 1, 3}),
                         [](const auto& info) {
                           const Case& k = info.param;
                           return std::to_string(k.res_a) + "x" + std::to_string(k.res_b) + "_" +
                                  std::to_string(k.channels_a) + "ch_" +
                                  std::to_string(k.channels_b) + "ch";
                         });

TEST(Convolution, ToleranceZeroReproducesTheDenseResult) {
  for (int n : {2, 16, 128}) {
    const auto fa = test_functions(n, 3, 7), fb = test_functions(n, 3, 8);
    for (const auto& [name_a, grid_a] : fa)
      for (const auto& [name_b, grid_b] : fb) {
        const Quadtree a = project(grid_a, {.tolerance = 0});
        const Quadtree b = project(grid_b, {.tolerance = 0});
        const Convolution conv = convolve(a.view(), b.view());
        const Rgb naive = dense_convolve_naive(grid_a, grid_b);
        const Grid abs_a = absolute(grid_a), abs_b = absolute(grid_b);
        for (int c = 0; c < 3; ++c) {
          EXPECT_LT(relative_gap(conv.value[c], naive[c]), 2e-6) << name_a << " x " << name_b;
          // Every texel is its own leaf: only rounding is left to bound.
          EXPECT_LE(conv.bound[c], float_sums_cover(n, dense_product({&abs_a, &abs_b}, 0, c)));
          EXPECT_LE(std::abs(conv.value[c] - naive[c]), conv.bound[c]) << name_a << " x " << name_b;
        }
      }
  }
}

TEST(Convolution, DenseSimdMatchesNaive) {
  for (int n : {8, 32, 256}) {
    const auto fa = test_functions(n, 3, 9), fb = test_functions(n, 1, 10);
    for (std::size_t i = 0; i < fa.size(); ++i) {
      const Rgb naive = dense_convolve_naive(fa[i].grid, fb[i].grid);
      const Rgb simd = dense_convolve_simd(fa[i].grid, fb[i].grid);
      for (int c = 0; c < 3; ++c) {
        EXPECT_LT(relative_gap(naive[c], simd[c]), 1e-5) << fa[i].name;
        EXPECT_LT(relative_gap(naive[c], dense_product({&fa[i].grid, &fb[i].grid}, 0, c)), 1e-7);
      }
    }
  }
}

TEST(Convolution, GroupsEqualSeparateDenseProductsInSimdAndScalar) {
  Grid a(32, 3, 3);
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> unit(-1, 2);
  for (float& t : a.texels)
    t = unit(rng);
  const auto fb = test_functions(32, 3, 12);
  for (const auto& [name, grid_b] : fb) {
    const Quadtree ta = project(a, {.tolerance = 0.1});
    const Quadtree tb = project(grid_b, {.tolerance = 0.1});
    const Grid ra = reconstruct(ta.view()), rb = reconstruct(tb.view());
    const GroupConvolution groups = convolve_groups(ta.view(), tb.view());
    for (int g = 0; g < 3; ++g)
      for (int c = 0; c < 3; ++c) {
        const double expected = dense_product({&ra, &rb}, g, c);
        EXPECT_NEAR(groups.value[g][c], expected, 2e-6 * std::abs(expected) + 1e-6) << name << g;
      }
    EXPECT_EQ(groups.value[0], convolve_value(ta.view(), tb.view()));
    EXPECT_EQ(groups.bound, convolve(ta.view(), tb.view()).bound);
    // The portable path agrees with the SIMD one, group by group.
    const GroupConvolution scalar = convolve_groups_scalar(ta.view(), tb.view());
    const Grid abs_a = absolute(ra), abs_b = absolute(rb);
    for (int c = 0; c < 3; ++c) {
      for (int g = 0; g < 3; ++g)
        EXPECT_NEAR(scalar.value[g][c], groups.value[g][c],
                    1e-6 * std::abs(groups.value[g][c]) + 1e-6)
            << name << g;
      expect_simd_bound_covers_scalar(groups.bound[c], scalar.bound[c], 32,
                                      dense_product({&abs_a, &abs_b}, 0, c), name);
    }
  }
}

TEST(Convolution, ProductOfThreeEqualsDenseTripleProduct) {
  const auto brdf = test_functions(32, 1, 13);
  const auto radiance = test_functions(64, 3, 14);
  const auto visibility = test_functions(16, 1, 15);
  for (std::size_t i = 0; i < brdf.size(); ++i)
    for (std::size_t j = 0; j < radiance.size(); ++j) {
      const Quadtree a = project(brdf[i].grid, {.tolerance = 0.05});
      const Quadtree b = project(radiance[j].grid, {.tolerance = 0.05});
      const Quadtree v = project(visibility[(i + j) % visibility.size()].grid, {.tolerance = 0.05});
      const Grid ra = reconstruct(a.view()), rb = reconstruct(b.view()), rv = reconstruct(v.view());
      const QuadtreeView factors[] = {a.view(), b.view(), v.view()};
      const Rgb product = convolve_product(factors);
      for (int c = 0; c < 3; ++c) {
        const double expected = dense_product({&ra, &rb, &rv}, 0, c);
        EXPECT_LT(relative_gap(product[c], expected), 1e-6) << brdf[i].name << radiance[j].name;
      }
      // Two factors reduce to the ordinary convolution.
      const QuadtreeView pair[] = {a.view(), b.view()};
      const Rgb two = convolve_product(pair);
      const Rgb conv = convolve_value(a.view(), b.view());
      for (int c = 0; c < 3; ++c)
        EXPECT_LT(relative_gap(two[c], conv[c]), 1e-6);
    }
}

TEST(Convolution, RejectsIncompatibleChannels) {
  Grid two(8, 3);
  const Quadtree a = project(two);
  Grid mono(8, 1);
  const Quadtree b = project(mono);
  EXPECT_NO_THROW(convolve(a.view(), b.view()));
  EXPECT_THROW(convolve_product(std::span<const QuadtreeView>()), std::invalid_argument);
  EXPECT_THROW(dense_convolve_naive(Grid(8, 1), Grid(16, 1)), std::invalid_argument);
}

// A normalised Phong lobe (n + 2) / (2 pi) cos^n(theta) around the normal reflects all of a
// constant unit radiance: pi * integral over the square of f = 1. Point-sampled texels converge
// as the resolution grows; supersampled texel averages are right at every resolution.
TEST(PhongLobe, AlbedoConvergesWithResolution) {
  for (int exponent : {10, 100, 1000}) {
    const double norm = (exponent + 2) / (2 * std::numbers::pi);
    auto lobe = [&](double u, double v) {
      return norm * std::pow(square_to_cosine_hemisphere({u, v}).z(), exponent);
    };
    Grid constant(2, 1);
    for (float& t : constant.texels)
      t = 1;
    const Quadtree light = project(constant);
    double previous_error = 1e9;
    for (int n : {32, 64, 128, 256, 512}) {
      const Grid point =
          testing::sample_grid(n, 1, [&](double u, double v, int) { return lobe(u, v); });
      const double albedo =
          std::numbers::pi * convolve(project(point).view(), light.view()).value[0];
      const double error = std::abs(albedo - 1);
      EXPECT_LE(error, previous_error * 1.05 + 1e-4) << exponent << " at " << n;
      previous_error = error;
      if (n == 512) {
        EXPECT_LT(error, 5e-3) << exponent;
      }

      const int ss = n <= 64 ? 16 : 4;
      Grid averaged(n, 1);
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          double sum = 0;
          for (int j = 0; j < ss; ++j)
            for (int i = 0; i < ss; ++i)
              sum += lobe((x + (i + 0.5) / ss) / n, (y + (j + 0.5) / ss) / n);
          averaged.at(0, 0, x, y) = float(sum / (ss * ss));
        }
      const double averaged_albedo =
          std::numbers::pi * convolve(project(averaged).view(), light.view()).value[0];
      EXPECT_NEAR(averaged_albedo, 1, exponent == 1000 && n == 32 ? 2e-2 : 3e-3)
          << exponent << " at " << n;
    }
  }
}

}  // namespace
}  // namespace basis
