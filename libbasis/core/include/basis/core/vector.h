// Vector types shared by the library: Eigen double-precision 2- and 3-vectors.
// Directions are unit Vec3 in a right-handed frame whose z axis is the surface normal.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace basis {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

// Angle in radians between two unit directions (accurate near 0 and pi).
inline double angle_between(const Vec3& a, const Vec3& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

}  // namespace basis
