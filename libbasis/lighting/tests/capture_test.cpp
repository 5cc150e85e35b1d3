// Captures against independent ground truth: constant light, direct integration of maps over
// their pixels, a wall hiding half the hemisphere, and a one-pixel sun.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>
#include <vector>

#include "basis/brdf/table_lookup.h"
#include "basis/core/hemisphere.h"
#include "basis/core/projection.h"
#include "basis/core/random.h"
#include "basis/lighting/capture.h"
#include "basis/lighting/embree_scene.h"
#include "basis/lighting/shading.h"
#include "support/environments.h"

namespace basis {
namespace {

std::vector<Vec3> normals() {
  return {Vec3(0, 0, 1), Vec3(1, 0, 0), Vec3(0.3, -0.4, 0.866).normalized(),
          Vec3(-0.5, 0.7, -0.5).normalized(), Vec3(0, 0, -1)};
}

// Reflected radiance of a white Lambert surface (albedo 1) under the capture: the irradiance
// over pi, through a real BRDF table and its four-entry lookup.
Rgb white_lambert(const Capture& capture) {
  static const BrdfTable table = [] {
    BrdfTableOptions o;
    o.wo_resolution = 3;
    o.wi_resolution = 2;
    o.tilt_derivatives = false;
    return tabulate_brdf(Lambert{{1, 1, 1}}, o);
  }();
  const PackedTree tree = pack(project(capture.texels, {.tolerance = 0.05}));
  return reflect(table.view(), tree.view(), Vec3::UnitZ()).value;
}

// Within 0.06 %: what is left is the texels' rounding to shared-exponent words (a step of at
// most 2^-8 of the largest channel), the same in every texel of a constant light, and the
// table's halves.
TEST(Capture, ConstantLightGivesTheConstantThroughAWhiteLambertTable) {
  const Environment env = Environment::constant({0.7, 1.3, 2.0});
  for (int res : {8, 16, 32, 64, 128})
    for (const Vec3& n : normals()) {
      const Rgb lo = white_lambert(
          capture(env, nullptr, Vec3(1, 2, 3), Frame::from_normal(n), {.resolution = res}));
      EXPECT_NEAR(lo[0], 0.7, 6e-4 * 0.7) << res;
      EXPECT_NEAR(lo[1], 1.3, 6e-4 * 1.3) << res;
      EXPECT_NEAR(lo[2], 2.0, 6e-4 * 2.0) << res;
    }
  // A constant lat-long image too (summed-area filtering keeps constants exact).
  Image flat(64, 32, 3);
  for (float& p : flat.pixels)
    p = 0.5f;
  const Rgb lo = white_lambert(capture(Environment(flat), nullptr, Vec3::Zero(),
                                       Frame::from_normal(normals()[2]), {.resolution = 32}));
  EXPECT_NEAR(lo[1], 0.5, 6e-4 * 0.5);
}

// Shading a set at one wo with the entries found once gives what the light is; a tilted lookup
// needs its entries found per capture, so it is refused.
TEST(Capture, ShadingWithEntriesFoundBeforehandGivesTheConstantAndIsUntiltedOnly) {
  BrdfTableOptions o;
  o.wo_resolution = 3;
  o.wi_resolution = 2;
  o.tilt_derivatives = false;
  const BrdfTable table = tabulate_brdf(Lambert{{1, 1, 1}}, o);
  const Environment env = Environment::constant({0.7, 1.3, 2.0});
  const std::vector<SurfacePoint> points = {{Vec3::Zero(), Vec3::UnitZ()},
                                            {Vec3(1, 0, 0), Vec3(0, 1, 0)}};
  const CaptureSet set = capture_set(env, nullptr, points, {});
  ShadingOptions shading;
  shading.wo = Vec3(0.3, 0.2, 0.9).normalized();
  const EntriesAtWo entries = entries_at(table.view(), shading.wo, shading.interpolation);
  EXPECT_TRUE(entries.folded.has_value() || !folding_available());
  for (std::size_t k = 0; k < points.size(); ++k) {
    const Convolution lo = shade(table.view(), entries, set.view(), k, shading);
    EXPECT_NEAR(lo.value[0], 0.7, 0.005 * 0.7) << k;
    EXPECT_NEAR(lo.value[1], 1.3, 0.005 * 1.3) << k;
    EXPECT_NEAR(lo.value[2], 2.0, 0.005 * 2.0) << k;
  }
  // wo is a direction whatever its length; a zero one is refused.
  const Vec3 wo = shading.wo;
  shading.wo = wo * 1e300;
  EXPECT_NEAR(shade(table.view(), set.view(), 0, shading).value[1], 1.3, 0.005 * 1.3);
  shading.wo = Vec3::Zero();
  EXPECT_THROW(shade(table.view(), set.view(), 0, shading), std::invalid_argument);
  EXPECT_THROW(shade(table.view(), entries, set.view(), 0, shading), std::invalid_argument);
  shading.wo = wo;
  shading.normal = Vec3(0, 0.1, 1).normalized();
  EXPECT_THROW(shade(table.view(), entries, set.view(), 0, shading), std::invalid_argument);
}

// Lights that take f from the table read it texel by texel from entries_at's texels or walk the
// entries from their roots: both give the same bits, values and bounds, for a colored GGX table
// with derivatives over wo (three groups, four entries between rows) and a grey Phong one, lights
// anywhere on the hemisphere, on the quadrants' edges and at the horizon.
TEST(Capture, LightsReadFromTheEntriesTexelsGiveWhatTheirWalkGives) {
  BrdfTableOptions o;
  o.wo_resolution = 5;
  o.wi_resolution = 32;
  o.tilt_derivatives = false;
  const std::vector<BrdfTable> tables = {
      tabulate_brdf(Ggx{{0.1, 0.2, 0.3}, {0.9, 0.6, 0.5}, 0.15}, o),
      tabulate_brdf(Phong{{0.2, 0.2, 0.2}, {0.5, 0.5, 0.5}, 40}, o)};
  const std::vector<SurfacePoint> points = {{Vec3::Zero(), Vec3::UnitZ()}};
  CaptureSet set = capture_set(Environment::constant({0.1, 0.2, 0.3}), nullptr, points, {});
  for (int i = 0; i < 400; ++i) {
    // Random texel positions, and positions on the edges of the quadrants of levels 1 to 5.
    const double u = i < 300 ? unit_random(2 * i) : (i % 32) / 32.0;
    const double v = i < 300 ? unit_random(2 * i + 1) : ((i / 32) % 32) / 32.0;
    set.lights.push_back(
        {square_to_cosine_hemisphere(Vec2(u, v)), {1 + 0.01 * i, 2.0, 0.5 + 0.002 * i}});
  }
  set.lights.push_back({Vec3(1, 0, 1e-9).normalized(), {1, 1, 1}});  // at the horizon
  set.lights.push_back({Vec3(0, -1, 1e-12).normalized(), {1, 1, 1}});
  set.light_offsets = {0, std::uint32_t(set.lights.size())};
  for (const BrdfTable& table : tables)
    for (const Vec3& wo : {Vec3(0, 0, 1), Vec3(0.5, 0, 0.866), Vec3(0.3, 0.2, 0.93)}) {
      ShadingOptions shading;
      shading.wo = wo.normalized();
      const EntriesAtWo walked = entries_at(table.view(), shading.wo, shading.interpolation);
      const EntriesAtWo read =
          entries_at(table.view(), shading.wo, shading.interpolation, /*with_texels=*/true);
      ASSERT_TRUE(read.texels.has_value());
      EXPECT_EQ(read.texels->resolution, 32);
      // Texel by texel, in doubles: each entry's leaf there, found from the root.
      for (int y = 0; y < 32; y += 3)
        for (int x = 0; x < 32; x += 3) {
          std::array<double, 6> walk{};
          for (const TableTap& tap : read.taps) {
            if (!tap.reads_anything()) continue;
            const PackedTreeView entry = table.view().entry(tap.i, tap.j);
            const LeafQuadrant leaf = find_leaf(entry, (x + 0.5) / 32, (y + 0.5) / 32);
            for (int g = 0; g < (tap.reads_derivatives() ? 3 : 1); ++g)
              for (int c = 0; c < 3; ++c) {
                const int channel = std::min(c, entry.shape().channels - 1);
                walk[c] += tap.weights[g] * entry.value(leaf.node, g, channel, leaf.quadrant);
                walk[3 + c] +=
                    std::abs(tap.weights[g]) *
                    entry.largest_deviation_bound(leaf.node, g, channel, leaf.quadrant, leaf.level);
              }
          }
          EXPECT_EQ(read.texels->at(x, y), walk) << x << " " << y;
        }
      const Convolution a = shade(table.view(), walked, set.view(), 0, shading);
      const Convolution b = shade(table.view(), read, set.view(), 0, shading);
      // Without lights, what they add.
      const Convolution none = reflect(table.view(), walked, set.view().trees.tree(0));
      for (int c = 0; c < 3; ++c) {
        EXPECT_EQ(a.value[c], b.value[c]) << wo.transpose() << " channel " << c;
        EXPECT_EQ(a.bound[c], b.bound[c]) << wo.transpose() << " channel " << c;
        EXPECT_GT(a.value[c], 2 * none.value[c]);
        EXPECT_GT(a.bound[c], none.bound[c]);
      }
    }
}

void check_against_map(const std::string& name, const Environment& env) {
  double worst = 0;
  for (const Vec3& n : normals()) {
    const Color e = env.irradiance(n);  // direct integration over the map's pixels
    const Rgb lo = white_lambert(
        capture(env, nullptr, Vec3::Zero(), Frame::from_normal(n), {.resolution = 64}));
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(lo[c], e[c] / std::numbers::pi, 0.0075 * e[c] / std::numbers::pi)
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
  int probes = 0;
  for (const std::string name : {"grace", "uffizi", "pisa", "ennis", "wells"})
    if (const auto probe = testing::real_probe(name)) {
      check_against_map(name, Environment(*probe));
      ++probes;
    }
  if (probes == 0) GTEST_SKIP() << "no shared probe is present";
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
      EXPECT_NEAR(lo[0], 0.5, 0.0025) << res;
    }
  // Facing the wall's side at 45 degrees: the wall covers the directions with x < 0.
  const Vec3 n = Vec3(1, 0, 1).normalized();
  const Rgb lo =
      white_lambert(capture(env, &scene, Vec3::Zero(), Frame::from_normal(n), {.resolution = 64}));
  // Cosine-weighted fraction of the hemisphere of n with x >= 0: (1 + sin 45) / 2.
  EXPECT_NEAR(lo[0], (1 + std::sqrt(0.5)) / 2, 0.005 * (1 + std::sqrt(0.5)) / 2);
}

// Points on a floor under a square roof of half-side 1 at height 0.5, the whole tilted by 30
// degrees, at scales 1e-4 and 1, and at scale 1 1e5 away from the origin, with the offset the
// tools take (TriangleMesh::ray_offset): the sky a point sees is 1 minus the roof's form
// factor, the sum over the four rectangles the point splits the roof into of the closed form
// for a parallel rectangle of sides X h, Y h with a corner above the point at height h,
// (X atan(Y / sqrt(1 + X^2)) / sqrt(1 + X^2) + Y atan(X / sqrt(1 + Y^2)) / sqrt(1 + Y^2)) / 2pi,
// h being the rays' origin's height under the roof. At scale 1e-4 rays started 1e-4 above the
// floor passed over the roof (the sky read 1). Far from the origin the offset now grows with the
// coordinates' float steps (capture2qt on a tilted plane 20 wide at 1e5 read skies of 0 to 1,
// mean 0.92, where this reads 1): here it must still see the roof as it is.
TEST(Capture, NeitherTheScaleNorTheDistanceFromTheOriginLetsSurfacesShadeThemselves) {
  auto rectangle = [](double X, double Y) {
    const double x = std::sqrt(1 + X * X), y = std::sqrt(1 + Y * Y);
    return (X / x * std::atan(Y / x) + Y / y * std::atan(X / y)) / (2 * std::numbers::pi);
  };
  const Environment env = Environment::constant({1, 1, 1});
  const Eigen::Matrix3d tilt =
      Eigen::AngleAxisd(30 * std::numbers::pi / 180, Vec3(1, 1, 0).normalized()).toRotationMatrix();
  const Vec3 normal = tilt * Vec3::UnitZ();
  const std::pair<double, double> cases[] = {{1e-4, 0}, {1, 0}, {1, 1e5}};  // scale, distance
  for (const auto& scale_and_distance : cases) {
    // Named apart: clang 14 cannot capture structured bindings in the lambda below.
    const double scale = scale_and_distance.first, away = scale_and_distance.second;
    const Vec3 centre = Vec3::Constant(away);
    auto place = [&](double px, double py, double pz) -> std::array<float, 3> {
      const Vec3 p = centre + tilt * (Vec3(px, py, pz) * scale);
      return {float(p.x()), float(p.y()), float(p.z())};
    };
    TriangleMesh mesh;
    const double a = 1, h = 0.5, floor = 10;
    mesh.vertices = {place(-floor, -floor, 0), place(floor, -floor, 0), place(floor, floor, 0),
                     place(-floor, floor, 0),  place(-a, -a, h),        place(-a, a, h),
                     place(a, a, h),           place(a, -a, h)};
    mesh.triangles = {{0, 1, 2}, {0, 2, 3}, {4, 5, 6}, {4, 6, 7}};
    mesh.emission.assign(4, {0, 0, 0});
    const EmbreeScene scene(mesh);
    // Points on the floor under the roof, given in double as sampled points would be.
    std::vector<Vec2> points;
    for (const double u : {-0.4137, 0.0, 0.2718})
      for (const double v : {-0.3141, 0.0123, 0.4142})
        points.push_back(Vec2(u, v));
    auto vertex = [&](int k) {
      return Vec3(mesh.vertices[k][0], mesh.vertices[k][1], mesh.vertices[k][2]);
    };
    for (const Vec2& at : points) {
      // On the floor's triangles as stored (float vertices), as a point sampled on them lies.
      const double s = (at.x() + floor) / (2 * floor), t = (at.y() + floor) / (2 * floor);
      const Vec3 point =
          t <= s ? vertex(0) + s * (vertex(1) - vertex(0)) + t * (vertex(2) - vertex(1))
                 : vertex(0) + t * (vertex(3) - vertex(0)) + s * (vertex(2) - vertex(3));
      const double lift =
          (ray_origin_above(point, normal, mesh.ray_offset()) - point).dot(normal) / scale;
      // The lift as documented, from the vertices' box and the point's coordinates: 1e-4 of the
      // box's diagonal, or 2^-19 of the largest coordinate where that is more.
      Vec3 box_lo = Vec3::Constant(INFINITY), box_hi = Vec3::Constant(-INFINITY);
      for (int k = 0; k < 8; ++k) {
        box_lo = box_lo.cwiseMin(vertex(k));
        box_hi = box_hi.cwiseMax(vertex(k));
      }
      const double documented =
          std::max(1e-4 * (box_hi - box_lo).norm(), std::ldexp(point.cwiseAbs().maxCoeff(), -19));
      EXPECT_NEAR(lift * scale, documented, 1e-9 * documented);
      EXPECT_LT(lift, (away == 0 ? 0.01 : 0.5) * h);
      const double height = h - lift;
      double roof = 0;
      for (const double dx : {a - at.x(), a + at.x()})
        for (const double dy : {a - at.y(), a + at.y()})
          roof += rectangle(dx / height, dy / height);
      const double sky = 1 - roof;
      const Rgb lo =
          white_lambert(capture(env, &scene, point, Frame::from_normal(normal),
                                {.resolution = 64, .strata = 2, .ray_offset = mesh.ray_offset()}));
      // The roof's edges through 64^2 texels of two strata: within 2 % of the closed form.
      EXPECT_NEAR(lo[0], sky, 0.02 * sky + 0.002)
          << "scale " << scale << ", " << away << " from the origin, at " << at.transpose()
          << ", the rays' origin " << lift << " above the floor";
    }
  }
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
    const Grid g =
        capture(env, nullptr, Vec3::Zero(), Frame::from_normal(n), {.resolution = res}).texels;
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

// A map with two one-pixel suns and a bright patch 6 x 6 pixels (8 degrees) wide over a grey
// background: the suns are compact lights, the patch is not.
Image two_suns_and_a_patch() {
  Image image(256, 128, 3);
  for (float& p : image.pixels)
    p = 1;
  for (int c = 0; c < 3; ++c) {
    image.at(57, 40, c) = 1e5f;
    image.at(150, 30, c) = 5e4f * (c + 1);
    for (int y = 50; y < 56; ++y)
      for (int x = 200; x < 206; ++x)
        image.at(x, y, c) = 1000;
  }
  return image;
}

TEST(Capture, CompactLightsAreFoundWithTheirEnergyAndDirection) {
  const Image image = two_suns_and_a_patch();
  const Environment env(image);
  ASSERT_EQ(env.lights().size(), 2u);
  // The map's own geometry: a pixel's solid angle 2 pi / W (cos theta0 - cos theta1).
  auto pixel_solid_angle = [](int row) {
    return 2 * std::numbers::pi / 256 *
           (std::cos(std::numbers::pi * row / 128) - std::cos(std::numbers::pi * (row + 1) / 128));
  };
  for (const auto& light : env.lights()) {
    const bool first = light.direction.isApprox(env.direction(57.5, 40.5), 1e-9);
    const int row = first ? 40 : 30;
    EXPECT_TRUE(first || light.direction.isApprox(env.direction(150.5, 30.5), 1e-9));
    for (int c = 0; c < 3; ++c) {
      const double excess = image.at(first ? 57 : 150, row, c) - 1;
      // The excess over the smooth level, which is well under 1 % of a sun.
      EXPECT_NEAR(light.energy[c], excess * pixel_solid_angle(row),
                  0.01 * excess * pixel_solid_angle(row));
      EXPECT_LT(light.energy[c], excess * pixel_solid_angle(row));
    }
    EXPECT_NEAR(light.radius, std::sqrt(0.5) * std::numbers::pi / 128, 1e-9);  // half a pixel
  }
  for (const auto& b : env.bright_pixels())
    EXPECT_EQ(b.light >= 0, (b.column == 57 && b.row == 40) || (b.column == 150 && b.row == 30))
        << b.column << " " << b.row;
}

// Many compact lights come most luminous first, whatever their order in the map: 70 dim
// one-pixel lights in the upper rows and a sun below them in row-major order (a consumer that
// keeps the first 64, as the radiance cache's light masks do, lost the sun's shadows). Every
// bright pixel still names the light it belongs to: within that light's radius.
TEST(Capture, CompactLightsComeMostLuminousFirst) {
  Image image(256, 128, 3);
  for (float& p : image.pixels)
    p = 0.02f;
  for (int k = 0; k < 70; ++k)
    for (int c = 0; c < 3; ++c)
      image.at(3 * k + 20, 10 + (k % 3) * 4, c) = 5.0f + 0.01f * float(k);
  for (int c = 0; c < 3; ++c)
    image.at(100, 40, c) = 2000.0f;
  const Environment env(image);
  const auto lights = env.lights();
  ASSERT_EQ(lights.size(), 71u);
  EXPECT_TRUE(lights[0].direction.isApprox(env.direction(100.5, 40.5), 1e-9));
  for (std::size_t k = 1; k < lights.size(); ++k)
    EXPECT_GE(luminance(lights[k - 1].energy), luminance(lights[k].energy)) << k;
  int named = 0;
  for (const auto& b : env.bright_pixels())
    if (b.light >= 0) {
      const auto& light = lights[std::size_t(b.light)];
      EXPECT_LE(std::acos(std::clamp(
                    light.direction.dot(env.direction(b.column + 0.5, b.row + 0.5)), -1.0, 1.0)),
                light.radius + 1e-12)
          << b.column << " " << b.row;
      ++named;
    }
  EXPECT_EQ(named, 71);
}

// A map rotated about z moves a feature at azimuth phi to phi + rotation: the suns' lights lie at
// their pixel centres' directions computed here from the lat-long convention (theta = pi y / H,
// phi = 2 pi x / W), turned by the rotation, and the bright patch is seen there, not where it
// lies in the image.
TEST(Capture, RotatingTheMapMovesItsFeaturesToPhiPlusTheRotation) {
  const Image image = two_suns_and_a_patch();
  auto direction = [](double column, double row, double rotation_degrees) {
    const double theta = std::numbers::pi * row / 128;
    const double phi =
        2 * std::numbers::pi * column / 256 + rotation_degrees * std::numbers::pi / 180;
    return Vec3(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
  };
  for (const double rotation : {0.0, 30.0, -75.0, 200.0}) {
    const Environment env(image, rotation);
    ASSERT_EQ(env.lights().size(), 2u) << rotation;
    for (const auto& [column, row] : {std::pair{57.5, 40.5}, std::pair{150.5, 30.5}}) {
      const Vec3 expected = direction(column, row, rotation);
      EXPECT_TRUE(std::ranges::any_of(
          env.lights(),
          [&](const auto& light) { return (light.direction - expected).norm() < 1e-9; }))
          << rotation << " " << column;
    }
    const Vec3 patch = direction(203, 53, rotation);
    EXPECT_NEAR(env.radiance(patch)[0], 1000, 1e-3) << rotation;
    if (rotation != 0) {
      EXPECT_NEAR(env.radiance(direction(203, 53, 0))[0], 1, 1e-6) << rotation;
    }
  }
}

// A light 2 x 2 pixels (3 degrees) wide is kept as the four quarters of its extent: their
// energies add up to the light's, each lies on its own side of the light's centre, and a sharp
// lobe shaded with them is closer to direct integration over the map than with one point at the
// centre.
TEST(Capture, WideCompactLightsAreKeptAsTheirFourQuarters) {
  Image image(256, 128, 3);
  for (float& p : image.pixels)
    p = 1;
  for (int y = 30; y < 32; ++y)
    for (int x = 100; x < 102; ++x)
      for (int c = 0; c < 3; ++c)
        image.at(x, y, c) = 2e4f * float(1 + (x - 100) + 2 * (y - 30));  // uneven on purpose
  const Environment env(image);
  ASSERT_EQ(env.lights().size(), 1u);
  const auto& light = env.lights()[0];
  ASSERT_GT(light.radius, kSplitLightRadiusDegrees * std::numbers::pi / 180);
  const Frame frame = Frame::from_normal(Vec3(0.3, 0.1, 1).normalized());
  const Capture c =
      capture(env, nullptr, Vec3::Zero(), frame,
              {.resolution = 32, .compact_lights = CaptureOptions::CompactLights::apart});
  ASSERT_EQ(c.lights.size(), 4u);
  Color sum{0, 0, 0};
  Vec3 centre = Vec3::Zero();
  for (const DirectionalLight& q : c.lights) {
    for (int ch = 0; ch < 3; ++ch)
      sum[ch] += q.energy[ch];
    centre += luminance(q.energy) * q.direction;
    EXPECT_LT(angle_between(q.direction, frame.to_local(light.direction)), light.radius);
    EXPECT_GT(angle_between(q.direction, frame.to_local(light.direction)), 0.002);
  }
  for (int ch = 0; ch < 3; ++ch)
    EXPECT_NEAR(sum[ch], light.energy[ch], 0.01 * light.energy[ch]);
  centre.normalize();
  // f of a Phong 300 lobe aimed at the light, integrated over the light's pixels against its
  // quarters and its centre.
  const Phong lobe{{0, 0, 0}, {1, 1, 1}, 300};
  const Vec3 at = frame.to_local(light.direction);
  const Vec3 wo = Vec3(-at.x(), -at.y(), at.z()) + Vec3(0.02, 0, 0);
  double exact = 0;
  for (int y = 30; y < 32; ++y)
    env.for_each_subpixel(y, 100, 102, 8, [&](int x, const Vec3& w, double dw) {
      const Vec3 l = frame.to_local(w);
      const double excess = image.at(x, y, 1) - 1;
      exact += evaluate(lobe, l, wo)[1] * excess * dw * l.z();
    });
  double quarters = 0;
  for (const DirectionalLight& q : c.lights)
    quarters += evaluate(lobe, q.direction, wo)[1] * q.energy[1] * q.direction.z();
  const double point = evaluate(lobe, centre, wo)[1] * sum[1] * centre.z();
  EXPECT_LT(std::abs(quarters - exact), 0.5 * std::abs(point - exact))
      << "quarters " << quarters << " point " << point << " exact " << exact;
}

TEST(Capture, LightsKeptApartCarryWhatTheTexelsWouldHold) {
  const Environment env(two_suns_and_a_patch());
  for (const Vec3& n : {Vec3(0.2, 0.1, 1).normalized(), Vec3(0.3, 0.9, 0.4).normalized()}) {
    const Frame frame = Frame::from_normal(n);
    const Color expected = env.irradiance(n);  // integral of L cos over the map's pixels
    for (int res : {16, 64}) {
      const Capture kept_apart =
          capture(env, nullptr, Vec3::Zero(), frame,
                  {.resolution = res, .compact_lights = CaptureOptions::CompactLights::apart});
      const Grid& apart = kept_apart.texels;
      const std::vector<DirectionalLight>& lights = kept_apart.lights;
      const Grid splatted = capture(env, nullptr, Vec3::Zero(), frame, {.resolution = res}).texels;
      std::size_t seen = 0;
      for (const auto& light : env.lights())
        seen += frame.to_local(light.direction).z() > 0 ? 1 : 0;
      ASSERT_EQ(lights.size(), seen) << res;
      for (const DirectionalLight& l : lights) {
        const Vec3& w = l.direction;
        EXPECT_NEAR(w.norm(), 1, 1e-12);
        const bool matched = std::any_of(env.lights().begin(), env.lights().end(), [&](auto& e) {
          return std::acos(std::min(1.0, frame.to_local(e.direction).dot(w))) < 0.5 * 0.0246;
        });
        EXPECT_TRUE(matched) << "a light's direction is off by more than half a pixel";
      }
      // Texels plus lights hold what the splatted capture holds, and both the map's energy.
      Grid sum = apart;
      splat_lights(lights, sum);
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(sum.mean(0, c), splatted.mean(0, c), 2e-3 * splatted.mean(0, c)) << res;
        EXPECT_NEAR(std::numbers::pi * sum.mean(0, c), expected[c], 0.01 * expected[c]) << res;
      }
      // Where: the same rays made both captures, so the splatted one minus the one with lights
      // apart is the lights' pieces, which lie in the texel of the light's direction or its
      // neighbours (a light's pixel may straddle a border) and nowhere else.
      std::vector<double> near(std::size_t(res) * res, 0);
      for (const DirectionalLight& l : lights) {
        const Vec2 uv = cosine_hemisphere_to_square(l.direction);
        const int tx = int(uv.x() * res), ty = int(uv.y() * res);
        double pieces = 0;
        for (int y = std::max(0, ty - 1); y <= std::min(res - 1, ty + 1); ++y)
          for (int x = std::max(0, tx - 1); x <= std::min(res - 1, tx + 1); ++x) {
            pieces += splatted.at(0, 1, x, y) - apart.at(0, 1, x, y);
            near[std::size_t(y) * res + x] = 1;
          }
        // Texel energy to light energy: times texel area and pi, over the cosine.
        EXPECT_NEAR(pieces * std::numbers::pi / (res * res) / l.direction.z(), l.energy[1],
                    0.01 * l.energy[1])
            << res;
      }
      for (int y = 0; y < res; ++y)
        for (int x = 0; x < res; ++x)
          if (!near[std::size_t(y) * res + x]) {
            EXPECT_NEAR(splatted.at(0, 1, x, y), apart.at(0, 1, x, y),
                        1e-5 * std::abs(apart.at(0, 1, x, y)))
                << res << " texel " << x << "," << y;
          }
    }
  }
}

// A lookup exactly at the horizon keeps the lights that one a hair above it keeps: their f is
// the BRDF's limit from above the horizon. It was taken at wo itself, where f is 0, and the suns
// were lost; through a white Lambert table they are most of the light. Near the horizon, the
// lights' share is the sum of f(wi, wo) E cos over the lights at wo itself (as a reference
// takes it), for Lambert and for GGX, whose f changes with wo there.
TEST(Capture, LookupsAtTheHorizonKeepTheLights) {
  BrdfTableOptions o;
  o.wo_resolution = 5;
  o.wi_resolution = 16;
  o.tilt_derivatives = false;
  const std::vector<SurfacePoint> points = {{Vec3::Zero(), Vec3::UnitZ()}};
  CaptureSetOptions options;
  options.capture.resolution = 32;
  options.capture.compact_lights = CaptureOptions::CompactLights::apart;
  const CaptureSet set = capture_set(Environment(two_suns_and_a_patch()), nullptr, points, options);
  const std::span<const DirectionalLight> lights = set.view().lights_of(0);
  ASSERT_EQ(lights.size(), 2u);
  const PackedTreeView sky = set.view().trees.tree(0);
  for (const Brdf& brdf :
       {Brdf(Lambert{{1, 1, 1}}), Brdf(Ggx{{0.1, 0.1, 0.1}, {0.9, 0.9, 0.9}, 0.3})}) {
    const BrdfTable table = tabulate_brdf(brdf, o);
    const Convolution sky_alone = reflect(table.view(), sky, Vec3::UnitZ());
    for (const Vec3& horizon : {Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(-0.6, 0.8, 0)}) {
      for (const Brdf* light_brdf : {&brdf, static_cast<const Brdf*>(nullptr)}) {
        ShadingOptions at, above;
        at.wo = horizon;
        above.wo = horizon + Vec3(0, 0, 1e-9);
        at.light_brdf = above.light_brdf = light_brdf;
        const Convolution lo_at = shade(table.view(), set.view(), 0, at);
        const Convolution lo_above = shade(table.view(), set.view(), 0, above);
        for (int c = 0; c < 3; ++c) {
          if (std::holds_alternative<Lambert>(brdf)) {  // the suns are most of it
            EXPECT_GT(lo_above.value[c], 2 * sky_alone.value[c]) << horizon.transpose();
          }
          EXPECT_NEAR(lo_at.value[c], lo_above.value[c],
                      lo_at.bound[c] + lo_above.bound[c] + 1e-6 * lo_above.value[c])
              << horizon.transpose() << (light_brdf ? ", f from the BRDF" : ", f from the table");
        }
      }
      // 89.7 degrees from the normal, past the table's last entries: the lights' f at wo.
      const Vec3 grazing = (horizon + Vec3(0, 0, 0.005)).normalized();
      ShadingOptions near;
      near.wo = grazing;
      near.light_brdf = &brdf;
      const Convolution lo = shade(table.view(), set.view(), 0, near);
      const Convolution table_part = reflect(table.view(), sky, grazing);
      Color lights_part{0, 0, 0};
      for (const DirectionalLight& l : lights) {
        const Color f = evaluate(brdf, l.direction, grazing);
        for (int c = 0; c < 3; ++c)
          lights_part[c] += f[c] * l.energy[c] * l.direction.z();
      }
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(lo.value[c] - table_part.value[c], lights_part[c], 1e-5 * lo.value[c])
            << horizon.transpose();
    }
  }
}

// Products of captures whose lights are kept apart against the product of their full texel
// grids with the lights splatted in (both captured here), within the certified bound, in full
// and with an accuracy target; without the bound, the full descent's values.
TEST(Capture, ProductsWithLightsStayWithinTheirBoundOfTheTexels) {
  const Environment env(two_suns_and_a_patch());
  const std::vector<SurfacePoint> points = {{Vec3::Zero(), Vec3(0.2, 0.1, 1).normalized()},
                                            {Vec3::Zero(), Vec3(0.3, 0.9, 0.4).normalized()}};
  std::vector<Grid> apart_grids(points.size()), splat_grids(points.size());
  CaptureSetOptions options;
  options.capture.resolution = 16;
  options.capture.compact_lights = CaptureOptions::CompactLights::apart;
  options.projection.tolerance = 0.2;  // coarse trees: the bound has work to do
  options.on_grid = [&](std::size_t k, const Grid& grid, std::span<const DirectionalLight> l) {
    apart_grids[k] = grid;
    splat_lights(l, apart_grids[k]);
  };
  const CaptureSet apart = capture_set(env, nullptr, points, options);
  options.capture.compact_lights = CaptureOptions::CompactLights::splatted;
  options.on_grid = [&](std::size_t k, const Grid& grid, std::span<const DirectionalLight>) {
    splat_grids[k] = grid;
  };
  const CaptureSet splat = capture_set(env, nullptr, points, options);
  ASSERT_GT(apart.lights.size(), 0u);
  ASSERT_TRUE(splat.lights.empty());
  // pi times the mean of the texel products: the hemisphere integral of L_a L_b cos.
  auto dense = [](const Grid& a, const Grid& b, int c) {
    double sum = 0;
    for (int y = 0; y < a.resolution; ++y)
      for (int x = 0; x < a.resolution; ++x)
        sum += double(a.at(0, c, x, y)) * b.at(0, c, x, y);
    return std::numbers::pi * sum / (double(a.resolution) * a.resolution);
  };
  for (std::size_t k = 0; k < points.size(); ++k) {
    const Convolution self = capture_product(apart.view(), apart.view(), k);
    const Convolution mixed = capture_product(apart.view(), splat.view(), k);
    for (int c = 0; c < 3; ++c) {
      const double exact_self = dense(apart_grids[k], apart_grids[k], c);
      const double exact_mixed = dense(apart_grids[k], splat_grids[k], c);
      EXPECT_LE(std::abs(self.value[c] - exact_self), self.bound[c] * 1.0001 + 1e-6 * exact_self)
          << k << " " << c;
      EXPECT_LE(std::abs(mixed.value[c] - exact_mixed),
                mixed.bound[c] * 1.0001 + 1e-6 * exact_mixed)
          << k << " " << c;
      EXPECT_LT(self.bound[c], 0.5 * exact_self) << "a bound too loose to mean anything";
    }
    // The descent takes its options: an accuracy target keeps the bound; without the bound the
    // values are the full descent's.
    const Convolution targeted = capture_product(apart.view(), apart.view(), k, {.accuracy = 0.2});
    const Convolution alone = capture_product(apart.view(), splat.view(), k, {.bound = false});
    EXPECT_EQ(alone.value, mixed.value) << k;
    for (int c = 0; c < 3; ++c) {
      const double exact_self = dense(apart_grids[k], apart_grids[k], c);
      EXPECT_LE(std::abs(targeted.value[c] - exact_self),
                targeted.bound[c] * 1.0001 + 1e-6 * exact_self)
          << k << " " << c;
      EXPECT_EQ(alone.bound[c], std::numeric_limits<float>::infinity()) << k << " " << c;
    }
  }
  // Captures at different resolutions multiply as the functions they are, each light splatted
  // at its own capture's resolution: against the product of the grids, the coarser one's texels
  // repeated over the finer one's (they were refused, whenever either held lights).
  std::vector<Grid> fine_grids(points.size());
  options.capture.resolution = 64;
  options.capture.compact_lights = CaptureOptions::CompactLights::apart;
  options.on_grid = [&](std::size_t k, const Grid& grid, std::span<const DirectionalLight> l) {
    fine_grids[k] = grid;
    splat_lights(l, fine_grids[k]);
  };
  const CaptureSet fine = capture_set(env, nullptr, points, options);
  ASSERT_GT(fine.lights.size(), 0u);
  auto across_resolutions = [](const Grid& coarse, const Grid& fine_grid, int c) {
    const int step = fine_grid.resolution / coarse.resolution;
    double sum = 0;
    for (int y = 0; y < fine_grid.resolution; ++y)
      for (int x = 0; x < fine_grid.resolution; ++x)
        sum += double(coarse.at(0, c, x / step, y / step)) * fine_grid.at(0, c, x, y);
    return std::numbers::pi * sum / (double(fine_grid.resolution) * fine_grid.resolution);
  };
  for (std::size_t k = 0; k < points.size(); ++k)
    for (const bool coarse_apart : {true, false}) {
      const CaptureSetView coarse = coarse_apart ? apart.view() : splat.view();
      const Grid& coarse_grid = coarse_apart ? apart_grids[k] : splat_grids[k];
      const Convolution ab = capture_product(coarse, fine.view(), k);
      const Convolution ba = capture_product(fine.view(), coarse, k);
      for (int c = 0; c < 3; ++c) {
        const double exact = across_resolutions(coarse_grid, fine_grids[k], c);
        for (const Convolution& r : {ab, ba})
          EXPECT_LE(std::abs(r.value[c] - exact), r.bound[c] * 1.0001 + 1e-6 * exact)
              << k << " " << c << (coarse_apart ? ", lights apart" : ", lights splatted");
        EXPECT_LT(ab.bound[c], 0.5 * exact) << "a bound too loose to mean anything";
      }
    }
}

TEST(Capture, AnOccludedSunIsNoLight) {
  Image dark(256, 128, 3);
  for (int c = 0; c < 3; ++c)
    dark.at(57, 40, c) = 1e5f;
  const Environment env(dark);
  ASSERT_EQ(env.lights().size(), 1u);
  const Vec3 sun = env.lights()[0].direction;
  // A wall across the sun's side of the point, or across the other side.
  for (const double side : {1.0, -1.0}) {
    const Vec3 a = sun.unitOrthogonal(), b = sun.cross(a);
    const Vec3 centre = side * 0.5 * sun;
    TriangleMesh wall;
    auto corner = [&](double s, double t) {
      const Vec3 p = centre + 10 * (s * a + t * b);
      return std::array<float, 3>{float(p.x()), float(p.y()), float(p.z())};
    };
    wall.vertices = {corner(-1, -1), corner(1, -1), corner(1, 1), corner(-1, 1)};
    wall.triangles = {{0, 1, 2}, {0, 2, 3}};
    wall.emission = {{0, 0, 0}, {0, 0, 0}};
    const EmbreeScene scene(wall);
    const std::vector<DirectionalLight> lights =
        capture(env, &scene, Vec3::Zero(), Frame::from_normal(sun),
                {.resolution = 16, .compact_lights = CaptureOptions::CompactLights::apart})
            .lights;
    EXPECT_EQ(lights.size(), side > 0 ? 0u : 1u) << side;
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
  const Grid a = capture(env, &scene, Vec3::Zero(), f, {.resolution = 32, .seed = 3}, 7).texels;
  const Grid b = capture(env, &scene, Vec3::Zero(), f, {.resolution = 32, .seed = 3}, 7).texels;
  const Grid c = capture(env, &scene, Vec3::Zero(), f, {.resolution = 32, .seed = 4}, 7).texels;
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
      capture(env, nullptr, Vec3::Zero(), Frame::from_normal(Vec3::UnitZ()), {.resolution = 16})
          .texels;
  for (float t : g.texels)
    ASSERT_TRUE(std::isfinite(t) && t >= 0);
}

}  // namespace
}  // namespace basis
