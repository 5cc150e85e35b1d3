// Independent reference integrals of BRDFs for tests: directional albedo by Gauss-Legendre
// quadrature on a mesh graded towards the mirror direction, where lobes are sharp.
#pragma once

#include <cmath>
#include <numbers>
#include <vector>

#include "basis/brdf/brdf.h"
#include "basis/core/gauss_legendre.h"

namespace basis::testing {

// 16-point Gauss-Legendre nodes and weights on [-1, 1].
inline const std::vector<QuadratureNode>& gauss_legendre_16() {
  static const std::vector<QuadratureNode> rule = gauss_legendre(16);
  return rule;
}

// Integral over the sphere of g(w) dw in spherical coordinates around the unit axis `centre`,
// with polar intervals graded towards the axis. g must be zero where it does not apply.
template <typename G>
double integrate_around(const Vec3& centre, G g, int azimuths = 512) {
  const Vec3 a = centre.normalized();
  const Vec3 t = (std::abs(a.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(a).normalized();
  const Vec3 b = a.cross(t);
  const double knots[] = {0,    0.001, 0.003, 0.01, 0.02,
                          0.04, 0.08,  0.15,  0.3,  0.6,
                          1.0,  1.5,   2.0,   2.6,  std::numbers::pi};
  double sum = 0;
  for (std::size_t k = 0; k + 1 < std::size(knots); ++k) {
    const double lo = knots[k], hi = knots[k + 1];
    for (const auto& [x, weight] : gauss_legendre_16()) {
      const double theta = lo + (hi - lo) * (x + 1) / 2;
      const double ring = weight * (hi - lo) / 2 * std::sin(theta);
      double around = 0;
      for (int j = 0; j < azimuths; ++j) {
        const double phi = 2 * std::numbers::pi * (j + 0.5) / azimuths;
        const Vec3 w =
            a * std::cos(theta) + (t * std::cos(phi) + b * std::sin(phi)) * std::sin(theta);
        around += g(w);
      }
      sum += ring * around * 2 * std::numbers::pi / azimuths;
    }
  }
  return sum;
}

// Directional albedo of channel c: integral of f(wi, wo) cos(theta_i) over the hemisphere.
inline double reference_albedo(const Brdf& brdf, const Vec3& wo, int c) {
  const Vec3 mirror(-wo.x(), -wo.y(), wo.z());
  return integrate_around(mirror, [&](const Vec3& wi) {
    return wi.z() > 0 ? evaluate(brdf, wi, wo)[c] * wi.z() : 0.0;
  });
}

}  // namespace basis::testing
