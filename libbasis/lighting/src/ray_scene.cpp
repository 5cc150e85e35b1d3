#include "basis/lighting/ray_scene.h"

#include <algorithm>
#include <cmath>

namespace basis {

Vec3 ray_origin_above(const Vec3& position, const Vec3& normal, double offset) {
  const double largest = position.cwiseAbs().maxCoeff();
  return position + normal * std::max(offset, std::ldexp(largest, -19));
}

}  // namespace basis
