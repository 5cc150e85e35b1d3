// Point files: surface points with their normals, one "x,y,z,nx,ny,nz" per line (the points
// capture2qt --points captures at).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "basis/core/file_error.h"
#include "basis/core/vector.h"

namespace basis {

// A point on a surface and the unit normal of the side it faces.
struct SurfacePoint {
  Vec3 position;
  Vec3 normal;
};

// Most points a point file or a capture set holds.
inline constexpr std::size_t kMaxSurfacePoints = 10'000'000;

// Reads points "x,y,z,nx,ny,nz" per line ('#' starts a comment; normals are normalised), at
// most kMaxSurfacePoints. Throws FileError naming the file and line for anything else.
std::vector<SurfacePoint> read_points(const std::string& path);

}  // namespace basis
