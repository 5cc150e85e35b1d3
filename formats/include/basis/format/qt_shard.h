// Shard files of a sharded capture run (capture2qt --shard I/N): each written with its checksum
// beside it, and checked before a re-run skips it, a manifest lists it or qtmerge joins it.
#pragma once

#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "basis/format/qt_file.h"
#include "basis/format/qt_recipe.h"

namespace basis {

// Writes an encoded shard atomically, then its checksum file (PATH.xxh128, checksum.h). A
// checksum file left by an earlier run is removed first, so that no file ever sits beside a
// checksum that is not its own: a shard killed at any moment has either no file or no checksum.
void write_shard_file(const std::string& path, std::span<const std::byte> encoded);

// Writes an encoded file that is not a shard atomically, first removing a checksum file an
// earlier shard left at PATH.xxh128, which would no longer be its own.
void write_unsharded_file(const std::string& path, std::span<const std::byte> encoded);

// A shard file loaded and checked.
struct ShardFile {
  QtFile file;
  CaptureRecipe recipe;        // recipe.shard says which shard of which run
  std::string run_parameters;  // the whole run's parameters (qt_recipe.h run_parameters)
  std::string xxh128;
};

// Loads a shard file and checks it: its bytes match the checksum written beside it, it verifies
// as a .qt file, it is a capture set whose recipe names a shard (capture2qt --shard) and holds
// that shard's points. Throws FileError with one line naming the file: missing, no checksum,
// altered since it was written, not a shard, or holding other points than its shard.
ShardFile open_shard_file(const std::string& path);

// What a re-run of shard `recipe.shard` expects to find at `path` to skip it: a shard file
// that opens (open_shard_file) with exactly these parameters (capture_parameters(recipe)),
// sources and bound kind, made by this version of the tools. Returns why it cannot be skipped
// ("PATH: problem"), or nothing when it can. Never throws for a bad or missing file.
std::optional<std::string> why_shard_must_be_made(const std::string& path,
                                                  const CaptureRecipe& recipe,
                                                  const std::vector<std::string>& sources,
                                                  BoundKind bounds);

// Checks that shard files are the shards of one run, complete, and sorts them by shard index:
// the same run parameters, sources, tree shape and projection, shard counts, and indices
// 0 .. N - 1 once each. Throws FileError naming the first file that does not fit (or the shard
// that is missing).
void order_shards_of_one_run(std::vector<ShardFile>& shards);

}  // namespace basis
