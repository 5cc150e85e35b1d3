#include "basis/render/render_scene.h"

#include <algorithm>

#include "basis/io/image_file.h"

namespace basis {

namespace {

std::unique_ptr<Environment> load_environment(const SceneFile& file,
                                              const SceneLoadOptions& options) {
  const SceneFile::EnvironmentSpec& e = file.environment;
  if (e.map.empty()) return std::make_unique<Environment>(Environment::constant(e.constant));
  auto environment = std::make_unique<Environment>(read_image(e.map), e.rotate_degrees, e.map);
  const std::string repaired =
      repaired_texels_warning(*environment, /*zero_invalid=*/false, "repair the map");
  if (!repaired.empty() && options.note) options.note(repaired);
  return environment;
}

}  // namespace

RenderScene load_render_scene(const SceneFile& file, const SceneLoadOptions& options) {
  RenderScene scene;
  scene.file = file;
  scene.environment = load_environment(file, options);
  scene.environment_sampler = std::make_unique<EnvironmentSampler>(*scene.environment);
  auto where = [&](std::size_t m) {
    return file.path + ":" + std::to_string(file.meshes[m].line) + ": mesh " + std::to_string(m) +
           ": ";
  };
  // Every mesh first, so that the files they name are known before any material is loaded.
  std::vector<std::size_t> triangles(file.meshes.size());
  std::vector<std::string> material_files;
  for (std::size_t m = 0; m < file.meshes.size(); ++m) {
    const SceneFile::MeshSpec& spec = file.meshes[m];
    TriangleMesh mesh;
    try {
      mesh = read_obj(spec.obj);
    } catch (const FileError& e) {
      throw FileError(where(m) + e.what());
    }
    if (mesh.dropped_degenerate > 0 && options.note)
      options.note(spec.obj + ": " + std::to_string(mesh.dropped_degenerate) +
                   " degenerate triangles dropped");
    for (const std::string& warning : mesh.reader_warnings)
      if (options.note) options.note(warning);
    material_files.insert(material_files.end(), mesh.material_files.begin(),
                          mesh.material_files.end());
    triangles[m] = mesh.triangles.size();
    scene.mesh.append(mesh);
  }
  if (options.before_materials) options.before_materials(material_files);
  for (std::size_t m = 0; m < file.meshes.size(); ++m) {
    const SceneFile::MeshSpec& spec = file.meshes[m];
    // A material used twice is loaded once.
    std::size_t material = m;
    for (std::size_t k = 0; k < m; ++k)
      if (file.meshes[k].material == spec.material) material = k;
    if (material == m) {
      MaterialReport report;
      try {
        scene.materials.push_back(
            load_material(spec.material, options.tables, options.control, &report));
      } catch (const FileError& e) {
        throw FileError(where(m) + e.what());
      }
      if (report.tabulated && options.note)
        options.note(spec.material + ": tabulated" +
                     (report.cache_written ? ", cached in " + table_cache_path(spec.material)
                                           : ", not cached (" + report.cache_problem + ")"));
    } else {
      scene.materials.push_back(scene.materials[material]);
    }
    scene.material_of.insert(scene.material_of.end(), triangles[m], std::uint32_t(material));
  }
  scene.rays = std::make_unique<EmbreeScene>(scene.mesh);
  scene.ray_offset = scene.mesh.ray_offset();
  return scene;
}

}  // namespace basis
