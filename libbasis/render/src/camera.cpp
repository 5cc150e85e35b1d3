#include "basis/render/camera.h"

#include <cmath>
#include <numbers>
#include <string>

namespace basis {

Ray Camera::ray(double x, double y) const {
  const Vec3 forward = (look_at - eye).normalized();
  const Vec3 right = forward.cross(up).normalized();
  const Vec3 true_up = right.cross(forward);
  const double half = std::tan(fov_degrees * std::numbers::pi / 360);
  const double aspect = double(width) / height;
  const double px = (2 * x / width - 1) * half * aspect, py = (1 - 2 * y / height) * half;
  return {eye, (forward + px * right + py * true_up).normalized()};
}

double Camera::pixel_angle() const {
  return 2 * std::tan(fov_degrees * std::numbers::pi / 360) / height;
}

std::string camera_problem(const Camera& camera) {
  if (!camera.eye.allFinite() || !camera.look_at.allFinite() || !camera.up.allFinite())
    return "eye, look_at and up must be finite";
  const Vec3 view = camera.look_at - camera.eye;
  if (!(view.norm() > 1e-9)) return "looks nowhere: look_at is the eye";
  if (!(camera.up.norm() > 1e-12)) return "up must not be zero";
  if (!(view.normalized().cross(camera.up.normalized()).norm() > 1e-6))
    return "up is along the direction of view";
  if (!(camera.fov_degrees > 0 && camera.fov_degrees < 180))
    return "fov must be between 0 and 180 degrees";
  if (camera.width < 1 || camera.height < 1) return "width and height must be at least 1";
  if (camera.width > kMaxImageSide || camera.height > kMaxImageSide ||
      (long long)camera.width * camera.height > kMaxRenderPixels)
    return "image of " + std::to_string(camera.width) + " x " + std::to_string(camera.height) +
           " pixels is larger than the limit (" + std::to_string(kMaxImageSide) + " a side, " +
           std::to_string(kMaxRenderPixels) + " pixels)";
  return {};
}

}  // namespace basis
