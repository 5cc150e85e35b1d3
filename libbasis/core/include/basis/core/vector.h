// Vector types shared by the library: Eigen double-precision 2- and 3-vectors.
// Directions are unit Vec3 in a right-handed frame whose z axis is the surface normal.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace basis {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

// The unit vector along v whatever its length (1e-300 and 1e300 alike: scaled by its largest
// component before normalising); the zero vector when v is zero or not finite.
inline Vec3 unit_direction(const Vec3& v) {
  if (!v.allFinite()) return Vec3::Zero();
  const double largest = v.cwiseAbs().maxCoeff();
  if (!(largest > 0)) return Vec3::Zero();
  return (v / largest).normalized();
}

// Angle in radians between two unit directions (accurate near 0 and pi).
inline double angle_between(const Vec3& a, const Vec3& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

}  // namespace basis
