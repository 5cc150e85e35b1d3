#include "basis/brdf/tilt_derivative.h"

#include <algorithm>

#include "basis/core/tilt.h"

namespace basis {

Color tilt_derivative(const Brdf& brdf, const Vec3& w, const Vec3& wo, int axis, double h) {
  if (w.z() <= 1e-12) return {0, 0, 0};
  auto b = [&](double t) {
    const Vec3 normal = rotate_about_tangent_axis(Vec3::UnitZ(), axis, t);
    const double cosine_ratio = std::max(0.0, w.dot(normal)) / w.z();
    const Color tilted = evaluate(brdf, rotate_about_tangent_axis(w, axis, -t), wo);
    const Color reparametrised = evaluate(brdf, w, rotate_about_tangent_axis(wo, axis, -t));
    Color out;
    for (int c = 0; c < 3; ++c)
      out[c] = tilted[c] * cosine_ratio - reparametrised[c];
    return out;
  };
  const Color plus = b(h), minus = b(-h);
  return {(plus[0] - minus[0]) / (2 * h), (plus[1] - minus[1]) / (2 * h),
          (plus[2] - minus[2]) / (2 * h)};
}

}  // namespace basis
