#include "basis/format/qt_manifest.h"

#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "basis/core/file_error.h"
#include "basis/io/atomic_file.h"
#include "basis/io/checksum.h"
#include "basis/io/json_fields.h"
#include "basis/io/json_text.h"
#include "basis/io/points_file.h"

namespace basis {

namespace {

constexpr const char* kManifestFormat = "libbasis capture-set manifest";
// Manifests are small: a line per shard.
constexpr std::uintmax_t kMaxManifestBytes = std::uintmax_t(1) << 30;

using nlohmann::json;

std::uint64_t whole_number(const JsonFields& fields, const json& object, const std::string& key,
                           const std::string& path, std::uint64_t lo, std::uint64_t hi) {
  if (!object.contains(key))
    fields.fail(path, "missing (a whole number from " + std::to_string(lo) + " to " +
                          std::to_string(hi) + ")");
  const json& v = object.at(key);
  if (!v.is_number_unsigned() && !(v.is_number_integer() && v.get<std::int64_t>() >= 0))
    fields.fail(path, "must be a whole number from " + std::to_string(lo) + " to " +
                          std::to_string(hi) + ", got " + v.dump());
  const std::uint64_t x = v.get<std::uint64_t>();
  if (x < lo || x > hi)
    fields.fail(path, "must be from " + std::to_string(lo) + " to " + std::to_string(hi) +
                          ", got " + std::to_string(x));
  return x;
}

std::string read_text(const std::string& path) {
  check_regular_file(path, "a manifest");
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) throw FileError(path + ": " + ec.message());
  if (size > kMaxManifestBytes)
    throw FileError(path + ": " + std::to_string(size) + " bytes, too large for a manifest");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path + ": cannot open");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw FileError(path + ": cannot read");
  return text.str();
}

// The folder a file lies in as the file system resolves it (symbolic links, ".."): where a
// manifest written through a link to a file elsewhere lands, and names its shards from.
std::filesystem::path resolved_folder(const std::filesystem::path& file) {
  std::error_code error;
  const std::filesystem::path resolved =
      std::filesystem::weakly_canonical(std::filesystem::absolute(file, error), error);
  return error ? file.parent_path() : resolved.parent_path();
}

}  // namespace

std::string CaptureManifest::shard_path(std::size_t k) const {
  const std::filesystem::path file(shards.at(k).file);
  if (file.is_absolute()) return file.string();
  // Named from the folder the manifest lies in, resolved; as spelt from the manifest's path
  // when that leads to the same file (so that messages keep the user's spelling).
  const std::filesystem::path given = std::filesystem::path(path).parent_path() / file;
  const std::filesystem::path resolved = resolved_folder(path) / file;
  std::error_code error;
  const std::filesystem::path given_resolved =
      std::filesystem::weakly_canonical(std::filesystem::absolute(given, error), error);
  if (!error && given_resolved == std::filesystem::weakly_canonical(resolved, error) && !error)
    return given.string();
  return resolved.string();
}

PointRange CaptureManifest::shard_points(std::size_t k) const {
  return shard_range(total_points, {int(k), int(shards.size())});
}

bool is_manifest(const std::string& path) {
  // Only a regular file is read: a FIFO would wait for a writer (the .qt reader names it).
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) return false;
  std::ifstream in(path, std::ios::binary);
  char c = 0;
  while (in.get(c))
    if (!std::isspace(static_cast<unsigned char>(c))) return c == '{';
  return false;
}

CaptureManifest read_manifest(const std::string& path) {
  const std::string text = read_text(path);
  const JsonFields fields(text, path);
  const json root = fields.parse();
  if (!root.is_object()) fields.fail("", "a manifest is a JSON object");
  // JSON without the manifest's format (a spec, a scene) is not a manifest at all: said so
  // before its fields are judged as a manifest's.
  if (!root.contains("format") || !root.at("format").is_string() ||
      root.at("format").get<std::string>() != kManifestFormat)
    throw FileError(path +
                    ": JSON, but not a .qt file or a capture-set manifest (its field 'format' is "
                    "not \"" +
                    kManifestFormat + "\")");
  fields.only(root, {"format", "version", "total_points", "run", "shards"}, "");
  const std::uint64_t version = whole_number(fields, root, "version", "version", 1, 1u << 30);
  if (version > std::uint64_t(kManifestVersion))
    fields.fail("version", "version " + std::to_string(version) +
                               " is newer than this libbasis reads (" +
                               std::to_string(kManifestVersion) + ")");
  CaptureManifest manifest;
  manifest.path = path;
  manifest.total_points =
      whole_number(fields, root, "total_points", "total_points", 1, std::uint64_t(1) << 40);
  if (!root.contains("run") || !root.at("run").is_object())
    fields.fail("run", "missing (the run's capture parameters, an object)");
  manifest.run_parameters = json_text(root.at("run"));
  if (!root.contains("shards") || !root.at("shards").is_array() || root.at("shards").empty())
    fields.fail("shards", "missing (a list of shard files)");
  const json& shards = root.at("shards");
  if (shards.size() > std::size_t(kMaxShards))
    fields.fail("shards", "more than " + std::to_string(kMaxShards) + " shards");
  for (std::size_t k = 0; k < shards.size(); ++k) {
    const json& s = shards[k];
    const std::string at = "shards[" + std::to_string(k) + "]";
    if (!s.is_object()) fields.fail("shards", "shard " + std::to_string(k) + " is not an object");
    fields.only(s, {"file", "points", "bytes", "xxh128"}, at);
    ManifestShard shard;
    shard.file = fields.string(s, "file", at + ".file");
    if (shard.file.empty() || shard.file.find('\0') != std::string::npos)
      fields.fail(at + ".file", "must name a file");
    shard.points = whole_number(fields, s, "points", at + ".points", 1, kMaxSurfacePoints);
    shard.bytes = whole_number(fields, s, "bytes", at + ".bytes", 1, kQtMaxFileBytes);
    shard.xxh128 = fields.string(s, "xxh128", at + ".xxh128");
    if (!is_checksum_text(shard.xxh128))
      fields.fail(at + ".xxh128", "must be 32 lowercase hex digits (an XXH3-128 checksum)");
    manifest.shards.push_back(std::move(shard));
  }
  for (std::size_t k = 0; k < manifest.shards.size(); ++k) {
    const std::uint64_t expected = manifest.shard_points(k).count;
    if (manifest.shards[k].points != expected)
      fields.fail("shards[" + std::to_string(k) + "].points",
                  "shard " + std::to_string(k) + " of " + std::to_string(manifest.shards.size()) +
                      " of a run of " + std::to_string(manifest.total_points) + " points holds " +
                      std::to_string(expected) + ", not " +
                      std::to_string(manifest.shards[k].points));
  }
  return manifest;
}

CaptureManifest make_manifest(const std::vector<ShardFile>& shards,
                              const std::string& manifest_path) {
  if (shards.empty()) throw FileError(manifest_path + ": no shards to list");
  CaptureManifest manifest;
  manifest.path = manifest_path;
  manifest.total_points = shards.front().recipe.shard->total_points;
  manifest.run_parameters = shards.front().run_parameters;
  // Both folders as the file system resolves them (symbolic links, "..") before one is named from
  // the other: a name relative to an unresolved folder can lead elsewhere. A shard keeps its own
  // name (a link to a shard is listed as the link).
  const std::filesystem::path folder = resolved_folder(manifest_path);
  for (const ShardFile& s : shards) {
    const std::filesystem::path name(s.file.name());
    const std::filesystem::path file = resolved_folder(name) / name.filename();
    const std::string listed = file.lexically_relative(folder).string();
    std::error_code error;
    if (listed.empty() || !std::filesystem::equivalent(folder / listed, s.file.name(), error))
      throw FileError(s.file.name() + ": " + manifest_path +
                      " cannot name it from its folder; write the manifest elsewhere");
    // A JSON manifest names its shards in UTF-8; another name could not be read back as itself.
    if (!json_holds_exactly(listed))
      throw FileError(s.file.name() + ": a manifest cannot list a file whose name is not UTF-8");
    manifest.shards.push_back({listed, s.file.captures().size(), s.file.byte_size(), s.xxh128});
  }
  return manifest;
}

std::string manifest_json(const CaptureManifest& manifest) {
  nlohmann::ordered_json j;
  j["format"] = kManifestFormat;
  j["version"] = kManifestVersion;
  j["total_points"] = manifest.total_points;
  j["run"] = nlohmann::ordered_json::parse(manifest.run_parameters);
  j["shards"] = nlohmann::ordered_json::array();
  for (const ManifestShard& s : manifest.shards)
    j["shards"].push_back(
        {{"file", s.file}, {"points", s.points}, {"bytes", s.bytes}, {"xxh128", s.xxh128}});
  // One line per shard, so that the file reads (and diffs) as a list.
  std::string text = "{\n";
  bool first = true;
  for (const auto& [key, value] : j.items()) {
    text += first ? "" : ",\n";
    first = false;
    text += "  " + json_text(json(key)) + ": ";
    if (key != "shards") {
      text += json_text(value);
      continue;
    }
    text += "[\n";
    for (std::size_t k = 0; k < value.size(); ++k)
      text += "    " + json_text(value[k]) + (k + 1 < value.size() ? ",\n" : "\n");
    text += "  ]";
  }
  return text + "\n}\n";
}

void write_manifest(const CaptureManifest& manifest) {
  const std::string text = manifest_json(manifest);
  write_file_atomically(manifest.path, std::as_bytes(std::span(text.data(), text.size())));
}

QtFile open_manifest_shard(const CaptureManifest& manifest, std::size_t k) {
  const ManifestShard& entry = manifest.shards.at(k);
  const std::string path = manifest.shard_path(k);
  const std::string listed = " (listed by " + manifest.path + ")";
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) throw FileError(path + ": " + ec.message() + listed);
  if (size != entry.bytes)
    throw FileError(path + ": " + std::to_string(size) + " bytes where the manifest says " +
                    std::to_string(entry.bytes) + ": altered or replaced since " + manifest.path +
                    " was made");
  auto altered = [&](const std::string& actual) {
    return FileError(path + ": altered since " + manifest.path + " was made (checksum " +
                     actual.substr(0, 12) + "..., the manifest says " + entry.xxh128.substr(0, 12) +
                     "...)");
  };
  std::optional<QtFile> loaded;
  try {
    loaded.emplace(QtFile::load(path));
  } catch (const FileError&) {
    // A file that no longer verifies is reported as altered, when its checksum says so.
    if (const std::string actual = file_checksum_hex(path); actual != entry.xxh128)
      throw altered(actual);
    throw;
  }
  QtFile& file = *loaded;
  if (const std::string actual = checksum_hex(file.bytes()); actual != entry.xxh128)
    throw altered(actual);
  if (file.kind() != QtKind::capture_set)
    throw FileError(path + ": a " + std::string(to_string(file.kind())) +
                    ", not a shard of captures" + listed);
  const CaptureRecipe recipe = capture_recipe(file);
  const Shard expected{int(k), int(manifest.shards.size())};
  if (!recipe.shard || recipe.shard->shard != expected ||
      recipe.shard->total_points != manifest.total_points)
    throw FileError(path + ": not shard " + std::to_string(k) + "/" +
                    std::to_string(manifest.shards.size()) + " of the run of " +
                    std::to_string(manifest.total_points) + " points" + listed);
  if (json::parse(run_parameters(file.provenance().parameters, path)) !=
      json::parse(manifest.run_parameters))
    throw FileError(path + ": a shard of another run (other capture parameters)" + listed);
  return std::move(file);
}

CaptureSource CaptureSource::open(const std::string& path) {
  CaptureSource source;
  source.path_ = path;
  if (basis::is_manifest(path))
    source.manifest_ = read_manifest(path);
  else
    source.file_.emplace(QtFile::load(path));
  return source;
}

std::uint64_t CaptureSource::size() const {
  if (manifest_) return manifest_->total_points;
  return file_->trees().size();
}

PointRange CaptureSource::shard_points(std::size_t k) const {
  if (manifest_) return manifest_->shard_points(k);
  return {0, size()};
}

std::size_t CaptureSource::shard_of(std::uint64_t point) const {
  if (!manifest_) return 0;
  const std::size_t n = manifest_->shards.size();
  // Shard k starts at floor(k total / n): the shard is about point n / total, then adjusted.
  std::size_t k = std::size_t(double(point) * double(n) / double(manifest_->total_points));
  k = std::min(k, n - 1);
  while (k > 0 && shard_points(k).first > point)
    --k;
  while (k + 1 < n && shard_points(k).end() <= point)
    ++k;
  return k;
}

const QtFile& CaptureSource::shard(std::size_t k) {
  if (!manifest_) return *file_;
  if (file_ && open_shard_ == k) return *file_;
  file_.reset();
  file_.emplace(open_manifest_shard(*manifest_, k));
  open_shard_ = k;
  return *file_;
}

}  // namespace basis
