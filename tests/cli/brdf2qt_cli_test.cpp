// brdf2qt end to end: specs in, tables out, every failure one line and a clean exit status.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <fstream>

#include "basis/format/qt_file.h"
#include "support/run_tool.h"
#include "support/temp_dir.h"

namespace basis {
namespace {

using testing::run_tool;
using testing::TempDir;

TEST(Brdf2qtCli, TabulatesASpecWithDefaultsAndOverrides) {
  TempDir dir;
  std::ofstream(dir.file("glossy.json"))
      << R"({"model": "phong", "kd": 0.5, "ks": 0.4, "exponent": 40,
             "table": {"wo_res": 5, "wi_res": 16, "tolerance": 0.1}})";
  // Default output: the spec's name with .qt, in the working folder.
  const auto r = run_tool("brdf2qt", {"glossy.json"}, dir.path());
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("glossy.qt: phong, 5 x 5 entries of 16 x 16 texels"), std::string::npos)
      << r.out;
  const QtFile table = QtFile::load(dir.file("glossy.qt"));
  ASSERT_EQ(table.kind(), QtKind::brdf_table);
  EXPECT_EQ(table.brdf_table().wo_resolution, 5);
  EXPECT_EQ(table.trees().shape().resolution, 16);
  EXPECT_EQ(table.projection().tolerance, 0.1);
  EXPECT_TRUE(table.brdf_table().has_tilt());
  EXPECT_EQ(table.brdf_model(), "phong");
  EXPECT_EQ(table.provenance().tool, "brdf2qt");
  // Flags override the spec's table block.
  const auto o = run_tool("brdf2qt",
                          {"glossy.json", "-o", "other.qt", "--wo-res", "7", "--wi-res", "32",
                           "--tolerance", "0.02", "--no-tilt", "--quiet", "--threads", "1"},
                          dir.path());
  ASSERT_EQ(o.status, 0) << o.err;
  EXPECT_TRUE(o.out.empty());
  const QtFile other = QtFile::load(dir.file("other.qt"));
  EXPECT_EQ(other.brdf_table().wo_resolution, 7);
  EXPECT_EQ(other.trees().shape().resolution, 32);
  EXPECT_EQ(other.projection().tolerance, 0.02);
  EXPECT_FALSE(other.brdf_table().has_tilt());
  // The same spec and flags give the same bytes, whatever the thread count.
  const auto again = run_tool("brdf2qt",
                              {"glossy.json", "-o", "again.qt", "--wo-res", "7", "--wi-res", "32",
                               "--tolerance", "0.02", "--no-tilt", "--quiet", "--threads", "2"},
                              dir.path());
  ASSERT_EQ(again.status, 0);
  EXPECT_EQ(testing::slurp(dir.file("other.qt")), testing::slurp(dir.file("again.qt")));
  // More threads than cores run on every core, quietly (oneTBB printed its own warning) and to
  // the same bytes.
  const auto more = run_tool("brdf2qt",
                             {"glossy.json", "-o", "more.qt", "--wo-res", "7", "--wi-res", "32",
                              "--tolerance", "0.02", "--no-tilt", "--quiet", "--threads", "1024"},
                             dir.path());
  ASSERT_EQ(more.status, 0) << more.err;
  EXPECT_EQ(more.err.find("TBB"), std::string::npos) << more.err;
  EXPECT_EQ(testing::line_count(more.err), 1) << more.err;  // the grid's warning alone
  EXPECT_EQ(testing::slurp(dir.file("other.qt")), testing::slurp(dir.file("more.qt")));
  // --json says what was written, quiet or not (-q leaves out progress and the summary; the
  // warning of a grid too coarse for the lobe stays).
  const auto quiet =
      run_tool("brdf2qt",
               {"glossy.json", "-o", "quiet.qt", "--wo-res", "3", "--wi-res", "8", "--json", "-q"},
               dir.path());
  ASSERT_EQ(quiet.status, 0) << quiet.err;
  const auto j = nlohmann::json::parse(quiet.out);
  EXPECT_EQ(j["output"], "quiet.qt");
  EXPECT_EQ(j["entries"].get<std::size_t>(), QtFile::load(dir.file("quiet.qt")).trees().size());
  EXPECT_EQ(j["bytes"].get<std::uintmax_t>(), std::filesystem::file_size(dir.file("quiet.qt")));
}

// Resolutions too coarse for the lobe are written as asked, with one warning line each naming
// the spec; the defaults draw none.
TEST(Brdf2qtCli, WarnsOfResolutionsTooCoarseForTheLobe) {
  TempDir dir;
  std::ofstream(dir.file("sharp.json")) << R"({"model": "phong", "ks": 1, "exponent": 10000})";
  const auto coarse =
      run_tool("brdf2qt", {"sharp.json", "--wo-res", "3", "--wi-res", "2", "-q"}, dir.path());
  ASSERT_EQ(coarse.status, 0) << coarse.err;
  EXPECT_NE(coarse.err.find("brdf2qt: warning: sharp.json: 3 x 3 outgoing directions are coarser "
                            "than this lobe"),
            std::string::npos)
      << coarse.err;
  EXPECT_NE(coarse.err.find("texel averages may miss it; use at least 8 x 8"), std::string::npos)
      << coarse.err;
  EXPECT_EQ(QtFile::load(dir.file("sharp.qt")).brdf_table().wo_resolution, 3);
  std::ofstream(dir.file("phong.json")) << R"({"model": "phong", "kd": 0.5, "ks": 0.4,
                                                "exponent": 100, "table": {"wi_res": 16}})";
  const auto fine = run_tool("brdf2qt", {"phong.json", "-q"}, dir.path());
  ASSERT_EQ(fine.status, 0) << fine.err;
  EXPECT_EQ(fine.err, "");
}

TEST(Brdf2qtCli, BadSpecsAreOneLineExitOneAndNoOutput) {
  TempDir dir;
  std::ofstream(dir.file("negative.json"))
      << "{\"model\": \"phong\",\n \"ks\": -0.4,\n \"exponent\": 3}";
  std::ofstream(dir.file("broken.json")) << "{\"model\": \"phong\",\n \"ks\": 0.4,\n";
  std::ofstream(dir.file("unknown.json")) << R"({"model": "velvet"})";
  for (const std::string name : {"negative", "broken", "unknown", "missing"}) {
    const auto r = run_tool("brdf2qt", {dir.file(name + ".json"), "-o", dir.file(name + ".qt")});
    EXPECT_EQ(r.status, 1) << name << r.err;
    EXPECT_EQ(testing::line_count(r.err), 1) << r.err;
    EXPECT_EQ(r.err.rfind("brdf2qt: " + dir.file(name + ".json") + ":", 0), 0u) << r.err;
  }
  const auto negative = run_tool("brdf2qt", {dir.file("negative.json")});
  EXPECT_NE(negative.err.find(".json:2: field 'ks'"), std::string::npos) << negative.err;
  EXPECT_EQ(dir.entries(),
            (std::vector<std::string>{"broken.json", "negative.json", "unknown.json"}));
}

TEST(Brdf2qtCli, BadUsageIsExitTwo) {
  TempDir dir;
  std::ofstream(dir.file("l.json")) << R"({"model": "lambert", "albedo": 0.5})";
  for (const std::vector<std::string>& args : {std::vector<std::string>{},
                                               {"l.json", "--wi-res", "3"},
                                               {"l.json", "--wi-res", "1024"},
                                               {"l.json", "--wo-res", "1"},
                                               {"l.json", "--tolerance", "-1"},
                                               {"l.json", "--threads", "0"},
                                               {"l.json", "--frobnicate"}}) {
    const auto r = run_tool("brdf2qt", args, dir.path());
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_EQ(testing::line_count(r.err), 1) << r.err;
  }
  const auto missing_folder = run_tool(
      "brdf2qt", {"l.json", "-o", "no/such/l.qt", "--wo-res", "3", "--wi-res", "8"}, dir.path());
  EXPECT_EQ(missing_folder.status, 1);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"l.json"});
}

TEST(Brdf2qtCli, InterruptLeavesNoOutput) {
  TempDir dir;
  std::ofstream(dir.file("sharp.json")) << R"({"model": "ggx", "f0": 0.9, "alpha": 0.02})";
  for (const int signal_number : {SIGINT, SIGTERM}) {
    const auto r = run_tool("brdf2qt", {"sharp.json", "--wo-res", "129", "--wi-res", "256"},
                            dir.path(), 400, signal_number);
    EXPECT_EQ(r.status, 130) << r.err;
    EXPECT_NE(r.err.find("interrupted"), std::string::npos);
    EXPECT_EQ(dir.entries(), std::vector<std::string>{"sharp.json"});
  }
}

}  // namespace
}  // namespace basis
