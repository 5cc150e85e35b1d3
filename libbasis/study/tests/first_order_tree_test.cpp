// First-order trees: their products hold within the certified bound of the plain texel loop's
// integral (dense_convolve_naive, a second implementation) at every accuracy, with and without
// their slopes, are exact up to rounding at accuracy 0, keep the bound within about the
// accuracy asked for, and stop earlier than means alone on smooth functions; bad arguments are
// refused.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "basis/core/dense.h"
#include "basis/study/first_order_tree.h"
#include "support/test_functions.h"

namespace basis {
namespace {

using testing::test_functions;

// A smooth lobe (a Gaussian of width `width` about (cu, cv)) on a floor, texel centres sampled.
Grid lobe(int n, double cu, double cv, double width, double floor) {
  Grid grid(n, 3);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const double u = (x + 0.5) / n, v = (y + 0.5) / n;
      const double r2 = (u - cu) * (u - cu) + (v - cv) * (v - cv);
      for (int c = 0; c < 3; ++c)
        grid.at(0, c, x, y) = float(floor + (1 + 0.3 * c) * std::exp(-r2 / (width * width)));
    }
  return grid;
}

TEST(FirstOrderTree, ProductsHoldWithinTheirBoundAtEveryAccuracy) {
  for (const int n : {2, 16, 64})
    for (const int channels_a : {1, 3})
      for (const auto& [name_a, grid_a] : test_functions(n, channels_a, 71))
        for (const auto& [name_b, grid_b] : test_functions(n, 3, 72)) {
          const FirstOrderTree a = first_order_tree(grid_a), b = first_order_tree(grid_b);
          const FirstOrderTree flat_a = without_slopes(a), flat_b = without_slopes(b);
          const CompactFirstOrderTree compact_b = compact(b);
          const Rgb exact = dense_convolve_naive(grid_a, grid_b);
          for (const double accuracy : {0.0, 0.001, 0.01, 0.1, 0.5})
            for (const std::string form : {"planes", "means", "compact"}) {
              const Convolution r =
                  form == "planes"  ? convolve_first_order(a, b, accuracy).convolution
                  : form == "means" ? convolve_first_order(flat_a, flat_b, accuracy).convolution
                                    : convolve_first_order(a, compact_b, accuracy).convolution;
              for (int c = 0; c < 3; ++c) {
                SCOPED_TRACE(name_a + " x " + name_b + " at " + std::to_string(n) + ", accuracy " +
                             std::to_string(accuracy) + ", " + form + ", channel " +
                             std::to_string(c));
                EXPECT_LE(std::abs(double(r.value[c]) - exact[c]), double(r.bound[c]));
                if (accuracy == 0) {  // exact but for rounding (halves': 2^-11)
                  EXPECT_LE(r.bound[c],
                            (form == "compact" ? 3e-3 : 1e-5) * std::abs(exact[c]) + 1e-30);
                }
                // The test functions are non-negative: the stops' bounds add up to at most the
                // accuracy times the value (and the estimate's share of it).
                if (exact[c] > 0) {
                  EXPECT_LE(r.bound[c], 1.5 * accuracy * exact[c] +
                                            (form == "compact" ? 3e-3 : 1e-5) * exact[c]);
                }
              }
            }
        }
}

TEST(FirstOrderTree, SmoothProductsStopEarlyAndStayAccurate) {
  const int n = 128;
  const Grid a = lobe(n, 0.45, 0.55, 0.12, 0.0), b = lobe(n, 0.6, 0.4, 0.3, 0.2);
  const FirstOrderTree ta = first_order_tree(a), tb = first_order_tree(b);
  const Rgb exact = dense_convolve_naive(a, b);
  // The lobe is refined down to its texels where it is not flat: a full descent meets
  // thousands of pairs.
  const FirstOrderConvolution full_descent = convolve_first_order(ta, tb, 0);
  EXPECT_GT(full_descent.pairs, 2000u);
  const Convolution full = full_descent.convolution;
  const FirstOrderConvolution planes = convolve_first_order(ta, tb, 0.01);
  const FirstOrderConvolution means =
      convolve_first_order(without_slopes(ta), without_slopes(tb), 0.01);
  // Planes stop levels earlier than means on smooth functions, for a smaller error.
  EXPECT_LT(4 * planes.pairs, means.pairs);
  const Convolution loose = planes.convolution;
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(full.value[c], exact[c], 1e-5 * exact[c]);
    EXPECT_LE(std::abs(double(loose.value[c]) - exact[c]), double(loose.bound[c]));
    EXPECT_LE(loose.bound[c], 0.015 * exact[c]);
    // Planes fit smooth lobes far better than means: the error is a small share of the bound.
    EXPECT_LE(std::abs(double(loose.value[c]) - exact[c]), 0.002 * exact[c]);
    EXPECT_LE(std::abs(double(means.convolution.value[c]) - exact[c]),
              double(means.convolution.bound[c]));
  }
}

TEST(FirstOrderTree, PlanesStopOnTheRootsQuadrantsOnLinearFunctions) {
  // f = 1 + u + 2 v and g = 3 - v, sampled at texel centres: the texel averages of planes. What
  // the planes leave out is the texels' steps, an RMS of about (1/n) / sqrt(12) per unit slope,
  // so any accuracy above that stops on the root's quadrants.
  const int n = 64;
  Grid f(n, 1), g(n, 3);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const double u = (x + 0.5) / n, v = (y + 0.5) / n;
      f.at(0, 0, x, y) = float(1 + u + 2 * v);
      for (int c = 0; c < 3; ++c)
        g.at(0, c, x, y) = float(3 - v);
    }
  const Rgb exact = dense_convolve_naive(f, g);
  const FirstOrderTree tf = first_order_tree(f), tg = first_order_tree(g);
  const FirstOrderConvolution planes = convolve_first_order(tf, tg, 1e-3);
  EXPECT_EQ(planes.pairs, 1u);  // the root's quadrants only
  const Convolution r = planes.convolution;
  for (int c = 0; c < 3; ++c) {
    EXPECT_LE(std::abs(double(r.value[c]) - exact[c]), double(r.bound[c]));
    EXPECT_LE(r.bound[c], 1e-3 * exact[c]);
  }
}

TEST(FirstOrderTree, RefusesWhatItCannotConvolve) {
  const Grid a = lobe(16, 0.5, 0.5, 0.2, 0), b = lobe(32, 0.5, 0.5, 0.2, 0);
  const FirstOrderTree ta = first_order_tree(a), tb = first_order_tree(b);
  EXPECT_THROW(convolve_first_order(ta, tb, 0), std::invalid_argument);
  EXPECT_THROW(convolve_first_order(ta, ta, -0.1), std::invalid_argument);
  EXPECT_THROW(convolve_first_order(ta, ta, std::numeric_limits<double>::quiet_NaN()),
               std::invalid_argument);
  Grid bad = a;
  bad.at(0, 1, 3, 4) = std::numeric_limits<float>::infinity();
  EXPECT_THROW(first_order_tree(bad), std::invalid_argument);
  EXPECT_THROW(first_order_tree(Grid(12, 3)), std::invalid_argument);
  EXPECT_THROW(first_order_tree(Grid(16, 2)), std::invalid_argument);
  // A control: the same grids of one resolution convolve.
  EXPECT_NO_THROW(convolve_first_order(ta, ta, 0));
  EXPECT_NO_THROW(first_order_tree(Grid(16, 1)));
}

}  // namespace
}  // namespace basis
