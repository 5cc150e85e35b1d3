#include "basis/format/qt_shard.h"

#include <algorithm>
#include <filesystem>

#include "basis/core/version.h"
#include "basis/io/checksum.h"

namespace basis {

namespace {

std::string shard_name(const Shard& s) {
  return std::to_string(s.index) + "/" + std::to_string(s.count);
}

bool same_shape(const PackedShape& a, const PackedShape& b) {
  return a.resolution == b.resolution && a.channels == b.channels && a.groups == b.groups &&
         a.bounded_groups == b.bounded_groups && a.bounds == b.bounds;
}

void remove_checksum_file(const std::string& path) {
  std::error_code ec;
  std::filesystem::remove(checksum_path(path), ec);
  // A name too long to exist (an output's own name near the longest) has nothing to remove.
  if (ec && ec != std::errc::filename_too_long)
    throw FileError(checksum_path(path) + ": cannot remove: " + ec.message());
}

}  // namespace

void write_shard_file(const std::string& path, std::span<const std::byte> encoded) {
  check_name_fits_checksum_line(path);
  remove_checksum_file(path);
  write_qt(path, encoded);
  write_checksum_file(path, checksum_hex(encoded));
}

void write_unsharded_file(const std::string& path, std::span<const std::byte> encoded) {
  remove_checksum_file(path);
  write_qt(path, encoded);
}

ShardFile open_shard_file(const std::string& path) {
  const std::string recorded = read_checksum_file(path);
  auto altered = [&](const std::string& actual) {
    return FileError(path + ": altered since it was written (checksum " + actual.substr(0, 12) +
                     "..., its checksum file says " + recorded.substr(0, 12) +
                     "...); make the shard again");
  };
  std::optional<QtFile> loaded;
  try {
    loaded.emplace(QtFile::load(path));
  } catch (const FileError&) {
    // A file that no longer verifies is reported as what it is, when its checksum says so.
    std::error_code ec;
    if (!recorded.empty() && std::filesystem::is_regular_file(path, ec)) {
      const std::string actual = file_checksum_hex(path);
      if (actual != recorded) throw altered(actual);
    }
    throw;
  }
  QtFile& file = *loaded;
  // What the file is comes first: a table or a whole set has no checksum to look for.
  if (file.kind() != QtKind::capture_set)
    throw FileError(path + ": a " + to_string(file.kind()) + ", not a shard of captures");
  CaptureRecipe recipe = capture_recipe(file);
  if (!recipe.shard)
    throw FileError(path +
                    ": a whole capture set, not a shard of a sharded run (capture2qt "
                    "--shard)");
  if (recorded.empty())
    throw FileError(path + ": no checksum beside it (" + checksum_path(path) +
                    "): the run that wrote it did not finish; make the shard again");
  const std::string actual = checksum_hex(file.bytes());
  if (actual != recorded) throw altered(actual);
  std::string run = run_parameters(file.provenance().parameters, path);
  return {std::move(file), std::move(recipe), std::move(run), actual};
}

std::optional<std::string> why_shard_must_be_made(const std::string& path,
                                                  const CaptureRecipe& recipe,
                                                  const std::vector<std::string>& sources,
                                                  BoundKind bounds) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return path + ": missing";
  try {
    const ShardFile shard = open_shard_file(path);
    const Provenance p = shard.file.provenance();
    if (p.parameters != capture_parameters(recipe))
      return path + ": made with other parameters (" + p.parameters + ")";
    if (p.sources != sources) return path + ": made from other files";
    if (shard.file.trees().shape().bounds != bounds) return path + ": holds other --bounds";
    // A merge refuses shards of different versions: an upgrade re-makes every shard.
    if (p.tool_version != kVersion) return path + ": made by version " + p.tool_version;
  } catch (const FileError& e) {
    return e.what();
  }
  return std::nullopt;
}

void order_shards_of_one_run(std::vector<ShardFile>& shards) {
  if (shards.empty()) throw FileError("no shard files given");
  std::stable_sort(shards.begin(), shards.end(), [](const ShardFile& a, const ShardFile& b) {
    return a.recipe.shard->shard.index < b.recipe.shard->shard.index;
  });
  const ShardFile& first = shards.front();
  const CaptureShard& run = *first.recipe.shard;
  const Provenance first_provenance = first.file.provenance();
  for (std::size_t k = 0; k < shards.size(); ++k) {
    const ShardFile& s = shards[k];
    const std::string& name = s.file.name();
    const CaptureShard& mine = *s.recipe.shard;
    if (s.run_parameters != first.run_parameters)
      throw FileError(name + ": a shard of another run than " + first.file.name() +
                      " (other capture parameters)");
    if (mine.shard.count != run.shard.count || mine.total_points != run.total_points)
      throw FileError(name + ": shard " + shard_name(mine.shard) + " of " +
                      std::to_string(mine.total_points) + " points, where " + first.file.name() +
                      " is of a run of " + std::to_string(run.shard.count) + " shards and " +
                      std::to_string(run.total_points) + " points");
    if (s.file.provenance().sources != first_provenance.sources ||
        s.file.provenance().tool_version != first_provenance.tool_version)
      throw FileError(name + ": a shard of another run than " + first.file.name() +
                      " (other sources or tool version)");
    if (!same_shape(s.file.trees().shape(), first.file.trees().shape()) ||
        s.file.projection().tolerance != first.file.projection().tolerance ||
        s.file.projection().mode != first.file.projection().mode ||
        s.file.projection().max_depth != first.file.projection().max_depth)
      throw FileError(name + ": its trees differ in shape, bounds or tolerance from " +
                      first.file.name() + "'s");
    if (std::size_t(mine.shard.index) != k) {
      if (k > 0 && shards[k - 1].recipe.shard->shard.index == mine.shard.index)
        throw FileError(name + ": shard " + shard_name(mine.shard) + " given twice (also " +
                        shards[k - 1].file.name() + ")");
      throw FileError("shard " + std::to_string(k) + "/" + std::to_string(run.shard.count) +
                      " is missing (before " + name + ")");
    }
  }
  if (shards.size() != std::size_t(run.shard.count))
    throw FileError("shard " + std::to_string(shards.size()) + "/" +
                    std::to_string(run.shard.count) + " is missing (after " +
                    shards.back().file.name() + ")");
}

}  // namespace basis
