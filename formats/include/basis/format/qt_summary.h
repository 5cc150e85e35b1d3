// What a .qt file holds, summarised for people (text) and scripts (JSON): kind, shape,
// tolerance, node counts, depth histogram, storage against dense grids, provenance.
#pragma once

#include <string>

#include "basis/format/qt_file.h"

namespace basis {

// A multi-line human-readable summary.
std::string summary_text(const QtFile& file);

// The same facts as one JSON object (pretty-printed).
std::string summary_json(const QtFile& file);

}  // namespace basis
