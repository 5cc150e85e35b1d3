// Vector types shared by the library: Eigen double-precision 2- and 3-vectors.
// Directions are unit Vec3 in a right-handed frame whose z axis is the surface normal.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace basis {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

}  // namespace basis
