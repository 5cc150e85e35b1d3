// Small rotations of a shading frame against the frame a capture was recorded in (radiance
// cache re-use, DESIGN section 5): the tilt, its rotation, and the tilted BRDF's derivative.
#pragma once

#include "basis/brdf.h"
#include "basis/frame.h"
#include "basis/vector.h"

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

// The integrand of the tilted reflection, in the record's frame and the cosine-weighted
// measure of the record's normal, relative to its re-parametrised approximation:
//   B(t) = f(R^-1 w, wo) max(0, w . R z) / w.z  -  f(w, R^-1 wo),  R = rotation by t about axis,
// and its derivative at t = 0 by central differences of step h: the compensation term stored
// as channel groups 1 (axis 0) and 2 (axis 1) of BRDF tables. Zero at the rim (w.z = 0).
Color tilt_derivative(const Brdf& brdf, const Vec3& w, const Vec3& wo, int axis, double h);

}  // namespace basis
