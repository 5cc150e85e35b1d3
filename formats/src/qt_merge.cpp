#include "basis/format/qt_merge.h"

#include <cstdio>
#include <stdexcept>

#include "basis/format/qt_recipe.h"

namespace basis {

Provenance run_provenance(const QtFile& shard) {
  Provenance p = shard.provenance();
  p.parameters = run_parameters(p.parameters, shard.name());
  return p;
}

std::uint64_t merged_size_bound(std::span<const QtFile* const> sets, const Provenance& provenance) {
  std::uint64_t bytes = 64 << 10;  // the file's tables, offsets and alignment, generously
  bytes += provenance.tool.size() + provenance.tool_version.size() + provenance.parameters.size();
  for (const std::string& s : provenance.sources)
    bytes += s.size() + 8;
  for (const QtFile* set : sets) {
    const CaptureSetView c = set->captures();
    // The trees as files store them (without the values loading restores), which is how the
    // joined file stores them too; their size in memory is about 30 % more.
    bytes += set->stored_tree_bytes() + 16;
    bytes += c.size() * (3 * sizeof(Vec3) + sizeof(std::uint32_t)) + 16;
    bytes += c.lights.size_bytes() + 16;
  }
  return bytes;
}

std::vector<std::byte> merge_capture_sets(std::span<const QtFile* const> sets,
                                          const Provenance& provenance, const std::string& output,
                                          std::uint64_t max_bytes) {
  if (sets.empty()) throw std::invalid_argument("no capture sets to merge");
  const std::uint64_t bound = merged_size_bound(sets, provenance);
  const std::uint64_t limit = std::min<std::uint64_t>(max_bytes, kQtMaxFileBytes);
  if (bound > limit) {
    char size[64];
    std::snprintf(size, sizeof size, "%.2f GiB", double(bound) / double(1 << 30));
    throw FileError(
        output + ": the " + std::to_string(sets.size()) + " files hold up to " + size +
        ", more than one .qt file holds (" + std::to_string(limit) +
        " bytes): keep them as shards and list them in a manifest (qtmerge --manifest)");
  }
  const CaptureSetView first = sets.front()->captures();
  CaptureSet merged;
  merged.trees = TreeSet(first.trees.shape());
  bool any_lights = false;
  for (const QtFile* set : sets) {
    const CaptureSetView c = set->captures();
    if (!(c.trees.shape() == first.trees.shape()))
      throw std::invalid_argument(set->name() + ": trees of another shape than " +
                                  sets.front()->name() + "'s");
    for (std::size_t k = 0; k < c.size(); ++k) {
      merged.trees.append(c.trees.tree(k));
      merged.positions.push_back(c.positions[k]);
      merged.normals.push_back(c.normals[k]);
      merged.tangents.push_back(c.tangents[k]);
      merged.light_offsets.push_back(std::uint32_t(merged.lights.size()));
      const auto lights = c.lights_of(k);
      merged.lights.insert(merged.lights.end(), lights.begin(), lights.end());
      any_lights = any_lights || !lights.empty();
    }
  }
  merged.light_offsets.push_back(std::uint32_t(merged.lights.size()));
  // A set whose captures see no light stores no offsets (as one process writes it).
  if (!any_lights) merged.light_offsets.clear();
  return encode_capture_set(merged.view(), sets.front()->projection(), provenance);
}

}  // namespace basis
