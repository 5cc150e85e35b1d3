// BRDF tables against independent numeric integration: directional albedo of every model
// through the table's four-entry lookup, at and between entries, up to 80 degrees.
#include <gtest/gtest.h>

#include <numbers>
#include <vector>

#include "basis/brdf/table_lookup.h"
#include "basis/core/projection.h"
#include "support/brdf_reference.h"

namespace basis {
namespace {

Vec3 outgoing(double theta_degrees, double phi_degrees) {
  const double t = theta_degrees * std::numbers::pi / 180, p = phi_degrees * std::numbers::pi / 180;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

PackedTree constant_radiance() {
  Grid g(2, 1);
  for (float& t : g.texels)
    t = 1;
  return pack(project(g));
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
  // At 0, 30, 60, 80 degrees, on grid rows and between entries.
  std::vector<Vec3> directions;
  for (const double theta : {0.0, 30.0, 60.0, 80.0})
    for (const double phi : {0.0, 17.0, 45.0, 200.0})
      directions.push_back(outgoing(theta, phi));
  BrdfTableOptions options;  // default outgoing grid (33 x 33)
  options.wi_resolution = 32;
  options.tilt_derivatives = false;
  options.only_for = directions;  // the entries these lookups read (PartialTable.*)
  const BrdfTable table = tabulate_brdf(m.brdf, options);
  const PackedTree light = constant_radiance();
  const int channels = channel_count(m.brdf);
  double worst = 0;
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

// A partial table (only_for) holds the full table's entries, bit for bit, where lookups at its
// directions read, and zero trees of the same shape elsewhere.
TEST(PartialTable, MatchesTheFullTableWhereItsDirectionsRead) {
  const Brdf brdf = Phong{{0.3, 0.2, 0.1}, {0.5, 0.5, 0.5}, 40};
  BrdfTableOptions options;
  options.wo_resolution = 9;
  options.wi_resolution = 16;
  const BrdfTable full = tabulate_brdf(brdf, options);
  const std::vector<Vec3> directions = {outgoing(0, 0), outgoing(35, 70), outgoing(75, 200)};
  options.only_for = directions;
  const BrdfTable partial = tabulate_brdf(brdf, options);
  ASSERT_EQ(partial.trees.size(), full.trees.size());
  ASSERT_EQ(partial.tilt.size(), full.tilt.size());
  const PackedTree light = constant_radiance();
  std::vector<char> read(std::size_t(9 * 9), 0);
  for (const Vec3& wo : directions) {
    const Convolution a = reflect(full.view(), light.view(), wo);
    const Convolution b = reflect(partial.view(), light.view(), wo);
    EXPECT_EQ(a.value, b.value);
    EXPECT_EQ(a.bound, b.bound);
    for (const TableTap& tap : table_taps(9, wo))
      read[std::size_t(tap.j) * 9 + tap.i] = 1;
  }
  int zero = 0;
  for (std::size_t k = 0; k < read.size(); ++k) {
    if (read[k]) continue;
    EXPECT_EQ(partial.trees.view().tree(k).node_count(), 1) << k;
    EXPECT_EQ(integrate(partial.trees.view().tree(k), 0, 0), 0.0) << k;
    ++zero;
  }
  EXPECT_GT(zero, 60);  // most of the 81 entries were never tabulated
}

INSTANTIATE_TEST_SUITE_P(Models, TableAlbedo, ::testing::Range(0, int(models().size())),
                         [](const auto& info) { return models()[info.param].name; });

}  // namespace
}  // namespace basis
