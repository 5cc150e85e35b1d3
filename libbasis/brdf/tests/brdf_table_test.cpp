// BRDF tables against independent numeric integration: directional albedo of every model
// through the table's lookup, at and between entries, up to 80 degrees; partial and symmetric
// tabulation against tabulating every entry; the Hermite weights against polynomials they must
// reproduce; the derivatives over wo against the closed form of Phong's, integrated over each
// texel (a midpoint rule of the test's own); the
// lobe width against a closed form; entries folded for a batch of lookups against their own.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "basis/brdf/table_lookup.h"
#include "basis/core/hemisphere.h"
#include "basis/core/parabolic.h"
#include "basis/core/projection.h"
#include "support/brdf_reference.h"
#include "support/test_functions.h"

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
      {"lambert", Lambert{{0.8, 0.5, 0.2}}, 0.001},
      {"phong1", Phong{none, {0.9, 0.9, 0.9}, 1}, 0.001},
      {"phong10", Phong{grey, {0.4, 0.4, 0.4}, 10}, 0.001},
      {"phong100", Phong{grey, {0.4, 0.4, 0.4}, 100}, 0.001},
      {"phong1000", Phong{none, {0.9, 0.9, 0.9}, 1000}, 0.001},
      {"blinn_phong100", BlinnPhong{grey, {0.4, 0.4, 0.4}, 100}, 0.001},
      {"ward_a0p1", Ward{grey, {0.3, 0.3, 0.3}, 0.1}, 0.001},
      {"ggx_a1", Ggx{none, {0.9, 0.9, 0.9}, 1.0}, 0.001},
      {"ggx_a0p2", Ggx{grey, {0.04, 0.04, 0.04}, 0.2}, 0.001},
      {"ggx_a0p02", Ggx{none, {0.95, 0.64, 0.54}, 0.02}, 0.001},
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
      // The same entries found and folded beforehand, as a batch of lookups at wo reads them.
      const Convolution folded = reflect(
          table.view(), entries_at(table.view(), wo, WoInterpolation::hermite), light.view());
      for (int ch = 0; ch < channels; ++ch) {
        const double expected = testing::reference_albedo(m.brdf, wo, ch);
        EXPECT_NEAR(c.value[ch], expected, m.tolerance * expected)
            << m.name << " theta " << theta << " phi " << phi << " channel " << ch;
        EXPECT_NEAR(folded.value[ch], expected, m.tolerance * expected)
            << m.name << " folded, theta " << theta << " phi " << phi << " channel " << ch;
        worst = std::max({worst, std::abs(c.value[ch] - expected) / expected,
                          std::abs(folded.value[ch] - expected) / expected});
      }
    }
  std::printf("[  ALBEDO  ] %s: largest relative error %.4f\n", m.name.c_str(), worst);
}

// What table_resolution_warnings says of coarse options, and that it is so: a Phong 10^4 lobe
// tabulated at the normal over 2 x 2 texels is lost (its directional albedo is 1 by the
// normalisation, here under half of it), over 128 x 128 it is not; an outgoing grid coarser
// than the lobe needs is named; Lambert, and the defaults, draw no warning.
TEST(TableResolution, WarnsWhereTexelsMissTheLobeOrEntriesAreTooFarApart) {
  const Brdf sharp = Phong{{0, 0, 0}, {1, 1, 1}, 1e4};
  BrdfTableOptions options;
  options.wo_resolution = default_wo_resolution(sharp);
  for (const int n : {2, 128}) {
    options.wi_resolution = n;
    const Grid entry = tabulate_entry(sharp, Vec3::UnitZ(), options);
    // f cos integrated over the hemisphere: pi times f's mean over the cosine-weighted square.
    const double albedo = std::numbers::pi * entry.mean(0, 0);
    const auto warnings = table_resolution_warnings(sharp, options);
    if (n == 2) {
      EXPECT_LT(albedo, 0.5);
      ASSERT_EQ(warnings.size(), 1u);
      EXPECT_NE(warnings[0].find("texel averages may miss it"), std::string::npos) << warnings[0];
    } else {
      EXPECT_NEAR(albedo, 1, 0.01);
      EXPECT_TRUE(warnings.empty()) << warnings.front();
    }
  }
  const Brdf broad = Phong{{0, 0, 0}, {1, 1, 1}, 1};
  options.wi_resolution = 32;
  options.wo_resolution = 4;
  const auto coarse = table_resolution_warnings(broad, options);
  ASSERT_EQ(coarse.size(), 1u);
  EXPECT_NE(coarse[0].find("coarser than this lobe"), std::string::npos) << coarse[0];
  options.wo_resolution = default_wo_resolution(broad);
  EXPECT_TRUE(table_resolution_warnings(broad, options).empty());
  options.wo_resolution = 2;
  EXPECT_TRUE(table_resolution_warnings(Lambert{}, options).empty());
  options.wo_resolution = 129;
  options.wi_resolution = 128;
  EXPECT_TRUE(table_resolution_warnings(sharp, options).empty());
}

// Lookups at one wo with the entries folded (entries_at) give the entries' own lookups under a
// light with a bright spot and edges: the same value up to the folded sum's halves, and a bound
// at most theirs up to the folded codes' rounding up. Folded only where more than one entry, or
// one entry's derivatives, is read.
TEST(FoldedEntries, GiveTheEntriesOwnLookups) {
  if (!folding_available())
    GTEST_SKIP() << "this build does not fold (no SSE4.1 and F16C): folded lookups are the "
                    "entries' own, and the test would compare them with themselves";
  BrdfTableOptions options;
  options.wo_resolution = 9;
  options.wi_resolution = 32;
  options.tilt_derivatives = false;
  const BrdfTable table = tabulate_brdf(Ggx{{0.1, 0.1, 0.1}, {0.9, 0.6, 0.5}, 0.2}, options);
  const Grid sky = testing::sample_grid(64, 3, [](double u, double v, int c) {
    return (u > 0.6 ? 2.0 : 0.3) + 0.2 * c +
           400 * std::exp(-900 * ((u - 0.4) * (u - 0.4) + (v - 0.55) * (v - 0.55)));
  });
  const PackedTree light = pack_exact_texels(project(sky, {.tolerance = 0.05}));
  int folded_count = 0;
  for (const Vec3& wo :
       {outgoing(0, 0), outgoing(30, 0), outgoing(33, 17), outgoing(60, 200), outgoing(80, 45)}) {
    const EntriesAtWo entries = entries_at(table.view(), wo, WoInterpolation::hermite);
    int read = 0;
    bool derivatives = false;
    for (const TableTap& tap : entries.taps) {
      read += tap.reads_anything();
      derivatives = derivatives || tap.reads_derivatives();
    }
    EXPECT_EQ(entries.folded.has_value(), folding_available() && (read > 1 || derivatives));
    folded_count += entries.folded.has_value();
    const Convolution folded = reflect(table.view(), entries, light.view());
    const Convolution own = reflect(table.view(), light.view(), wo);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(folded.value[c], own.value[c], 4e-3 * own.value[c]) << wo.transpose();
      EXPECT_LE(folded.bound[c], 1.125 * own.bound[c] + 0x1p-10 * own.value[c]) << wo.transpose();
    }
  }
  EXPECT_GE(folded_count, folding_available() ? 3 : 0);
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

// Tabulating one entry per orbit of the BRDF's symmetries and moving it gives the table that
// tabulating every entry gives, derivatives over wo and tilt derivatives included (the moved
// grids' quadrature sees the same samples mirrored, so they agree to the quadrature's rounding).
TEST(SymmetricTabulation, MatchesTabulatingEveryEntry) {
  for (const Brdf& brdf : {Brdf{Phong{{0.3, 0.2, 0.1}, {0.5, 0.5, 0.5}, 40}},
                           Brdf{Ggx{{0.1, 0.1, 0.1}, {0.95, 0.64, 0.54}, 0.15}}}) {
    EXPECT_EQ(brdf_symmetries(brdf).size(), 8u);
    BrdfTableOptions options;
    options.wo_resolution = 8;  // even: the grid's centre is no entry
    options.wi_resolution = 16;
    options.projection = {.tolerance = 0};
    options.use_symmetries = false;
    const BrdfTable every = tabulate_brdf(brdf, options);
    options.use_symmetries = true;
    const BrdfTable moved = tabulate_brdf(brdf, options);
    for (const auto& [a, b] : {std::pair{every.trees.view(), moved.trees.view()},
                               std::pair{every.tilt.view(), moved.tilt.view()}})
      for (std::size_t k = 0; k < a.size(); ++k) {
        const Grid ga = reconstruct(a.tree(k)), gb = reconstruct(b.tree(k));
        ASSERT_EQ(ga.texels.size(), gb.texels.size());
        double largest = 0;
        for (const float v : ga.texels)
          largest = std::max(largest, double(std::abs(v)));
        for (std::size_t t = 0; t < ga.texels.size(); ++t)
          ASSERT_NEAR(ga.texels[t], gb.texels[t], 3e-3 * largest) << "tree " << k << " texel " << t;
      }
  }
}

// Hermite weights reproduce values, per-step derivatives and their combination exactly for
// functions cubic along s plus cubic along t plus bilinear (whose cross derivative the weights'
// estimate gets right); at an entry only that entry's value is read.
TEST(HermiteTaps, ReproduceCubicsAlongEachAxis) {
  const int m = 17;
  const double h = 2.0 / (m - 1);
  auto f = [](double s, double t) {
    return 0.3 + s - 2 * s * s + 0.7 * s * s * s + 0.4 * t + 1.5 * t * t * t - 0.8 * s * t;
  };
  auto fs = [](double s, double t) { return 1 - 4 * s + 2.1 * s * s - 0.8 * t; };
  auto ft = [](double s, double t) { return 0.4 + 4.5 * t * t - 0.8 * s; };
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(-0.6, 0.6);
  for (int k = 0; k < 200; ++k) {
    const double s0 = unit(rng), t0 = unit(rng);
    const Vec2 st(s0, t0);
    double sum = 0, value_weights = 0;
    for (const TableTap& tap :
         table_taps(m, parabolic_to_hemisphere(st), WoInterpolation::hermite)) {
      const double s = -1 + h * tap.i, t = -1 + h * tap.j;
      sum +=
          tap.weights[0] * f(s, t) + tap.weights[1] * h * fs(s, t) + tap.weights[2] * h * ft(s, t);
      value_weights += tap.weights[0];
    }
    EXPECT_NEAR(sum, f(st.x(), st.y()), 1e-9) << st.transpose();
    EXPECT_NEAR(value_weights, 1, 1e-12);
  }
  const Vec3 at_entry = table_outgoing(5, 11, m);
  for (const TableTap& tap : table_taps(m, at_entry, WoInterpolation::hermite)) {
    const bool it = tap.i == 5 && tap.j == 11;
    EXPECT_NEAR(tap.weights[0], it ? 1 : 0, 1e-9);
    EXPECT_NEAR(tap.weights[1], 0, 1e-9);
    EXPECT_NEAR(tap.weights[2], 0, 1e-9);
  }
}

// Groups 1 and 2 of an entry are texel averages of h df/ds and h df/dt: compared with a midpoint
// rule of 24 x 24 samples per texel of the closed form, for Phong ks (n + 2) / 2 pi (wi . r)^n
// with r the mirror of wo = (2s, 2t, 1 - s^2 - t^2) / (1 + s^2 + t^2), the parabolic map:
// d/ds of it is n ks (n + 2) / 2 pi (wi . r)^(n-1) (wi . dr/ds), where
// dwo/ds = (2 (1 + t^2 - s^2), -4 s t, -4 s) / (1 + s^2 + t^2)^2 (and likewise for t).
TEST(WoDerivatives, AreTexelAveragesOfTheDerivativesOverWo) {
  const double kd = 0.2, ks = 0.6, exponent = 30;
  const Brdf brdf = Phong{{kd, kd, kd}, {ks, ks, ks}, exponent};
  BrdfTableOptions options;
  options.wo_resolution = 9;
  options.wi_resolution = 16;
  const int n = options.wi_resolution, k = 24;
  const double h = 2.0 / (options.wo_resolution - 1);
  for (const auto& [i, j] : {std::pair{4, 4}, {6, 3}, {2, 7}}) {
    const Grid entry = tabulate_table_entry(brdf, i, j, options);
    ASSERT_EQ(entry.groups, 3);
    const double s = -1 + h * i, t = -1 + h * j, d = 1 + s * s + t * t;
    const Vec3 wo(2 * s / d, 2 * t / d, (1 - s * s - t * t) / d);
    const Vec3 mirror(-wo.x(), -wo.y(), wo.z());
    for (int axis = 0; axis < 2; ++axis) {
      const Vec3 dwo = axis == 0 ? Vec3(2 * (1 + t * t - s * s), -4 * s * t, -4 * s) / (d * d)
                                 : Vec3(-4 * s * t, 2 * (1 + s * s - t * t), -4 * t) / (d * d);
      const Vec3 dmirror(-dwo.x(), -dwo.y(), dwo.z());
      double largest = 0;
      for (const float v : entry.plane(1 + axis, 0))
        largest = std::max(largest, double(std::abs(v)));
      ASSERT_GT(largest, 0);
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          double sum = 0;
          for (int b = 0; b < k; ++b)
            for (int a = 0; a < k; ++a) {
              const Vec3 wi =
                  square_to_cosine_hemisphere({(x + (a + 0.5) / k) / n, (y + (b + 0.5) / k) / n});
              const double c = wi.dot(mirror);
              if (c > 0)
                sum += h * exponent * ks * (exponent + 2) / (2 * std::numbers::pi) *
                       std::pow(c, exponent - 1) * wi.dot(dmirror);
            }
          ASSERT_NEAR(entry.at(1 + axis, 0, x, y), sum / (k * k), 0.01 * largest)
              << "entry " << i << "," << j << " axis " << axis << " texel " << x << "," << y;
        }
    }
  }
}

// The lobe width of normalised Phong is its half width at half maximum, acos(2^(-1/n)), over
// the Gaussian's ratio 1.1774; Lambert has none. The default resolution follows it.
TEST(LobeWidth, OfPhongIsItsHalfWidthOverTheGaussianRatio) {
  for (const double n : {10.0, 40.0, 100.0, 200.0, 1000.0}) {
    const double expected = std::acos(std::pow(2.0, -1 / n)) / 1.1774;
    EXPECT_NEAR(lobe_width(Phong{{0.2, 0.2, 0.2}, {0.6, 0.6, 0.6}, n}), expected, 0.005 * expected)
        << n;
  }
  EXPECT_TRUE(std::isinf(lobe_width(Lambert{})));
  EXPECT_EQ(default_wo_resolution(Lambert{}), 33);
  int previous = 0;
  for (const double n : {10.0, 40.0, 100.0, 200.0, 1000.0, 1e5}) {
    const int m = default_wo_resolution(Phong{{0, 0, 0}, {1, 1, 1}, n});
    EXPECT_GE(m, previous);
    EXPECT_EQ((m - 1) % 8, 0);
    EXPECT_LE(m, 129);
    previous = m;
  }
}

INSTANTIATE_TEST_SUITE_P(Models, TableAlbedo, ::testing::Range(0, int(models().size())),
                         [](const auto& info) { return models()[info.param].name; });

}  // namespace
}  // namespace basis
