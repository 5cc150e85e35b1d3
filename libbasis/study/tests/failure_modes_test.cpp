// Where methods fail, asserted: spherical harmonics ring and go negative on sharp lobes while
// quadtrees never do; grazing outgoing directions, steps along the concentric map's diagonals,
// a sun smaller than a texel with HDR values of 1e5: every method's error is reported and the
// quadtree's stays within its certified bound and its documented accuracy.
#include <gtest/gtest.h>

#include <numbers>

#include "basis/brdf/table_lookup.h"
#include "basis/core/dense.h"
#include "basis/core/hemisphere.h"
#include "basis/core/projection.h"
#include "basis/study/comparison.h"
#include "basis/study/haar.h"
#include "basis/study/sh.h"
#include "support/brdf_reference.h"
#include "support/test_functions.h"

namespace basis {
namespace {

TEST(FailureModes, SphericalHarmonicsGoNegativeOnASharpLobeQuadtreesNever) {
  BrdfTableOptions o;
  o.wi_resolution = 128;
  const Grid lobe = tabulate_entry(Phong{{0, 0, 0}, {1, 1, 1}, 1000}, Vec3::UnitZ(), o);
  const int order = 16, count = sh_count(order);
  const auto transfer = sh_project(lobe, order, true);
  // Reconstruct f cos over the hemisphere and integrate its negative and positive parts.
  double negative = 0, positive = 0, most_negative = 0;
  std::vector<double> y(count);
  for (int j = 0; j < 256; ++j)
    for (int i = 0; i < 256; ++i) {
      const Vec3 w = square_to_cosine_hemisphere({(i + 0.5) / 256, (j + 0.5) / 256});
      sh_evaluate(order, w, y);
      double value = 0;
      for (int k = 0; k < count; ++k)
        value += transfer[k] * y[k];
      const double dw = std::numbers::pi / (256.0 * 256) / std::max(w.z(), 1e-6);
      (value < 0 ? negative : positive) += value * dw;
      most_negative = std::min(most_negative, value);
    }
  std::printf(
      "[  RINGING ] SH order 16 of Phong 1000: negative mass %.4f of positive %.4f, "
      "lowest value %.3f\n",
      negative, positive, most_negative);
  EXPECT_LT(negative, -0.25 * positive);  // SH rings and goes negative (measured -0.60)
  EXPECT_LT(most_negative, -1.0);         // (measured -2.4)
  for (double tolerance : {0.0, 0.05, 0.5}) {
    const Grid back = reconstruct(project(lobe, {.tolerance = tolerance}).view());
    EXPECT_GE(*std::min_element(back.texels.begin(), back.texels.end()), 0.0f) << tolerance;
  }
}

PackedTree constant_light() {
  Grid g(2, 1);
  for (float& t : g.texels)
    t = 1;
  return pack(project(g));
}

TEST(FailureModes, GrazingOutgoingDirections) {
  // Directional albedo at 80 and 88 degrees: the table (33 x 33, entries beyond the rim
  // evaluated 1 degree above the horizon) against quadrature; SH order 16 for comparison.
  BrdfTableOptions o;
  o.wi_resolution = 64;
  o.tilt_derivatives = false;
  auto grazing = [](double degrees) {
    const double t = degrees * std::numbers::pi / 180;
    return Vec3(std::sin(t) * 0.6, std::sin(t) * 0.8, std::cos(t));
  };
  o.only_for = {grazing(80), grazing(88)};  // the entries these lookups read (PartialTable.*)
  for (const auto& [name, brdf, tolerance_80, tolerance_88] :
       std::vector<std::tuple<std::string, Brdf, double, double>>{
           {"phong100", Phong{{0.5, 0.5, 0.5}, {0.4, 0.4, 0.4}, 100}, 0.005, 0.005},
           {"ggx0.2", Ggx{{0.1, 0.1, 0.1}, {0.9, 0.9, 0.9}, 0.2}, 0.005, 0.005}}) {
    const BrdfTable table = tabulate_brdf(brdf, o);
    for (const double degrees : {80.0, 88.0}) {
      const Vec3 wo = grazing(degrees);
      const double exact = testing::reference_albedo(brdf, wo, 1);
      const double quadtree = reflect(table.view(), constant_light().view(), wo).value[1];
      BrdfTableOptions slice;
      slice.wi_resolution = 128;
      Grid sky(128, 1);
      for (float& v : sky.texels)
        v = 1;
      const double sh = sh_dot(sh_project(tabulate_entry(brdf, wo, slice), 16, true), 1,
                               sh_project(sky, 16, false), 1, 16)[1];
      std::printf("[  GRAZING ] %s at %.0f deg: albedo %.4f; quadtree error %.4f, SH 16 %.4f\n",
                  name.c_str(), degrees, exact, std::abs(quadtree - exact) / exact,
                  std::abs(sh - exact) / exact);
      EXPECT_NEAR(quadtree, exact, (degrees < 85 ? tolerance_80 : tolerance_88) * exact)
          << name << " " << degrees;
      // SH 16 errs more than the table there (measured 0.16-0.33 % against 0.01-0.04 %).
      EXPECT_GT(std::abs(sh - exact), std::abs(quadtree - exact)) << name << " " << degrees;
    }
  }
}

// A light with a step along the concentric map's diagonal (not differentiable there), a sun
// of 1e5 inside one texel, and a glossy BRDF: every method against the full-resolution
// product; the quadtree within its certified bound.
TEST(FailureModes, DiagonalStepsAndASubTexelSunOfHdrValues) {
  const int n = 128;
  Grid light = testing::sample_grid(
      n, 3, [](double u, double v, int c) { return (u > v ? 2.0 : 0.2) + 0.1 * c; });
  for (int c = 0; c < 3; ++c)
    light.at(0, c, 77, 40) = 1e5f;  // a sun much smaller than the map
  BrdfTableOptions o;
  o.wi_resolution = n;
  const Vec3 wo = Vec3(0.3, 0.2, 0.93).normalized();
  const Grid brdf = tabulate_entry(Phong{{0.3, 0.3, 0.3}, {0.6, 0.6, 0.6}, 200}, wo, o);
  const Rgb exact = dense_convolve_naive(brdf, light);  // the full-resolution product
  for (double tolerance : {0.01, 0.05, 0.3}) {
    const Quadtree a = project(brdf, {.tolerance = tolerance});
    const Quadtree b = project(light, {.tolerance = tolerance});
    const Convolution q = convolve(a.view(), b.view());
    for (int c = 0; c < 3; ++c)
      EXPECT_LE(std::abs(q.value[c] - exact[c]), q.bound[c] + 1e-5 * exact[c]) << tolerance;
    std::printf("[  STEPS   ] quadtree %.2f: error %.5f (bound %.5f), %d + %d nodes\n", tolerance,
                std::abs(q.value[1] - exact[1]) / exact[1], q.bound[1] / exact[1], a.node_count(),
                b.node_count());
  }
  const auto sh = sh_dot(sh_project(brdf, 16, true), 1, sh_project(light, 16, false), 3, 16);
  const auto haar = haar_dot(haar_project(brdf, 1024), haar_project(light, 1024));
  const Rgb dense32 = dense_convolve_naive(downsample(brdf, 32), downsample(light, 32));
  const double sh_error = std::abs(sh[1] / std::numbers::pi - exact[1]) / exact[1],
               haar_error = std::abs(haar[1] - exact[1]) / exact[1],
               dense32_error = std::abs(dense32[1] - exact[1]) / exact[1];
  std::printf("[  STEPS   ] SH 16 error %.4f, Haar 1024 %.4f, dense 32 %.4f\n", sh_error,
              haar_error, dense32_error);
  // SH 16 fails outright (measured 199 %); Haar with 1024 coefficients and a 32^2 grid do not
  // (measured 0.00 % and 0.7 %).
  EXPECT_GT(sh_error, 0.5);
  EXPECT_LT(haar_error, 1e-3);
  EXPECT_LT(dense32_error, 0.02);
}

}  // namespace
}  // namespace basis
