// Sharded runs end to end: capture2qt --shard, qtmerge, manifests read by qtconvolve and qtinfo,
// qtconvolve --shard. Shards joined are the bytes of one process; lookup shards concatenated
// are its output; shards that changed, went missing or belong elsewhere are named in one line;
// re-runs redo only what is missing or altered; a killed shard leaves nothing.
#include <gtest/gtest.h>
#include <signal.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "basis/io/checksum.h"
#include "support/run_tool.h"
#include "support/temp_dir.h"

namespace basis {
namespace {

using testing::run_tool;
using testing::slurp;
using testing::TempDir;

// A real map with a sun (compact lights kept apart, so lights and their offsets are joined too)
// from Debian's blender-data, which the set-up installs; else a constant sky.
std::vector<std::string> light() {
  const std::string sunrise = "/usr/share/blender/datafiles/studiolights/world/sunrise.exr";
  if (std::filesystem::exists(sunrise)) return {"--env", sunrise};
  std::printf("[  NOTE    ] %s is absent: a constant sky is used\n", sunrise.c_str());
  return {"--env-constant", "1,2,3"};
}

const std::string kScene = std::string(BASIS_SOURCE_DIR) + "/data/scene.obj";

// capture2qt over the bundled scene's points at 16^2 with `extra` arguments.
testing::ToolResult capture(const TempDir& dir, std::vector<std::string> extra) {
  std::vector<std::string> args = light();
  for (const char* a : {"--scene", kScene.c_str(), "--res", "16", "--spp", "1", "-q"})
    args.push_back(a);
  args.insert(args.end(), extra.begin(), extra.end());
  return run_tool("capture2qt", args, dir.path());
}

std::vector<std::string> sample(int points) {
  return {"--sample", std::to_string(points), "--seed", "5"};
}

std::vector<std::string> with(std::vector<std::string> a, const std::vector<std::string>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

// Shards 0 .. count - 1 of a run as DIR/s.K.qt.
void capture_shards(const TempDir& dir, const std::vector<std::string>& points, int count,
                    const std::string& prefix = "s") {
  for (int k = 0; k < count; ++k) {
    const auto r = capture(
        dir,
        with(points, {"--shard", std::to_string(k) + "/" + std::to_string(count), "--threads",
                      std::to_string(1 + k % 2), "-o", prefix + "." + std::to_string(k) + ".qt"}));
    ASSERT_EQ(r.status, 0) << r.err;
  }
}

// A small Phong table at 16^2 texels.
void write_table(const TempDir& dir) {
  std::ofstream(dir.file("phong.json"))
      << R"({"model": "phong", "kd": 0.3, "ks": 0.5, "exponent": 40})";
  ASSERT_EQ(
      run_tool("brdf2qt", {"phong.json", "--wo-res", "9", "--wi-res", "16", "--no-tilt", "-q"},
               dir.path())
          .status,
      0);
}

std::string tool_output(const TempDir& dir, const std::string& tool,
                        const std::vector<std::string>& args) {
  const auto r = run_tool(tool, args, dir.path());
  EXPECT_EQ(r.status, 0) << tool << ": " << r.err;
  return r.out;
}

// The tool fails with exit status `status` and one line on stderr that names `mentions`.
void expect_refusal(const testing::ToolResult& r, int status, const std::string& mentions) {
  EXPECT_EQ(r.status, status) << r.err;
  EXPECT_EQ(testing::line_count(r.err), 1) << r.err;
  EXPECT_NE(r.err.find(mentions), std::string::npos) << r.err;
}

TEST(ShardCli, ShardsJoinIntoTheBytesOfOneProcess) {
  TempDir dir;
  ASSERT_EQ(capture(dir, with(sample(37), {"-o", "single.qt"})).status, 0);
  capture_shards(dir, sample(37), 4);
  // Any order: each shard records which it is.
  const auto merged =
      run_tool("qtmerge", {"s.2.qt", "s.0.qt", "s.3.qt", "s.1.qt", "-o", "m.qt"}, dir.path());
  ASSERT_EQ(merged.status, 0) << merged.err;
  EXPECT_EQ(slurp(dir.file("m.qt")), slurp(dir.file("single.qt")));
  // The same through a manifest.
  ASSERT_EQ(run_tool("qtmerge", {"s.0.qt", "s.1.qt", "s.2.qt", "s.3.qt", "--manifest", "set.qtm"},
                     dir.path())
                .status,
            0);
  // --json says what was written, quiet or not (-q leaves out progress and the summary line).
  const auto joined = run_tool("qtmerge", {"set.qtm", "-o", "m2.qt", "--json", "-q"}, dir.path());
  ASSERT_EQ(joined.status, 0) << joined.err;
  const auto report = nlohmann::json::parse(joined.out);
  EXPECT_EQ(report["points"], 37);
  EXPECT_EQ(report["shards"], 4);
  EXPECT_EQ(report["output"], "m2.qt");
  EXPECT_EQ(slurp(dir.file("m2.qt")), slurp(dir.file("single.qt")));
  // Each shard's checksum file is what xxh128sum checks.
  EXPECT_EQ(::system(("cd '" + dir.path() + "' && xxh128sum -c --quiet s.*.qt.xxh128").c_str()), 0);

  // Points from a file, three shards.
  std::ofstream points(dir.file("points.csv"));
  for (int i = 0; i < 11; ++i)
    points << 0.3 * i - 1.5 << "," << 0.1 * i << ",0.001,0,0," << 1 << "\n";
  points.close();
  ASSERT_EQ(capture(dir, {"--points", "points.csv", "-o", "p.qt"}).status, 0);
  capture_shards(dir, {"--points", "points.csv"}, 3, "p");
  ASSERT_EQ(run_tool("qtmerge", {"p.1.qt", "p.2.qt", "p.0.qt", "-o", "pm.qt"}, dir.path()).status,
            0);
  EXPECT_EQ(slurp(dir.file("pm.qt")), slurp(dir.file("p.qt")));
}

TEST(ShardCli, LookupShardsConcatenateToTheOutputOfOneRun) {
  TempDir dir;
  write_table(dir);
  ASSERT_EQ(capture(dir, with(sample(29), {"-o", "single.qt"})).status, 0);
  capture_shards(dir, sample(29), 3);
  ASSERT_EQ(run_tool("qtmerge", {"s.0.qt", "s.1.qt", "s.2.qt", "--manifest", "set.qtm"}, dir.path())
                .status,
            0);
  for (const bool csv : {true, false}) {
    const std::vector<std::string> lookup =
        csv ? std::vector<std::string>{"--wo", "0.3,0.2,0.9", "--csv"}
            : std::vector<std::string>{"--wo", "0.3,0.2,0.9"};
    const std::string single =
        tool_output(dir, "qtconvolve", with({"phong.qt", "single.qt"}, lookup));
    ASSERT_NE(single.find("28"), std::string::npos);
    // The manifest as a whole, in either order.
    EXPECT_EQ(tool_output(dir, "qtconvolve", with({"phong.qt", "set.qtm"}, lookup)), single);
    if (csv) {
      EXPECT_EQ(tool_output(dir, "qtconvolve", with({"set.qtm", "phong.qt"}, lookup)), single);
    }
    // Four lookup shards across the three capture shards, and of the single file.
    for (const std::string captures : {"set.qtm", "single.qt"}) {
      if (!csv && captures == "single.qt") continue;
      std::string joined;
      for (int k = 0; k < 4; ++k) {
        const std::string part = "part." + std::to_string(k);
        ASSERT_EQ(
            run_tool("qtconvolve",
                     with({"phong.qt", captures, "--shard", std::to_string(k) + "/4", "-o", part},
                          lookup),
                     dir.path())
                .status,
            0);
        joined += slurp(dir.file(part));
      }
      EXPECT_EQ(joined, single) << captures;
    }
  }
  // Lookup shards concatenate; a JSON document or text with a timing line would not.
  expect_refusal(
      run_tool("qtconvolve", {"phong.qt", "set.qtm", "--shard", "0/2", "--json"}, dir.path()), 2,
      "--json");
  expect_refusal(
      run_tool("qtconvolve", {"phong.qt", "set.qtm", "--shard", "0/2", "--time"}, dir.path()), 2,
      "--csv");
  // Inputs that do not go together print nothing, not even the header.
  for (const bool csv : {false, true}) {
    const auto r = run_tool("qtconvolve",
                            with({"phong.qt", "phong.qt"}, csv ? std::vector<std::string>{"--csv"}
                                                               : std::vector<std::string>{}),
                            dir.path());
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_EQ(r.out, "");
  }
  // Products of captures, a manifest on either side.
  const std::string products = tool_output(dir, "qtconvolve", {"single.qt", "single.qt", "--csv"});
  EXPECT_EQ(tool_output(dir, "qtconvolve", {"single.qt", "set.qtm", "--csv"}), products);
  EXPECT_EQ(tool_output(dir, "qtconvolve", {"set.qtm", "set.qtm", "--csv"}), products);
  // Full-resolution references re-trace each capture with the jitter of its index in the run:
  // shard by shard they are the whole file's, and every lookup lies within its bound of them.
  const std::string whole =
      tool_output(dir, "qtconvolve", {"phong.qt", "single.qt", "--reference", "--json", "-q"});
  const std::string sharded =
      tool_output(dir, "qtconvolve", {"phong.qt", "set.qtm", "--reference", "--json", "-q"});
  const auto a = nlohmann::json::parse(whole), b = nlohmann::json::parse(sharded);
  ASSERT_EQ(a["results"].size(), 29u);
  EXPECT_EQ(a["results"], b["results"]);
  for (const auto& r : b["results"])
    for (int c = 0; c < 3; ++c)
      EXPECT_LE(std::abs(r["value"][c].get<double>() - r["reference"][c].get<double>()),
                r["bound"][c].get<double>() * (1 + 1e-5) + 1e-7)
          << r.dump();
}

TEST(ShardCli, ManifestShardsThatChangedAreNamedInOneLine) {
  TempDir dir;
  write_table(dir);
  capture_shards(dir, sample(21), 3);
  ASSERT_EQ(run_tool("qtmerge", {"s.0.qt", "s.1.qt", "s.2.qt", "--manifest", "set.qtm"}, dir.path())
                .status,
            0);
  const std::string original = slurp(dir.file("s.1.qt"));
  auto refused_everywhere = [&](const std::string& mentions) {
    const auto before = dir.entries();
    expect_refusal(
        run_tool("qtconvolve", {"phong.qt", "set.qtm", "--csv", "-o", "out.csv"}, dir.path()), 1,
        mentions);
    expect_refusal(run_tool("qtinfo", {"set.qtm"}, dir.path()), 1, mentions);
    expect_refusal(run_tool("qtmerge", {"set.qtm", "-o", "out.qt"}, dir.path()), 1, mentions);
    EXPECT_EQ(dir.entries(), before);  // nothing written
  };
  // Altered in place: same size, one value's byte changed.
  std::string altered = original;
  altered[altered.size() - 100] = char(altered[altered.size() - 100] ^ 1);
  std::ofstream(dir.file("s.1.qt"), std::ios::binary | std::ios::trunc) << altered;
  refused_everywhere("s.1.qt: altered since set.qtm was made");
  // Replaced by another shard of the run.
  std::filesystem::copy_file(dir.file("s.2.qt"), dir.file("s.1.qt"),
                             std::filesystem::copy_options::overwrite_existing);
  refused_everywhere("s.1.qt");
  // Missing.
  std::filesystem::remove(dir.file("s.1.qt"));
  refused_everywhere("s.1.qt");
  // Restored: read again.
  std::ofstream(dir.file("s.1.qt"), std::ios::binary | std::ios::trunc) << original;
  EXPECT_EQ(run_tool("qtinfo", {"set.qtm"}, dir.path()).status, 0);
  // A shard of another run (another seed) where shard 1 belongs: qtmerge names it.
  capture_shards(dir, {"--sample", "21", "--seed", "6"}, 3, "o");
  expect_refusal(run_tool("qtmerge", {"s.0.qt", "o.1.qt", "s.2.qt", "-o", "m.qt"}, dir.path()), 1,
                 "o.1.qt: a shard of another run");
  expect_refusal(run_tool("qtmerge", {"s.0.qt", "s.2.qt", "-o", "m.qt"}, dir.path()), 1,
                 "shard 1/3 is missing");
  EXPECT_FALSE(std::filesystem::exists(dir.file("m.qt")));
  // A join that cannot be written leaves no manifest either.
  EXPECT_NE(run_tool("qtmerge",
                     {"s.0.qt", "s.1.qt", "s.2.qt", "--manifest", "new.qtm", "-o", "no/such/m.qt"},
                     dir.path())
                .status,
            0);
  EXPECT_FALSE(std::filesystem::exists(dir.file("new.qtm")));
}

// Shards of a run whose scene changed between them, under the same name and with the same
// recorded parameters (one face's winding reversed: the same vertices and extent, so the same
// ray offset): not of one run. Only the inputs' checksum tells them apart; qtmerge took them.
TEST(ShardCli, ShardsOfAChangedSceneAreNotOfOneRun) {
  TempDir dir;
  std::filesystem::copy_file(kScene, dir.file("scene.obj"));
  auto shard = [&](int k) {
    std::vector<std::string> args = light();
    for (const char* a : {"--scene", "scene.obj", "--res", "16", "--spp", "1", "-q", "--sample",
                          "12", "--seed", "3"})
      args.push_back(a);
    args.insert(args.end(),
                {"--shard", std::to_string(k) + "/3", "-o", "c." + std::to_string(k) + ".qt"});
    return run_tool("capture2qt", args, dir.path());
  };
  ASSERT_EQ(shard(0).status, 0);
  ASSERT_EQ(shard(2).status, 0);
  std::string text = slurp(dir.file("scene.obj"));
  const std::size_t face = text.find("\nf 1 2 3 4\n");
  ASSERT_NE(face, std::string::npos);
  text.replace(face, 11, "\nf 4 3 2 1\n");
  std::ofstream(dir.file("scene.obj"), std::ios::trunc) << text;
  ASSERT_EQ(shard(1).status, 0);
  expect_refusal(run_tool("qtmerge", {"c.0.qt", "c.1.qt", "c.2.qt", "-o", "m.qt"}, dir.path()), 1,
                 "c.1.qt: a shard of another run");
  EXPECT_FALSE(std::filesystem::exists(dir.file("m.qt")));
  // A reference traced again from the changed scene: refused, naming the captures and why.
  write_table(dir);
  const auto reference =
      run_tool("qtconvolve", {"phong.qt", "c.0.qt", "--reference", "--csv"}, dir.path());
  expect_refusal(reference, 1, "c.0.qt: cannot read what it was captured from (");
  EXPECT_NE(reference.err.find("scene scene.obj changed since the capture"), std::string::npos)
      << reference.err;
  // Shard 1 was captured from the scene as it is now: its reference runs.
  EXPECT_EQ(
      run_tool("qtconvolve", {"phong.qt", "c.1.qt", "--reference", "--csv"}, dir.path()).status, 0);
}

TEST(ShardCli, ReRunsRedoOnlyTheShardsThatAreMissingOrAltered) {
  TempDir dir;
  ASSERT_EQ(capture(dir, with(sample(26), {"-o", "single.qt"})).status, 0);
  capture_shards(dir, sample(26), 4);
  const auto untouched = std::filesystem::last_write_time(dir.file("s.0.qt"));
  std::filesystem::remove(dir.file("s.1.qt"));  // a task that never ran
  std::string altered = slurp(dir.file("s.2.qt"));
  altered[altered.size() - 100] = char(altered[altered.size() - 100] ^ 1);
  std::ofstream(dir.file("s.2.qt"), std::ios::binary | std::ios::trunc) << altered;
  std::filesystem::remove(checksum_path(dir.file("s.3.qt")));  // killed before its checksum
  std::string skipped;
  for (int k = 0; k < 4; ++k) {
    std::vector<std::string> args = light();
    for (const std::string& a :
         {std::string("--scene"), kScene, std::string("--res"), std::string("16"),
          std::string("--spp"), std::string("1"), std::string("--skip-existing"),
          std::string("--shard"), std::to_string(k) + "/4", std::string("-o"),
          "s." + std::to_string(k) + ".qt"})
      args.push_back(a);
    const auto r = run_tool("capture2qt", with(args, sample(26)), dir.path());
    ASSERT_EQ(r.status, 0) << r.err;
    if (r.out.find("skipped") != std::string::npos) skipped += std::to_string(k);
  }
  EXPECT_EQ(skipped, "0");
  EXPECT_EQ(std::filesystem::last_write_time(dir.file("s.0.qt")), untouched);
  // With --json (quiet or not), a skipped shard says so as JSON.
  std::vector<std::string> again = light();
  for (const std::string& a :
       {std::string("--scene"), kScene, std::string("--res"), std::string("16"),
        std::string("--spp"), std::string("1"), std::string("--skip-existing"),
        std::string("--shard"), std::string("0/4"), std::string("-o"), std::string("s.0.qt"),
        std::string("--json"), std::string("-q")})
    again.push_back(a);
  const auto as_json = run_tool("capture2qt", with(again, sample(26)), dir.path());
  ASSERT_EQ(as_json.status, 0) << as_json.err;
  const auto j = nlohmann::json::parse(as_json.out);
  EXPECT_EQ(j["skipped"], true);
  EXPECT_EQ(j["output"], "s.0.qt");
  ASSERT_EQ(run_tool("qtmerge", {"s.0.qt", "s.1.qt", "s.2.qt", "s.3.qt", "-o", "m.qt"}, dir.path())
                .status,
            0);
  EXPECT_EQ(slurp(dir.file("m.qt")), slurp(dir.file("single.qt")));
  // Other parameters are not this run's shard: made again.
  const auto r = capture(dir, with(sample(26), {"--skip-existing", "--shard", "0/4", "--tolerance",
                                                "0.1", "-o", "s.0.qt"}));
  EXPECT_EQ(r.status, 0);
  EXPECT_EQ(r.out.find("skipped"), std::string::npos);
}

TEST(ShardCli, AShardKilledOrInterruptedLeavesNothing) {
  TempDir dir;
  for (const int signal : {SIGKILL, SIGTERM}) {
    std::vector<std::string> args = light();
    for (const std::string& a : {std::string("--scene"), kScene, std::string("--res"),
                                 std::string("64"), std::string("--shard"), std::string("1/2"),
                                 std::string("-o"), std::string("s.1.qt"), std::string("-q")})
      args.push_back(a);
    const auto r = run_tool("capture2qt", with(args, sample(4000)), dir.path(), 300, signal);
    EXPECT_EQ(r.status, signal == SIGKILL ? 128 + SIGKILL : 130) << r.err;
    EXPECT_TRUE(dir.entries().empty()) << signal;  // no shard, no checksum, no temporary
  }
}

// A file written without --shard over a shard's takes its checksum away: the checksum
// would not be its own (xxh128sum -c reported it FAILED).
TEST(ShardCli, AnUnshardedOutputOverAShardLeavesNoChecksum) {
  TempDir dir;
  std::vector<std::string> args = light();
  for (const std::string& a :
       {std::string("--scene"), kScene, std::string("--sample"), std::string("2"),
        std::string("--res"), std::string("8"), std::string("-q")})
    args.push_back(a);
  ASSERT_EQ(run_tool("capture2qt", with(args, {"--shard", "0/1", "-o", "c.qt"}), dir.path()).status,
            0);
  ASSERT_TRUE(std::filesystem::exists(dir.file("c.qt.xxh128")));
  ASSERT_EQ(run_tool("capture2qt", with(args, {"--seed", "7", "-o", "c.qt"}), dir.path()).status,
            0);
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"c.qt"}));
}

TEST(ShardCli, QtinfoAddsUpTheShards) {
  TempDir dir;
  capture_shards(dir, sample(19), 2);
  ASSERT_EQ(
      run_tool("qtmerge", {"s.0.qt", "s.1.qt", "--manifest", "set.qtm", "-o", "m.qt"}, dir.path())
          .status,
      0);
  const auto a = nlohmann::json::parse(tool_output(dir, "qtinfo", {"set.qtm", "--json"}));
  const auto b = nlohmann::json::parse(tool_output(dir, "qtinfo", {"m.qt", "--json"}));
  EXPECT_EQ(a["nodes"], b["nodes"]);
  EXPECT_EQ(a["captures"], b["captures"]);
  EXPECT_EQ(a["trees"], b["trees"]);
  EXPECT_EQ(a["storage"]["tree_bytes"], b["storage"]["tree_bytes"]);
  EXPECT_EQ(a["provenance"], b["provenance"]);
  EXPECT_EQ(a["manifest"]["shards"].size(), 2u);
  EXPECT_EQ(a["checksum_verified"], true);
  EXPECT_EQ(b["checksum_verified"], true);
  // A picture of capture 12, the second shard's third (shards of 9 and 10).
  ASSERT_EQ(run_tool("qtinfo", {"set.qtm", "--png", "a.png", "--index", "12"}, dir.path()).status,
            0);
  ASSERT_EQ(run_tool("qtinfo", {"s.1.qt", "--png", "b.png", "--index", "3"}, dir.path()).status, 0);
  EXPECT_EQ(slurp(dir.file("a.png")), slurp(dir.file("b.png")));
}

TEST(ShardCli, ShardsNoRunHasAreUsageErrors) {
  TempDir dir;
  for (const std::string shard : {"4/4", "-1/4", "1", "a/b", "0/0"})
    expect_refusal(capture(dir, with(sample(5), {"--shard", shard})), 2, "--shard");
  expect_refusal(capture(dir, with(sample(5), {"--shard", "2/6"})), 2, "use at most 5");
  expect_refusal(capture(dir, with(sample(5), {"--skip-existing"})), 2, "--skip-existing");
  expect_refusal(capture(dir, sample(20000000)), 2, "--shard");
  expect_refusal(run_tool("qtmerge", {"x.qt"}, dir.path()), 2, "-o OUT.qt");
  expect_refusal(run_tool("capture2qt", {"--image", "c.exr", "--shard", "0/2"}, dir.path()), 2,
                 "--image");
  EXPECT_TRUE(dir.entries().empty());
}

// A shard's checksum file is one line naming it, so a shard name with a line break is refused
// before any work, in one line, rather than written with a checksum file no reader would take.
TEST(ShardCli, AShardNameWithALineBreakIsRefusedBeforeAnyWork) {
  TempDir dir;
  expect_refusal(capture(dir, with(sample(5), {"--shard", "0/2", "-o", "a\nb.qt"})), 1,
                 "a\\nb.qt: a line break in the name");
  // Before any input is read: the name is refused, not the missing map.
  expect_refusal(
      run_tool("capture2qt",
               {"--env", "missing.exr", "--at", "0,0,0", "--shard", "0/1", "-o", "c\rd.qt"},
               dir.path()),
      1, "c\\rd.qt: a line break in the name");
  EXPECT_TRUE(dir.entries().empty());
}

}  // namespace
}  // namespace basis
