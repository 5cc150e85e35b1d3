#include "basis/core/frame.h"

#include <cmath>

namespace basis {

Frame Frame::from_normal(const Vec3& n) {
  // Duff, Burgess, Christensen, Hery, Kensler, Liani, Villemin 2017, listing 3.
  const double sign = std::copysign(1.0, n.z());
  const double a = -1 / (sign + n.z());
  const double b = n.x() * n.y() * a;
  Frame f;
  f.tangent = Vec3(1 + sign * n.x() * n.x() * a, sign * b, -sign * n.x());
  f.bitangent = Vec3(b, sign + n.y() * n.y() * a, -n.y());
  f.normal = n;
  return f;
}

Vec3 Frame::to_local(const Vec3& world) const {
  return {tangent.dot(world), bitangent.dot(world), normal.dot(world)};
}

Vec3 Frame::to_world(const Vec3& local) const {
  return tangent * local.x() + bitangent * local.y() + normal * local.z();
}

}  // namespace basis
