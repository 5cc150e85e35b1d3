// Scene files for rendering: JSON naming a pinhole camera, the environment and the meshes with
// their materials.
//   {"camera": {"eye": [0, -6, 2], "look_at": [0, 0, 0.5], "up": [0, 0, 1], "fov": 40,
//               "width": 320, "height": 240},
//    "environment": {"map": "sunrise.exr", "rotate": 0},   or {"constant": [1, 1, 1]}
//    "meshes": [{"obj": "scene.obj", "material": "phong.json"}]}
// A material is a BRDF spec (.json) or a BRDF table (.qt). Relative paths are relative to the
// scene file's folder.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "basis/core/color.h"
#include "basis/core/file_error.h"
#include "basis/render/camera.h"

namespace basis {

struct SceneFile {
  std::string path;  // the scene file, for errors
  Camera camera;
  struct EnvironmentSpec {
    std::string map;  // a lat-long map, or empty for a constant
    double rotate_degrees = 0;
    Color constant{0, 0, 0};
  } environment;
  struct MeshSpec {
    std::string obj;
    std::string material;  // a BRDF spec (.json) or table (.qt)
    int line = 1;          // where the mesh is described, for errors about its files
  };
  std::vector<MeshSpec> meshes;
};

// Reads and checks a scene file. Every problem is a FileError "PATH:LINE: field 'F': problem":
// missing or unknown fields, wrong types, a camera that looks nowhere (camera_problem), an
// image size of 0 or beyond the limits, no meshes. Files named are not opened here.
SceneFile read_scene_file(const std::string& path);

// The same from text in memory; `name` stands for the file and `folder` resolves paths.
SceneFile parse_scene_file(const std::string& text, const std::string& name,
                           const std::string& folder);

}  // namespace basis
