// The baselines qtbench compares with: real spherical harmonics (orthonormality, convergence of
// the dot product, exact rotation) and Haar wavelets (exact when all coefficients are kept).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "basis/core/dense.h"
#include "basis/core/gauss_legendre.h"
#include "basis/study/comparison.h"
#include "basis/study/haar.h"
#include "basis/study/sh.h"
#include "support/brdf_reference.h"
#include "support/test_functions.h"

namespace basis {
namespace {

// Integrals over the sphere of the products of `values(w)` (a vector) by Gauss-Legendre in
// z (16 points on each of 14 graded intervals) and 64 azimuths, in one pass: the Gram matrix
// sum over quadrature points of weight * values * values^T.
template <typename F>
std::vector<double> sphere_gram(int count, F values) {
  std::vector<double> gram(std::size_t(count) * count, 0.0);
  std::vector<double> v(count);
  const auto& rule = testing::gauss_legendre_16();
  const double knots[] = {0, 0.1, 0.3, 0.6, 1.0, 1.4, 1.8, 2.2, 2.6, std::numbers::pi};
  for (std::size_t k = 0; k + 1 < std::size(knots); ++k)
    for (const auto& [x, weight] : rule) {
      const double theta = knots[k] + (knots[k + 1] - knots[k]) * (x + 1) / 2;
      const double ring = weight * (knots[k + 1] - knots[k]) / 2 * std::sin(theta);
      for (int j = 0; j < 64; ++j) {
        const double phi = 2 * std::numbers::pi * (j + 0.5) / 64;
        values(
            Vec3(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)),
            v);
        const double w = ring * 2 * std::numbers::pi / 64;
        for (int a = 0; a < count; ++a)
          for (int b = 0; b < count; ++b)
            gram[std::size_t(a) * count + b] += w * v[a] * v[b];
      }
    }
  return gram;
}

// The quadrature under the SH rotation and the reference integrals: n nodes integrate x^k over
// [-1, 1] exactly for k <= 2n - 1 (2 / (k + 1) for even k, 0 for odd), and not for k = 2n.
TEST(GaussLegendre, IsExactUpToDegreeTwoNMinusOne) {
  for (int n = 1; n <= 16; ++n) {
    const std::vector<QuadratureNode> rule = gauss_legendre(n);
    ASSERT_EQ(rule.size(), std::size_t(n));
    for (int k = 0; k <= 2 * n; ++k) {
      double sum = 0;
      for (const auto& [x, weight] : rule)
        sum += weight * std::pow(x, k);
      const double exact = k % 2 ? 0.0 : 2.0 / (k + 1);
      if (k < 2 * n) {
        EXPECT_NEAR(sum, exact, 1e-13) << "n " << n << " degree " << k;
      } else if (n <= 8) {
        EXPECT_GT(std::abs(sum - exact), 1e-6) << "n " << n << " degree " << k;
      }
    }
  }
}

TEST(SphericalHarmonics, AreOrthonormal) {
  const int order = 8, count = sh_count(order);
  const auto gram =
      sphere_gram(count, [&](const Vec3& w, std::vector<double>& v) { sh_evaluate(order, w, v); });
  for (int a = 0; a < count; ++a)
    for (int b = 0; b < count; ++b)
      EXPECT_NEAR(gram[std::size_t(a) * count + b], a == b ? 1.0 : 0.0, 1e-9) << a << " " << b;
}

TEST(SphericalHarmonics, DotProductConvergesToTheHemisphereIntegral) {
  // A white Lambert transfer (cos / pi over the upper hemisphere) against a unit sky gives 1.
  Grid lambert(128, 1), sky(128, 1);
  for (float& t : lambert.texels)
    t = float(1 / std::numbers::pi);
  for (float& t : sky.texels)
    t = 1;
  double previous = 1;
  for (int order : {2, 4, 8, 16}) {
    const auto transfer = sh_project(lambert, order, true);
    const auto radiance = sh_project(sky, order, false);
    const double error = std::abs(sh_dot(transfer, 1, radiance, 1, order)[0] - 1);
    EXPECT_LT(error, previous + 1e-9) << order;
    previous = error;
  }
  EXPECT_LT(previous, 0.02);
}

TEST(SphericalHarmonics, RotationMatchesProjectingTheRotatedFunction) {
  const int order = 8, count = sh_count(order);
  const Eigen::Matrix3d r =
      Eigen::AngleAxisd(0.7, Vec3(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  const Vec3 a(0.4, 0.2, -0.9);
  auto f = [&](const Vec3& w) { return std::exp(w.dot(a)) + w.x() * w.y(); };
  // Coefficients by quadrature: the last row of the Gram matrix of (Y_0 .. Y_n, g).
  auto project_sphere = [&](auto g) {
    const auto gram = sphere_gram(count + 1, [&](const Vec3& w, std::vector<double>& v) {
      sh_evaluate(order, w, std::span<double>(v.data(), count));
      v[count] = g(w);
    });
    return std::vector<double>(gram.begin() + std::ptrdiff_t(count) * (count + 1),
                               gram.begin() + std::ptrdiff_t(count) * (count + 1) + count);
  };
  const std::vector<double> original = project_sphere(f);
  const std::vector<double> expected =
      project_sphere([&](const Vec3& w) { return f(r.transpose() * w); });
  const std::vector<double> m = sh_rotation(order, r);
  const std::vector<double> rotated = sh_rotate(original, 1, order, m);
  for (int i = 0; i < count; ++i)
    EXPECT_NEAR(rotated[i], expected[i], 1e-6) << i;
  // The matrix is orthogonal.
  for (int i = 0; i < count; ++i)
    for (int j = 0; j < count; ++j) {
      double dot = 0;
      for (int k = 0; k < count; ++k)
        dot += m[i * count + k] * m[j * count + k];
      EXPECT_NEAR(dot, i == j ? 1 : 0, 1e-9);
    }
}

TEST(Haar, KeepingEverythingIsExactAndFewerCoefficientsConverge) {
  const auto fa = testing::test_functions(32, 3, 21), fb = testing::test_functions(32, 1, 22);
  for (std::size_t i = 0; i < fa.size(); ++i) {
    const HaarApproximation a = haar_project(fa[i].grid, 1 << 20),
                            b = haar_project(fb[i].grid, 1 << 20);
    const auto exact = dense_convolve_naive(fa[i].grid, fb[i].grid);
    const auto dot = haar_dot(a, b);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(dot[c], exact[c], 1e-5 * std::abs(exact[c]) + 1e-9);
    const Grid back = haar_reconstruct(a);
    for (std::size_t t = 0; t < back.texels.size(); ++t)
      ASSERT_NEAR(back.texels[t], fa[i].grid.texels[t],
                  1e-3 * std::abs(fa[i].grid.texels[t]) + 1e-4);
    EXPECT_EQ(a.bytes(), 3u * 32 * 32 * 8);
  }
  // Non-linear approximation: the error of the reconstruction shrinks as K grows.
  const Grid smooth = testing::test_functions(64, 1, 3)[1].grid;
  double previous = 1e30;
  for (std::size_t k : {4, 16, 64, 256, 1024}) {
    const Grid back = haar_reconstruct(haar_project(smooth, k));
    double error = 0;
    for (std::size_t t = 0; t < back.texels.size(); ++t)
      error += std::pow(back.texels[t] - smooth.texels[t], 2);
    EXPECT_LT(error, previous);
    previous = error;
  }
}

TEST(Comparison, DownsamplingKeepsTheIntegral) {
  const Grid g = testing::test_functions(64, 3, 4)[5].grid;  // the spike
  for (int n : {32, 8, 2}) {
    const Grid d = downsample(g, n);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(d.mean(0, c), g.mean(0, c), 1e-4 * g.mean(0, c));
  }
}

}  // namespace
}  // namespace basis
