#include "basis/render/material.h"

#include <filesystem>

#include "basis/brdf/brdf_spec.h"
#include "basis/core/version.h"
#include "basis/format/qt_recipe.h"

namespace basis {

std::string table_cache_path(const std::string& spec_path) {
  std::filesystem::path p = spec_path;
  return (p.parent_path() / (p.stem().string() + ".table.qt")).string();
}

namespace {

// The cached table, when it is a table of this spec with these options.
std::shared_ptr<const QtFile> valid_cache(const std::string& cache, const BrdfSpec& spec,
                                          const BrdfTableOptions& options) {
  if (!std::filesystem::exists(cache)) return nullptr;
  try {
    auto file = std::make_shared<QtFile>(QtFile::load(cache));
    if (file->kind() != QtKind::brdf_table || file->brdf_spec() != spec.text ||
        file->provenance().parameters != table_parameters(options, spec.brdf))
      return nullptr;
    return file;
  } catch (const FileError&) {
    return nullptr;  // unreadable or altered: tabulated again (replaceable_cache decides)
  }
}

// Whether a file at the cache's path may be replaced: none is there, or one that this tool
// wrote (a table of another spec or options). A file of anyone else's, or one that does not
// load (whose maker cannot be told), is left as it is.
bool replaceable_cache(const std::string& cache) {
  if (!std::filesystem::exists(cache)) return true;
  try {
    return QtFile::load(cache).provenance().tool == "qtrender";
  } catch (const FileError&) {
    return false;
  }
}

}  // namespace

Material load_material(const std::string& path, bool with_table, const TaskControl& control,
                       MaterialReport* report) {
  Material material;
  material.path = path;
  if (std::filesystem::path(path).extension() == ".qt") {
    auto file = std::make_shared<QtFile>(QtFile::load(path));
    if (file->kind() != QtKind::brdf_table)
      throw FileError(path + ": a " + to_string(file->kind()) + ", not a BRDF table");
    material.brdf = table_brdf(*file).brdf;
    if (with_table) material.table = std::move(file);
    return material;
  }
  const BrdfSpec spec = read_brdf_spec(path);
  material.brdf = spec.brdf;
  if (!with_table) return material;
  const BrdfTableOptions options = table_options(spec);
  const std::string cache = table_cache_path(path);
  material.table = valid_cache(cache, spec, options);
  if (material.table) return material;
  const BrdfTable table = tabulate_brdf(spec.brdf, options, control);
  const auto bytes =
      encode_brdf_table(table.view(), spec.model, spec.text, options.projection,
                        {"qtrender", kVersion, table_parameters(options, spec.brdf), {path}});
  MaterialReport r{true, false, {}};
  if (!replaceable_cache(cache)) {
    r.cache_problem =
        cache + ": a file qtrender did not write, or that does not load, left as it is";
  } else {
    try {
      write_qt(cache, bytes);
      r.cache_written = true;
    } catch (const FileError& e) {
      r.cache_problem = e.what();
    }
  }
  if (report) *report = r;
  material.table = std::make_shared<QtFile>(QtFile::from_bytes(bytes, path + " (tabulated)"));
  return material;
}

}  // namespace basis
