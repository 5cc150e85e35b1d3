// Lookups between table entries under high-contrast light: default tables (outgoing resolution
// from the lobe's width, derivatives over wo, Hermite lookups) and default captures (128^2,
// compact lights apart) at the zenith of every probe in ../shared/data/probes and of a
// synthetic map of sharp bright windows on a dark ground, at 32 outgoing directions up to 70
// degrees that fall between entries. Three errors are asserted:
//   what the table adds: the lookup against the same capture tree convolved with f tabulated
//     at wo itself, uncompressed (the same per-texel quadrature and convolution as the table's,
//     so this isolates the entries' interpolation and compression; it is not independent of
//     them, the next check is);
//   the whole result against direct integration over the map's pixels, which adds the 128^2
//     texels' product and the capture's own compression (README: where each error comes from);
//   the same table's bilinear lookups (--interpolation bilinear, and tables without
//     derivatives) against the map, far looser since the lobe blends rather than moves.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "basis/brdf/brdf_table.h"
#include "basis/core/parabolic.h"
#include "basis/lighting/capture.h"
#include "basis/lighting/shading.h"
#include "basis/study/wo_study.h"
#include "support/environments.h"
#include "support/reflection_reference.h"

namespace basis {
namespace {

struct Case {
  std::string name;
  Brdf brdf;
  // Largest relative errors allowed, any map, direction and channel: of what the table adds,
  // of the result against the map, and of the same table's bilinear lookups against the map.
  double table_tolerance, total_tolerance, bilinear_tolerance;
};

class LookupAccuracy : public ::testing::TestWithParam<Case> {};

TEST_P(LookupAccuracy, BetweenEntriesMatchesDirectIntegrationUnderHighContrastLight) {
  const Case& k = GetParam();
  std::vector<std::pair<std::string, Image>> maps = {{"windows", bright_windows_map()}};
  for (const std::string name : {"grace", "uffizi", "pisa", "ennis", "wells"})
    if (auto probe = testing::real_probe(name)) maps.push_back({name, std::move(*probe)});

  BrdfTableOptions options;
  options.wo_resolution = default_wo_resolution(k.brdf);
  options.tilt_derivatives = false;  // untilted lookups do not read them
  const std::vector<Vec3> directions = directions_between_entries(options.wo_resolution, 32);
  options.only_for = directions;
  const BrdfTable table = tabulate_brdf(k.brdf, options);
  // The first version's table, for the record (33^2 entries, no derivatives over wo, cut
  // relative to the mean, bilinear lookups).
  BrdfTableOptions first_options = options;
  first_options.wo_resolution = 33;
  first_options.wo_derivatives = false;
  first_options.projection.local_floor = 0;
  const BrdfTable first = tabulate_brdf(k.brdf, first_options);
  const Frame frame = Frame::from_normal(Vec3::UnitZ());
  const SurfacePoint zenith{Vec3::Zero(), Vec3::UnitZ()};
  CaptureSetOptions capture_options;
  capture_options.capture.compact_lights = CaptureOptions::CompactLights::apart;

  double worst = 0, worst_bilinear = 0, worst_table = 0, worst_first = 0;
  // f at each direction itself, texel-averaged like an entry and uncompressed.
  std::vector<PackedTree> at_wo;
  for (const Vec3& wo : directions)
    at_wo.push_back(pack(project(tabulate_entry(k.brdf, wo, options), {.tolerance = 0})));
  for (const auto& [map_name, image] : maps) {
    const Environment environment(image, 0, map_name);
    const testing::MapSamples samples = testing::map_samples(environment, 3);
    const CaptureSet set = capture_set(environment, nullptr, {&zenith, 1}, capture_options);
    double map_worst = 0, map_worst_bilinear = 0, map_worst_table = 0;
    for (std::size_t d = 0; d < directions.size(); ++d) {
      const Vec3& wo = directions[d];
      const Color exact = testing::exact_reflection_rgb(samples, k.brdf, frame, wo);
      ShadingOptions shading;
      shading.wo = wo;
      shading.light_brdf = &k.brdf;
      const Convolution hermite = shade(table.view(), set.view(), 0, shading);
      shading.interpolation = WoInterpolation::bilinear;
      const Convolution bilinear = shade(table.view(), set.view(), 0, shading);
      const Convolution first_version = shade(first.view(), set.view(), 0, shading);
      // The same capture tree and lights through f at wo instead of the table.
      const Convolution direct = convolve(at_wo[d].view(), set.view().trees.tree(0));
      Color through_f{0, 0, 0};
      for (int c = 0; c < 3; ++c)
        through_f[c] = std::numbers::pi * direct.value[c];
      for (const DirectionalLight& light : set.view().lights_of(0)) {
        const Color f = evaluate(k.brdf, light.direction, wo);
        for (int c = 0; c < 3; ++c)
          through_f[c] += f[c] * light.energy[c] * light.direction.z();
      }
      for (int c = 0; c < 3; ++c) {
        const double t = std::abs(hermite.value[c] - through_f[c]) / through_f[c];
        EXPECT_LE(t, k.table_tolerance)
            << k.name << " under " << map_name << ", wo " << wo.transpose() << ", channel " << c
            << ": " << hermite.value[c] << " against " << through_f[c] << " through f at wo";
        const double e = std::abs(hermite.value[c] - exact[c]) / exact[c];
        EXPECT_LE(e, k.total_tolerance)
            << k.name << " under " << map_name << ", wo " << wo.transpose() << ", channel " << c
            << ": " << hermite.value[c] << " against " << exact[c] << " from the map";
        map_worst_table = std::max(map_worst_table, t);
        map_worst = std::max(map_worst, e);
        const double b = std::abs(bilinear.value[c] - exact[c]) / exact[c];
        EXPECT_LE(b, k.bilinear_tolerance)
            << k.name << " under " << map_name << ", wo " << wo.transpose() << ", channel " << c
            << ": bilinear " << bilinear.value[c] << " against " << exact[c] << " from the map";
        map_worst_bilinear = std::max(map_worst_bilinear, b);
        worst_first = std::max(worst_first, std::abs(first_version.value[c] - exact[c]) / exact[c]);
      }
    }
    std::printf(
        "[ LOOKUP   ] %-9s %-8s M %3d: the table adds %.2f %%; against the map %.2f %% "
        "(bilinear %.2f %%)\n",
        k.name.c_str(), map_name.c_str(), options.wo_resolution, 100 * map_worst_table,
        100 * map_worst, 100 * map_worst_bilinear);
    worst = std::max(worst, map_worst);
    worst_table = std::max(worst_table, map_worst_table);
    worst_bilinear = std::max(worst_bilinear, map_worst_bilinear);
  }
  std::printf(
      "[ LOOKUP   ] %-9s all maps: the table adds %.2f %%; against the map %.2f %% "
      "(bilinear %.2f %%, the first version's table %.2f %%), %d x %d entries\n",
      k.name.c_str(), 100 * worst_table, 100 * worst, 100 * worst_bilinear, 100 * worst_first,
      options.wo_resolution, options.wo_resolution);
}

const Color kGrey1{0.1, 0.1, 0.1}, kGrey2{0.2, 0.2, 0.2}, kKs{0.6, 0.6, 0.6}, kF0{0.9, 0.9, 0.9};

INSTANTIATE_TEST_SUITE_P(
    Brdfs, LookupAccuracy,
    ::testing::Values(Case{"phong10", Phong{kGrey2, kKs, 10}, 0.01, 0.03, 0.04},
                      Case{"phong40", Phong{kGrey2, kKs, 40}, 0.01, 0.03, 0.11},
                      Case{"phong100", Phong{kGrey2, kKs, 100}, 0.01, 0.03, 0.17},
                      Case{"ggx0_5", Ggx{kGrey1, kF0, 0.5}, 0.01, 0.03, 0.012},
                      Case{"ggx0_2", Ggx{kGrey1, {0.95, 0.64, 0.54}, 0.2}, 0.01, 0.03, 0.12},
                      Case{"ggx0_1", Ggx{kGrey1, kF0, 0.1}, 0.01, 0.03, 0.08},
                      Case{"phong200", Phong{kGrey1, {0.8, 0.8, 0.8}, 200}, 0.01, 0.08, 0.24},
                      Case{"ggx0_05", Ggx{kGrey1, kF0, 0.05}, 0.02, 0.08, 0.27}),
    [](const auto& info) { return info.param.name; });

}  // namespace
}  // namespace basis
