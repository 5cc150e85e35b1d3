#include "basis/core/latlong.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace basis {

Vec3 latlong_to_direction(const Vec2& pixel, int width, int height) {
  const double theta = std::numbers::pi * pixel.y() / height;
  const double phi = 2 * std::numbers::pi * pixel.x() / width;
  const double s = std::sin(theta);
  return {s * std::cos(phi), s * std::sin(phi), std::cos(theta)};
}

Vec2 direction_to_latlong(const Vec3& w, int width, int height) {
  const double theta = std::acos(std::clamp(w.z() / w.norm(), -1.0, 1.0));
  double phi = std::atan2(w.y(), w.x());
  if (phi < 0) phi += 2 * std::numbers::pi;
  double x = phi * width / (2 * std::numbers::pi);
  if (x >= width) x -= width;  // phi rounded up to 2 pi
  return {x, theta * height / std::numbers::pi};
}

double latlong_pixel_solid_angle(int row, int width, int height) {
  const double t0 = std::numbers::pi * row / height;
  const double t1 = std::numbers::pi * (row + 1) / height;
  return 2 * std::numbers::pi / width * (std::cos(t0) - std::cos(t1));
}

double latlong_to_direction_jacobian(double y, int width, int height) {
  return 2 * std::numbers::pi / width * std::numbers::pi / height *
         std::sin(std::numbers::pi * y / height);
}

}  // namespace basis
