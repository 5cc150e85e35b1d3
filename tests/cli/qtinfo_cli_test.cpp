// qtinfo end to end: the real executable on files written by the library.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "basis/core/projection.h"
#include "basis/format/qt_file.h"
#include "basis/io/image_file.h"
#include "support/run_tool.h"
#include "support/temp_dir.h"
#include "support/test_functions.h"

namespace basis {
namespace {

using testing::run_tool;
using testing::TempDir;

std::string write_sample_tree(const TempDir& dir, Quadtree& tree) {
  tree = project(testing::test_functions(64, 3, 5)[1].grid, {.tolerance = 0.03});
  const std::string path = dir.file("smooth.qt");
  write_qt(path,
           encode_tree(pack(tree).view(), {.tolerance = 0.03}, {"test", "1", "{}", {"x.exr"}}));
  return path;
}

TEST(QtinfoCli, DescribesATreeInTextAndJson) {
  TempDir dir;
  Quadtree tree;
  const std::string path = write_sample_tree(dir, tree);
  const auto text = run_tool("qtinfo", {path});
  ASSERT_EQ(text.status, 0) << text.err;
  EXPECT_NE(text.out.find("kind         tree"), std::string::npos);
  EXPECT_NE(text.out.find(std::to_string(tree.node_count()) + " in all"), std::string::npos);
  EXPECT_NE(text.out.find("3 % of each channel's mean"), std::string::npos);
  EXPECT_NE(text.out.find(", checksum verified)"), std::string::npos);

  const auto json = run_tool("qtinfo", {path, "--json"});
  ASSERT_EQ(json.status, 0) << json.err;
  const auto j = nlohmann::json::parse(json.out);
  EXPECT_EQ(j["kind"], "tree");
  EXPECT_EQ(j["resolution"], 64);
  EXPECT_EQ(j["channels"], 3);
  EXPECT_EQ(j["nodes"]["total"], tree.node_count());
  const std::vector<int> levels = depth_histogram(tree.view());
  EXPECT_EQ(j["nodes"]["per_level"].get<std::vector<int>>(), levels);
  EXPECT_DOUBLE_EQ(j["storage"]["dense_bytes"].get<double>(), 64.0 * 64 * 3 * 4);
  EXPECT_EQ(j["provenance"]["sources"][0], "x.exr");
  EXPECT_EQ(j["checksum_verified"], true);
}

TEST(QtinfoCli, DrawsThePictureWithCellOutlines) {
  TempDir dir;
  Quadtree tree;
  const std::string path = write_sample_tree(dir, tree);
  const auto r = run_tool("qtinfo", {path, "--png", dir.file("tree.png"), "--size", "256"});
  ASSERT_EQ(r.status, 0) << r.err;
  const Image image = read_image(dir.file("tree.png"));
  EXPECT_EQ(image.width, 256);
  EXPECT_EQ(image.height, 256);
  // Outlines are dark grey lines; the function's bright blob is brighter than its surroundings.
  int outline = 0;
  for (int x = 0; x < 256; ++x)
    outline += image.at(x, 0, 0) < 0.3f;
  EXPECT_GT(outline, 200);
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"smooth.qt", "tree.png"}));
}

TEST(QtinfoCli, BadInputIsOneLineAndExitOne) {
  TempDir dir;
  Quadtree tree;
  const std::string good = write_sample_tree(dir, tree);
  std::ofstream(dir.file("empty.qt")).close();
  {
    std::ifstream in(good, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir.file("truncated.qt"), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    std::ofstream(dir.file("text.qt")) << "not a tree\n";
  }
  for (const std::string name : {"missing.qt", "empty.qt", "truncated.qt", "text.qt", ""}) {
    const std::string path = dir.file(name);
    const auto r = run_tool("qtinfo", {path});
    EXPECT_EQ(r.status, 1) << name;
    EXPECT_EQ(testing::line_count(r.err), 1) << r.err;
    EXPECT_EQ(r.err.rfind("qtinfo: " + path + ": ", 0), 0u) << r.err;
    EXPECT_TRUE(r.out.empty());
  }
}

TEST(QtinfoCli, BadUsageIsExitTwo) {
  TempDir dir;
  Quadtree tree;
  const std::string path = write_sample_tree(dir, tree);
  EXPECT_EQ(run_tool("qtinfo", {}).status, 2);
  EXPECT_EQ(run_tool("qtinfo", {path, "--size", "0"}).status, 2);
  EXPECT_EQ(run_tool("qtinfo", {path, "--index", "3", "--png", dir.file("x.png")}).status, 2);
  EXPECT_EQ(run_tool("qtinfo", {path, "--group", "1", "--png", dir.file("x.png")}).status, 2);
  EXPECT_EQ(run_tool("qtinfo", {path, "--bogus"}).status, 2);
  const auto help = run_tool("qtinfo", {"--help"});
  EXPECT_EQ(help.status, 0);
  EXPECT_NE(help.out.find("--png"), std::string::npos);
  // Unwritable picture destinations fail cleanly and leave nothing.
  const auto missing_dir = run_tool("qtinfo", {path, "--png", dir.file("no/such/x.png")});
  EXPECT_EQ(missing_dir.status, 1);
  EXPECT_EQ(testing::line_count(missing_dir.err), 1) << missing_dir.err;
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"smooth.qt"});
}

}  // namespace
}  // namespace basis
