// Triangle scenes for captures: meshes read from OBJ files (tinyobjloader), emission per
// triangle from their materials, and points sampled on their surfaces.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "basis/core/color.h"
#include "basis/core/file_error.h"
#include "basis/core/shard.h"
#include "basis/core/vector.h"
#include "basis/io/points_file.h"
#include "basis/lighting/ray_scene.h"

namespace basis {

struct TriangleMesh {
  std::vector<std::array<float, 3>> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<Color> emission;  // per triangle: the material's Ke, black when none
  // Per triangle, the unit normals at its three corners (the OBJ's vertex normals; the face's
  // normal at corners that have none); empty when the file has no vertex normals.
  std::vector<std::array<std::array<float, 3>, 3>> corner_normals;

  // Problems repaired while reading: degenerate (zero-area) triangles dropped.
  long long dropped_degenerate = 0;
  // What the OBJ reader went past, one line each naming the file: a material file or material
  // it could not find (the triangles that use it then emit nothing).
  std::vector<std::string> reader_warnings;
  // The material files (mtllib) it read, as paths from the working folder: inputs that no
  // output may overwrite.
  std::vector<std::string> material_files;

  bool has_emitters() const;
  // Length of the bounding box's diagonal (0 for an empty mesh).
  double extent() const;
  // How far rays leaving its surfaces start above them (CaptureOptions::ray_offset, world
  // units): 1e-4 of the extent (1e-4 for an empty mesh); ray_origin_above takes the larger of
  // it and what the coordinates' precision needs. One outlying triangle far away widens it with
  // the extent.
  double ray_offset() const;
  // Area and unit normal (counter-clockwise winding faces the normal) of triangle t.
  double area(std::size_t t) const;
  Vec3 normal(std::size_t t) const;
  // The point of triangle t at barycentric coordinates (u, v) (weights of corners 1 and 2).
  Vec3 point(std::size_t t, double u, double v) const;
  // The shading normal there: the corner normals interpolated and normalised, or the face's
  // normal when the mesh has none.
  Vec3 shading_normal(std::size_t t, double u, double v) const;
  // Appends another mesh's triangles (with their emission and normals).
  void append(const TriangleMesh& other);
};

// Largest mesh accepted (checked while reading) and largest OBJ file (checked before).
inline constexpr std::size_t kMaxTriangles = std::size_t(1) << 28;
inline constexpr std::uintmax_t kMaxObjBytes = std::uintmax_t(4) << 30;
// The largest emission (Ke) a material may have: captures average radiance in floats.
inline constexpr double kLargestEmission = 1e30;

// Reads an OBJ file (and its MTL materials) with tinyobjloader; polygons are triangulated.
// Material files are looked for from the OBJ's folder (an absolute name as it is); one that is
// missing is a reader warning, its faces emitting nothing. Throws FileError for unreadable
// files, a material file that is not a regular file, NaN or infinite vertices, indices out of
// range, an emission (Ke) beyond kLargestEmission, or a mesh with no triangles. Degenerate
// triangles are dropped and counted. Vertex normals that are not finite or zero count as absent
// (the face's normal stands in).
TriangleMesh read_obj(const std::string& path);

// `count` points uniformly distributed over the mesh's area, each with its triangle's normal
// (the side its counter-clockwise winding faces). Deterministic for a seed.
std::vector<SurfacePoint> sample_surface(const TriangleMesh& mesh, std::size_t count,
                                         std::uint64_t seed);

// Points [range.first, range.end()) of that sampling, for any number of points: point i depends
// on the seed and i alone, so a shard of a run samples only its own points.
std::vector<SurfacePoint> sample_surface(const TriangleMesh& mesh, PointRange range,
                                         std::uint64_t seed);

}  // namespace basis
