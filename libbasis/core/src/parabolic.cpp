#include "basis/core/parabolic.h"

#include <algorithm>
#include <cmath>

namespace basis {

Vec2 hemisphere_to_parabolic(const Vec3& w) {
  const double z = std::max(0.0, w.z());
  Vec2 st = Vec2(w.x(), w.y()) / (1 + z);
  const double r = st.norm();
  if (r > 1) st /= r;
  return st;
}

Vec3 parabolic_to_hemisphere(const Vec2& st) {
  Vec2 p = st;
  double r2 = p.squaredNorm();
  if (r2 > 1) {
    p /= std::sqrt(r2);
    r2 = 1;
  }
  const double inv = 1 / (1 + r2);
  return {2 * p.x() * inv, 2 * p.y() * inv, (1 - r2) * inv};
}

double parabolic_to_hemisphere_jacobian(const Vec2& st) {
  const double q = 1 + st.squaredNorm();
  return 4 / (q * q);
}

}  // namespace basis
