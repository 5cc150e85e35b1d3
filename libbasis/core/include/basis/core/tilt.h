// Small rotations of a shading frame against the frame a capture was recorded in (radiance
// cache re-use): the tilt, its rotation matrix, and the tilted frame.
#pragma once

#include "basis/core/frame.h"
#include "basis/core/vector.h"

namespace basis {

// A tilt is the rotation vector (x, y, 0) in the record's frame: rotation by |(x, y)| radians
// about the tangent-plane axis (x, y, 0) / |(x, y)|.
struct Tilt {
  double x = 0;
  double y = 0;
  double angle() const;
};

// The smallest rotation taking the record's normal (+z) to `normal` (a unit vector in the
// record's frame, z > -1).
Tilt tilt_to(const Vec3& normal);

// Rotation matrix of a tilt (Rodrigues).
Eigen::Matrix3d tilt_rotation(const Tilt& tilt);

// The record's frame rotated by a tilt: the frame of a surface tilted against the record, in
// world coordinates.
Frame tilted_frame(const Frame& record, const Tilt& tilt);

// The rotation of the record's frame by `angle` radians about its tangent (axis 0) or
// bitangent (axis 1), applied to v.
Vec3 rotate_about_tangent_axis(const Vec3& v, int axis, double angle);

}  // namespace basis
