// Capture sets in several files: shard files and their checksums, manifests and their errors,
// joining shards; every refusal is one line naming the file.
#include <gtest/gtest.h>

#include <fstream>

#include "basis/core/version.h"
#include "basis/format/qt_manifest.h"
#include "basis/format/qt_merge.h"
#include "basis/format/qt_recipe.h"
#include "basis/format/qt_shard.h"
#include "basis/io/checksum.h"
#include "basis/lighting/capture.h"
#include "support/run_tool.h"
#include "support/temp_dir.h"

namespace basis {
namespace {

using testing::TempDir;

// Points on a line, facing up, and a sky brighter towards +x: captures that differ.
std::vector<SurfacePoint> line_points(std::uint64_t count) {
  std::vector<SurfacePoint> points;
  for (std::uint64_t i = 0; i < count; ++i)
    points.push_back({Vec3(double(i), 0, 0), Vec3(0.1 * double(i % 3), 0, 1).normalized()});
  return points;
}

CaptureRecipe run_recipe() {
  CaptureRecipe r;
  r.constant = {1, 2, 3};
  r.options.resolution = 8;
  r.options.strata = 1;
  return r;
}

// Shard `s` of a run over line_points(total), encoded as capture2qt of `version` encodes it.
std::vector<std::byte> encode_shard(std::uint64_t total, const Shard& s,
                                    const std::string& version = "test") {
  CaptureRecipe recipe = run_recipe();
  recipe.shard = CaptureShard{s, total};
  const PointRange mine = recipe.shard->points();
  const std::vector<SurfacePoint> all = line_points(total);
  CaptureSetOptions options;
  options.capture = recipe.options;
  options.first_index = mine.first;
  const CaptureSet set = capture_set(
      Environment::constant(recipe.constant), nullptr,
      std::span(all).subspan(std::size_t(mine.first), std::size_t(mine.count)), options);
  return encode_capture_set(set.view(), recipe.projection,
                            {"capture2qt", version, capture_parameters(recipe), {}});
}

// Writes shards 0 .. count - 1 of a run of `total` points as DIR/s.K.qt with their checksums.
std::vector<std::string> write_run(const TempDir& dir, std::uint64_t total, int count) {
  std::vector<std::string> paths;
  for (int k = 0; k < count; ++k) {
    paths.push_back(dir.file("s." + std::to_string(k) + ".qt"));
    write_shard_file(paths.back(), encode_shard(total, {k, count}));
  }
  return paths;
}

std::vector<ShardFile> open_all(const std::vector<std::string>& paths) {
  std::vector<ShardFile> shards;
  for (const std::string& p : paths)
    shards.push_back(open_shard_file(p));
  return shards;
}

void expect_file_error(const std::function<void()>& f, const std::string& mentions) {
  try {
    f();
    ADD_FAILURE() << "no error; expected one mentioning " << mentions;
  } catch (const FileError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(mentions), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

TEST(ShardFiles, RunParametersAreTheSingleProcessText) {
  CaptureRecipe r = run_recipe();
  const std::string whole = capture_parameters(r);
  r.shard = CaptureShard{{2, 5}, 1000};
  const std::string shard = capture_parameters(r);
  EXPECT_NE(shard, whole);
  EXPECT_EQ(run_parameters(shard, "x"), whole);
  expect_file_error([] { run_parameters("[1, 2]", "odd.qt"); }, "odd.qt");
}

TEST(ShardFiles, OrderedCompleteAndOfOneRun) {
  TempDir dir;
  std::vector<std::string> paths = write_run(dir, 23, 4);
  std::vector<ShardFile> shards = open_all({paths[2], paths[0], paths[3], paths[1]});
  order_shards_of_one_run(shards);
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(shards[std::size_t(k)].recipe.shard->shard.index, k);
    EXPECT_EQ(shards[std::size_t(k)].file.captures().size(), shard_range(23, {k, 4}).count);
  }
  std::vector<ShardFile> missing = open_all({paths[0], paths[1], paths[3]});
  expect_file_error([&] { order_shards_of_one_run(missing); }, "shard 2/4 is missing");
  std::vector<ShardFile> twice = open_all({paths[0], paths[1], paths[1], paths[2], paths[3]});
  expect_file_error([&] { order_shards_of_one_run(twice); }, "given twice");
  // A shard of a run split another way.
  write_shard_file(dir.file("other.qt"), encode_shard(23, {1, 3}));
  std::vector<ShardFile> mixed = open_all({paths[0], dir.file("other.qt"), paths[2], paths[3]});
  expect_file_error([&] { order_shards_of_one_run(mixed); }, "other.qt");
}

TEST(ShardFiles, AlteredOrUncheckedFilesAreRefused) {
  TempDir dir;
  const std::vector<std::string> paths = write_run(dir, 10, 2);
  // A value's byte changed near the end (the file still verifies as a .qt file, or not).
  std::string bytes = testing::slurp(paths[1]);
  bytes[bytes.size() - 300] = char(bytes[bytes.size() - 300] ^ 1);
  std::ofstream(paths[1], std::ios::binary) << bytes;
  expect_file_error([&] { open_shard_file(paths[1]); }, "altered since it was written");
  std::filesystem::remove(checksum_path(paths[0]));
  expect_file_error([&] { open_shard_file(paths[0]); }, "no checksum beside it");
  // A whole capture set is not a shard.
  CaptureRecipe r = run_recipe();
  CaptureSetOptions options;
  options.capture = r.options;
  const auto points = line_points(3);
  const CaptureSet set = capture_set(Environment::constant(r.constant), nullptr, points, options);
  write_shard_file(dir.file("whole.qt"),
                   encode_capture_set(set.view(), r.projection,
                                      {"capture2qt", "test", capture_parameters(r), {}}));
  expect_file_error([&] { open_shard_file(dir.file("whole.qt")); }, "not a shard");
}

TEST(ShardFiles, ReRunsKeepOnlyShardsOfTheSameRunAndVersion) {
  TempDir dir;
  CaptureRecipe recipe = run_recipe();
  recipe.shard = CaptureShard{{0, 2}, 10};
  const std::string path = dir.file("s.0.qt");
  EXPECT_EQ(why_shard_must_be_made(path, recipe, {}, BoundKind::l2), path + ": missing");
  write_shard_file(path, encode_shard(10, {0, 2}, kVersion));
  EXPECT_EQ(why_shard_must_be_made(path, recipe, {}, BoundKind::l2), std::nullopt);
  EXPECT_NE(why_shard_must_be_made(path, recipe, {}, BoundKind::linf), std::nullopt);
  EXPECT_NE(why_shard_must_be_made(path, recipe, {"sky.exr"}, BoundKind::l2), std::nullopt);
  // Made by another version of the tools: a merge would refuse it beside new shards.
  write_shard_file(path, encode_shard(10, {0, 2}, "0.0.1"));
  EXPECT_EQ(why_shard_must_be_made(path, recipe, {}, BoundKind::l2),
            path + ": made by version 0.0.1");
}

TEST(Manifests, ListShardsAndCheckThemAsTheyOpen) {
  TempDir dir;
  const std::vector<std::string> paths = write_run(dir, 23, 3);
  std::vector<ShardFile> shards = open_all(paths);
  order_shards_of_one_run(shards);
  CaptureManifest made = make_manifest(shards, dir.file("set.qtm"));
  write_manifest(made);
  ASSERT_TRUE(is_manifest(dir.file("set.qtm")));
  EXPECT_FALSE(is_manifest(paths[0]));
  const CaptureManifest m = read_manifest(dir.file("set.qtm"));
  EXPECT_EQ(m.total_points, 23u);
  ASSERT_EQ(m.shards.size(), 3u);
  EXPECT_EQ(m.shards[1].file, "s.1.qt");  // relative to the manifest's folder
  std::uint64_t points = 0;
  for (std::size_t k = 0; k < 3; ++k) {
    const QtFile f = open_manifest_shard(m, k);
    EXPECT_EQ(f.captures().size(), m.shards[k].points);
    EXPECT_EQ(m.shard_points(k).first, points);
    points += m.shards[k].points;
    EXPECT_EQ(m.shards[k].xxh128, file_checksum_hex(paths[k]));
  }
  EXPECT_EQ(points, 23u);
  // The source walks shards in order and finds each point's.
  CaptureSource source = CaptureSource::open(dir.file("set.qtm"));
  EXPECT_EQ(source.size(), 23u);
  for (std::uint64_t p = 0; p < 23; ++p) {
    const std::size_t k = source.shard_of(p);
    EXPECT_GE(p, source.shard_points(k).first);
    EXPECT_LT(p, source.shard_points(k).end());
  }

  // Altered in place (same size), replaced by another shard, missing: one line each.
  const std::string original = testing::slurp(paths[2]);
  std::string altered = original;
  altered[altered.size() - 200] = char(altered[altered.size() - 200] ^ 4);
  std::ofstream(paths[2], std::ios::binary) << altered;
  expect_file_error([&] { open_manifest_shard(m, 2); }, "s.2.qt: altered since");
  std::filesystem::copy_file(paths[0], paths[2], std::filesystem::copy_options::overwrite_existing);
  expect_file_error([&] { open_manifest_shard(m, 2); }, "s.2.qt");
  std::filesystem::remove(paths[2]);
  expect_file_error([&] { open_manifest_shard(m, 2); }, "s.2.qt");
}

// A manifest written through ".." or a symbolic link names its shards from the folder it
// lands in: they used to be named from the path as given, and were then not found.
TEST(Manifests, NameTheirShardsFromTheFolderTheyLandIn) {
  TempDir dir;
  const std::vector<std::string> paths = write_run(dir, 7, 2);
  std::vector<ShardFile> shards = open_all(paths);
  order_shards_of_one_run(shards);
  std::filesystem::create_directory(dir.file("a"));
  std::filesystem::create_directory(dir.file("other"));
  std::filesystem::create_directories(dir.file("deep/er/other"));
  std::filesystem::create_directory_symlink(dir.file("deep/er/other"), dir.file("link"));
  // A link one level down to a folder three levels down: "../s.0.qt" from the link's folder
  // would lead to deep/er/s.0.qt.
  for (const auto& [manifest, listed] :
       {std::pair<std::string, std::string>{"a/../other/up.qtm", "../s.0.qt"},
        {"link/linked.qtm", "../../../s.0.qt"}}) {
    write_manifest(make_manifest(shards, dir.file(manifest)));
    const CaptureManifest m = read_manifest(dir.file(manifest));
    EXPECT_EQ(m.shards[0].file, listed) << manifest;
    for (std::size_t k = 0; k < 2; ++k)
      EXPECT_EQ(open_manifest_shard(m, k).captures().size(), m.shards[k].points) << manifest;
  }
}

TEST(Manifests, MalformedManifestsNameTheLineAndField) {
  TempDir dir;
  const std::string path = dir.file("bad.qtm");
  const std::string hex(32, 'a');
  const std::string shard =
      R"({"file": "a.qt", "points": 5, "bytes": 100, "xxh128": ")" + hex + R"("})";
  auto manifest = [&](const std::string& total, const std::string& shards,
                      const std::string& extra = "") {
    return "{\n\"format\": \"libbasis capture-set manifest\",\n\"version\": 1,\n"
           "\"total_points\": " +
           total + ",\n\"run\": {},\n\"shards\": [\n" + shards + "\n]" + extra + "\n}\n";
  };
  std::ofstream(path) << manifest("10", shard + ",\n" + shard);
  EXPECT_EQ(read_manifest(path).shards.size(), 2u);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"{", "invalid JSON"},
      {"[]", "a JSON object"},
      {manifest("10", shard + ",\n" + shard, ",\n\"extra\": 1"), "'extra'"},
      {manifest("-3", shard), "'total_points'"},
      {manifest("1.5", shard), "'total_points'"},
      {manifest("11", shard + ",\n" + shard), "shards[1].points"},
      {manifest("10", ""), "'shards'"},
      {manifest("10", shard + ",\n" + R"({"file": "", "points": 5, "bytes": 1, "xxh128": ")" + hex +
                          R"("})"),
       "shards[1].file"},
      {manifest("10", shard + ",\n" + R"({"file": "b", "points": 5, "bytes": 1, "xxh128": "xyz"})"),
       "shards[1].xxh128"},
      {manifest("10", shard + ",\n" + R"({"file": "b", "points": 5, "bytes": 1e99, "xxh128": ")" +
                          hex + R"("})"),
       "shards[1].bytes"},
      {"{\"format\": \"other\", \"version\": 1}", "'format'"},
      {"{\"format\": \"libbasis capture-set manifest\", \"version\": 7}", "newer"}};
  for (const auto& [text, mentions] : cases) {
    std::ofstream(path, std::ios::trunc) << text;
    expect_file_error([&] { read_manifest(path); }, mentions);
    expect_file_error([&] { read_manifest(path); }, "bad.qtm");
  }
  expect_file_error([&] { read_manifest(dir.file("missing.qtm")); }, "missing.qtm");
  expect_file_error([&] { read_manifest(dir.path()); }, "is a directory");
}

TEST(MergeCaptureSets, RefusesWhatOneFileCannotHoldBeforeAssemblingIt) {
  TempDir dir;
  const std::vector<std::string> paths = write_run(dir, 12, 3);
  std::vector<ShardFile> shards = open_all(paths);
  order_shards_of_one_run(shards);
  std::vector<const QtFile*> sets;
  for (const ShardFile& s : shards)
    sets.push_back(&s.file);
  const Provenance provenance = run_provenance(shards[0].file);
  const std::vector<std::byte> merged = merge_capture_sets(sets, provenance, "all.qt");
  // The bound covers the real size, and a limit under it is refused in one line naming the output.
  const std::uint64_t bound = merged_size_bound(sets, provenance);
  EXPECT_GE(bound, merged.size());
  // And by no more than its allowance for the file's tables: it counted trees as they lie in
  // memory, a quarter more than files hold, and refused joins of sets one file holds.
  EXPECT_LE(bound, merged.size() + (64 << 10) + 512);
  expect_file_error([&] { merge_capture_sets(sets, provenance, "all.qt", bound - 1); },
                    "all.qt: the 3 files hold up to");
  // What was joined: the shards' captures in order, each tree word for word.
  const QtFile joined = QtFile::from_bytes(merged, "all.qt");
  ASSERT_EQ(joined.captures().size(), 12u);
  std::size_t k = 0;
  for (const ShardFile& s : shards)
    for (std::size_t i = 0; i < s.file.captures().size(); ++i, ++k) {
      EXPECT_EQ(joined.captures().positions[k], s.file.captures().positions[i]);
      const auto a = joined.trees().tree(k).words(), b = s.file.trees().tree(i).words();
      EXPECT_TRUE(std::equal(a.begin(), a.end(), b.begin(), b.end()));
    }
  EXPECT_EQ(joined.provenance().parameters, capture_parameters(run_recipe()));
}

}  // namespace
}  // namespace basis
