#include "basis/render/scene_file.h"

#include <filesystem>

#include "basis/core/file_error.h"
#include "basis/io/json_fields.h"
#include "basis/io/text_file.h"

namespace basis {

using nlohmann::json;

namespace {

Vec3 vector_field(const JsonFields& r, const json& object, const std::string& key,
                  const std::string& path) {
  if (!object.contains(key)) r.fail(path, "missing (an array [x, y, z])");
  const json& v = object.at(key);
  if (!v.is_array() || v.size() != 3) r.fail(path, "must be an array [x, y, z] of three numbers");
  Vec3 out;
  for (int i = 0; i < 3; ++i) {
    if (!v[i].is_number()) r.fail(path, "must hold three numbers");
    out[i] = v[i].get<double>();
    if (!std::isfinite(out[i]) || std::abs(out[i]) > 1e30)
      r.fail(path, "components must be finite numbers within 1e30");
  }
  return out;
}

int whole_number(const JsonFields& r, const json& object, const std::string& key,
                 const std::string& path, int lo, int hi) {
  const double x = r.number(object, key, path, lo, hi);
  if (x != std::floor(x)) r.fail(path, "must be a whole number, got " + JsonFields::show(x));
  return int(x);
}

std::string resolve(const std::string& folder, const std::string& file) {
  std::filesystem::path p = file;
  if (p.is_relative() && !folder.empty()) p = std::filesystem::path(folder) / p;
  return p.lexically_normal().string();
}

}  // namespace

SceneFile parse_scene_file(const std::string& text, const std::string& name,
                           const std::string& folder) {
  const JsonFields r(text, name);
  const json root = r.parse();
  if (!root.is_object())
    r.fail("", "a scene is a JSON object {\"camera\": ..., \"environment\": ..., \"meshes\": ...}");
  r.only(root, {"camera", "environment", "meshes", "name"}, "");
  SceneFile scene;
  scene.path = name;

  if (!root.contains("camera") || !root["camera"].is_object())
    r.fail("camera", "missing or not an object {eye, look_at, up, fov, width, height}");
  const json& c = root["camera"];
  r.only(c, {"eye", "look_at", "up", "fov", "width", "height"}, "camera");
  Camera& camera = scene.camera;
  camera.eye = vector_field(r, c, "eye", "camera.eye");
  camera.look_at = vector_field(r, c, "look_at", "camera.look_at");
  camera.up = c.contains("up") ? vector_field(r, c, "up", "camera.up") : Vec3(0, 0, 1);
  camera.fov_degrees = r.number(c, "fov", "camera.fov", 1e-3, 179.9);
  camera.width = whole_number(r, c, "width", "camera.width", 1, kMaxImageSide);
  camera.height = whole_number(r, c, "height", "camera.height", 1, kMaxImageSide);
  if (const std::string problem = camera_problem(camera); !problem.empty()) {
    const std::string field = problem.find("up") != std::string::npos      ? "camera.up"
                              : problem.find("look") != std::string::npos  ? "camera.look_at"
                              : problem.find("image") != std::string::npos ? "camera.width"
                                                                           : "camera";
    r.fail(field, problem);
  }

  if (!root.contains("environment") || !root["environment"].is_object())
    r.fail("environment",
           "missing or not an object {\"map\": FILE, \"rotate\": DEGREES} or "
           "{\"constant\": [r, g, b]}");
  const json& e = root["environment"];
  r.only(e, {"map", "rotate", "constant"}, "environment");
  if (e.contains("map") == e.contains("constant"))
    r.fail("environment", "give one of \"map\" (a lat-long image) or \"constant\" ([r, g, b])");
  if (e.contains("map")) {
    scene.environment.map = resolve(folder, r.string(e, "map", "environment.map"));
    if (e.contains("rotate"))
      scene.environment.rotate_degrees = r.number(e, "rotate", "environment.rotate", -1e6, 1e6);
  } else {
    if (e.contains("rotate")) r.fail("environment.rotate", "rotates a map, not a constant");
    scene.environment.constant = r.color(e, "constant", "environment.constant", 3.4e38);
  }

  if (!root.contains("meshes") || !root["meshes"].is_array() || root["meshes"].empty())
    r.fail("meshes", "missing or empty (an array of {\"obj\": FILE, \"material\": FILE})");
  const json& meshes = root["meshes"];
  for (std::size_t i = 0; i < meshes.size(); ++i) {
    const std::string at = "meshes[" + std::to_string(i) + "]";
    const json& m = meshes[i];
    if (!m.is_object()) r.fail("meshes", "element " + std::to_string(i) + " is not an object");
    r.only(m, {"obj", "material"}, at);
    SceneFile::MeshSpec mesh;
    mesh.obj = resolve(folder, r.string(m, "obj", at + ".obj"));
    mesh.material = resolve(folder, r.string(m, "material", at + ".material"));
    mesh.line = r.line_of(at + ".obj");
    const std::string extension = std::filesystem::path(mesh.material).extension().string();
    if (extension != ".json" && extension != ".qt")
      r.fail(at + ".material",
             "must be a BRDF spec (.json) or a BRDF table (.qt), got '" + mesh.material + "'");
    scene.meshes.push_back(mesh);
  }
  return scene;
}

SceneFile read_scene_file(const std::string& path) {
  const std::string text = read_text_file(path, std::size_t(1) << 22, "a scene");
  return parse_scene_file(text, path, std::filesystem::path(path).parent_path().string());
}

}  // namespace basis
