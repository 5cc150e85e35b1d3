#include "basis/core/hemisphere.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "basis/core/concentric.h"

namespace basis {

Vec3 square_to_cosine_hemisphere(const Vec2& uv) {
  const Vec2 d = square_to_uniform_disk_concentric(uv);
  const double z = std::sqrt(std::max(0.0, 1 - d.squaredNorm()));
  return {d.x(), d.y(), z};
}

Vec2 cosine_hemisphere_to_square(const Vec3& w) {
  Vec2 d(w.x(), w.y());
  const double r = d.norm();
  if ((w.z() <= 0 || r > 1) && r > 0) d /= r;  // on or below the horizon: the disk's rim
  return uniform_disk_to_square_concentric(d);
}

double square_to_cosine_hemisphere_pdf(const Vec3& w) {
  return std::max(0.0, w.z()) / std::numbers::pi;
}

std::array<int, 2> cosine_hemisphere_texel(const Vec3& w, int n) {
  const Vec2 uv = cosine_hemisphere_to_square(w);
  return {std::clamp(int(uv.x() * n), 0, n - 1), std::clamp(int(uv.y() * n), 0, n - 1)};
}

Vec3 square_to_uniform_hemisphere(const Vec2& uv) {
  const Vec2 d = square_to_uniform_disk_concentric(uv);
  const double r2 = d.squaredNorm();
  const double scale = std::sqrt(std::max(0.0, 2 - r2));  // sin(theta) / r
  return {d.x() * scale, d.y() * scale, 1 - r2};
}

Vec2 uniform_hemisphere_to_square(const Vec3& w) {
  // r = sqrt(1 - z) and sin(theta) = sqrt(1 - z^2), so the disk point is (x, y) / sqrt(1 + z).
  const double z = std::clamp(w.z(), 0.0, 1.0);
  Vec2 d = Vec2(w.x(), w.y()) / std::sqrt(1 + z);
  const double r = d.norm();
  if (r > 1) d /= r;
  return uniform_disk_to_square_concentric(d);
}

double square_to_uniform_hemisphere_pdf() {
  return 1 / (2 * std::numbers::pi);
}

Vec3 half_vector(const Vec3& wi, const Vec3& wo) {
  return (wi + wo).stableNormalized();
}

}  // namespace basis
