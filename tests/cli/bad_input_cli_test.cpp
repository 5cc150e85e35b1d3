// The bad-input matrix over every tool: missing, empty, directory, truncated, foreign and
// future-version inputs; absurd sizes and tolerances; outputs that cannot be written. Each
// gives one to three lines on stderr naming the input and the problem, exit status 1 for bad
// data and 2 for bad usage, and leaves no output or temporary file behind.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "basis/format/qt_file.h"
#include "basis/io/image.h"
#include "basis/io/image_file.h"
#include "basis_generated.h"
#include "support/merl_file.h"
#include "support/run_tool.h"
#include "support/temp_dir.h"

namespace basis {
namespace {

using testing::run_tool;
using testing::TempDir;
using testing::write_text;

struct Expectation {
  std::vector<std::string> args;
  int status;
  std::string mentions;  // text stderr must contain (the input's name)
};

// Valid inputs every case starts from, and broken variants of each kind of file.
void write_inputs(const TempDir& dir) {
  write_text(dir.file("ok.json"), R"({"model": "lambert", "albedo": 0.5})");
  ASSERT_EQ(
      run_tool("brdf2qt", {"ok.json", "--wo-res", "3", "--wi-res", "8", "-q"}, dir.path()).status,
      0);
  ASSERT_EQ(
      run_tool("capture2qt",
               {"--env-constant", "1,1,1", "--at", "0,0,0", "--res", "8", "-o", "cap.qt", "-q"},
               dir.path())
          .status,
      0);
  ASSERT_EQ(run_tool("capture2qt",
                     {"--env-constant", "1,1,1", "--at", "0,0,0", "--res", "8", "--shard", "0/1",
                      "-o", "shard.0.qt", "-q"},
                     dir.path())
                .status,
            0);
  write_text(dir.file("truncated.qtm"), "{\"format\": \"libbasis capture-set manifest\",");
  write_text(dir.file("foreign.qtm"), "{\"format\": \"something else\", \"version\": 1}");
  const std::string table = testing::slurp(dir.file("ok.qt"));
  write_text(dir.file("truncated.qt"), table.substr(0, table.size() / 3));
  std::string changed = table;  // one bit of the trees' words, which only the checksum sees
  changed[changed.size() / 2] ^= 1;
  write_text(dir.file("changed.qt"), changed);
  write_text(dir.file("empty.qt"), "");
  write_text(dir.file("empty.json"), "");
  write_text(dir.file("foreign.qt"), "\x89PNG\r\n\x1a\n....");
  write_text(dir.file("truncated.json"), R"({"model": "phong", "ks": 0.4)");
  write_text(dir.file("foreign.json"), "\x89PNG\r\n\x1a\n....");
  write_text(dir.file("nan.json"), R"({"model": "phong", "ks": NaN, "exponent": 3})");
  write_text(dir.file("negative.json"), R"({"model": "phong", "ks": -1, "exponent": 3})");
  write_text(dir.file("missing_field.json"), R"({"model": "ggx", "f0": 0.04})");
  write_text(dir.file("unknown.json"), R"({"model": "cook-torrance", "ks": 1})");
  write_text(dir.file("truncated.exr"), "v/1\x01\x02");
  write_text(dir.file("foreign.exr"), "this is not an image\n");
  write_text(dir.file("empty.obj"), "");
  write_text(dir.file("truncated.obj"), "v 0 0 0\nv 1 0 0\nv 0 1");
  write_text(dir.file("foreign.obj"), "\x89PNG\r\n\x1a\n....");
  write_text(dir.file("empty.csv"), "");
  write_text(dir.file("foreign.csv"), "\x89PNG\r\n\x1a\n....");
  // Environment maps with one NaN, one infinite and one negative texel.
  for (const auto& [name, value] : {std::pair<std::string, float>{"nan.exr", std::nanf("")},
                                    {"inf.exr", INFINITY},
                                    {"negative.exr", -1.0f}}) {
    Image env(16, 16, 3);  // square: also a valid capture image but for the bad texel
    for (float& p : env.pixels)
      p = 1;
    env.at(5, 3, 1) = value;
    write_image(dir.file(name), env);
  }
  // A map whose texels are all finite floats, too large to average without overflow.
  Image huge(16, 16, 3);
  for (float& p : huge.pixels)
    p = 3e38f;
  write_image(dir.file("huge.exr"), huge);
  // A map of one pixel (a lat-long map needs two columns) and an OBJ whose material emits
  // more than a float holds.
  write_image(dir.file("one_pixel.exr"), Image(1, 1, 3));
  write_text(dir.file("bright.mtl"), "newmtl glow\nKe 1e39 1e39 1e39\n");
  write_text(dir.file("bright.obj"),
             "mtllib bright.mtl\nv 0 0 1\nv 1 0 1\nv 0 1 1\nusemtl glow\nf 1 2 3\n");
  std::filesystem::create_directories(dir.file("folder"));
  // A .qt file of a future format version, otherwise well formed.
  const QtFile ok = QtFile::load(dir.file("ok.qt"));
  flatbuffers::FlatBufferBuilder b;
  const PackedTreeView tree = ok.tree();
  const format::PackedExtent extent(0, std::uint32_t(tree.node_count()), tree.scales().value_scale,
                                    tree.scales().bound_scale);
  const auto extents = b.CreateVectorOfStructs(&extent, 1);
  const auto words = b.CreateVector(tree.words().data(), tree.words().size());
  format::TreeSetBuilder set(b);
  set.add_resolution(tree.shape().resolution);
  set.add_channels(tree.shape().channels);
  set.add_groups(1);
  set.add_packed_extents(extents);
  set.add_words(words);
  const auto trees = set.Finish();
  format::FinishFileBuffer(
      b, format::CreateFile(b, 99, format::Kind::Tree, format::Mapping::CosineConcentric, trees));
  std::ofstream(dir.file("future.qt"), std::ios::binary)
      .write(reinterpret_cast<const char*>(b.GetBufferPointer()), std::streamsize(b.GetSize()));
}

void check(const TempDir& dir, const std::string& tool, const Expectation& e) {
  const auto before = dir.entries();
  const auto r = run_tool(tool, e.args, dir.path());
  std::string command = tool;
  for (const auto& a : e.args)
    command += " " + a;
  EXPECT_EQ(r.status, e.status) << command << "\n" << r.err;
  const int lines = testing::line_count(r.err);
  EXPECT_TRUE(lines >= 1 && lines <= 3) << command << "\n" << r.err;
  EXPECT_NE(r.err.find(e.mentions), std::string::npos) << command << "\n" << r.err;
  EXPECT_EQ(dir.entries(), before) << command;  // no output, no temporary
}

TEST(BadInputMatrix, QtReaders) {
  TempDir dir;
  write_inputs(dir);
  for (const std::string name : {"missing.qt", "empty.qt", "folder", "truncated.qt", "foreign.qt",
                                 "future.qt", "changed.qt", "truncated.qtm", "foreign.qtm"}) {
    check(dir, "qtinfo", {{name}, 1, name});
    check(dir, "qtconvolve", {{name, "cap.qt"}, 1, name});
    check(dir, "qtconvolve", {{"ok.qt", name}, 1, name});
    check(dir, "qtmerge", {{name, "-o", "out.qt"}, 1, name});
  }
  // Files that are not shards of a run.
  check(dir, "qtmerge", {{"cap.qt", "-o", "out.qt"}, 1, "cap.qt: a whole capture set, not a"});
  check(dir, "qtmerge", {{"ok.qt", "--manifest", "out.qtm"}, 1, "ok.qt: a brdf-table, not a"});
  check(dir, "qtinfo", {{"future.qt"}, 1, "format version 99 is newer"});
  check(dir, "qtinfo", {{"changed.qt"}, 1, "changed.qt: checksum mismatch"});
  // JSON of another kind (a spec) is named as such, not judged as a manifest's fields.
  check(dir, "qtinfo", {{"ok.json"}, 1, "ok.json: JSON, but not a .qt file or a capture-set"});
  check(dir, "qtconvolve", {{"ok.qt", "ok.json"}, 1, "ok.json: JSON, but not a .qt file"});
}

TEST(BadInputMatrix, Specs) {
  TempDir dir;
  write_inputs(dir);
  for (const std::string name :
       {"missing.json", "empty.json", "folder", "truncated.json", "foreign.json", "nan.json",
        "negative.json", "missing_field.json", "unknown.json"})
    check(dir, "brdf2qt", {{name, "-o", "out.qt", "-q"}, 1, name});
  check(dir, "brdf2qt", {{"negative.json", "-o", "out.qt"}, 1, "field 'ks'"});
  check(dir, "brdf2qt", {{"missing_field.json", "-o", "out.qt"}, 1, "field 'alpha'"});
  check(dir, "brdf2qt", {{"unknown.json", "-o", "out.qt"}, 1, "unknown model 'cook-torrance'"});
  // A MERL file of finite samples too large for a table's floats: refused by name.
  testing::write_merl_samples(dir.file("huge.binary"),
                              std::vector<double>(testing::kMerlSamples, 1e300));
  write_text(dir.file("huge_merl.json"), R"({"model": "merl", "file": "huge.binary"})");
  check(dir, "brdf2qt", {{"huge_merl.json", "-o", "out.qt"}, 1, "huge.binary: MERL samples"});
}

TEST(BadInputMatrix, CaptureInputs) {
  TempDir dir;
  write_inputs(dir);
  for (const std::string name : {"missing.exr", "truncated.exr", "foreign.exr", "folder"}) {
    check(dir, "capture2qt", {{"--env", name, "--at", "0,0,0", "-o", "out.qt"}, 1, name});
    check(dir, "capture2qt", {{"--image", name, "-o", "out.qt"}, 1, name});
  }
  // Negative environment texels are read as 0 with a warning (Capture2qtCli tests that).
  for (const std::string name : {"nan.exr", "inf.exr"})
    check(dir, "capture2qt", {{"--env", name, "--at", "0,0,0", "-o", "out.qt"}, 1, name});
  for (const std::string name : {"nan.exr", "inf.exr", "negative.exr"})
    check(dir, "capture2qt", {{"--image", name, "-o", "out.qt"}, 1, name});
  // Radiance that overflows float once averaged into texels and trees: refused, never written
  // as a file that readers refuse.
  check(dir, "capture2qt", {{"--env", "huge.exr", "--at", "0,0,0", "-o", "out.qt"}, 1, "huge.exr"});
  check(dir, "capture2qt", {{"--image", "huge.exr", "-o", "out.qt"}, 1, "huge.exr"});
  check(
      dir, "capture2qt",
      {{"--env-constant", "1e39,1,1", "--at", "0,0,0", "-o", "out.qt"}, 2, "--env-constant 1e39"});
  check(dir, "capture2qt",
        {{"--env", "one_pixel.exr", "--at", "0,0,0", "-o", "out.qt"}, 1, "one_pixel.exr: "});
  // Radiance that a float holds, whose product with itself does not: an error naming the
  // capture (it printed inf with a finite bound, exit 0), in the trees' product and the dense one.
  ASSERT_EQ(run_tool("capture2qt",
                     {"--env-constant", "1.1e19,1.1e19,1.1e19", "--at", "0,0,0", "--res", "8", "-o",
                      "bright.qt", "-q"},
                     dir.path())
                .status,
            0);
  for (const std::vector<std::string>& extra : {std::vector<std::string>{}, {"--dense"}}) {
    std::vector<std::string> args = {"bright.qt", "bright.qt", "--csv"};
    args.insert(args.end(), extra.begin(), extra.end());
    check(dir, "qtconvolve", {args, 1, "bright.qt: capture 0: the convolution's value"});
  }
  std::filesystem::remove(dir.file("bright.qt"));
  check(dir, "capture2qt",
        {{"--env-constant", "1,1,1", "--scene", "bright.obj", "--at", "0.2,0.2,0", "-o", "out.qt"},
         1,
         "bright.obj: material 'glow'"});
  for (const std::string name :
       {"missing.obj", "empty.obj", "truncated.obj", "foreign.obj", "folder"})
    check(dir, "capture2qt",
          {{"--env-constant", "1,1,1", "--scene", name, "--sample", "2", "-o", "out.qt"}, 1, name});
  for (const std::string name : {"missing.csv", "empty.csv", "foreign.csv", "folder"})
    check(dir, "capture2qt",
          {{"--env-constant", "1,1,1", "--points", name, "-o", "out.qt"}, 1, name});
  // A point's normal is a direction whatever its length: one whose squared length overflows is
  // taken along its direction and gives a file the readers accept; a zero one is refused.
  std::ofstream(dir.file("zero_normal.csv")) << "0,0,0,0,0,0\n";
  check(dir, "capture2qt",
        {{"--env-constant", "1,1,1", "--points", "zero_normal.csv", "-o", "out.qt"},
         1,
         "zero_normal.csv:1: the normal is zero"});
  std::ofstream(dir.file("huge_normal.csv")) << "0,0,0,0,0,1e200\n";
  const auto huge =
      run_tool("capture2qt",
               {"--env-constant", "1,1,1", "--points", "huge_normal.csv", "-o", "huge.qt", "-q"},
               dir.path());
  ASSERT_EQ(huge.status, 0) << huge.err;
  const auto info = run_tool("qtinfo", {"huge.qt", "--json"}, dir.path());
  ASSERT_EQ(info.status, 0) << info.err;
  EXPECT_NE(info.out.find("\"trees\": 1,"), std::string::npos) << info.out;
}

TEST(BadInputMatrix, AbsurdSizesAndTolerances) {
  TempDir dir;
  write_inputs(dir);
  // Texel resolutions are powers of two from 2 to 512; the outgoing grid takes 2 to 256.
  for (const std::string res : {"1", "3", "1000000", "-4", "x"}) {
    check(dir, "brdf2qt", {{"ok.json", "--wi-res", res, "-o", "out.qt"}, 2, "--wi-res"});
    check(dir, "capture2qt",
          {{"--env-constant", "1,1,1", "--at", "0,0,0", "--res", res, "-o", "out.qt"}, 2, "--res"});
  }
  for (const std::string res : {"1", "257", "1000000", "-4", "x"})
    check(dir, "brdf2qt", {{"ok.json", "--wo-res", res, "-o", "out.qt"}, 2, "--wo-res"});
  check(dir, "brdf2qt", {{"ok.json", "--tolerance", "-0.1", "-o", "out.qt"}, 2, "--tolerance"});
  check(dir, "capture2qt",
        {{"--env-constant", "1,1,1", "--at", "0,0,0", "--tolerance", "-1", "-o", "out.qt"},
         2,
         "--tolerance"});
  check(dir, "capture2qt",
        {{"--env-constant", "1,1,1", "--at", "0,0,0", "--spp", "1000000", "-o", "out.qt"},
         2,
         "--spp"});
  check(dir, "capture2qt",
        {{"--env-constant", "1,1,1", "--sample", "10000000000000", "-o", "out.qt"}, 2, "--sample"});
  check(dir, "capture2qt",
        {{"--env-constant", "1,1,1", "--at", "0,0,0", "--shard", "0/1000000000", "-o", "out.qt"},
         2,
         "--shard"});
  check(dir, "qtinfo", {{"ok.qt", "--png", "x.png", "--size", "1000000"}, 2, "--size"});
}

// Numeric flags take finite numbers: NaN and infinity are bad usage, named, as out-of-range
// values are (CLI11's own checks let NaN through).
TEST(BadInputMatrix, NumbersThatAreNotFiniteAreBadUsage) {
  TempDir dir;
  write_inputs(dir);
  for (const std::string bad : {"nan", "inf", "-inf"}) {
    check(dir, "brdf2qt", {{"ok.json", "--tolerance", bad, "-o", "out.qt"}, 2, "--tolerance"});
    check(dir, "brdf2qt",
          {{"ok.json", "--tolerance-floor", bad, "-o", "out.qt"}, 2, "--tolerance-floor"});
    check(dir, "capture2qt",
          {{"--env-constant", "1,1,1", "--at", "0,0,0", "--env-rotate", bad, "-o", "out.qt"},
           2,
           "--env-rotate"});
    check(dir, "capture2qt",
          {{"--env-constant", "1,1,1", "--at", "0,0,0", "--tolerance", bad, "-o", "out.qt"},
           2,
           "--tolerance"});
    check(dir, "qtconvolve",
          {{"ok.qt", "cap.qt", "--accuracy", bad, "-o", "out.csv"}, 2, "--accuracy"});
  }
  check(dir, "brdf2qt", {{"ok.json", "--wi-res", "0", "-o", "out.qt"}, 2, "--wi-res"});
  // Finite numbers too large for the work they scale are bad usage too, naming the flag (they
  // overflowed into "tolerance ... got inf" and "rotation is not finite", exit 1, no flag named).
  check(dir, "brdf2qt",
        {{"ok.json", "--tolerance", "1.8e307", "-o", "out.qt"}, 2, "--tolerance: a number from"});
  check(dir, "brdf2qt",
        {{"ok.json", "--tolerance-floor", "1e300", "-o", "out.qt"}, 2, "--tolerance-floor"});
  check(dir, "capture2qt",
        {{"--env-constant", "1,1,1", "--at", "0,0,0", "--env-rotate", "1e308", "-o", "out.qt"},
         2,
         "--env-rotate: a number from"});
}

// A .qt path that is a FIFO is refused at once (it would otherwise wait for a writer).
// No reader waits for a FIFO's writer (the specs, maps, points, scenes and measured data once
// did, and only SIGKILL stopped them): readers that need a file refuse a FIFO by name at once,
// and specs and scenes, which are read to their end, read one that no process writes as empty.
TEST(BadInputMatrix, FifosAreRefusedNotWaitedOn) {
  TempDir dir;
  write_inputs(dir);
  for (const std::string pipe :
       {"pipe.qt", "pipe.json", "pipe.exr", "pipe.txt", "pipe.obj", "pipe.binary", "pipe.mtl"})
    ASSERT_EQ(::mkfifo(dir.file(pipe).c_str(), 0600), 0) << pipe;
  // Scenes whose material file is a FIFO or a folder (read as empty, its emitters went dark).
  for (const std::string material : {"pipe", "folder"})
    write_text(dir.file(material + "_material.obj"), "mtllib " + material +
                                                         ".mtl\nv 0 0 1\nv 1 0 1\nv 0 1 1\n"
                                                         "usemtl glow\nf 1 2 3\n");
  std::filesystem::create_directories(dir.file("folder.mtl"));
  write_text(dir.file("merl.json"), R"({"model": "merl", "file": "pipe.binary"})");
  check(dir, "qtinfo", {{"pipe.qt"}, 1, "pipe.qt: is not a regular file"});
  check(dir, "qtconvolve", {{"ok.qt", "pipe.qt"}, 1, "pipe.qt: is not a regular file"});
  check(dir, "brdf2qt", {{"pipe.json"}, 1, "pipe.json:"});
  check(dir, "brdf2qt", {{"merl.json"}, 1, "pipe.binary: is not a regular file"});
  check(dir, "capture2qt",
        {{"--env", "pipe.exr", "--at", "0,0,0", "-o", "out.qt"}, 1, "pipe.exr: is not a regular"});
  check(dir, "capture2qt",
        {{"--env-constant", "1,1,1", "--points", "pipe.txt", "-o", "out.qt"}, 1, "pipe.txt"});
  check(dir, "capture2qt",
        {{"--env-constant", "1,1,1", "--scene", "pipe.obj", "--sample", "4", "-o", "out.qt"},
         1,
         "pipe.obj: is not a regular file"});
  for (const auto& [material, problem] :
       {std::pair<std::string, std::string>{"pipe", "pipe.mtl: is not a regular file"},
        {"folder", "folder.mtl: is a directory, not a material file"}})
    check(dir, "capture2qt",
          {{"--env-constant", "1,1,1", "--scene", material + "_material.obj", "--sample", "4", "-o",
            "out.qt"},
           1,
           problem});
  check(dir, "qtrender", {{"pipe.json", "-o", "out.exr"}, 1, "pipe.json:"});
  // A spec through a pipe that a process writes is read as a file is.
  const std::string command = "cat ok.json | '" + (testing::tool_directory() / "brdf2qt").string() +
                              "' /dev/stdin --wo-res 3 --wi-res 8 -q -o piped.qt";
  EXPECT_EQ(std::system(("cd '" + dir.path() + "' && " + command).c_str()), 0) << command;
  const auto piped = run_tool("qtinfo", {"piped.qt", "--json"}, dir.path());
  ASSERT_EQ(piped.status, 0) << piped.err;
  EXPECT_EQ(nlohmann::json::parse(piped.out)["kind"], "brdf-table");
  // Points too (--points <(...) in a shell).
  const std::string points =
      "printf '0,0,0,0,0,1\\n1,0,0,0,0,1\\n' | '" +
      (testing::tool_directory() / "capture2qt").string() +
      "' --env-constant 1,1,1 --points /dev/stdin --res 8 -q -o piped_points.qt";
  EXPECT_EQ(std::system(("cd '" + dir.path() + "' && " + points).c_str()), 0) << points;
  const auto captured = run_tool("qtinfo", {"piped_points.qt", "--json"}, dir.path());
  ASSERT_EQ(captured.status, 0) << captured.err;
  EXPECT_EQ(nlohmann::json::parse(captured.out)["captures"]["points"], 2);
}

// File names that are not UTF-8 still give --json output, their bad bytes replaced.
TEST(BadInputMatrix, FileNamesThatAreNotUtf8StillGiveJson) {
  TempDir dir;
  write_inputs(dir);
  const std::string name = "caf\xe9.json";
  write_text(dir.file(name), R"({"model": "lambert", "albedo": 0.5})");
  const auto r =
      run_tool("brdf2qt", {name, "--wo-res", "3", "--wi-res", "8", "--json"}, dir.path());
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["entries"].get<int>(), 9);
  const auto info = run_tool("qtinfo", {"caf\xe9.qt", "--json"}, dir.path());
  ASSERT_EQ(info.status, 0) << info.err;
  EXPECT_EQ(nlohmann::json::parse(info.out)["kind"], "brdf-table");
  // A capture's provenance must name its scene as it is: refused before any work, and nothing
  // written.
  std::filesystem::copy_file(std::string(BASIS_SOURCE_DIR) + "/data/scene.obj",
                             dir.file("caf\xe9.obj"));
  check(dir, "capture2qt",
        {{"--env-constant", "1,1,1", "--scene", "caf\xe9.obj", "--sample", "4", "--res", "8", "-o",
          "out.qt"},
         1,
         "not UTF-8"});
}

TEST(BadInputMatrix, UnwritableOutputs) {
  TempDir dir;
  write_inputs(dir);
  // A missing folder, a folder /proc refuses (even to root), and a full device.
  for (const std::string out : {"no/such/folder/out.qt", "/proc/basis-test.qt", "/dev/full"}) {
    check(dir, "brdf2qt", {{"ok.json", "--wo-res", "3", "--wi-res", "8", "-q", "-o", out}, 1, out});
    check(dir, "capture2qt",
          {{"--env-constant", "1,1,1", "--at", "0,0,0", "--res", "8", "-q", "-o", out}, 1, out});
  }
  for (const std::string out : {"no/such/folder/out.csv", "/proc/basis-test.csv", "/dev/full"}) {
    check(dir, "qtconvolve", {{"ok.qt", "cap.qt", "--csv", "-o", out}, 1, out});
    check(dir, "qtmerge", {{"shard.0.qt", "-o", out}, 1, out});
    check(dir, "qtmerge", {{"shard.0.qt", "--manifest", out}, 1, out});
    // Two outputs: when either cannot be written, neither is.
    check(dir, "qtmerge", {{"shard.0.qt", "-o", "joined.qt", "--manifest", out}, 1, out});
    check(dir, "qtmerge", {{"shard.0.qt", "-o", out, "--manifest", "listed.qtm"}, 1, out});
  }
  for (const std::string out : {"no/such/folder/x.png", "/proc/basis-test.png"}) {
    check(dir, "qtinfo", {{"ok.qt", "--png", out}, 1, out});
    check(dir, "qtconvolve", {{"ok.qt", "cap.qt", "--png", out}, 1, out});
  }
  // Images on a full disk, which a link to the full device stands for: the PNG and EXR writers
  // did not report the failed writes, and a cut image was put in place with exit 0 (EXRs: in
  // QtrenderCli).
  std::filesystem::create_symlink("/dev/full", dir.file("full.png"));
  const std::string problem = "full.png: No space left on device";
  check(dir, "qtinfo", {{"ok.qt", "--png", "full.png"}, 1, problem});
  check(dir, "qtinfo", {{"cap.qt", "--png", "full.png"}, 1, problem});
  check(dir, "qtconvolve", {{"ok.qt", "cap.qt", "--png", "full.png"}, 1, problem});
}

// A capture set `name` of `count` points under a constant sky, in dir (exit status 0 asserted by
// the caller).
int write_capture_set(const TempDir& dir, const std::string& name, int count) {
  std::ofstream points(dir.file(name + ".csv"));
  for (int p = 0; p < count; ++p)
    points << p << ",0,0,0,0,1\n";
  points.close();
  return run_tool("capture2qt",
                  {"--env-constant", "1,1,1", "--points", name + ".csv", "--res", "8", "-o",
                   name + ".qt", "-q"},
                  dir.path())
      .status;
}

// std::system's status for `command` (a tool and its arguments) run in dir by the shell, after
// the shell commands `limits` (each followed by " && "), its standard output to `output` and its
// standard error to err.txt.
int run_in_shell(const TempDir& dir, const std::string& limits, const std::string& command,
                 const std::string& output) {
  const std::string shell = "cd '" + dir.path() + "' && " + limits + "'" +
                            testing::tool_directory().string() + "'/" + command + " > " + output +
                            " 2> err.txt";
  return std::system(shell.c_str());
}

// Results printed to a standard output that cannot take them (a full device) are an error
// naming it and why, where they used to be lost with exit 0; so is help. Results longer than
// the output's buffer fail while the tool works, and the reason is still given.
TEST(BadInputMatrix, ResultsThatStandardOutputCannotTakeAreAnError) {
  TempDir dir;
  write_inputs(dir);
  ASSERT_EQ(write_capture_set(dir, "many", 400), 0);
  for (const std::string command :
       {"qtinfo ok.qt --json", "qtconvolve ok.qt cap.qt --csv", "qtconvolve ok.qt many.qt --csv",
        "brdf2qt --help", "capture2qt --help", "qtinfo --help", "qtconvolve --help",
        "qtmerge --help", "qtrender --help", "qtinfo --version"}) {
    const int status = run_in_shell(dir, "", command, "/dev/full");
    ASSERT_TRUE(WIFEXITED(status)) << command;
    EXPECT_EQ(WEXITSTATUS(status), 1) << command;
    const std::string err = testing::slurp(dir.file("err.txt"));
    EXPECT_EQ(testing::line_count(err), 1) << err;
    EXPECT_NE(err.find(command.substr(0, command.find(' ')) +
                       ": standard output: " + std::strerror(ENOSPC)),
              std::string::npos)
        << err;
    const bool help = command.ends_with("--help") || command.ends_with("--version");
    EXPECT_NE(err.find(help ? "; help lost" : "; results lost"), std::string::npos) << err;
  }
  // A regular file that stops taking results while the tool works (here: over the size limit the
  // shell sets, its signal ignored, as a full disk would): the failed write's own reason, where
  // the message used to say only "write error".
  const int status = run_in_shell(dir, "trap '' XFSZ && ulimit -f 4 && ",
                                  "qtconvolve ok.qt many.qt --csv", "limited.csv");
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1);
  const std::string err = testing::slurp(dir.file("err.txt"));
  EXPECT_EQ(err, std::string("qtconvolve: standard output: ") + std::strerror(EFBIG) +
                     "; results lost\n");
  // The shell's limit counts blocks of 512 bytes.
  EXPECT_LE(std::filesystem::file_size(dir.file("limited.csv")), 4 * 512);
  // Results that fit the output's buffer (20 rows, over one block and under the buffer's 4 KiB)
  // fail only when it is flushed, at the end: the same.
  ASSERT_EQ(write_capture_set(dir, "few", 20), 0);
  const int small_status = run_in_shell(dir, "trap '' XFSZ && ulimit -f 1 && ",
                                        "qtconvolve ok.qt few.qt --csv", "small.csv");
  ASSERT_TRUE(WIFEXITED(small_status));
  EXPECT_EQ(WEXITSTATUS(small_status), 1);
  EXPECT_EQ(testing::slurp(dir.file("err.txt")), std::string("qtconvolve: standard output: ") +
                                                     std::strerror(EFBIG) + "; results lost\n");
  EXPECT_LE(std::filesystem::file_size(dir.file("small.csv")), 512u);
}

// An output that would destroy an input, or another output, is bad usage: exit 2, one line,
// and the input keeps its bytes. An output that is a folder is refused before any work.
TEST(BadInputMatrix, OutputsThatWouldDestroyAnInputAreRefused) {
  TempDir dir;
  write_inputs(dir);
  const std::string table = testing::slurp(dir.file("ok.qt"));
  const std::string spec = testing::slurp(dir.file("ok.json"));
  check(dir, "brdf2qt", {{"ok.json", "-o", "ok.json"}, 2, "the file spec reads"});
  check(dir, "brdf2qt", {{"ok.json", "-o", "./sub/../ok.json"}, 2, "the file spec reads"});
  check(dir, "qtconvolve", {{"ok.qt", "cap.qt", "-o", "ok.qt"}, 2, "the file a reads"});
  check(dir, "qtconvolve",
        {{"ok.qt", "cap.qt", "--png", "p.png", "-o", "p.png"}, 2, "name the same file"});
  check(dir, "qtinfo", {{"cap.qt", "--png", "cap.qt"}, 2, "the file file reads"});
  check(dir, "qtmerge", {{"shard.0.qt", "-o", "shard.0.qt"}, 2, "the file inputs reads"});
  // The data file a measured BRDF's spec names is an input too.
  testing::write_merl_samples(dir.file("m.binary"),
                              std::vector<double>(testing::kMerlSamples, 0.1));
  write_text(dir.file("m.json"), R"({"model": "merl", "file": "m.binary"})");
  const std::string samples = testing::slurp(dir.file("m.binary"));
  check(dir, "brdf2qt", {{"m.json", "-o", "m.binary"}, 2, "m.binary is the file spec's"});
  EXPECT_EQ(testing::slurp(dir.file("m.binary")), samples);
  // So are the map and the scene a reference traces again.
  ASSERT_EQ(run_tool("capture2qt",
                     {"--env", "negative.exr", "--at", "0,0,0", "--res", "8", "-o", "lit.qt", "-q"},
                     dir.path())
                .status,
            0);
  const std::string map = testing::slurp(dir.file("negative.exr"));
  check(dir, "qtconvolve",
        {{"ok.qt", "lit.qt", "--reference", "-o", "negative.exr"},
         2,
         "negative.exr is the file --reference reads"});
  EXPECT_EQ(testing::slurp(dir.file("negative.exr")), map);
  // A shard's checksum beside it is part of it.
  check(dir, "qtmerge",
        {{"shard.0.qt", "--manifest", "shard.0.qt.xxh128"}, 2, "the checksum of shard.0.qt"});
  check(dir, "capture2qt",
        {{"--env-constant", "1,1,1", "--points", "ok.json", "-o", "ok.json"},
         2,
         "the file --points reads"});
  // And the checksum a shard run writes beside its output is an output: an input of that name
  // (a scene, a points file) was overwritten, and a folder of that name replaced.
  write_text(dir.file("points.qt.xxh128"), "0,0,0,0,0,1\n");
  const std::string points = testing::slurp(dir.file("points.qt.xxh128"));
  check(dir, "capture2qt",
        {{"--env-constant", "1,1,1", "--points", "points.qt.xxh128", "--res", "8", "--shard", "0/1",
          "-o", "points.qt"},
         2,
         "the checksum of -o points.qt.xxh128 is the file --points reads"});
  EXPECT_EQ(testing::slurp(dir.file("points.qt.xxh128")), points);
  std::filesystem::create_directory(dir.file("held.qt.xxh128"));
  check(dir, "capture2qt",
        {{"--env-constant", "1,1,1", "--at", "0,0,0", "--res", "8", "--shard", "0/1", "-o",
          "held.qt"},
         1,
         "held.qt.xxh128: is a folder"});
  // A manifest's shards are inputs too.
  ASSERT_EQ(run_tool("qtmerge", {"shard.0.qt", "--manifest", "m.qtm", "-q"}, dir.path()).status, 0);
  const std::string shard = testing::slurp(dir.file("shard.0.qt"));
  check(dir, "qtmerge", {{"m.qtm", "-o", "shard.0.qt"}, 2, "shard.0.qt is a shard m.qtm lists"});
  check(dir, "qtconvolve",
        {{"ok.qt", "m.qtm", "-o", "shard.0.qt.xxh128"}, 2, "the checksum of a shard m.qtm lists"});
  EXPECT_EQ(testing::slurp(dir.file("shard.0.qt")), shard);
  EXPECT_EQ(testing::slurp(dir.file("ok.qt")), table);
  EXPECT_EQ(testing::slurp(dir.file("ok.json")), spec);
  std::filesystem::create_directory(dir.file("folder"));
  check(dir, "brdf2qt", {{"ok.json", "-o", "folder"}, 1, "folder: is a folder"});
  check(dir, "capture2qt",
        {{"--env-constant", "1,1,1", "--at", "0,0,0", "-o", "folder"}, 1, "folder: is a folder"});
  check(dir, "brdf2qt", {{"ok.json", "-o", "no/such/folder/x.qt"}, 1, "no such folder"});
  // The material files an OBJ names (mtllib) are inputs too, for a capture and for the
  // reference that traces it again.
  write_text(dir.file("lamp.mtl"), "newmtl glow\nKe 5 5 5\n");
  write_text(dir.file("lamp.obj"),
             "mtllib lamp.mtl\nv 0 0 1\nv 1 0 1\nv 0 1 1\nusemtl glow\nf 1 2 3\n");
  const std::string materials = testing::slurp(dir.file("lamp.mtl"));
  check(dir, "capture2qt",
        {{"--env-constant", "1,1,1", "--scene", "lamp.obj", "--sample", "2", "--res", "8", "-o",
          "lamp.mtl"},
         2,
         "lamp.mtl is a material file lamp.obj names"});
  ASSERT_EQ(run_tool("capture2qt",
                     {"--env-constant", "1,1,1", "--scene", "lamp.obj", "--sample", "2", "--res",
                      "8", "-o", "lamp.qt", "-q"},
                     dir.path())
                .status,
            0);
  check(dir, "qtconvolve",
        {{"ok.qt", "lamp.qt", "--reference", "-o", "lamp.mtl"},
         2,
         "lamp.mtl is a material file lamp.obj names"});
  EXPECT_EQ(testing::slurp(dir.file("lamp.mtl")), materials);
  // qtrender checks them before any material is tabulated (its table would be cached beside the
  // spec): here the render's PNG would replace the material file an OBJ names.
  write_text(dir.file("odd.png"), "newmtl glow\nKe 5 5 5\n");
  write_text(dir.file("odd.obj"),
             "mtllib odd.png\nv 0 0 1\nv 1 0 1\nv 0 1 1\nusemtl glow\nf 1 2 3\n");
  write_text(dir.file("scene.json"),
             R"({"camera": {"eye": [0, -9, 4], "look_at": [0, 0, 0.7], "up": [0, 0, 1],
                 "fov": 40, "width": 8, "height": 6},
                 "environment": {"constant": [1, 1, 1]},
                 "meshes": [{"obj": "odd.obj", "material": "ok.json"}]})");
  const std::string odd = testing::slurp(dir.file("odd.png"));
  check(dir, "qtrender",
        {{"scene.json", "-o", "odd.exr"},
         2,
         "its PNG odd.png is a material file a mesh of scene.json names"});
  EXPECT_EQ(testing::slurp(dir.file("odd.png")), odd);
}

// Output names up to the longest a file may have (255 bytes) are written: the temporaries and
// checksum files beside them, whose names would be longer, do not stop them.
TEST(BadInputMatrix, OutputNamesUpToTheLongestAreWritten) {
  TempDir dir;
  write_inputs(dir);
  const std::string table = std::string(252, 't') + ".qt", captures = std::string(252, 'c') + ".qt";
  ASSERT_EQ(table.size(), 255u);
  const auto t = run_tool(
      "brdf2qt", {"ok.json", "--wo-res", "3", "--wi-res", "8", "-o", table, "-q"}, dir.path());
  EXPECT_EQ(t.status, 0) << t.err;
  const auto c = run_tool(
      "capture2qt",
      {"--env-constant", "1,1,1", "--at", "0,0,0", "--res", "8", "-o", captures, "-q"}, dir.path());
  EXPECT_EQ(c.status, 0) << c.err;
  const auto v = run_tool("qtconvolve", {table, captures}, dir.path());
  EXPECT_EQ(v.status, 0) << v.err;
  EXPECT_NE(v.out.find("reflected radiance at each capture"), std::string::npos) << v.out;
}

// An empty value names nothing: bad usage, where an empty output name used to fall back to the
// default one and write over it.
TEST(BadInputMatrix, EmptyValuesAreBadUsage) {
  TempDir dir;
  write_inputs(dir);
  const std::string captures = testing::slurp(dir.file("cap.qt"));
  ASSERT_EQ(run_tool("capture2qt", {"--env-constant", "1,1,1", "--at", "0,0,0", "--res", "8", "-q"},
                     dir.path())
                .status,
            0);
  const std::string default_output = testing::slurp(dir.file("captures.qt"));
  check(dir, "capture2qt",
        {{"--env-constant", "2,2,2", "--at", "0,0,0", "--res", "8", "-o", ""}, 2, "--output"});
  EXPECT_EQ(testing::slurp(dir.file("captures.qt")), default_output);
  check(dir, "brdf2qt", {{"ok.json", "-o", ""}, 2, "--output is given an empty value"});
  check(dir, "capture2qt", {{"--env", "", "--at", "0,0,0"}, 2, "--env is given an empty value"});
  check(dir, "qtinfo", {{"ok.qt", "--png", ""}, 2, "--png is given an empty value"});
  check(dir, "qtconvolve", {{"ok.qt", ""}, 2, "is given an empty value"});
  check(dir, "qtrender", {{"s.json", "-o", ""}, 2, "--output is given an empty value"});
  EXPECT_EQ(testing::slurp(dir.file("cap.qt")), captures);
}

// A capture set sun.qt of one point under a dim sky with one bright texel, a directional light
// kept apart.
void write_sun_capture(const TempDir& dir) {
  Image sky(256, 128, 3);
  for (float& p : sky.pixels)
    p = 0.1f;
  for (int c = 0; c < 3; ++c)
    sky.at(40, 30, c) = 1e5f;
  write_image(dir.file("sun.exr"), sky);
  ASSERT_EQ(run_tool("capture2qt",
                     {"--env", "sun.exr", "--at", "0,0,0", "--res", "8", "-o", "sun.qt", "-q"},
                     dir.path())
                .status,
            0);
  ASSERT_GT(QtFile::load(dir.file("sun.qt")).captures().lights.size(), 0u);
}

// qtconvolve TABLE sun.qt says `problem` in one line and lights the sun with the texels of
// `texels_of` (a table of the same trees) as --lights table does; qtrender refuses TABLE as a
// material, saying the same.
void expect_the_tables_texels_light_the_sun(const TempDir& dir, const std::string& table,
                                            const std::string& texels_of,
                                            const std::string& problem) {
  const auto lit = run_tool("qtconvolve", {table, "sun.qt", "--json"}, dir.path());
  ASSERT_EQ(lit.status, 0) << lit.err;
  EXPECT_NE(lit.err.find(problem), std::string::npos) << lit.err;
  EXPECT_EQ(testing::line_count(lit.err), 1) << lit.err;
  const auto texels =
      run_tool("qtconvolve", {texels_of, "sun.qt", "--json", "--lights", "table"}, dir.path());
  ASSERT_EQ(texels.status, 0) << texels.err;
  EXPECT_EQ(nlohmann::json::parse(lit.out)["results"],
            nlohmann::json::parse(texels.out)["results"]);
  write_text(dir.file("s.json"),
             R"({"camera": {"eye": [0, -9, 4], "look_at": [0, 0, 0.7], "up": [0, 0, 1],
                 "fov": 40, "width": 8, "height": 6},
                 "environment": {"constant": [1, 1, 1]},
                 "meshes": [{"obj": ")" +
                 std::string(BASIS_SOURCE_DIR) + R"(/data/scene.obj", "material": ")" + table +
                 R"("}]})");
  check(dir, "qtrender", {{"s.json", "--method", "mc", "--spp", "1", "-o", "r.exr"}, 1, problem});
}

// A table whose stored spec is not its BRDF (a damaged file: its trees a grey Phong's, its spec
// an RGB Lambert's of the same length) is not taken for its BRDF: qtconvolve says so and lights
// the directional lights with the table's texels, as for a measured BRDF whose data moved (it
// lit them with the other BRDF under an unchanged bound); qtrender refuses it as a material.
TEST(BadInputMatrix, ATableWhoseSpecIsNotItsBrdfIsNotTakenForIt) {
  TempDir dir;
  write_text(dir.file("ph.json"), R"({"model": "phong", "kd": 0.5, "ks": 0.4, "exponent": 10})");
  ASSERT_EQ(
      run_tool("brdf2qt", {"ph.json", "--wo-res", "3", "--wi-res", "8", "-q"}, dir.path()).status,
      0);
  write_sun_capture(dir);
  std::string table = testing::slurp(dir.file("ph.qt"));
  const std::string spec = testing::slurp(dir.file("ph.json"));
  const std::size_t at = table.find(spec);
  ASSERT_NE(at, std::string::npos);
  std::string other = R"({"model": "lambert", "albedo": [1, 0, 0]})";
  ASSERT_LE(other.size(), spec.size());
  other.insert(other.size() - 1, spec.size() - other.size(), ' ');
  table.replace(at, spec.size(), other);
  std::ofstream(dir.file("damaged.qt"), std::ios::binary) << table;
  // Changed after it was written, the file is refused by its checksum...
  const auto changed = run_tool("qtconvolve", {"damaged.qt", "sun.qt", "--json"}, dir.path());
  EXPECT_EQ(changed.status, 1);
  EXPECT_NE(changed.err.find("damaged.qt: checksum mismatch"), std::string::npos) << changed.err;
  EXPECT_EQ(testing::line_count(changed.err), 1) << changed.err;
  // ...and written so by a writer that checks nothing (its checksum sealed over the wrong spec),
  // its texels light the sun.
  std::vector<std::byte> sealed(reinterpret_cast<const std::byte*>(table.data()),
                                reinterpret_cast<const std::byte*>(table.data()) + table.size());
  ASSERT_TRUE(seal_qt_checksum(sealed));
  std::ofstream(dir.file("damaged.qt"), std::ios::binary)
      .write(reinterpret_cast<const char*>(sealed.data()), std::streamsize(sealed.size()));
  expect_the_tables_texels_light_the_sun(
      dir, "damaged.qt", "ph.qt",
      "damaged.qt: its stored spec (lambert, 3 channels) is not its table's BRDF (phong, 1)");
}

// A measured BRDF's data file changed after its table was made: the table's texels light the
// directional lights, with a warning that says so, as when the file is gone (the new data lit
// them, three times brighter under the same bound, without a word); qtrender refuses the table
// as a material.
TEST(BadInputMatrix, ATableWhoseMeasuredDataChangedIsNotTakenForIt) {
  TempDir dir;
  testing::write_merl_samples(dir.file("m.binary"),
                              std::vector<double>(testing::kMerlSamples, 0.1));
  write_text(dir.file("m.json"), R"({"model": "merl", "file": "m.binary"})");
  ASSERT_EQ(
      run_tool("brdf2qt", {"m.json", "--wo-res", "3", "--wi-res", "8", "-q"}, dir.path()).status,
      0);
  write_sun_capture(dir);
  const auto same = run_tool("qtconvolve", {"m.qt", "sun.qt", "--json"}, dir.path());
  ASSERT_EQ(same.status, 0) << same.err;
  EXPECT_EQ(same.err, "");
  testing::write_merl_samples(dir.file("m.binary"),
                              std::vector<double>(testing::kMerlSamples, 0.5));
  const auto texels =
      run_tool("qtconvolve", {"m.qt", "sun.qt", "--json", "--lights", "table"}, dir.path());
  ASSERT_EQ(texels.status, 0) << texels.err;
  EXPECT_NE(nlohmann::json::parse(same.out)["results"],
            nlohmann::json::parse(texels.out)["results"]);
  expect_the_tables_texels_light_the_sun(dir, "m.qt", "m.qt",
                                         "m.qt: the data file its spec names (m.binary) has "
                                         "changed since the table was made from it");
}

// A table block's wi_res that is not a power of two is the spec's error (exit 1, naming the file
// and the field), not a flag the user never gave.
TEST(BadInputMatrix, ATableBlocksResolutionIsTheSpecsError) {
  TempDir dir;
  write_text(dir.file("tb.json"),
             R"({"model": "lambert", "albedo": 0.5, "table": {"wi_res": 12, "wo_res": 5}})");
  check(dir, "brdf2qt",
        {{"tb.json"}, 1, "tb.json:1: field 'table.wi_res': must be a power of two"});
}

// qtinfo checks what --png would draw before it prints the summary: a usage error leaves
// stdout empty.
TEST(BadInputMatrix, QtinfoChecksItsChoicesBeforePrinting) {
  TempDir dir;
  write_inputs(dir);
  ASSERT_EQ(run_tool("qtmerge", {"shard.0.qt", "--manifest", "m.qtm", "-q"}, dir.path()).status, 0);
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"ok.qt", "--json", "--index", "2"},
        {"ok.qt", "--entry", "1,1"},
        {"ok.qt", "--png", "x.png", "--index", "0"},
        {"cap.qt", "--png", "x.png", "--entry", "0,0"},
        {"cap.qt", "--png", "x.png", "--index", "5"},
        {"cap.qt", "--png", "x.png", "--index", "-1"},
        {"cap.qt", "--png", "x.png", "--group", "1"},
        {"m.qtm", "--png", "x.png", "--group", "1"},
        {"m.qtm", "--png", "x.png", "--entry", "0,0"}}) {
    const auto r = run_tool("qtinfo", args, dir.path());
    std::string command = "qtinfo";
    for (const auto& a : args)
      command += " " + a;
    EXPECT_EQ(r.status, 2) << command << "\n" << r.err;
    EXPECT_EQ(r.out, "") << command;
    EXPECT_EQ(testing::line_count(r.err), 1) << command << "\n" << r.err;
  }
}

// Flags that would be ignored, or that contradict each other, are bad usage (exit 2, one line,
// nothing written), as are seeds outside 0 .. 2^64 - 1 (CLI11 wrapped -1 to 2^64 - 1).
TEST(BadInputMatrix, IgnoredOrContradictoryFlagsAreBadUsage) {
  TempDir dir;
  write_inputs(dir);
  const std::vector<std::string> at = {"--env-constant", "1,1,1", "--at", "0,0,0", "-o", "x.qt"};
  auto with = [](std::vector<std::string> args, std::initializer_list<std::string> more) {
    args.insert(args.end(), more);
    return args;
  };
  check(dir, "capture2qt", {with(at, {"--seed", "-1"}), 2, "--seed"});
  check(dir, "capture2qt", {with(at, {"--seed", "18446744073709551616"}), 2, "--seed"});
  check(dir, "capture2qt", {with(at, {"--env", "map.exr"}), 2, "exclude each other"});
  check(dir, "capture2qt", {with(at, {"--sample", "3"}), 2, "exclude each other"});
  check(dir, "qtrender", {{"s.json", "--method", "cache", "--spp", "2"}, 2, "--spp"});
  check(dir, "qtrender", {{"s.json", "--method", "mc", "--record-res", "64"}, 2, "--record-res"});
  check(dir, "qtrender",
        {{"s.json", "--method", "mc", "--spp", "2", "--time-budget", "1"}, 2, "exclude"});
  check(dir, "qtrender", {{"s.json", "--seed", "-5"}, 2, "--seed"});
  check(dir, "qtconvolve", {{"ok.qt", "cap.qt", "--tilt", "none"}, 2, "--tilt"});
  check(dir, "qtconvolve", {{"cap.qt", "cap.qt", "--lights", "table"}, 2, "--lights"});
  check(dir, "capture2qt", {with(at, {"--env-rotate", "10"}), 2, "--env-rotate is for --env"});
  check(dir, "capture2qt", {with(at, {"--zero-invalid"}), 2, "--zero-invalid is for --env"});
  check(dir, "qtrender",
        {{"s.json", "--method", "mc", "--time-budget", "1e300"}, 2, "--time-budget"});
  // A PNG's name is checked before the work, not after it.
  check(dir, "qtinfo", {{"ok.qt", "--png", "noext"}, 2, "--png names a PNG file"});
  check(dir, "qtconvolve", {{"ok.qt", "cap.qt", "--png", "p.exr"}, 2, "--png names a PNG file"});
  // A spec is read to its end: a NUL byte does not end it.
  write_text(dir.file("nul.json"), std::string(R"({"model": "lambert", "albedo": 0.5})") +
                                       std::string(1, '\0') + "garbage{{{");
  check(dir, "brdf2qt", {{"nul.json"}, 1, "nul.json:1: invalid JSON: a NUL byte"});
  // --image takes the image as it is, and prints JSON when asked.
  std::filesystem::create_directory(dir.file("dump"));
  ASSERT_EQ(
      run_tool("capture2qt", with(at, {"--res", "8", "--dump", "dump", "-q"}), dir.path()).status,
      0);
  std::filesystem::remove(dir.file("x.qt"));
  // No output is an image --dump writes.
  std::filesystem::create_directory(dir.file("dump2"));
  check(dir, "capture2qt",
        {{"--env-constant", "1,1,1", "--at", "0,0,0", "--res", "8", "--dump", "dump2", "-o",
          "dump2/capture_00000.exr"},
         2,
         "is an image --dump writes"});
  check(dir, "capture2qt",
        {{"--image", "dump/capture_00000.exr", "--env-rotate", "5", "-o", "i.qt"},
         2,
         "--env-rotate"});
  check(dir, "capture2qt",
        {{"--image", "dump/capture_00000.exr", "--res", "32", "-o", "i.qt"}, 2, "--res"});
  // Flags the rest of the command makes mean nothing (they were ignored, exit 0).
  check(dir, "capture2qt",
        {{"--image", "dump/capture_00000.exr", "--threads", "2", "-o", "i.qt"}, 2, "--threads"});
  check(dir, "qtinfo", {{"ok.qt", "--size", "64"}, 2, "--size"});
  check(dir, "qtconvolve",
        {{"ok.qt", "cap.qt", "--dense", "--accuracy", "0.1", "-o", "out.csv"}, 2, "--accuracy"});
  check(dir, "qtconvolve", {{"ok.qt", "cap.qt", "--dense", "--no-bound"}, 2, "--no-bound"});
  const auto timed =
      run_tool("qtconvolve",
               {"ok.qt", "cap.qt", "--dense", "--accuracy", "0.1", "--time", "--json"}, dir.path());
  EXPECT_EQ(timed.status, 0) << timed.err;  // the trees beside the dense product take it
  const auto image = run_tool(
      "capture2qt", {"--image", "dump/capture_00000.exr", "--json", "-o", "i.qt"}, dir.path());
  ASSERT_EQ(image.status, 0) << image.err;
  const auto j = nlohmann::json::parse(image.out);
  EXPECT_EQ(j["captures"], 1);
  EXPECT_EQ(j["resolution"], 8);
}

}  // namespace
}  // namespace basis
