// qtrender end to end: the real executable on scene files written here; bad scenes get one line
// naming the file and no image.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <thread>

#include "basis/io/image_file.h"
#include "support/run_tool.h"
#include "support/temp_dir.h"

namespace basis {
namespace {

using testing::line_count;
using testing::run_tool;
using testing::TempDir;
using testing::write_text;

std::string scene_text(const std::string& camera, const std::string& material) {
  return R"({"camera": )" + camera + R"(,
  "environment": {"constant": [1, 0.9, 0.8]},
  "meshes": [{"obj": ")" +
         std::string(BASIS_SOURCE_DIR) + R"(/data/scene.obj", "material": ")" + material +
         R"("}]})";
}

const std::string kCamera =
    R"({"eye": [0, -9, 4], "look_at": [0, 0, 0.7], "up": [0, 0, 1], "fov": 40, "width": 24,
    "height": 18})";

TEST(QtrenderCli, RendersAnExrAndAPngAndReportsTimesAsJson) {
  TempDir dir;
  write_text(dir.file("m.json"), R"({"model": "phong", "kd": 0.5, "ks": 0.4, "exponent": 40,
    "table": {"wo_res": 17, "wi_res": 32}})");
  write_text(dir.file("s.json"), scene_text(kCamera, "m.json"));
  const auto mc = run_tool("qtrender", {dir.file("s.json"), "--method", "mc", "--spp", "1024", "-o",
                                        dir.file("mc.exr"), "--json"});
  ASSERT_EQ(mc.status, 0) << mc.err;
  const auto j = nlohmann::json::parse(mc.out);
  EXPECT_EQ(j["spp"], 1024);
  EXPECT_GT(j["total_s"].get<double>(), 0);
  const Image image = read_image(dir.file("mc.exr"));
  EXPECT_EQ(image.width, 24);
  EXPECT_EQ(image.height, 18);
  EXPECT_TRUE(std::filesystem::exists(dir.file("mc.png")));
  // Under a constant sky of (1, 0.9, 0.8) nothing reflects more than the sky's radiance times
  // the BRDF's albedo (at most kd + ks = 0.9), and the sky itself shows where rays miss.
  for (std::size_t i = 0; i < image.pixels.size(); i += 3) {
    EXPECT_LE(image.pixels[i], 1.0 + 1e-6);
    EXPECT_LE(image.pixels[i + 2], 0.8 + 1e-6);
  }

  // A record at every pixel (radii of half a pixel): what is left is the table's and the
  // records' own error, and the Monte Carlo image's noise.
  const auto cache = run_tool(
      "qtrender", {dir.file("s.json"), "-o", dir.file("cache.exr"), "--compare", dir.file("mc.exr"),
                   "--json", "-q", "--max-spacing", "0.5", "--min-spacing", "0.5"});
  ASSERT_EQ(cache.status, 0) << cache.err;
  const auto c = nlohmann::json::parse(cache.out);
  for (const char* key : {"total_s", "primary_s", "record_tracing_s", "projection_s",
                          "convolution_s", "interpolation_s", "records", "relmse", "rmse"})
    EXPECT_TRUE(c.contains(key)) << key;
  EXPECT_GT(c["records"].get<int>(), 0);
  EXPECT_EQ(c["records"].get<int>(), c["compared_pixels"].get<int>());
  EXPECT_LT(c["relmse"].get<double>(), 0.005);
  // The spec's table was cached beside it.
  EXPECT_TRUE(std::filesystem::exists(dir.file("m.table.qt")));
  // The same render again, a second later and on one thread, gives the same bytes: the images
  // carry no time of writing (OpenEXR's capDate).
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));
  for (const std::string threads : {"1", "2"}) {
    const auto again = run_tool(
        "qtrender", {dir.file("s.json"), "-o", dir.file("again" + threads + ".exr"),
                     "--max-spacing", "0.5", "--min-spacing", "0.5", "--threads", threads, "-q"});
    ASSERT_EQ(again.status, 0) << again.err;
    EXPECT_EQ(testing::slurp(dir.file("again" + threads + ".exr")),
              testing::slurp(dir.file("cache.exr")));
  }
  EXPECT_EQ(testing::slurp(dir.file("again1.png")), testing::slurp(dir.file("again2.png")));
}

// The files a scene names are inputs: an output onto one is bad usage (-o onto its material
// replaced it with the render), and a table of someone else's where a spec's table would be
// cached is kept (it was replaced by the cache).
TEST(QtrenderCli, TheFilesASceneNamesAreKept) {
  TempDir dir;
  write_text(dir.file("m.json"), R"({"model": "lambert", "albedo": 0.5,
    "table": {"wo_res": 3, "wi_res": 8}})");
  write_text(dir.file("s.json"), scene_text(kCamera, "m.json"));
  Image sky(16, 8, 3);
  for (float& p : sky.pixels)
    p = 1;
  write_image(dir.file("env.exr"), sky);
  const std::string map = testing::slurp(dir.file("env.exr"));
  write_text(dir.file("lit.json"), R"({"camera": )" + kCamera + R"(,
  "environment": {"map": ")" + dir.file("env.exr") +
                                       R"("},
  "meshes": [{"obj": ")" + std::string(BASIS_SOURCE_DIR) +
                                       R"(/data/scene.obj", "material": "m.json"}]})");
  const auto onto = run_tool("qtrender", {dir.file("lit.json"), "--method", "mc", "--spp", "1",
                                          "-o", dir.file("env.exr")});
  EXPECT_EQ(onto.status, 2) << onto.err;
  EXPECT_NE(onto.err.find("is the file " + dir.file("lit.json") + " reads"), std::string::npos)
      << onto.err;
  EXPECT_EQ(testing::slurp(dir.file("env.exr")), map);
  // A table brdf2qt made, of another spec, under the cache's name.
  write_text(dir.file("other.json"), R"({"model": "lambert", "albedo": 0.25})");
  ASSERT_EQ(run_tool("brdf2qt",
                     {"other.json", "--wo-res", "3", "--wi-res", "8", "-q", "-o", "m.table.qt"},
                     dir.path())
                .status,
            0);
  const std::string table = testing::slurp(dir.file("m.table.qt"));
  const auto cached =
      run_tool("qtrender", {dir.file("s.json"), "--max-spacing", "4", "-o", dir.file("c.exr")});
  ASSERT_EQ(cached.status, 0) << cached.err;
  EXPECT_EQ(testing::slurp(dir.file("m.table.qt")), table);
  EXPECT_NE(cached.err.find("a file qtrender did not write, or that does not load, left as it is"),
            std::string::npos)
      << cached.err;
}

TEST(QtrenderCli, BadScenesGetOneLineAndNoImage) {
  TempDir dir;
  write_text(dir.file("m.json"), R"({"model": "lambert", "albedo": 0.5})");
  write_text(dir.file("broken.json"), R"({"model": "phong", "ks": 2})");
  const std::string nowhere =
      R"({"eye": [1, 1, 1], "look_at": [1, 1, 1], "fov": 40, "width": 8, "height": 8})";
  const std::string empty =
      R"({"eye": [0, -9, 4], "look_at": [0, 0, 0], "fov": 40, "width": 0, "height": 8})";
  write_text(dir.file("nowhere.json"), scene_text(nowhere, "m.json"));
  write_text(dir.file("empty.json"), scene_text(empty, "m.json"));
  write_text(dir.file("material.json"), scene_text(kCamera, "broken.json"));
  write_text(dir.file("mesh.json"), R"({"camera": )" + kCamera + R"(,
    "environment": {"constant": 1}, "meshes": [{"obj": "gone.obj", "material": "m.json"}]})");
  write_text(dir.file("map.json"), R"({"camera": )" + kCamera + R"(,
    "environment": {"map": "gone.exr"}, "meshes": [{"obj": "x.obj", "material": "m.json"}]})");
  for (const std::string name : {"nowhere", "empty", "material", "mesh", "map", "absent"}) {
    const std::string out = dir.file(name + ".exr");
    const auto r = run_tool("qtrender", {dir.file(name + ".json"), "-o", out, "--method", "mc"});
    EXPECT_EQ(r.status, 1) << name << ": " << r.err;
    EXPECT_EQ(line_count(r.err), 1) << name << ": " << r.err;
    const std::string named = name == "map"        ? "gone.exr"
                              : name == "material" ? "broken.json"
                              : name == "mesh"     ? "gone.obj"
                                                   : name + ".json";
    EXPECT_NE(r.err.find(named), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(out)) << name;
  }
  // The EXR and its PNG are one output: when the PNG cannot be written (a folder in its place),
  // neither is, and nothing temporary is left.
  write_text(dir.file("good.json"), scene_text(kCamera, "m.json"));
  std::filesystem::create_directory(dir.file("good.png"));
  const auto both = run_tool("qtrender", {dir.file("good.json"), "-o", dir.file("good.exr"),
                                          "--method", "mc", "--spp", "1"});
  EXPECT_EQ(both.status, 1) << both.err;
  EXPECT_NE(both.err.find("good.png"), std::string::npos) << both.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("good.exr")));
  for (const auto& entry : std::filesystem::directory_iterator(dir.path()))
    EXPECT_EQ(entry.path().filename().string().find(".partial"), std::string::npos) << entry.path();
  // An image on a full disk, which a link to the full device stands for: the EXR writer did not
  // report the failed write, and the image was put in place cut, with exit 0.
  std::filesystem::create_symlink("/dev/full", dir.file("full.exr"));
  const auto full = run_tool("qtrender", {dir.file("good.json"), "-o", dir.file("full.exr"),
                                          "--method", "mc", "--spp", "1"});
  EXPECT_EQ(full.status, 1) << full.err;
  EXPECT_NE(full.err.find("full.exr: No space left on device"), std::string::npos) << full.err;
  // A missing folder is named as the output, not as a temporary.
  const auto missing = run_tool("qtrender", {dir.file("good.json"), "-o", dir.file("no/such/o.exr"),
                                             "--method", "mc", "--spp", "1"});
  EXPECT_EQ(missing.status, 1) << missing.err;
  EXPECT_NE(missing.err.find("no/such/o.exr: "), std::string::npos) << missing.err;
  EXPECT_EQ(missing.err.find(".partial"), std::string::npos) << missing.err;
  const auto usage = run_tool("qtrender", {dir.file("nowhere.json"), "-o", dir.file("x.png")});
  EXPECT_EQ(usage.status, 2);
  const auto help = run_tool("qtrender", {"--help"});
  EXPECT_EQ(help.status, 0);
  EXPECT_NE(help.out.find("radiance cache"), std::string::npos);
}

// Radiance near the largest float, a map of one pixel and a reference with NaN: one line that
// names the file, and no image (never one with infinities).
TEST(QtrenderCli, LightsBeyondFloatsAndBadReferencesNameTheirFile) {
  TempDir dir;
  write_text(dir.file("m.json"), R"({"model": "lambert", "albedo": 0.5})");
  // Under a constant 3e38 the records' error bounds overflow; so do some of Monte Carlo's
  // samples of the paper's BRDF (f cos / pdf above 1), at one sample per pixel.
  write_text(dir.file("p.json"), R"({"model": "phong", "kd": 0.5, "ks": 0.4, "exponent": 100})");
  for (const std::string material : {"m", "p"})
    write_text(dir.file("bright_" + material + ".json"), R"({"camera": )" + kCamera + R"(,
      "environment": {"constant": [3e38, 3e38, 3e38]},
      "meshes": [{"obj": ")" + std::string(BASIS_SOURCE_DIR) +
                                                             R"(/data/scene.obj", "material": ")" +
                                                             material + R"(.json"}]})");
  write_image(dir.file("one_pixel.exr"), Image(1, 1, 3));
  write_text(dir.file("dot.json"), R"({"camera": )" + kCamera + R"(,
    "environment": {"map": "one_pixel.exr"}, "meshes": [{"obj": "x.obj", "material": "m.json"}]})");
  write_text(dir.file("good.json"), scene_text(kCamera, "m.json"));
  Image reference(24, 18, 3);
  reference.at(3, 4, 1) = std::nanf("");
  write_image(dir.file("nan_reference.exr"), reference);
  struct Case {
    std::vector<std::string> args;
    std::string named;
  };
  for (const Case& k : std::vector<Case>{
           {{"bright_p.json", "--method", "mc", "--spp", "1"}, "bright_p.json: "},
           {{"bright_m.json", "--method", "cache"}, "bright_m.json: "},
           {{"dot.json", "--method", "mc"}, "one_pixel.exr: "},
           {{"good.json", "--method", "mc", "--compare", dir.file("nan_reference.exr")},
            "nan_reference.exr: 1 NaN"}}) {
    std::vector<std::string> args = k.args;
    args[0] = dir.file(args[0]);
    args.insert(args.end(), {"-o", dir.file("out.exr"), "-q"});
    const auto r = run_tool("qtrender", args);
    EXPECT_EQ(r.status, 1) << k.args[0] << ": " << r.err;
    EXPECT_EQ(line_count(r.err), 1) << k.args[0] << ": " << r.err;
    EXPECT_NE(r.err.find(k.named), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir.file("out.exr"))) << k.args[0];
    EXPECT_FALSE(std::filesystem::exists(dir.file("out.png"))) << k.args[0];
  }
}

TEST(QtrenderCli, AnInterruptedRenderWritesNothing) {
  TempDir dir;
  write_text(dir.file("m.json"), R"({"model": "lambert", "albedo": 0.5})");
  write_text(dir.file("s.json"), scene_text(kCamera, "m.json"));
  const auto r = run_tool(
      "qtrender",
      {dir.file("s.json"), "--method", "mc", "--spp", "1000000", "-o", dir.file("out.exr")}, "",
      500);
  EXPECT_EQ(r.status, 130) << r.err;
  EXPECT_EQ(line_count(r.err), 1) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("out.exr")));
  EXPECT_FALSE(std::filesystem::exists(dir.file("out.png")));
}

}  // namespace
}  // namespace basis
