// Captures against independent ground truth: constant light, direct integration of maps over
// their pixels, a wall hiding half the hemisphere, and a one-pixel sun.
#include <gtest/gtest.h>

#include <numbers>

#include "basis/brdf_table.h"
#include "basis/capture.h"
#include "basis/trace.h"
#include "support/environments.h"

namespace basis {
namespace {

std::vector<Vec3> normals() {
  return {Vec3(0, 0, 1), Vec3(1, 0, 0), Vec3(0.3, -0.4, 0.866).normalized(),
          Vec3(-0.5, 0.7, -0.5).normalized(), Vec3(0, 0, -1)};
}

// Reflected radiance of a white Lambert surface (albedo 1) under the capture: the irradiance
// over pi, through a real BRDF table and its four-entry lookup.
Rgb white_lambert(const Grid& capture_grid) {
  static const BrdfTable table = [] {
    BrdfTableOptions o;
    o.wo_resolution = 3;
    o.wi_resolution = 2;
    o.tilt_derivatives = false;
    return tabulate_brdf(Lambert{{1, 1, 1}}, o);
  }();
  const Quadtree tree = project(capture_grid, {.tolerance = 0.05});
  return reflect(table.view(), tree.view(), Vec3::UnitZ()).value;
}

TEST(Capture, ConstantLightGivesTheConstantThroughAWhiteLambertTable) {
  const Environment env = Environment::constant({0.7, 1.3, 2.0});
  for (int res : {8, 16, 32, 64, 128})
    for (const Vec3& n : normals()) {
      const Rgb lo = white_lambert(
          capture(env, nullptr, Vec3(1, 2, 3), Frame::from_normal(n), {.resolution = res}));
      EXPECT_NEAR(lo[0], 0.7, 0.005 * 0.7) << res;
      EXPECT_NEAR(lo[1], 1.3, 0.005 * 1.3) << res;
      EXPECT_NEAR(lo[2], 2.0, 0.005 * 2.0) << res;
    }
  // A constant lat-long image too (summed-area filtering keeps constants exact).
  Image flat(64, 32, 3);
  for (float& p : flat.pixels)
    p = 0.5f;
  const Rgb lo = white_lambert(capture(Environment(flat), nullptr, Vec3::Zero(),
                                       Frame::from_normal(normals()[2]), {.resolution = 32}));
  EXPECT_NEAR(lo[1], 0.5, 0.0025);
}

void check_against_map(const std::string& name, const Environment& env) {
  double worst = 0;
  for (const Vec3& n : normals()) {
    const Color e = env.irradiance(n);  // direct integration over the map's pixels
    const Rgb lo = white_lambert(
        capture(env, nullptr, Vec3::Zero(), Frame::from_normal(n), {.resolution = 64}));
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(lo[c], e[c] / std::numbers::pi, 0.01 * e[c] / std::numbers::pi)
          << name << " normal " << n.transpose() << " channel " << c;
      worst =
          std::max(worst, std::abs(lo[c] - e[c] / std::numbers::pi) / (e[c] / std::numbers::pi));
    }
  }
  std::printf("[  LAMBERT ] %s: largest relative error %.4f\n", name.c_str(), worst);
}

TEST(Capture, LambertMatchesDirectIntegrationOfASyntheticMap) {
  check_against_map("synthetic sky", Environment(testing::synthetic_sky()));
  check_against_map("rotated synthetic sky", Environment(testing::synthetic_sky(), 77));
}

TEST(Capture, LambertMatchesDirectIntegrationOfRealProbes) {
  for (const std::string name : {"grace", "uffizi", "pisa", "ennis", "wells"})
    if (const auto probe = testing::real_probe(name)) check_against_map(name, Environment(*probe));
}

// A wall in the plane x = -0.001, far larger than its distance, hides the directions with
// x < 0: half of the cosine-weighted hemisphere of a point at the origin facing +z.
TEST(Capture, AWallHidingHalfTheHemisphereHalvesTheLight) {
  TriangleMesh wall;
  const float d = -0.001f, big = 1e4f;
  wall.vertices = {{d, -big, -big}, {d, big, -big}, {d, big, big}, {d, -big, big}};
  wall.triangles = {{0, 1, 2}, {0, 2, 3}};
  wall.emission = {{0, 0, 0}, {0, 0, 0}};
  const EmbreeScene scene(wall);
  const Environment env = Environment::constant({1, 1, 1});
  for (int res : {16, 64})
    for (int spp : {1, 2}) {
      const Rgb lo =
          white_lambert(capture(env, &scene, Vec3::Zero(), Frame::from_normal(Vec3::UnitZ()),
                                {.resolution = res, .strata = spp}));
      EXPECT_NEAR(lo[0], 0.5, 0.005) << res;
    }
  // Facing the wall's side at 45 degrees: the wall covers the directions with x < 0.
  const Vec3 n = Vec3(1, 0, 1).normalized();
  const Rgb lo =
      white_lambert(capture(env, &scene, Vec3::Zero(), Frame::from_normal(n), {.resolution = 64}));
  // Cosine-weighted fraction of the hemisphere of n with x >= 0: (1 + sin 45) / 2.
  EXPECT_NEAR(lo[0], (1 + std::sqrt(0.5)) / 2, 0.01);
}

TEST(Capture, EmittersShineTheirEmission) {
  TriangleMesh lamp;  // a large emitting ceiling over the point
  lamp.vertices = {{-1e3f, -1e3f, 1}, {1e3f, -1e3f, 1}, {1e3f, 1e3f, 1}, {-1e3f, 1e3f, 1}};
  lamp.triangles = {{0, 1, 2}, {0, 2, 3}};
  lamp.emission = {{4, 2, 1}, {4, 2, 1}};
  const EmbreeScene scene(lamp);
  const Rgb lo = white_lambert(capture(Environment::constant({1, 1, 1}), &scene, Vec3::Zero(),
                                       Frame::from_normal(Vec3::UnitZ()), {.resolution = 32}));
  EXPECT_NEAR(lo[0], 4, 0.04);
  EXPECT_NEAR(lo[2], 1, 0.01);
}

// One pixel of radiance 1e5 in a black map: all its energy lands in the capture, at any
// resolution, however small the pixel is against the texels.
TEST(Capture, ASunSmallerThanATexelKeepsItsEnergy) {
  Image dark(256, 128, 3);
  const int row = 40, column = 57;
  for (int c = 0; c < 3; ++c)
    dark.at(column, row, c) = 1e5f;
  const Environment env(dark);
  const Vec3 n = Vec3(0.2, 0.1, 1).normalized();
  const Color expected = env.irradiance(n);  // 1e5 x solid angle x cosine, by the map's pixels
  ASSERT_GT(expected[0], 0);
  for (int res : {8, 16, 32, 64}) {
    const Grid g = capture(env, nullptr, Vec3::Zero(), Frame::from_normal(n), {.resolution = res});
    const double energy = std::numbers::pi * g.mean(0, 0);  // integral of L cos over the texels
    EXPECT_NEAR(energy, expected[0], 0.02 * expected[0]) << res;
    // The sun stays where it is: a texel or its neighbours hold 99.9 % of the energy.
    const double total = g.mean(0, 0) * res * res;
    int lit = 0;
    for (float t : g.plane(0, 0))
      lit += t > 1e-3 * total;
    EXPECT_LE(lit, 4) << res;
  }
}

TEST(Capture, IsDeterministicAndJitterDependsOnTheSeed) {
  const Environment env(testing::synthetic_sky());
  TriangleMesh wall;
  wall.vertices = {{0.3f, -5, -5}, {0.3f, 5, -5}, {0.3f, 5, 5}};
  wall.triangles = {{0, 1, 2}};
  wall.emission = {{0, 0, 0}};
  const EmbreeScene scene(wall);
  const Frame f = Frame::from_normal(Vec3::UnitZ());
  const Grid a = capture(env, &scene, Vec3::Zero(), f, {.resolution = 32, .seed = 3}, 7);
  const Grid b = capture(env, &scene, Vec3::Zero(), f, {.resolution = 32, .seed = 3}, 7);
  const Grid c = capture(env, &scene, Vec3::Zero(), f, {.resolution = 32, .seed = 4}, 7);
  EXPECT_EQ(a.texels, b.texels);
  EXPECT_NE(a.texels, c.texels);
}

TEST(Capture, EnvironmentRepairsNonFiniteAndNegativeTexels) {
  Image bad = testing::synthetic_sky();
  bad.at(3, 3, 0) = std::nanf("");
  bad.at(4, 3, 1) = INFINITY;
  bad.at(5, 3, 2) = -INFINITY;
  bad.at(6, 3, 0) = -2;
  const Environment env(bad);
  EXPECT_EQ(env.repairs().nan, 1);
  EXPECT_EQ(env.repairs().infinite, 2);
  EXPECT_EQ(env.repairs().negative, 1);
  const Grid g =
      capture(env, nullptr, Vec3::Zero(), Frame::from_normal(Vec3::UnitZ()), {.resolution = 16});
  for (float t : g.texels)
    ASSERT_TRUE(std::isfinite(t) && t >= 0);
}

}  // namespace
}  // namespace basis
