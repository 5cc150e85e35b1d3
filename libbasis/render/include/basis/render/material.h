// Materials of rendered meshes: a BRDF and, for radiance-cache lookups, its table, from a BRDF
// spec (tabulated with brdf2qt's defaults and cached beside the spec) or a BRDF table file.
#pragma once

#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "basis/brdf/brdf.h"
#include "basis/brdf/brdf_table.h"
#include "basis/core/task.h"
#include "basis/format/qt_file.h"

namespace basis {

struct Material {
  std::string path;  // the spec (.json) or table (.qt) it was loaded from
  Brdf brdf;
  std::shared_ptr<const QtFile> table;  // null unless loaded with tables

  // The table's view; std::logic_error for a material loaded without tables.
  BrdfTableView table_view() const {
    if (!table) throw std::logic_error(path + ": the material was loaded without its table");
    return table->brdf_table();
  }
};

// The file a spec's table is cached in: SPEC_FOLDER/SPEC_STEM.table.qt.
std::string table_cache_path(const std::string& spec_path);

// What load_material did about the table, for reports.
struct MaterialReport {
  bool tabulated = false;      // the table was computed (no valid cache)
  bool cache_written = false;  // and written beside the spec
  std::string cache_problem;   // why the cache could not be written, if it could not
};

// Loads a material. With `with_table`, a spec's table is read from its cache when the cache
// holds this spec tabulated with these options (table_options), else tabulated (progress and
// cancellation through `control`) and written there atomically when the folder allows and no
// file is there that qtrender did not write (a user's table of that name is kept). Throws
// FileError naming the file for a spec or table that does not load.
Material load_material(const std::string& path, bool with_table, const TaskControl& control = {},
                       MaterialReport* report = nullptr);

}  // namespace basis
