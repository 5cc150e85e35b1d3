// capture2qt end to end: lights, scenes and points in, capture sets out; bad input refused in
// one line, unrepresentable environment texels counted, interrupts leave nothing.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "basis/format/qt_file.h"
#include "basis/io/image_file.h"
#include "support/run_tool.h"
#include "support/temp_dir.h"

namespace basis {
namespace {

using testing::run_tool;
using testing::TempDir;

// A floor (two triangles, facing +z) and a small box on it, as an OBJ with an emitting lamp.
void write_room(const TempDir& dir) {
  std::ofstream(dir.file("room.mtl")) << "newmtl lamp\nKe 5 5 4\nnewmtl plain\nKd 0.5 0.5 0.5\n";
  std::ofstream(dir.file("room.obj")) << "mtllib room.mtl\n"
                                         "v -5 -5 0\nv 5 -5 0\nv 5 5 0\nv -5 5 0\n"
                                         "v -1 -1 2\nv 1 -1 2\nv 1 1 2\nv -1 1 2\n"
                                         "usemtl plain\nf 1 2 3 4\n"
                                         "usemtl lamp\nf 5 8 7 6\n";
}

TEST(Capture2qtCli, CapturesAPointUnderAConstantLight) {
  TempDir dir;
  const auto r = run_tool("capture2qt",
                          {"--env-constant", "1,2,3", "--at", "0,0,0", "--normal", "0,0,2", "--res",
                           "16", "-o", "one.qt"},
                          dir.path());
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("one.qt: 1 captures of 16 x 16 texels"), std::string::npos) << r.out;
  const QtFile f = QtFile::load(dir.file("one.qt"));
  ASSERT_EQ(f.kind(), QtKind::capture_set);
  EXPECT_EQ(f.captures().size(), 1u);
  EXPECT_EQ(f.captures().normals[0], Vec3(0, 0, 1));
  EXPECT_EQ(f.trees().tree(0).node_count(), 1);  // constant: a single node
  EXPECT_NEAR(integrate(f.trees().tree(0), 0, 2), 3, 1e-6);
  // --json says what was written, quiet or not (-q leaves out progress, warnings and summary).
  const auto quiet = run_tool(
      "capture2qt",
      {"--env-constant", "1,2,3", "--at", "0,0,0", "--res", "16", "-o", "two.qt", "--json", "-q"},
      dir.path());
  ASSERT_EQ(quiet.status, 0) << quiet.err;
  EXPECT_EQ(quiet.err, "");
  const auto j = nlohmann::json::parse(quiet.out);
  EXPECT_EQ(j["output"], "two.qt");
  EXPECT_EQ(j["captures"], 1);
}

TEST(Capture2qtCli, SamplesAnObjSceneDeterministicallyAndDumpsTexels) {
  TempDir dir;
  write_room(dir);
  std::filesystem::create_directories(dir.file("dump"));
  std::filesystem::create_directories(dir.file("dump2"));
  const std::vector<std::string> args = {"--env-constant", "1,1,1", "--scene", "room.obj",
                                         "--sample",       "6",     "--seed",  "9",
                                         "--res",          "16",    "--quiet"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> all = args;
    all.insert(all.end(), extra.begin(), extra.end());
    return all;
  };
  // Each run dumps into a folder of its own: --dump writes only new images.
  ASSERT_EQ(
      run_tool("capture2qt", with({"-o", "a.qt", "--threads", "1", "--dump", "dump"}), dir.path())
          .status,
      0);
  ASSERT_EQ(
      run_tool("capture2qt", with({"-o", "b.qt", "--threads", "2", "--dump", "dump2"}), dir.path())
          .status,
      0);
  EXPECT_EQ(testing::slurp(dir.file("a.qt")), testing::slurp(dir.file("b.qt")));
  const QtFile f = QtFile::load(dir.file("a.qt"));
  ASSERT_EQ(f.captures().size(), 6u);
  for (std::size_t i = 0; i < 6; ++i) {
    const Vec3& p = f.captures().positions[i];
    // Points lie on the floor (z = 0, normal +z) or on the lamp (z = 2, facing down).
    EXPECT_TRUE(std::abs(p[2]) < 1e-6 || std::abs(p[2] - 2) < 1e-6);
    EXPECT_NEAR(std::abs(f.captures().normals[i][2]), 1, 1e-9);
  }
  const Image dumped = read_image(dir.file("dump/capture_00000.exr"));
  EXPECT_EQ(dumped.width, 16);
  EXPECT_EQ(dumped.height, 16);
  EXPECT_EQ(read_image(dir.file("dump2/capture_00005.exr")).pixels,
            read_image(dir.file("dump/capture_00005.exr")).pixels);
}

TEST(Capture2qtCli, ReadsPointFilesAndCompressesImages) {
  TempDir dir;
  std::ofstream(dir.file("points.csv")) << "# x,y,z,nx,ny,nz\n0,0,0,0,0,1\n\n1,2,3,0,3,0\n";
  ASSERT_EQ(run_tool("capture2qt",
                     {"--env-constant", "1,1,1", "--points", "points.csv", "--res", "8", "-q"},
                     dir.path())
                .status,
            0);
  const QtFile f = QtFile::load(dir.file("captures.qt"));
  ASSERT_EQ(f.captures().size(), 2u);
  EXPECT_EQ(f.captures().positions[1], Vec3(1, 2, 3));
  EXPECT_EQ(f.captures().normals[1], Vec3(0, 1, 0));

  Image image(32, 32, 3);
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x)
      for (int c = 0; c < 3; ++c)
        image.at(x, y, c) = x > y ? 2.0f : 0.5f + 0.1f * c;
  write_image(dir.file("capture.exr"), image);
  const auto r = run_tool("capture2qt", {"--image", "capture.exr", "--tolerance", "0"}, dir.path());
  ASSERT_EQ(r.status, 0) << r.err;
  const QtFile tree = QtFile::load(dir.file("capture.qt"));
  ASSERT_EQ(tree.kind(), QtKind::tree);
  // Tolerance 0 keeps every texel, to the precision of the shared-exponent words that captures
  // store texels in: 2^-9 of the texel's largest channel.
  const Grid back = reconstruct(tree.tree());
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) {
      const float largest = std::max({image.at(x, y, 0), image.at(x, y, 1), image.at(x, y, 2)});
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(back.at(0, c, x, y), image.at(x, y, c), largest * 0x1p-9);
    }
}

TEST(Capture2qtCli, RefusesNanAndInfiniteEnvironmentTexelsUnlessAskedToZeroThem) {
  TempDir dir;
  Image env(64, 32, 3);
  for (float& p : env.pixels)
    p = 1;
  env.at(1, 1, 0) = std::nanf("");
  env.at(2, 1, 1) = INFINITY;
  env.at(3, 1, 2) = -4;
  write_image(dir.file("env.exr"), env);
  const auto refused =
      run_tool("capture2qt", {"--env", "env.exr", "--at", "0,0,0", "--res", "8"}, dir.path());
  EXPECT_EQ(refused.status, 1);
  EXPECT_EQ(refused.err,
            "capture2qt: env.exr: 1 NaN and 1 infinite texel values (repair the "
            "map, or pass --zero-invalid to read them as 0)\n");
  EXPECT_FALSE(std::filesystem::exists(dir.file("captures.qt")));

  const auto r =
      run_tool("capture2qt", {"--env", "env.exr", "--at", "0,0,0", "--res", "8", "--zero-invalid"},
               dir.path());
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err,
            "capture2qt: warning: env.exr: 1 NaN, 1 infinite and 1 negative texel values "
            "set to 0\n");
  const QtFile f = QtFile::load(dir.file("captures.qt"));
  EXPECT_TRUE(std::isfinite(integrate(f.trees().tree(0), 0, 0)));

  // Negative texels alone (real maps carry a few from their processing) are read as 0.
  env.at(1, 1, 0) = 1;
  env.at(2, 1, 1) = 1;
  write_image(dir.file("negative.exr"), env);
  const auto negative =
      run_tool("capture2qt", {"--env", "negative.exr", "--at", "0,0,0", "--res", "8", "-o", "n.qt"},
               dir.path());
  ASSERT_EQ(negative.status, 0) << negative.err;
  EXPECT_EQ(negative.err,
            "capture2qt: warning: negative.exr: 0 NaN, 0 infinite and 1 negative "
            "texel values set to 0\n");
}

TEST(Capture2qtCli, BadScenesAndImagesAreOneLineExitOne) {
  TempDir dir;
  std::ofstream(dir.file("nan.obj")) << "v 0 0 0\n  v 1 0 nan\nv 0 1 0\nf 1 2 3\n";  // indented
  std::ofstream(dir.file("range.obj")) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n";
  std::ofstream(dir.file("empty.obj")) << "# nothing\n";
  // An index past 32 bits (which the OBJ reader would wrap round to vertex 3) and one that is
  // not a number.
  std::ofstream(dir.file("wrap.obj")) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4294967299\n";
  std::ofstream(dir.file("word.obj")) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/x 2 3\n";
  std::ofstream(dir.file("cr.obj")) << "v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 4294967299\r";
  std::ofstream(dir.file("bad.csv")) << "0,0,0,0,0,1\n1,2,three,0,0,1\n";
  Image wide(32, 16, 3);
  write_image(dir.file("wide.exr"), wide);
  const std::vector<std::vector<std::string>> cases = {
      {"--env-constant", "1,1,1", "--scene", "nan.obj", "--sample", "3"},
      {"--env-constant", "1,1,1", "--scene", "range.obj", "--sample", "3"},
      {"--env-constant", "1,1,1", "--scene", "empty.obj", "--sample", "3"},
      {"--env-constant", "1,1,1", "--scene", "missing.obj", "--sample", "3"},
      {"--env-constant", "1,1,1", "--points", "bad.csv"},
      {"--env", "missing.hdr", "--at", "0,0,0"},
      {"--env", "bad.csv", "--at", "0,0,0"},
      {"--image", "wide.exr"},
      {"--env-constant", "1,1,1", "--scene", "wrap.obj", "--sample", "3"},
      {"--env-constant", "1,1,1", "--scene", "word.obj", "--sample", "3"},
      {"--env-constant", "1,1,1", "--scene", "cr.obj", "--sample", "3"}};
  for (const auto& args : cases) {
    const auto r = run_tool("capture2qt", args, dir.path());
    EXPECT_EQ(r.status, 1) << args[3] << ": " << r.err;
    EXPECT_EQ(testing::line_count(r.err), 1) << r.err;
  }
  EXPECT_NE(run_tool("capture2qt", cases[0], dir.path()).err.find("nan.obj:2: vertex 2 is NaN"),
            std::string::npos);
  EXPECT_NE(run_tool("capture2qt", cases[1], dir.path()).err.find("uses vertex 9 of 3"),
            std::string::npos);
  EXPECT_NE(run_tool("capture2qt", cases[4], dir.path()).err.find("bad.csv:2:"), std::string::npos);
  EXPECT_NE(run_tool("capture2qt", cases[8], dir.path())
                .err.find("wrap.obj:4: face index '4294967299' is not a vertex number"),
            std::string::npos);
  EXPECT_NE(run_tool("capture2qt", cases[9], dir.path())
                .err.find("word.obj:4: face index 'x' is not a vertex number"),
            std::string::npos);
  // Lines that end at a lone carriage return are checked as the reader splits them.
  EXPECT_NE(run_tool("capture2qt", cases[10], dir.path())
                .err.find("cr.obj:4: face index '4294967299' is not a vertex number"),
            std::string::npos);
  // Two points on a scene under a constant light, at 8 x 8.
  auto capture_scene = [&](const std::string& obj, const std::string& output) {
    return run_tool(
        "capture2qt",
        {"--env-constant", "1,1,1", "--scene", obj, "--sample", "2", "--res", "8", "-o", output},
        dir.path());
  };
  // Signed indices, relative ones and the v/t/n forms are faces, not errors.
  std::ofstream(dir.file("forms.obj"))
      << "v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nvt 0 0\r\nvn 0 0 1\r\n"
         "f +1 +2 +3\r\nf\t-3/1 -2/1 -1/1\r\n  f 1//1 2//1 3//1\r\nf 1/1/1 2/1/1 3/1/1\r\n";
  const auto forms = capture_scene("forms.obj", "forms.qt");
  EXPECT_EQ(forms.status, 0) << forms.err;
  // A degenerate triangle is dropped with a warning.
  std::ofstream(dir.file("flat.obj")) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n";
  const auto flat = capture_scene("flat.obj", "flat.qt");
  EXPECT_EQ(flat.status, 0) << flat.err;
  EXPECT_NE(flat.err.find("1 degenerate triangles dropped"), std::string::npos) << flat.err;
  // A material file that is not there (its emitters would go dark) is warned of.
  std::ofstream(dir.file("lamp.obj")) << "mtllib gone.mtl\nv 0 0 1\nv 1 0 1\nv 0 1 1\n"
                                         "usemtl glow\nf 1 2 3\n";
  const auto lamp = capture_scene("lamp.obj", "lamp.qt");
  EXPECT_EQ(lamp.status, 0) << lamp.err;
  EXPECT_NE(lamp.err.find("capture2qt: warning: lamp.obj: Material file [ gone.mtl ] not found"),
            std::string::npos)
      << lamp.err;
  std::vector<std::string> expected = {"bad.csv",   "cr.obj",   "empty.obj", "flat.obj", "flat.qt",
                                       "forms.obj", "forms.qt", "lamp.obj",  "lamp.qt",  "nan.obj",
                                       "range.obj", "wide.exr", "word.obj",  "wrap.obj"};
  EXPECT_EQ(dir.entries(), expected);
}

// Image files go through a module the tools load on their first image, from the lib folder
// beside their own: a tool copied without it runs as long as it reads no image; a file in the
// module's place that is not the module is refused by name, in one line, and nothing is written
// (on a machine where no libbasis is installed in the configured prefix or the library path,
// where the tool would look next).
TEST(Capture2qtCli, TheImageModuleIsLoadedOnlyForImagesAndAMissingOrForeignOneIsOneLineExitOne) {
  TempDir dir;
  std::filesystem::create_directories(dir.file("bin"));
  std::filesystem::copy_file(testing::tool_directory() / "capture2qt", dir.file("bin/capture2qt"));
  write_image(dir.file("sky.exr"), Image(16, 8, 3));
  const std::vector<std::string> constant = {
      "--env-constant", "1,1,1", "--at", "0,0,0", "--res", "8", "-o", "constant.qt", "-q"};
  const auto without = run_tool(dir.file("bin/capture2qt"), constant, dir.path());
  EXPECT_EQ(without.status, 0) << without.err;
  EXPECT_TRUE(std::filesystem::exists(dir.file("constant.qt")));

  const std::vector<std::string> from_sky = {"--env", "sky.exr", "--at",   "0,0,0", "--res",
                                             "8",     "-o",      "sky.qt", "-q"};
  const auto missing = run_tool(dir.file("bin/capture2qt"), from_sky, dir.path());
  EXPECT_EQ(missing.status, 1) << missing.err;
  EXPECT_EQ(testing::line_count(missing.err), 1) << missing.err;
  EXPECT_NE(missing.err.find("sky.exr: cannot load the image library: libbasis_image_codec.so "
                             "not found in " +
                             dir.file("lib")),
            std::string::npos)
      << missing.err;

  std::filesystem::create_directories(dir.file("lib"));
  std::ofstream(dir.file("lib/libbasis_image_codec.so")) << "not a shared library\n";
  const auto foreign = run_tool(dir.file("bin/capture2qt"), from_sky, dir.path());
  EXPECT_EQ(foreign.status, 1) << foreign.err;
  EXPECT_EQ(testing::line_count(foreign.err), 1) << foreign.err;
  EXPECT_NE(foreign.err.find("sky.exr: cannot load the image library: "), std::string::npos)
      << foreign.err;
  EXPECT_NE(foreign.err.find("lib/libbasis_image_codec.so"), std::string::npos) << foreign.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("sky.qt")));
  // The build's own module in its place: the image is read.
  std::filesystem::copy_file(testing::tool_directory() / ".." / "lib" / "libbasis_image_codec.so",
                             dir.file("lib/libbasis_image_codec.so"),
                             std::filesystem::copy_options::overwrite_existing);
  const auto read = run_tool(dir.file("bin/capture2qt"), from_sky, dir.path());
  EXPECT_EQ(read.status, 0) << read.err;
  EXPECT_TRUE(std::filesystem::exists(dir.file("sky.qt")));
}

TEST(Capture2qtCli, BadUsageIsExitTwo) {
  TempDir dir;
  write_room(dir);
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"--at", "0,0,0"},
        {"--env-constant", "1,1,1"},
        {"--env-constant", "1,1,1", "--at", "0,0,0", "--res", "3"},
        {"--env-constant", "1,1,1", "--at", "0,0,0", "--spp", "3"},
        {"--env-constant", "1,1,1", "--at", "0,0"},
        {"--env-constant", "1,1,1", "--at", "0,0,0", "--normal", "0,0,0"},
        {"--env-constant", "1,1,1", "--sample", "5"},
        {"--env-constant", "1,-1,1", "--at", "0,0,0"},
        {"--env-constant", "1,1,1", "--at", "0,0,0", "--points", "p.csv"},
        {"--env-constant", "1,1,1", "--at", "0,0,0", "--env", "x.hdr"},
        // --normal is the normal at --at: with other points it would be ignored.
        {"--env-constant", "1,1,1", "--scene", "room.obj", "--sample", "5", "--normal", "0,0,1"},
        {"--env-constant", "1,1,1", "--points", "p.csv", "--normal", "0,0,1"}}) {
    const auto r = run_tool("capture2qt", args, dir.path());
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_EQ(testing::line_count(r.err), 1) << r.err;
  }
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"room.mtl", "room.obj"}));
}

TEST(Capture2qtCli, InterruptLeavesNoOutput) {
  TempDir dir;
  write_room(dir);
  for (const int signal_number : {SIGINT, SIGTERM}) {
    const auto r = run_tool(
        "capture2qt",
        {"--env-constant", "1,1,1", "--scene", "room.obj", "--sample", "100000", "--res", "64"},
        dir.path(), 500, signal_number);
    EXPECT_EQ(r.status, 130) << r.err;
    EXPECT_NE(r.err.find("interrupted"), std::string::npos) << r.err;
    EXPECT_EQ(dir.entries(), (std::vector<std::string>{"room.mtl", "room.obj"}));
  }
  // With --dump, interrupted or failing at its output, no image is left either; a missing
  // output folder is found before any capture.
  std::filesystem::create_directories(dir.file("dump"));
  const auto interrupted = run_tool("capture2qt",
                                    {"--env-constant", "1,1,1", "--scene", "room.obj", "--sample",
                                     "100000", "--res", "16", "--dump", "dump"},
                                    dir.path(), 500, SIGINT);
  EXPECT_EQ(interrupted.status, 130) << interrupted.err;
  EXPECT_TRUE(std::filesystem::is_empty(dir.file("dump")));
  // A small run dumping its images into dump/, its set written to `output`.
  auto dump_run = [&](const std::string& output) {
    return run_tool("capture2qt",
                    {"--env-constant", "1,1,1", "--scene", "room.obj", "--sample", "20", "--res",
                     "16", "--dump", "dump", "-o", output},
                    dir.path());
  };
  const auto nowhere = dump_run("no/such/c.qt");
  EXPECT_EQ(nowhere.status, 1) << nowhere.err;
  EXPECT_NE(nowhere.err.find("no/such/c.qt"), std::string::npos) << nowhere.err;
  EXPECT_TRUE(std::filesystem::is_empty(dir.file("dump")));
  // An image already there (an earlier run's, or a map) is neither replaced nor removed.
  std::ofstream(dir.file("dump/capture_00003.exr")) << "mine";
  const auto there = dump_run("c.qt");
  EXPECT_EQ(there.status, 1) << there.err;
  EXPECT_NE(there.err.find("capture_00003.exr: already there"), std::string::npos) << there.err;
  EXPECT_EQ(testing::slurp(dir.file("dump/capture_00003.exr")), "mine");
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.file("dump")),
                          std::filesystem::directory_iterator()),
            1);
  EXPECT_FALSE(std::filesystem::exists(dir.file("c.qt")));
}

}  // namespace
}  // namespace basis
