// Capture sets in several files: a manifest (a small JSON file) lists the shard files of one
// sharded capture run in order, with their point counts, sizes and XXH3-128 checksums (checksum.h),
// so that a set larger than one .qt file (2 GiB) can be read shard by shard in bounded memory.
//
//   {"format": "libbasis capture-set manifest", "version": 1, "total_points": 1000,
//    "run": {...the run's capture parameters...},
//    "shards": [{"file": "captures.0.qt", "points": 250, "bytes": 13720012,
//                "xxh128": "32 lowercase hex digits"}, ...]}
//
// Shard files are named relative to the manifest's folder (or absolutely). Shard k of N holds
// the run's points shard_range(total_points, {k, N}).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "basis/core/shard.h"
#include "basis/core/task.h"
#include "basis/format/qt_file.h"
#include "basis/format/qt_shard.h"

namespace basis {

inline constexpr int kManifestVersion = 1;

struct ManifestShard {
  std::string file;  // as the manifest names it
  std::uint64_t points = 0;
  std::uint64_t bytes = 0;
  std::string xxh128;
};

struct CaptureManifest {
  std::string path;  // where it was read from or goes
  std::uint64_t total_points = 0;
  std::string run_parameters;  // the run's capture parameters, JSON text
  std::vector<ManifestShard> shards;

  // Shard k's file as a path from here (relative names are relative to the manifest's folder).
  std::string shard_path(std::size_t k) const;
  // The run's points shard k holds.
  PointRange shard_points(std::size_t k) const;
};

// Whether a file is a manifest (JSON: its first character that is not white space is '{')
// rather than a .qt file. False for files that cannot be read (their reader reports them).
bool is_manifest(const std::string& path);

// Reads and checks a manifest; every problem is a FileError "PATH:LINE: field 'F': problem".
// Checks the fields' types and ranges, that the shards' points add up to total_points and that
// shard k holds shard k's points. The shard files are not opened.
CaptureManifest read_manifest(const std::string& path);

// The manifest of the shards of one run (ordered and checked by order_shards_of_one_run), to be
// written at `manifest_path`: each shard's name relative to the manifest's folder, its points,
// size and the checksum of the bytes that were verified.
CaptureManifest make_manifest(const std::vector<ShardFile>& shards,
                              const std::string& manifest_path);

// The manifest as JSON text (what read_manifest reads).
std::string manifest_json(const CaptureManifest& manifest);

// Writes manifest_json(manifest) to manifest.path atomically.
void write_manifest(const CaptureManifest& manifest);

// Opens shard k of a manifest and checks it against the manifest: its size, its checksum, that it
// verifies as a .qt file and is shard k of the manifest's run holding that shard's points.
// Throws FileError with one line naming the shard file: missing, altered since the manifest was
// made, or not the shard the manifest says.
QtFile open_manifest_shard(const CaptureManifest& manifest, std::size_t k);

// A capture set held by one .qt file (of any kind: a table or a tree is one "shard" too), or by
// the shard files a manifest lists, opened one at a time so that memory stays bounded.
class CaptureSource {
 public:
  // Opens a .qt file (loaded and verified) or reads a manifest (its shards are opened later).
  static CaptureSource open(const std::string& path);

  const std::string& path() const { return path_; }
  bool is_manifest() const { return manifest_.has_value(); }
  const CaptureManifest& manifest() const { return *manifest_; }
  // The kind of what it holds (a manifest holds a capture set).
  QtKind kind() const { return manifest_ ? QtKind::capture_set : file_->kind(); }
  // Captures in all (trees, for a .qt file that is not a capture set).
  std::uint64_t size() const;
  std::size_t shard_count() const { return manifest_ ? manifest_->shards.size() : 1; }
  PointRange shard_points(std::size_t k) const;
  // The shard holding capture `point`.
  std::size_t shard_of(std::uint64_t point) const;
  // Shard k's file: the .qt file itself, or shard k of the manifest, opened and checked
  // (open_manifest_shard) unless it is the one open already; opening another closes it.
  const QtFile& shard(std::size_t k);

 private:
  std::string path_;
  std::optional<CaptureManifest> manifest_;
  std::optional<QtFile> file_;
  std::size_t open_shard_ = 0;
};

}  // namespace basis
