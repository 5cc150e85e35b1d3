// qtbench's flags: those of the full study are bad usage with --lookups-only, which would
// ignore them, before any work and before its output folder is made.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "support/run_tool.h"
#include "support/temp_dir.h"

namespace basis {
namespace {

using testing::run_tool;
using testing::TempDir;

TEST(QtbenchCli, TheFullStudysFlagsAreBadUsageWithLookupsOnly) {
  TempDir dir;
  for (const std::string flag : {"--scene", "--measured", "--map", "--scene-points"}) {
    const auto r = run_tool(
        "qtbench", {"--out", "b", "--lookups-only", flag, flag == "--scene-points" ? "2" : "x"},
        dir.path());
    EXPECT_EQ(r.status, 2) << flag << ": " << r.err;
    EXPECT_EQ(testing::line_count(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(flag + " shapes the full study's panels: not with --lookups-only"),
              std::string::npos)
        << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir.file("b"))) << flag;
  }
}

}  // namespace
}  // namespace basis
