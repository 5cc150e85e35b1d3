#include "basis/core/tilt.h"

#include <cmath>

namespace basis {

double Tilt::angle() const {
  return std::hypot(x, y);
}

Tilt tilt_to(const Vec3& normal) {
  const Vec3 n = normal.normalized();
  const double sine = std::hypot(n.x(), n.y());
  if (sine == 0) return {};
  const double angle = std::atan2(sine, n.z());
  // Axis z x n / |z x n| = (-n.y, n.x, 0) / sine.
  return {-n.y() / sine * angle, n.x() / sine * angle};
}

Eigen::Matrix3d tilt_rotation(const Tilt& tilt) {
  const double angle = tilt.angle();
  if (angle == 0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, Vec3(tilt.x / angle, tilt.y / angle, 0)).toRotationMatrix();
}

Frame tilted_frame(const Frame& record, const Tilt& tilt) {
  const Eigen::Matrix3d r = tilt_rotation(tilt);
  Frame shading;
  shading.tangent = record.to_world(r * Vec3::UnitX());
  shading.bitangent = record.to_world(r * Vec3::UnitY());
  shading.normal = record.to_world(r * Vec3::UnitZ());
  return shading;
}

Vec3 rotate_about_tangent_axis(const Vec3& v, int axis, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  if (axis == 0) return {v.x(), c * v.y() - s * v.z(), s * v.y() + c * v.z()};
  return {c * v.x() + s * v.z(), v.y(), -s * v.x() + c * v.z()};
}

}  // namespace basis
