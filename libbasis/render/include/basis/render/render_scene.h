// A scene loaded for rendering: its meshes merged into one traced mesh with a material per
// triangle, the environment, and the camera.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "basis/lighting/embree_scene.h"
#include "basis/lighting/environment.h"
#include "basis/lighting/mesh.h"
#include "basis/render/environment_sampler.h"
#include "basis/render/material.h"
#include "basis/render/scene_file.h"

namespace basis {

struct RenderScene {
  SceneFile file;
  std::unique_ptr<Environment> environment;
  std::unique_ptr<EnvironmentSampler> environment_sampler;
  TriangleMesh mesh;                       // every mesh of the file, in order
  std::vector<std::uint32_t> material_of;  // per triangle of `mesh`
  std::vector<Material> materials;         // per mesh of the file
  std::unique_ptr<EmbreeScene> rays;
  // How far rays leave surfaces along their normal: TriangleMesh::ray_offset, 1e-4 of the mesh's
  // extent, or more where the coordinates' precision needs it (ray_origin_above).
  double ray_offset = 1e-4;
};

struct SceneLoadOptions {
  bool tables = true;  // load or tabulate the materials' tables (the radiance cache needs them)
  // Called with one line for what deserves a word (a table tabulated, triangles dropped,
  // environment texels repaired); may be empty.
  std::function<void(const std::string&)> note;
  TaskControl control;  // progress of tabulation, cancellation
  // Called with the meshes' material files (mtllib) once every mesh is read, before any
  // material is loaded or tabulated (a tool checks that its outputs spare them); may be empty.
  std::function<void(const std::vector<std::string>&)> before_materials;
};

// Loads every file a scene names. Problems are one-line FileErrors naming the scene file, the
// line of the mesh and its file (a missing OBJ, a material that does not load), or the
// environment map (unreadable, or NaN or infinite texels).
RenderScene load_render_scene(const SceneFile& file, const SceneLoadOptions& options = {});

}  // namespace basis
