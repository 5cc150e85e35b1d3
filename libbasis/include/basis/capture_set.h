// Capture sets: hemisphere captures of incident radiance at surface points, one quadtree per
// point over the cosine-weighted concentric map of the point's local frame.
#pragma once

#include <array>
#include <span>
#include <vector>

#include "basis/tree_set.h"

namespace basis {

using Point3 = std::array<double, 3>;

// Capture k: position, unit normal and unit tangent (bitangent = normal x tangent) in world
// coordinates, and tree k of `trees`.
struct CaptureSetView {
  std::span<const Point3> positions;
  std::span<const Point3> normals;
  std::span<const Point3> tangents;
  TreeSetView trees;

  std::size_t size() const { return positions.size(); }
};

struct CaptureSet {
  std::vector<Point3> positions;
  std::vector<Point3> normals;
  std::vector<Point3> tangents;
  TreeSet trees;

  CaptureSetView view() const { return {positions, normals, tangents, trees.view()}; }
};

}  // namespace basis
