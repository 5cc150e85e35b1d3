// What a .qt file holds, summarised for people (text) and scripts (JSON): kind, shape,
// tolerance, node counts, depth histogram, storage against dense grids, provenance.
#pragma once

#include <string>

#include "basis/core/task.h"
#include "basis/format/qt_file.h"
#include "basis/format/qt_manifest.h"

namespace basis {

// A multi-line human-readable summary.
std::string summary_text(const QtFile& file);

// The same facts as one JSON object (pretty-printed).
std::string summary_json(const QtFile& file);

// The same for the capture set a manifest lists: every shard opened and checked in turn
// (open_manifest_shard; a bad shard is a FileError naming it), the facts added up over the shards,
// the run's provenance, and the shards (JSON "manifest": {"path", "total_points", "shards"}).
std::string summary_text(const CaptureManifest& manifest, const TaskControl& control = {});
std::string summary_json(const CaptureManifest& manifest, const TaskControl& control = {});

}  // namespace basis
