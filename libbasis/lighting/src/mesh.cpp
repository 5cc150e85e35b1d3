#include "basis/lighting/mesh.h"
#include "basis/core/file_error.h"
#include "basis/core/random.h"

#include <tiny_obj_loader.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <string_view>

namespace basis {

namespace {

Vec3 vertex(const TriangleMesh& m, std::uint32_t i) {
  return {m.vertices[i][0], m.vertices[i][1], m.vertices[i][2]};
}

std::string first_line(const std::string& text) {
  std::string line = text.substr(0, text.find('\n'));
  while (!line.empty() && (line.back() == '\r' || line.back() == ' '))
    line.pop_back();
  return line;
}

// The materials of an MTL text whose emission Ke gives one number, which the MTL convention
// reads as grey (g and b equal to r); tinyobjloader reads the missing ones as 0, a red light.
// Each as its place among the text's material definitions (newmtl) and its name.
struct MaterialDefinition {
  std::size_t place;
  std::string name;
};
std::vector<MaterialDefinition> grey_emission_materials(const std::string& text) {
  std::vector<MaterialDefinition> grey;
  std::optional<MaterialDefinition> material;
  std::size_t definitions = 0;
  // Lines end at \n, \r\n or a lone \r, as the reader ends them.
  std::string lines_text = text;
  std::replace(lines_text.begin(), lines_text.end(), '\r', '\n');
  std::istringstream lines(lines_text);
  for (std::string line; std::getline(lines, line);) {
    std::istringstream tokens(line);
    std::string keyword;
    if (!(tokens >> keyword)) continue;
    if (keyword == "newmtl") {
      std::string name;
      std::getline(tokens >> std::ws, name);
      while (!name.empty() && (name.back() == ' ' || name.back() == '\t'))
        name.pop_back();
      material = MaterialDefinition{definitions++, name};
    } else if (keyword == "Ke" && material) {
      int numbers = 0;  // up to a comment
      for (std::string token; tokens >> token && token.front() != '#';)
        ++numbers;
      if (numbers == 1) grey.push_back(*material);
    }
  }
  return grey;
}

// The material files an OBJ names (mtllib), read with tinyobjloader's MTL reader: a relative
// name from the OBJ's folder, an absolute one as it is. One that is not a regular file is
// refused by name: a FIFO would block the read for ever, and a folder would read as empty.
class MaterialFilesBeside final : public tinyobj::MaterialReader {
 public:
  explicit MaterialFilesBeside(std::filesystem::path folder) : folder_(std::move(folder)) {}

  bool operator()(const std::string& name, std::vector<tinyobj::material_t>* materials,
                  std::map<std::string, int>* names, std::string* warning,
                  std::string* error) override {
    const std::filesystem::path path = folder_ / name;
    std::error_code status_error;
    if (!std::filesystem::exists(path, status_error)) {
      *warning += "Material file [ " + name + " ] not found (looked for " + path.string() + ")\n";
      return false;
    }
    check_regular_file(path.string(), "a material file");
    std::ifstream file(path);
    if (!file) {
      *warning += "Material file [ " + name + " ] cannot be opened\n";
      return false;
    }
    const std::string text((std::istreambuf_iterator<char>(file)),
                           std::istreambuf_iterator<char>());
    std::istringstream in(text);
    const std::size_t before = materials->size();  // the reader appends each definition
    tinyobj::LoadMtl(names, materials, &in, warning, error);
    for (const MaterialDefinition& grey : grey_emission_materials(text))
      if (before + grey.place < materials->size() &&
          (*materials)[before + grey.place].name == grey.name) {
        float* ke = (*materials)[before + grey.place].emission;
        ke[1] = ke[2] = ke[0];
      }
    files_.push_back(path.string());
    return true;
  }

  const std::vector<std::string>& files() const { return files_; }

 private:
  std::filesystem::path folder_;
  std::vector<std::string> files_;
};

// A face line's indices (v, v/t, v//n, v/t/n, negative from the end) that do not fit a 32-bit
// int, which tinyobjloader would wrap round to another vertex, or that are not integers; and
// relative normal indices before the first of the `normals` read so far, which it would read as
// "no normal" (normal indices past the file's normals are checked once it is read).
void check_face_indices(const std::string& path, int number, std::string_view rest,
                        long long normals) {
  auto separator = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '/'; };
  for (std::size_t at = 0; at < rest.size();) {
    if (separator(rest[at])) {
      ++at;
      continue;
    }
    std::size_t end = at;
    while (end < rest.size() && !separator(rest[end]))
      ++end;
    const std::string_view field = rest.substr(at, end - at);
    // The reader takes a leading + as its integer parsing does.
    const std::string_view digits = field.front() == '+' ? field.substr(1) : field;
    long long index = 0;
    const auto [stop, error] = std::from_chars(digits.data(), digits.data() + digits.size(), index);
    if (digits.empty() || error != std::errc() || stop != digits.data() + digits.size() ||
        index == 0 || index > std::numeric_limits<int>::max() ||
        index < -std::numeric_limits<int>::max())
      throw FileError(path + ":" + std::to_string(number) + ": face index '" + std::string(field) +
                      "' is not a vertex number");
    at = end;
  }
  std::istringstream corners{std::string(rest)};
  for (std::string corner; corners >> corner;) {
    // v//n or v/t/n: the normal after the second slash (none without one: npos + 1 is 0).
    const std::size_t second = corner.find('/', corner.find('/') + 1);
    if (second == std::string::npos) continue;
    long long index = 0;
    std::from_chars(corner.data() + second + 1, corner.data() + corner.size(), index);
    if (index < 0 && -index > normals)
      throw FileError(path + ":" + std::to_string(number) + ": face index '" +
                      corner.substr(second + 1) + "' names a normal before the first (" +
                      std::to_string(normals) + " read so far)");
  }
}

// tinyobjloader reads a coordinate it cannot parse ("nan", "abc") as 0 without a word, and
// wraps face indices beyond 32 bits round, so the numbers of vertex and face lines are checked
// here before it reads the file.
void check_vertex_numbers(const std::string& path) {
  std::ifstream in(path);
  long long vertex = 0, normals = 0;
  // Lines end at \n, \r\n or a lone \r, as the reader ends them.
  auto check_line = [&](const std::string& line, int number) {
    // The reader skips leading blanks, so a vertex or face line may be indented.
    const std::size_t start = std::min(line.find_first_not_of(" \t"), line.size());
    if (line.size() >= start + 2 && line[start] == 'f' &&
        (line[start + 1] == ' ' || line[start + 1] == '\t')) {
      check_face_indices(path, number, std::string_view(line).substr(start + 2), normals);
      return;
    }
    if (line.compare(start, 2, "vn") == 0 && line.size() > start + 2 &&
        (line[start + 2] == ' ' || line[start + 2] == '\t')) {
      ++normals;
      return;
    }
    if (line.size() < start + 2 || line[start] != 'v' ||
        (line[start + 1] != ' ' && line[start + 1] != '\t'))
      return;
    ++vertex;
    std::istringstream tokens(line.substr(start + 2));
    std::string token;
    int coordinates = 0;
    for (; tokens >> token; ++coordinates) {
      double value = 0;
      const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), value);
      if (error != std::errc() || end != token.data() + token.size())
        throw FileError(path + ":" + std::to_string(number) + ": vertex " + std::to_string(vertex) +
                        ": '" + token + "' is not a number");
      if (!std::isfinite(value))
        throw FileError(path + ":" + std::to_string(number) + ": vertex " + std::to_string(vertex) +
                        " is NaN or infinite");
    }
    // The reader takes missing coordinates as 0 without a word.
    if (coordinates < 3)
      throw FileError(path + ":" + std::to_string(number) + ": vertex " + std::to_string(vertex) +
                      " has " + std::to_string(coordinates) +
                      (coordinates == 1 ? " coordinate" : " coordinates") + ", not x, y and z");
  };
  int number = 0;
  for (std::string text; std::getline(in, text);) {
    std::istringstream parts(text);
    for (std::string line; std::getline(parts, line, '\r');)
      check_line(line, ++number);
    if (text.empty()) ++number;
  }
}

}  // namespace

bool TriangleMesh::has_emitters() const {
  return std::any_of(emission.begin(), emission.end(),
                     [](const Color& c) { return c[0] > 0 || c[1] > 0 || c[2] > 0; });
}

double TriangleMesh::ray_offset() const {
  const double size = extent();
  return size > 0 ? 1e-4 * size : 1e-4;
}

double TriangleMesh::extent() const {
  if (vertices.empty()) return 0;
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
  for (const auto& v : vertices)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(v[k]));
      hi[k] = std::max(hi[k], double(v[k]));
    }
  return (hi - lo).norm();
}

double TriangleMesh::area(std::size_t t) const {
  const auto& f = triangles[t];
  return 0.5 * (vertex(*this, f[1]) - vertex(*this, f[0]))
                   .cross(vertex(*this, f[2]) - vertex(*this, f[0]))
                   .norm();
}

Vec3 TriangleMesh::normal(std::size_t t) const {
  const auto& f = triangles[t];
  return (vertex(*this, f[1]) - vertex(*this, f[0]))
      .cross(vertex(*this, f[2]) - vertex(*this, f[0]))
      .normalized();
}

Vec3 TriangleMesh::point(std::size_t t, double u, double v) const {
  const auto& f = triangles[t];
  return vertex(*this, f[0]) * (1 - u - v) + vertex(*this, f[1]) * u + vertex(*this, f[2]) * v;
}

Vec3 TriangleMesh::shading_normal(std::size_t t, double u, double v) const {
  if (corner_normals.empty()) return normal(t);
  const auto& c = corner_normals[t];
  const Vec3 n = Vec3(c[0][0], c[0][1], c[0][2]) * (1 - u - v) +
                 Vec3(c[1][0], c[1][1], c[1][2]) * u + Vec3(c[2][0], c[2][1], c[2][2]) * v;
  return n.norm() > 1e-12 ? n.normalized() : normal(t);
}

void TriangleMesh::append(const TriangleMesh& other) {
  const auto offset = std::uint32_t(vertices.size());
  // Normals are kept per corner for every triangle as soon as one of the meshes has them.
  auto face_corners = [](const TriangleMesh& m, std::size_t t) {
    const Vec3 n = m.normal(t);
    const std::array<float, 3> c{float(n.x()), float(n.y()), float(n.z())};
    return std::array<std::array<float, 3>, 3>{c, c, c};
  };
  // Decided before anything is added: an empty mesh has no corner normals yet, and the first
  // mesh appended to it must keep its own.
  const bool per_corner = !corner_normals.empty() || !other.corner_normals.empty();
  if (per_corner && corner_normals.empty())
    for (std::size_t t = 0; t < triangles.size(); ++t)
      corner_normals.push_back(face_corners(*this, t));
  vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
  for (std::size_t t = 0; t < other.triangles.size(); ++t) {
    const auto& f = other.triangles[t];
    triangles.push_back({f[0] + offset, f[1] + offset, f[2] + offset});
    if (per_corner)
      corner_normals.push_back(other.corner_normals.empty() ? face_corners(other, t)
                                                            : other.corner_normals[t]);
  }
  emission.insert(emission.end(), other.emission.begin(), other.emission.end());
  dropped_degenerate += other.dropped_degenerate;
  reader_warnings.insert(reader_warnings.end(), other.reader_warnings.begin(),
                         other.reader_warnings.end());
  material_files.insert(material_files.end(), other.material_files.begin(),
                        other.material_files.end());
}

TriangleMesh read_obj(const std::string& path) {
  check_regular_file(path, "an OBJ file");
  if (std::filesystem::file_size(path) > kMaxObjBytes)
    throw FileError(path + ": larger than " + std::to_string(kMaxObjBytes >> 30) +
                    " GiB, the limit of an OBJ scene");
  check_vertex_numbers(path);
  std::ifstream obj(path);
  if (!obj) throw FileError(path + ": cannot open OBJ");
  MaterialFilesBeside material_files(std::filesystem::path(path).parent_path());
  tinyobj::attrib_t attrib;
  std::vector<tinyobj::shape_t> shapes;
  std::vector<tinyobj::material_t> materials;
  std::string reader_warning, reader_error;
  if (!tinyobj::LoadObj(&attrib, &shapes, &materials, &reader_warning, &reader_error, &obj,
                        &material_files, /*triangulate=*/true, /*default_vcols_fallback=*/false))
    throw FileError(
        path + ": " +
        (reader_error.empty() ? std::string("cannot read OBJ") : first_line(reader_error)));
  TriangleMesh mesh;
  mesh.material_files = material_files.files();
  std::istringstream warnings(reader_warning);
  for (std::string line; std::getline(warnings, line);)
    if (line.find_first_not_of(" \t\r.") != std::string::npos &&
        std::find(mesh.reader_warnings.begin(), mesh.reader_warnings.end(), path + ": " + line) ==
            mesh.reader_warnings.end())
      mesh.reader_warnings.push_back(path + ": " + line);
  const std::size_t vertex_count = attrib.vertices.size() / 3;
  mesh.vertices.resize(vertex_count);
  for (std::size_t i = 0; i < vertex_count; ++i)
    for (int k = 0; k < 3; ++k) {
      const float v = attrib.vertices[3 * i + k];
      if (!std::isfinite(v))
        throw FileError(path + ": vertex " + std::to_string(i + 1) + " is NaN or infinite");
      mesh.vertices[i][k] = v;
    }
  // Vertex normals: unit, or absent where not finite or zero.
  const std::size_t normal_count = attrib.normals.size() / 3;
  std::vector<std::optional<std::array<float, 3>>> normals(normal_count);
  for (std::size_t i = 0; i < normal_count; ++i) {
    const Vec3 n(attrib.normals[3 * i], attrib.normals[3 * i + 1], attrib.normals[3 * i + 2]);
    if (n.allFinite() && n.norm() > 1e-12) {
      const Vec3 u = n.normalized();
      normals[i] = std::array<float, 3>{float(u.x()), float(u.y()), float(u.z())};
    }
  }
  const bool has_normals = normal_count > 0;
  // Emission past kLargestEmission would overflow the captures' float texels. (The reader
  // takes a Ke it cannot parse, such as nan, as 0.)
  for (const tinyobj::material_t& material : materials) {
    for (const float e : material.emission)
      if (!(std::abs(e) <= kLargestEmission))
        throw FileError(path + ": material '" + material.name +
                        "': emission Ke is infinite or beyond 1e30");
    if (std::any_of(std::begin(material.emission), std::end(material.emission),
                    [](float e) { return e < 0; }))
      mesh.reader_warnings.push_back(path + ": material '" + material.name +
                                     "': negative emission Ke read as 0");
  }
  for (const tinyobj::shape_t& shape : shapes) {
    const auto& indices = shape.mesh.indices;
    for (std::size_t f = 0; f < shape.mesh.num_face_vertices.size(); ++f) {
      if (shape.mesh.num_face_vertices[f] != 3)
        throw FileError(path + ": face of " + std::to_string(shape.mesh.num_face_vertices[f]) +
                        " vertices left after triangulation");
      std::array<std::uint32_t, 3> t{};
      std::array<std::optional<std::array<float, 3>>, 3> corner;
      for (int k = 0; k < 3; ++k) {
        const int normal_index = indices[3 * f + k].normal_index;
        if (normal_index >= 0 && std::size_t(normal_index) >= normal_count)
          throw FileError(path + ": shape '" + shape.name + "' face " + std::to_string(f + 1) +
                          " uses normal " + std::to_string(normal_index + 1) + " of " +
                          std::to_string(normal_count));
        if (normal_index >= 0) corner[k] = normals[std::size_t(normal_index)];
        const int index = indices[3 * f + k].vertex_index;
        if (index < 0 || std::size_t(index) >= vertex_count)
          throw FileError(path + ": shape '" + shape.name + "' face " + std::to_string(f + 1) +
                          " uses vertex " + std::to_string(index + 1) + " of " +
                          std::to_string(vertex_count));
        t[k] = std::uint32_t(index);
      }
      if (mesh.triangles.size() >= kMaxTriangles)
        throw FileError(path + ": more than " + std::to_string(kMaxTriangles) + " triangles");
      mesh.triangles.push_back(t);
      Color emission{0, 0, 0};
      const int material = f < shape.mesh.material_ids.size() ? shape.mesh.material_ids[f] : -1;
      if (material >= 0 && std::size_t(material) < materials.size())
        for (int c = 0; c < 3; ++c)
          emission[c] = std::max(0.0f, materials[material].emission[c]);
      mesh.emission.push_back(emission);
      if (!(mesh.area(mesh.triangles.size() - 1) > 0)) {  // degenerate: drop it
        mesh.triangles.pop_back();
        mesh.emission.pop_back();
        ++mesh.dropped_degenerate;
        continue;
      }
      if (has_normals) {
        const Vec3 n = mesh.normal(mesh.triangles.size() - 1);
        std::array<std::array<float, 3>, 3> corners;
        for (int k = 0; k < 3; ++k)
          corners[k] =
              corner[k].value_or(std::array<float, 3>{float(n.x()), float(n.y()), float(n.z())});
        mesh.corner_normals.push_back(corners);
      }
    }
  }
  if (mesh.triangles.empty()) throw FileError(path + ": no triangles");
  return mesh;
}

std::vector<SurfacePoint> sample_surface(const TriangleMesh& mesh, std::size_t count,
                                         std::uint64_t seed) {
  return sample_surface(mesh, PointRange{0, count}, seed);
}

std::vector<SurfacePoint> sample_surface(const TriangleMesh& mesh, PointRange range,
                                         std::uint64_t seed) {
  const std::size_t count = range.count;
  std::vector<double> cdf(mesh.triangles.size());
  double total = 0;
  for (std::size_t t = 0; t < cdf.size(); ++t)
    cdf[t] = total += mesh.area(t);
  std::vector<SurfacePoint> points(count);
  const std::uint64_t stream = splitmix64(seed);
  for (std::size_t k = 0; k < count; ++k) {
    const std::uint64_t i = range.first + k;
    const double pick = unit_random(stream + 3 * i) * total;
    const std::size_t t = std::min(
        cdf.size() - 1, std::size_t(std::upper_bound(cdf.begin(), cdf.end(), pick) - cdf.begin()));
    // Uniform barycentrics by folding the unit square.
    double a = unit_random(stream + 3 * i + 1), b = unit_random(stream + 3 * i + 2);
    if (a + b > 1) {
      a = 1 - a;
      b = 1 - b;
    }
    const auto& f = mesh.triangles[t];
    points[k].position =
        vertex(mesh, f[0]) * (1 - a - b) + vertex(mesh, f[1]) * a + vertex(mesh, f[2]) * b;
    points[k].normal = mesh.normal(t);
  }
  return points;
}

}  // namespace basis
