// The main job's files for the lookup benchmarks, made on first use and kept in the build
// folder (named with the format version): data/phong.json and data/ggx.json tabulated at the
// defaults ("phong", "ggx") and as the first version tabulated them ("phong_first", "ggx_first":
// 33 x 33 entries without derivatives over wo, cut relative to the mean), and 1000 captures on
// data/scene.obj under the Poly Haven sunrise map (as scripts/demo.sh makes them; "captures"),
// and the same captures' texels, uncut ("captures_texels", tolerance 0). Loaded as the tools load
// them, so that trees are read from a memory-mapped file, cold unless reused.
#pragma once

#include <filesystem>
#include <map>
#include <string>

#include "basis/brdf/brdf_spec.h"
#include "basis/brdf/brdf_table.h"
#include "basis/format/qt_file.h"
#include "basis/format/qt_recipe.h"
#include "basis/io/image_file.h"
#include "basis/lighting/capture.h"
#include "basis/lighting/embree_scene.h"
#include "basis/lighting/mesh.h"

namespace basis::bench {

inline const QtFile& main_job_file(const std::string& name) {
  static std::map<std::string, QtFile> loaded;
  if (auto it = loaded.find(name); it != loaded.end()) return it->second;
  const std::filesystem::path folder = BASIS_BENCH_DATA_DIR;
  std::filesystem::create_directories(folder);
  const std::string path =
      (folder / (name + "_v" + std::to_string(kQtFormatVersion) + ".qt")).string();
  const std::string source = BASIS_SOURCE_DIR;
  if (!std::filesystem::exists(path)) {
    if (name == "captures" || name == "captures_texels") {
      CaptureRecipe recipe;
      recipe.environment = "/usr/share/blender/datafiles/studiolights/world/sunrise.exr";
      recipe.scene = source + "/data/scene.obj";
      const TriangleMesh mesh = read_obj(recipe.scene);
      const EmbreeScene scene(mesh);
      const Environment env(read_image(recipe.environment), 0, recipe.environment);
      recipe.options = {.resolution = 128,
                        .strata = 2,
                        .seed = 1,
                        .ray_offset = mesh.ray_offset(),
                        .compact_lights = CaptureOptions::CompactLights::apart};
      if (name == "captures_texels") recipe.projection.tolerance = 0;
      CaptureSetOptions options;
      options.capture = recipe.options;
      options.projection = recipe.projection;
      const CaptureSet set = capture_set(env, &scene, sample_surface(mesh, 1000, 1), options);
      write_qt(path, encode_capture_set(set.view(), recipe.projection,
                                        {"capture2qt", "bench", capture_parameters(recipe), {}}));
    } else {
      const bool first = name.ends_with("_first");
      const BrdfSpec spec =
          read_brdf_spec(source + "/data/" + name.substr(0, name.find('_')) + ".json");
      BrdfTableOptions options;
      options.wo_resolution = first ? 33 : default_wo_resolution(spec.brdf);
      if (first) {
        options.wo_derivatives = false;
        options.projection.local_floor = 0;
      }
      const BrdfTable table = tabulate_brdf(spec.brdf, options);
      write_qt(path, encode_brdf_table(table.view(), spec.model, spec.text, options.projection,
                                       {"brdf2qt", "bench", "{}", {}}));
    }
  }
  return loaded.emplace(name, QtFile::load(path)).first->second;
}

}  // namespace basis::bench
