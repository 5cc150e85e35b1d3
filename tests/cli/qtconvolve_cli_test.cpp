// qtconvolve end to end: reflected radiance of glossy BRDFs under a real map with a sun against
// direct integration over the map's pixels; certified bounds against full-resolution
// references; tilted normals against the exactly rotated integral; mismatched inputs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

#include "basis/brdf/brdf_spec.h"
#include "basis/core/tilt.h"
#include "basis/format/qt_file.h"
#include "basis/lighting/capture.h"
#include "support/environments.h"
#include "support/merl_file.h"
#include "support/reflection_reference.h"
#include "support/run_tool.h"
#include "support/temp_dir.h"

namespace basis {
namespace {

using testing::run_tool;
using testing::TempDir;

// A real HDR map with a sun: the Poly Haven sunrise from Debian's blender-data, which the
// set-up installs; a generated sky with a sun when it is absent.
std::string sun_map(const TempDir& dir) {
  const std::string sunrise = "/usr/share/blender/datafiles/studiolights/world/sunrise.exr";
  if (std::filesystem::exists(sunrise)) return sunrise;
  std::printf("[  NOTE    ] %s is absent: a generated sky with a sun is used\n", sunrise.c_str());
  write_image(dir.file("sky.exr"), testing::synthetic_sky(5e4f));
  return dir.file("sky.exr");
}

nlohmann::json convolve_json(const TempDir& dir, std::vector<std::string> args) {
  args.push_back("--json");
  const auto r = run_tool("qtconvolve", args, dir.path());
  EXPECT_EQ(r.status, 0) << r.err;
  return nlohmann::json::parse(r.out);
}

Vec3 direction(double theta_degrees, double phi_degrees) {
  const double t = theta_degrees * std::numbers::pi / 180, p = phi_degrees * std::numbers::pi / 180;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

std::string triple(const Vec3& v) {
  return std::to_string(v.x()) + "," + std::to_string(v.y()) + "," + std::to_string(v.z());
}

// Default tables (33 x 33 x 128 x 128) and captures (128 x 128), the sun kept apart as a
// directional light and shaded with the BRDF at its direction. (Splatted into its texel, the
// sun cost GGX 0.2 up to 5 %: near the horizon a texel spans 6 degrees of elevation, over which
// f varies by several percent.) One test per BRDF, so that they run in parallel.
struct Glossy {
  std::string name, spec;
  double tolerance;
};

void PrintTo(const Glossy& glossy, std::ostream* out) {
  *out << glossy.name;
}

class GlossyReflections : public ::testing::TestWithParam<Glossy> {};

TEST_P(GlossyReflections, OfASunMatchDirectIntegration) {
  const auto& [name, spec, tolerance] = GetParam();
  TempDir dir;
  const std::string map = sun_map(dir);
  const auto samples = testing::map_samples(Environment(read_image(map)), 1);
  ASSERT_EQ(run_tool("capture2qt",
                     {"--env", map, "--at", "0,0,0", "--normal", "0,0,1", "-o", "sky.qt", "-q"},
                     dir.path())
                .status,
            0);
  const Frame frame = Frame::from_normal(Vec3::UnitZ());
  std::ofstream(dir.file(name + ".json")) << spec;
  ASSERT_EQ(run_tool("brdf2qt", {name + ".json", "-q", "--no-tilt"}, dir.path()).status, 0);
  const Brdf brdf = parse_brdf_spec(spec, name, "").brdf;
  double worst = 0;
  for (const double theta : {0.0, 25.0, 50.0, 70.0})
    for (const double phi : {10.0, 130.0, 250.0}) {
      const Vec3 wo = direction(theta, phi);
      const auto j = convolve_json(dir, {name + ".qt", "sky.qt", "--wo", triple(wo)});
      const Color exact = testing::exact_reflection_rgb(samples, brdf, frame, wo);
      for (int c = 0; c < 3; ++c) {
        const double value = j["results"][0]["value"][c].get<double>();
        EXPECT_NEAR(value, exact[c], tolerance * exact[c])
            << name << " theta " << theta << " phi " << phi << " channel " << c;
        worst = std::max(worst, std::abs(value - exact[c]) / exact[c]);
      }
    }
  std::printf("[  GLOSSY  ] %s under %s: largest relative error %.4f\n", name.c_str(),
              std::filesystem::path(map).filename().c_str(), worst);
}

INSTANTIATE_TEST_SUITE_P(
    QtconvolveCli, GlossyReflections,
    ::testing::Values(
        Glossy{"phong40", R"({"model": "phong", "kd": 0.2, "ks": 0.6, "exponent": 40})", 0.006},
        Glossy{"ggx", R"({"model": "ggx", "kd": 0.1, "f0": 0.9, "alpha": 0.2})", 0.006},
        Glossy{"blinn100", R"({"model": "blinn-phong", "kd": 0.2, "ks": 0.6, "exponent": 100})",
               0.006}),
    [](const ::testing::TestParamInfo<Glossy>& info) { return info.param.name; });

// Off the grid's rows wo reads four entries, folded into one tree for the batch, whose bound the
// reference checks as well.
TEST(QtconvolveCli, CertifiedBoundHoldsAgainstTheFullResolutionReference) {
  TempDir dir;
  const std::string map = sun_map(dir);
  const std::string scene = std::string(BASIS_SOURCE_DIR) + "/data/scene.obj";
  std::ofstream(dir.file("glossy.json"))
      << R"({"model": "phong", "kd": 0.4, "ks": 0.5, "exponent": 60})";
  ASSERT_EQ(
      run_tool("brdf2qt", {"glossy.json", "--wo-res", "5", "--wi-res", "32", "-q"}, dir.path())
          .status,
      0);
  ASSERT_EQ(run_tool("capture2qt",
                     {"--env", map, "--scene", scene, "--sample", "24", "--res", "32",
                      "--tolerance", "0.2", "-o", "points.qt", "-q"},
                     dir.path())
                .status,
            0);
  const auto info = run_tool("qtinfo", {"points.qt", "--json"}, dir.path());
  ASSERT_GT(nlohmann::json::parse(info.out)["captures"]["points_with_lights"].get<int>(), 0);
  // The directional lights (the sun) shaded with the BRDF or with the table's texels. With the
  // BRDF the reference evaluates the lights as the lookup does (the glossy test checks that
  // term against the map); with the table the bound must cover the entries' leaves there.
  for (const std::string lights : {"brdf", "table"})
    for (const std::string wo : {"0,0,1", "0.6,0.3,0.74"}) {
      const auto j = convolve_json(
          dir, {"glossy.qt", "points.qt", "--wo", wo, "--reference", "--lights", lights, "-q"});
      ASSERT_EQ(j["results"].size(), 24u);
      // The dense product of the trees' reconstructions (a second implementation, one grid for
      // the table at wo) gives the trees' values up to their halves' rounding.
      const auto dense = convolve_json(
          dir, {"glossy.qt", "points.qt", "--wo", wo, "--dense", "--lights", lights, "-q"});
      // Values alone: the same descent, so the same values, and no bound printed.
      const auto alone = convolve_json(
          dir, {"glossy.qt", "points.qt", "--wo", wo, "--no-bound", "--lights", lights, "-q"});
      for (std::size_t k = 0; k < 24; ++k) {
        const auto& r = j["results"][k];
        EXPECT_EQ(alone["results"][k]["value"], r["value"]) << "point " << k << " wo " << wo;
        EXPECT_FALSE(alone["results"][k].contains("bound"));
        // The dense product certifies nothing: it prints no bound (it printed zeros).
        EXPECT_FALSE(dense["results"][k].contains("bound"));
        for (int c = 0; c < 3; ++c) {
          // The error against the reference, computed here rather than read from the tool.
          const double value = r["value"][c].get<double>();
          const double difference = std::abs(value - r["reference"][c].get<double>());
          const double bound = r["bound"][c].get<double>();
          EXPECT_LE(difference, bound * (1 + 1e-4) + 1e-6 * r["reference"][c].get<double>())
              << "point " << r["index"] << " channel " << c;
          EXPECT_NEAR(dense["results"][k]["value"][c].get<double>(), value, 4e-3 * std::abs(value))
              << "point " << r["index"] << " channel " << c << " wo " << wo;
        }
      }
      // Accuracy targets stop pairs early: the bound still holds against the reference, and it
      // grows past the full descent's by at most about the target's share of the value.
      for (const double accuracy : {0.05, 0.2}) {
        const auto targeted =
            convolve_json(dir, {"glossy.qt", "points.qt", "--wo", wo, "--reference", "--lights",
                                lights, "--accuracy", std::to_string(accuracy), "-q"});
        ASSERT_EQ(targeted["results"].size(), 24u);
        int looser = 0;  // values whose bound the target let grow: the target took effect
        for (std::size_t k = 0; k < 24; ++k)
          for (int c = 0; c < 3; ++c) {
            const auto& r = targeted["results"][k];
            const double value = r["value"][c].get<double>();
            const double reference = r["reference"][c].get<double>();
            const double bound = r["bound"][c].get<double>();
            EXPECT_LE(std::abs(value - reference), bound * (1 + 1e-4) + 1e-6 * reference)
                << "accuracy " << accuracy << " point " << k << " channel " << c << " wo " << wo;
            const double full_bound = j["results"][k]["bound"][c].get<double>();
            EXPECT_LE(bound, full_bound + 1.25 * accuracy * std::abs(value))
                << "accuracy " << accuracy << " point " << k << " channel " << c << " wo " << wo;
            looser += bound > full_bound * 1.01;
          }
        // At the normal 9 or 10 of the 72 values at 0.05, elsewhere 31 to 72.
        EXPECT_GE(looser, 72 / 10) << "accuracy " << accuracy << " wo " << wo;
      }
    }
}

// The product of a capture with a capture of a unit sky is the irradiance, whether the sun is
// kept apart or splatted: against the map's irradiance summed over its pixels.
TEST(QtconvolveCli, CaptureProductsCountLightsInTheirTexels) {
  TempDir dir;
  const std::string map = sun_map(dir);
  const Environment environment(read_image(map));
  ASSERT_EQ(environment.lights().size(), 1u);
  const Vec3 sun = environment.lights()[0].direction;
  const Vec3 normal = (sun + Vec3(0, 0, 2)).normalized();  // facing the sun's side
  auto capture_to = [&](std::vector<std::string> args, const std::string& output) {
    args.insert(args.end(), {"--at", "0,0,0", "--normal", triple(normal), "-o", output, "-q"});
    ASSERT_EQ(run_tool("capture2qt", args, dir.path()).status, 0) << output;
  };
  capture_to({"--env", map}, "apart.qt");
  capture_to({"--env", map, "--splat-lights"}, "splat.qt");
  capture_to({"--env-constant", "1,1,1"}, "ones.qt");
  const Color irradiance = environment.irradiance(normal);
  for (const std::string file : {"apart.qt", "splat.qt"}) {
    const auto info = nlohmann::json::parse(run_tool("qtinfo", {file, "--json"}, dir.path()).out);
    // Kept apart, the sun (wider than a degree) is the four quarters of its extent.
    EXPECT_EQ(info["captures"]["lights"].get<int>(), file == "apart.qt" ? 4 : 0);
    for (const auto& order : {std::vector<std::string>{file, "ones.qt"}, {"ones.qt", file}}) {
      const auto j = convolve_json(dir, order);
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(j["results"][0]["value"][c].get<double>(), irradiance[c], 0.01 * irradiance[c])
            << file << " channel " << c;
    }
  }
}

TEST(QtconvolveCli, TiltedNormalsAreCompensatedWithinTheDocumentedAccuracy) {
  TempDir dir;
  const std::string map = sun_map(dir);
  const auto samples = testing::map_samples(Environment(read_image(map)), 1);
  std::ofstream(dir.file("paper.json"))
      << R"({"model": "phong", "kd": 0.5, "ks": 0.4, "exponent": 100})";
  ASSERT_EQ(run_tool("brdf2qt", {"paper.json", "-q"}, dir.path()).status, 0);
  // A surface facing the sun's side (the sunrise's sun is 8 degrees above the horizon at
  // azimuth 216 degrees): light close to either horizon is what a tilt moves in or out of the
  // hemisphere the capture saw, which no compensation can restore (README).
  const double azimuth = 216 * std::numbers::pi / 180, elevation = 50 * std::numbers::pi / 180;
  const Vec3 record_normal(std::cos(elevation) * std::cos(azimuth),
                           std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
  ASSERT_EQ(run_tool("capture2qt",
                     {"--env", map, "--at", "0,0,0", "--normal", triple(record_normal), "-o",
                      "record.qt", "-q"},
                     dir.path())
                .status,
            0);
  const Brdf brdf = Phong{{0.5, 0.5, 0.5}, {0.4, 0.4, 0.4}, 100};
  const Frame record = Frame::from_normal(record_normal);
  // Documented accuracy in general (README): compensated within 1 % up to 5 degrees, 2 % at 10
  // degrees. This surface's mean errors measure 0.02, 0.12 and 0.57 % (the sun, kept apart,
  // turns with the surface exactly), and are held to a little above those.
  const std::map<double, double> limit = {{2, 0.001}, {5, 0.003}, {10, 0.008}};
  for (const double degrees : {2.0, 5.0, 10.0}) {
    double error_none = 0, error_compensated = 0;
    int count = 0;
    for (const double axis : {0.0, 120.0, 240.0})
      for (const double wo_theta : {0.0, 40.0}) {
        const double t = degrees * std::numbers::pi / 180, a = axis * std::numbers::pi / 180;
        const Tilt tilt{t * std::cos(a), t * std::sin(a)};
        const Frame shading = tilted_frame(record, tilt);
        const Vec3 wo = direction(wo_theta, 70);
        const double exact = testing::exact_reflection_rgb(samples, brdf, shading, wo)[1];
        auto value = [&](const std::string& mode) {
          const auto j =
              convolve_json(dir, {"paper.qt", "record.qt", "--normal", triple(shading.normal),
                                  "--wo", triple(wo), "--tilt", mode});
          return j["results"][0]["value"][1].get<double>();
        };
        error_none += std::abs(value("none") - exact) / exact;
        error_compensated += std::abs(value("compensated") - exact) / exact;
        ++count;
      }
    error_none /= count;
    error_compensated /= count;
    std::printf("[  TILT    ] %4.1f degrees: mean error none %.4f, compensated %.4f\n", degrees,
                error_none, error_compensated);
    EXPECT_LT(error_compensated, limit.at(degrees)) << degrees;
    EXPECT_LT(error_compensated, error_none) << degrees;
  }
}

// In dir: p.qt, a table of a Phong lobe (exponent 20) at 5^2 directions, 16^2 texels an entry, and
// sky.qt, one 16^2 capture of the sun map at the origin.
void make_lobe_and_sky(const TempDir& dir) {
  std::ofstream(dir.file("p.json")) << R"({"model": "phong", "kd": 0, "ks": 1, "exponent": 20})";
  ASSERT_EQ(
      run_tool("brdf2qt", {"p.json", "--wo-res", "5", "--wi-res", "16", "-q"}, dir.path()).status,
      0);
  ASSERT_EQ(run_tool("capture2qt",
                     {"--env", sun_map(dir), "--at", "0,0,0", "--res", "16", "-o", "sky.qt", "-q"},
                     dir.path())
                .status,
            0);
}

TEST(QtconvolveCli, WoIsADirectionWhateverItsLength) {
  TempDir dir;
  // A glossy lobe under the sunrise reflects differently towards wo and towards the normal,
  // and the same towards wo scaled by 1e200 or 1e-300 (whose squared lengths leave the double
  // range): --wo is a direction, whatever its length.
  make_lobe_and_sky(dir);
  if (::testing::Test::HasFatalFailure()) return;
  auto glossy = [&](const std::string& wo) {
    return convolve_json(dir, {"p.qt", "sky.qt", "--wo", wo})["results"][0]["value"][0]
        .get<double>();
  };
  const double towards_wo = glossy("0.6,0,0.8");
  EXPECT_GT(std::abs(towards_wo - glossy("0,0,1")), 1e-3 * towards_wo);
  EXPECT_NEAR(glossy("6e199,0,8e199"), towards_wo, 1e-6 * towards_wo);
  EXPECT_NEAR(glossy("6e-301,0,8e-301"), towards_wo, 1e-6 * towards_wo);
}

// --time measures without changing what is computed (with the bound or without): the same
// results as an untimed run, and, beside --dense, both sides' times and the median of the ratios of
// their runs, taken in pairs whose order swaps from pair to pair.
TEST(QtconvolveCli, TimingKeepsTheResultsAndReportsBothSides) {
  TempDir dir;
  make_lobe_and_sky(dir);
  if (::testing::Test::HasFatalFailure()) return;
  for (const bool dense : {false, true})
    for (const bool alone : {false, true}) {
      std::vector<std::string> args = {"p.qt", "sky.qt", "--wo", "0.6,0,0.8"};
      if (dense) args.push_back("--dense");
      // Untimed, the dense product takes no flag of the trees' (it prints no bound anyway).
      if (alone && !dense) args.push_back("--no-bound");
      const auto untimed = convolve_json(dir, args);
      if (alone && dense) args.push_back("--no-bound");
      args.push_back("--time");
      const auto timed = convolve_json(dir, args);
      EXPECT_EQ(timed["results"], untimed["results"]) << "dense " << dense;
      EXPECT_GT(timed["ns_per_lookup"].get<double>(), 0);
      EXPECT_EQ(timed.contains("tree_ns_per_lookup"), dense);
      EXPECT_EQ(timed.contains("tree_speedup"), dense);
      if (dense) {
        EXPECT_GT(timed["tree_ns_per_lookup"].get<double>(), 0);
        const double speedup = timed["tree_speedup"].get<double>();
        EXPECT_TRUE(std::isfinite(speedup) && speedup > 0) << speedup;
      }
    }
}

// In dir: l.qt, a table of Lambert 0.5 at 3^2 directions, 8^2 texels an entry.
void make_lambert_table(const TempDir& dir) {
  std::ofstream(dir.file("l.json")) << R"({"model": "lambert", "albedo": 0.5})";
  ASSERT_EQ(
      run_tool("brdf2qt", {"l.json", "--wo-res", "3", "--wi-res", "8", "-q"}, dir.path()).status,
      0);
}

// --dense over a table and captures of different resolutions (8^2 entries, 32^2 captures): the
// coarser grid is repeated over the finer's texels, and both evaluations give Lambert 0.5's
// reflection of a unit sky, 0.5, with no bound printed for the dense one.
TEST(QtconvolveCli, DenseProductsOfDifferentResolutionsAndTiltsPastTheSupportedOnes) {
  TempDir dir;
  make_lambert_table(dir);
  if (::testing::Test::HasFatalFailure()) return;
  ASSERT_EQ(
      run_tool("capture2qt",
               {"--env-constant", "1,1,1", "--at", "0,0,0", "--res", "32", "-o", "sky.qt", "-q"},
               dir.path())
          .status,
      0);
  for (const bool dense : {false, true}) {
    std::vector<std::string> args = {"l.qt", "sky.qt", "--wo", "0.3,0.2,0.93"};
    if (dense) args.push_back("--dense");
    const auto j = convolve_json(dir, args);
    ASSERT_EQ(j["results"].size(), 1u) << dense;
    EXPECT_EQ(j["results"][0].contains("bound"), !dense);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(j["results"][0]["value"][c].get<double>(), 0.5, 1e-3) << dense;
  }

  // Tilts past the supported 10 degrees are said once on stderr (the bound does not cover the
  // tilt's error); within them, nothing is.
  const auto tilted =
      run_tool("qtconvolve", {"l.qt", "sky.qt", "--normal", "0.5,0,0.866", "-q"}, dir.path());
  EXPECT_EQ(tilted.status, 0) << tilted.err;
  EXPECT_NE(tilted.err.find("warning: --normal tilts captures by up to 30.0 degrees"),
            std::string::npos)
      << tilted.err;
  EXPECT_EQ(std::count(tilted.err.begin(), tilted.err.end(), '\n'), 1) << tilted.err;
  const auto slight =
      run_tool("qtconvolve", {"l.qt", "sky.qt", "--normal", "0.1,0,1", "-q"}, dir.path());
  EXPECT_EQ(slight.status, 0) << slight.err;
  EXPECT_EQ(slight.err, "");
}

// A capture set of more results than one block (4,096) is computed block by block, also with
// --dense, so that its grids never all sit in memory: every result in order, the dense
// products (a second implementation) the trees' values, and the results past the first block
// those of a run that starts there (a shard).
TEST(QtconvolveCli, LargeSetsAreComputedBlockByBlockAsOneRun) {
  TempDir dir;
  make_lambert_table(dir);
  if (::testing::Test::HasFatalFailure()) return;
  const std::string scene = std::string(BASIS_SOURCE_DIR) + "/data/scene.obj";
  ASSERT_EQ(run_tool("capture2qt",
                     {"--env-constant", "1,0.8,0.6", "--scene", scene, "--sample", "4500", "--res",
                      "8", "--spp", "1", "-o", "many.qt", "-q"},
                     dir.path())
                .status,
            0);
  const auto rows = [&](std::vector<std::string> args) {
    args.insert(args.begin(), {"l.qt", "many.qt", "--wo", "0.3,0.2,0.93", "--csv"});
    const auto r = run_tool("qtconvolve", args, dir.path());
    EXPECT_EQ(r.status, 0) << r.err;
    std::vector<std::vector<double>> table;
    std::istringstream lines(r.out);
    for (std::string line; std::getline(lines, line);) {
      if (line.starts_with("index")) continue;  // the header (a shard after the first has none)
      std::vector<double> row;
      std::istringstream fields(line);
      for (std::string field; std::getline(fields, field, ',');)
        row.push_back(std::stod(field));
      table.push_back(row);
    }
    return table;
  };
  const auto trees = rows({});
  const auto dense = rows({"--dense"});
  const auto second_block = rows({"--shard", "1/2"});  // results 2,250 .. 4,499
  ASSERT_EQ(trees.size(), 4500u);
  ASSERT_EQ(dense.size(), 4500u);
  ASSERT_EQ(second_block.size(), 2250u);
  for (std::size_t k = 0; k < trees.size(); ++k) {
    ASSERT_EQ(trees[k].size(), 7u) << k;  // index, value and bound
    ASSERT_EQ(dense[k].size(), 4u) << k;  // index and value
    EXPECT_EQ(trees[k][0], double(k));
    EXPECT_EQ(dense[k][0], double(k));
    // The dense product of the trees' reconstructions: the trees' values up to the rounding of
    // their shared-exponent words, 2^-9 of the largest channel (4e-3 as elsewhere).
    const double largest = std::max({trees[k][1], trees[k][2], trees[k][3]});
    for (int c = 1; c <= 3; ++c)
      EXPECT_NEAR(dense[k][c], trees[k][c], 4e-3 * largest) << "result " << k << " channel " << c;
    if (k >= 2250) {
      EXPECT_EQ(second_block[k - 2250], trees[k]) << k;
    }
  }
}

// A capture set records its map as capture2qt was given it; --reference re-reads it. From a
// folder where that relative path leads nowhere: one line naming the captures and the map, no
// header or results; from the folder it was captured in, the reference is computed.
TEST(QtconvolveCli, AReferenceWhoseMapIsGoneNamesIt) {
  TempDir dir;
  make_lambert_table(dir);
  if (::testing::Test::HasFatalFailure()) return;
  Image map(16, 8, 3);
  for (float& p : map.pixels)
    p = 1;
  write_image(dir.file("flat.exr"), map);
  ASSERT_EQ(
      run_tool("capture2qt",
               {"--env", "flat.exr", "--at", "0,0,0", "--res", "8", "-o", "c.qt", "-q"}, dir.path())
          .status,
      0);
  std::filesystem::create_directories(dir.file("elsewhere"));
  const auto gone =
      run_tool("qtconvolve", {"../l.qt", "../c.qt", "--reference", "-q"}, dir.file("elsewhere"));
  EXPECT_EQ(gone.status, 1) << gone.err;
  EXPECT_EQ(testing::line_count(gone.err), 1) << gone.err;
  EXPECT_NE(gone.err.find("../c.qt: cannot read what it was captured from (flat.exr"),
            std::string::npos)
      << gone.err;
  EXPECT_NE(gone.err.find("relative paths are read from the current folder"), std::string::npos)
      << gone.err;
  EXPECT_EQ(gone.out, "");
  // The same for a measured table whose data file is gone: the table is named.
  std::filesystem::create_directories(dir.file("measured"));
  testing::write_merl_samples(dir.file("measured/grey.binary"),
                              std::vector<double>(testing::kMerlSamples, 0.1));
  std::ofstream(dir.file("measured/grey.json")) << R"({"model": "merl", "file": "grey.binary"})";
  ASSERT_EQ(run_tool("brdf2qt",
                     {"measured/grey.json", "-o", "measured/grey.qt", "--wo-res", "3", "--wi-res",
                      "8", "--no-tilt", "-q"},
                     dir.path())
                .status,
            0);
  std::filesystem::remove(dir.file("measured/grey.binary"));
  const auto data_gone =
      run_tool("qtconvolve", {"measured/grey.qt", "c.qt", "--reference", "-q"}, dir.path());
  EXPECT_EQ(data_gone.status, 1) << data_gone.err;
  EXPECT_EQ(testing::line_count(data_gone.err), 1) << data_gone.err;
  EXPECT_NE(data_gone.err.find("measured/grey.qt: cannot read the BRDF it was tabulated from ("),
            std::string::npos)
      << data_gone.err;
  EXPECT_NE(data_gone.err.find("grey.binary"), std::string::npos) << data_gone.err;
  EXPECT_EQ(data_gone.out, "");
  // Under a sun kept apart, the missing data file is a warning (the lights take the table's
  // texels): one line when the run succeeds, none before an error.
  ASSERT_EQ(run_tool("capture2qt",
                     {"--env", sun_map(dir), "--at", "0,0,0", "--res", "8", "-o", "sun.qt", "-q"},
                     dir.path())
                .status,
            0);
  const auto warned = run_tool("qtconvolve", {"measured/grey.qt", "sun.qt", "-q"}, dir.path());
  EXPECT_EQ(warned.status, 0) << warned.err;
  EXPECT_EQ(testing::line_count(warned.err), 1) << warned.err;
  EXPECT_NE(warned.err.find("qtconvolve: warning: "), std::string::npos) << warned.err;
  EXPECT_NE(warned.err.find("grey.binary"), std::string::npos) << warned.err;
  const auto failed =
      run_tool("qtconvolve", {"measured/grey.qt", "sun.qt", "--reference", "-q"}, dir.path());
  EXPECT_EQ(failed.status, 1) << failed.err;
  EXPECT_EQ(testing::line_count(failed.err), 1) << failed.err;
  EXPECT_EQ(failed.err.find("warning"), std::string::npos) << failed.err;
  EXPECT_EQ(failed.out, "");
  const auto here = convolve_json(dir, {"l.qt", "c.qt", "--reference"});
  // Lambert 0.5 under a unit sky reflects 0.5; the reference is computed in floats.
  EXPECT_NEAR(here["results"][0]["reference"][0].get<double>(), 0.5, 1e-5);
}

TEST(QtconvolveCli, MismatchedInputsAreClearErrors) {
  TempDir dir;
  make_lambert_table(dir);
  if (::testing::Test::HasFatalFailure()) return;
  ASSERT_EQ(
      run_tool("capture2qt",
               {"--env-constant", "1,1,1", "--at", "0,0,0", "--res", "8", "-o", "one.qt", "-q"},
               dir.path())
          .status,
      0);
  ASSERT_EQ(
      run_tool("capture2qt",
               {"--env-constant", "1,1,1", "--at", "1,0,0", "--res", "8", "-o", "other.qt", "-q"},
               dir.path())
          .status,
      0);
  // Lambert 0.5 under a unit sky reflects 0.5 at any wo, to the half precision trees store
  // values in (2^-11 relative).
  const auto ok = convolve_json(dir, {"l.qt", "one.qt", "--wo", "0.3,0.4,0.866"});
  EXPECT_NEAR(ok["results"][0]["value"][0].get<double>(), 0.5, 0.5 * 0x1p-11);
  const auto twice = convolve_json(dir, {"one.qt", "one.qt"});
  EXPECT_NEAR(twice["results"][0]["value"][0].get<double>(), std::numbers::pi, 1e-5);
  // Without the bound: the same values, no bound in any output form.
  const auto twice_alone = convolve_json(dir, {"one.qt", "one.qt", "--no-bound"});
  EXPECT_EQ(twice_alone["results"][0]["value"], twice["results"][0]["value"]);
  EXPECT_FALSE(twice_alone["results"][0].contains("bound"));
  for (const bool alone : {false, true}) {
    std::vector<std::string> csv_args = {"l.qt", "one.qt", "--csv"},
                             text_args = {"one.qt", "one.qt"};
    if (alone) {
      csv_args.push_back("--no-bound");
      text_args.push_back("--no-bound");
    }
    const std::string csv = run_tool("qtconvolve", csv_args, dir.path()).out;
    const std::string header = csv.substr(0, csv.find('\n'));
    const std::string row = csv.substr(header.size() + 1);
    EXPECT_EQ(header, alone ? "index,r,g,b" : "index,r,g,b,bound_r,bound_g,bound_b");
    EXPECT_EQ(std::count(row.begin(), row.end(), ','), alone ? 3 : 6) << row;
    const std::string text = run_tool("qtconvolve", text_args, dir.path()).out;
    EXPECT_EQ(text.find("+-") == std::string::npos, alone) << text;
  }
  struct Case {
    std::vector<std::string> args;
    int status;
  };
  for (const Case& k : std::vector<Case>{{{"l.qt", "l.qt"}, 1},
                                         {{"one.qt", "other.qt"}, 1},
                                         {{"l.qt", "one.qt", "--wo", "0,0.5,-0.1"}, 2},
                                         {{"l.qt", "one.qt", "--wo", "0,0,0"}, 2},
                                         {{"one.qt", "one.qt", "--reference"}, 2},
                                         {{"one.qt", "one.qt", "--wo", "0,1,1"}, 2},
                                         {{"l.qt", "one.qt", "--json", "--csv"}, 2},
                                         {{"l.qt", "one.qt", "--no-bound", "--accuracy", "0.1"}, 2},
                                         // A capture tilted past 90 degrees: found while
                                         // shading, before any output.
                                         {{"l.qt", "one.qt", "--normal", "0,0.2,-1"}, 1},
                                         {{"l.qt", "missing.qt"}, 1},
                                         {{"l.qt"}, 2}}) {
    const auto r = run_tool("qtconvolve", k.args, dir.path());
    EXPECT_EQ(r.status, k.status) << k.args[0] << " " << (k.args.size() > 1 ? k.args[1] : "");
    EXPECT_EQ(testing::line_count(r.err), 1) << r.err;
    EXPECT_EQ(r.out, "") << k.args[0];  // an error prints no header and no results
  }
}

}  // namespace
}  // namespace basis
