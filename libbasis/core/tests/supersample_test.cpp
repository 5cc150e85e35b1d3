// Texel averages by adaptive supersampling against their closed forms, with and without the
// quadrature graded towards the square's edge.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "basis/core/supersample.h"

namespace basis {
namespace {

// The average of 1 / sqrt(t) over [a, b].
double inverse_sqrt_average(double a, double b) {
  return 2 * (std::sqrt(b) - std::sqrt(a)) / (b - a);
}

// f(u, v) = 1 / sqrt(u) + 1 / sqrt(1 - v) + 2: singular on two edges of the square, as f of a
// BRDF whose f cos stays finite at the horizon is over the cosine-weighted disk. The largest
// relative error of the texel averages at resolution n against the closed form.
double largest_error_at_the_edges(int n, bool graded) {
  Grid grid(n, 1, 1);
  SupersampleOptions options;
  options.graded_boundary = graded;
  average_over_texels(
      grid,
      [](double u, double v, double* out, bool) {
        out[0] = 1 / std::sqrt(u) + 1 / std::sqrt(1 - v) + 2;
      },
      options);
  double largest = 0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const double expected = inverse_sqrt_average(double(x) / n, double(x + 1) / n) +
                              inverse_sqrt_average(1 - double(y + 1) / n, 1 - double(y) / n) + 2;
      largest = std::max(largest, std::abs(grid.at(0, 0, x, y) - expected) / expected);
    }
  return largest;
}

TEST(Supersample, GradedEdgesIntegrateAnInverseSquareRootSingularity) {
  for (int n : {1, 2, 8, 32}) {
    const double graded = largest_error_at_the_edges(n, true);
    const double plain = largest_error_at_the_edges(n, false);
    std::printf("[  INFO    ] n %2d: largest relative error %.2e graded, %.2e plain\n", n, graded,
                plain);
    // Well within the quadrature's relative tolerance (1e-3 by default): 3.3e-4 measured.
    EXPECT_LT(graded, 5e-4) << n;
    // Without grading, the edge texels keep a share of the singularity's mass out of reach of
    // the finest cells: the same averages err by far more.
    EXPECT_GT(plain, 5e-3) << n;
  }
}

// Grading is a change of variables: a smooth function's texel averages are unchanged, in every
// channel and group, within 1e-4 (a wrong Jacobian would miss by a good fraction of the value).
TEST(Supersample, GradedEdgesKeepSmoothAveragesInEveryGroup) {
  for (int n : {1, 4, 16}) {
    Grid grid(n, 2, 2);
    SupersampleOptions options;
    options.graded_boundary = true;
    options.relative_tolerance = 1e-6;
    options.max_depth = 8;
    options.checked_groups = 2;
    average_over_texels(
        grid,
        [](double u, double v, double* out, bool all_groups) {
          out[0] = u * u * v + 3;
          out[1] = std::cos(u + 2 * v);
          if (!all_groups) return;
          out[2] = u - v;
          out[3] = v * v * v;
        },
        options);
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const double u0 = double(x) / n, u1 = double(x + 1) / n;
        const double v0 = double(y) / n, v1 = double(y + 1) / n;
        const double area = (u1 - u0) * (v1 - v0);
        const double expected[4] = {
            (u1 * u1 * u1 - u0 * u0 * u0) / 3 * (v1 * v1 - v0 * v0) / 2 / area + 3,
            // The integral of cos(u + 2 v) is -(cos(u + 2 v)) / 2 differenced twice.
            -(std::cos(u1 + 2 * v1) - std::cos(u0 + 2 * v1) - std::cos(u1 + 2 * v0) +
              std::cos(u0 + 2 * v0)) /
                2 / area,
            (u0 + u1) / 2 - (v0 + v1) / 2, (v1 * v1 * v1 * v1 - v0 * v0 * v0 * v0) / 4 / (v1 - v0)};
        for (int k = 0; k < 4; ++k)
          EXPECT_NEAR(grid.at(k / 2, k % 2, x, y), expected[k], 1e-4)
              << n << " texel " << x << "," << y << " value " << k;
      }
  }
}

}  // namespace
}  // namespace basis
