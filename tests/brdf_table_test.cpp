// BRDF tables against independent numeric integration: directional albedo of every model
// through the table's four-entry lookup, at and between entries, up to 80 degrees.
#include <gtest/gtest.h>

#include <numbers>

#include "basis/brdf_table.h"
#include "support/brdf_reference.h"

namespace basis {
namespace {

Vec3 outgoing(double theta_degrees, double phi_degrees) {
  const double t = theta_degrees * std::numbers::pi / 180, p = phi_degrees * std::numbers::pi / 180;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

Quadtree constant_radiance() {
  Grid g(2, 1);
  for (float& t : g.texels)
    t = 1;
  return project(g);
}

struct ModelCase {
  std::string name;
  Brdf brdf;
  double tolerance;  // relative
};

std::vector<ModelCase> models() {
  const Color grey{0.5, 0.5, 0.5}, none{0, 0, 0};
  return {
      {"lambert", Lambert{{0.8, 0.5, 0.2}}, 0.005},
      {"phong1", Phong{none, {0.9, 0.9, 0.9}, 1}, 0.01},
      {"phong10", Phong{grey, {0.4, 0.4, 0.4}, 10}, 0.01},
      {"phong100", Phong{grey, {0.4, 0.4, 0.4}, 100}, 0.01},
      {"phong1000", Phong{none, {0.9, 0.9, 0.9}, 1000}, 0.01},
      {"blinn_phong100", BlinnPhong{grey, {0.4, 0.4, 0.4}, 100}, 0.01},
      {"ward_a0p1", Ward{grey, {0.3, 0.3, 0.3}, 0.1}, 0.01},
      {"ggx_a1", Ggx{none, {0.9, 0.9, 0.9}, 1.0}, 0.01},
      {"ggx_a0p2", Ggx{grey, {0.04, 0.04, 0.04}, 0.2}, 0.01},
      {"ggx_a0p02", Ggx{none, {0.95, 0.64, 0.54}, 0.02}, 0.01},
  };
}

class TableAlbedo : public ::testing::TestWithParam<int> {};

TEST_P(TableAlbedo, MatchesNumericIntegration) {
  const ModelCase m = models()[GetParam()];
  BrdfTableOptions options;  // default outgoing grid (33 x 33)
  options.wi_resolution = 32;
  options.tilt_derivatives = false;
  const BrdfTable table = tabulate_brdf(m.brdf, options);
  const Quadtree light = constant_radiance();
  const int channels = channel_count(m.brdf);
  double worst = 0;
  // At 0, 30, 60, 80 degrees, on grid rows and between entries.
  for (const double theta : {0.0, 30.0, 60.0, 80.0})
    for (const double phi : {0.0, 17.0, 45.0, 200.0}) {
      const Vec3 wo = outgoing(theta, phi);
      const Convolution c = reflect(table.view(), light.view(), wo);
      for (int ch = 0; ch < channels; ++ch) {
        const double expected = testing::reference_albedo(m.brdf, wo, ch);
        EXPECT_NEAR(c.value[ch], expected, m.tolerance * expected)
            << m.name << " theta " << theta << " phi " << phi << " channel " << ch;
        worst = std::max(worst, std::abs(c.value[ch] - expected) / expected);
      }
    }
  std::printf("[  ALBEDO  ] %s: largest relative error %.4f\n", m.name.c_str(), worst);
}

INSTANTIATE_TEST_SUITE_P(Models, TableAlbedo, ::testing::Range(0, int(models().size())),
                         [](const auto& info) { return models()[info.param].name; });

}  // namespace
}  // namespace basis
