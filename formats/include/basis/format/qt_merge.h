// Joining the shards of a sharded capture run into the one capture set a single process would
// have written, where it fits in one .qt file.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "basis/format/qt_file.h"

namespace basis {

// The provenance one process capturing every point would have recorded: the shard's, with the
// run's parameters (without the shard's).
Provenance run_provenance(const QtFile& shard);

// An upper bound on the encoded size of the capture sets' captures joined into one.
std::uint64_t merged_size_bound(std::span<const QtFile* const> sets, const Provenance& provenance);

// The capture sets' captures, trees and lights joined in order into one encoded capture set with
// this provenance: for the ordered shards of one run (qt_shard.h, qt_manifest.h) and
// run_provenance, byte for byte the file one process writes. Throws FileError naming `output`
// when merged_size_bound exceeds max_bytes (at most kQtMaxFileBytes, what one .qt file holds),
// before the set is assembled; std::invalid_argument for sets of different tree shapes.
std::vector<std::byte> merge_capture_sets(std::span<const QtFile* const> sets,
                                          const Provenance& provenance, const std::string& output,
                                          std::uint64_t max_bytes = kQtMaxFileBytes);

}  // namespace basis
