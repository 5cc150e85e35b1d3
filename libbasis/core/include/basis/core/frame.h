// Orthonormal frames built from a normal (Duff et al. 2017, "Building an Orthonormal Basis,
// Revisited"), and the change between world and local coordinates.
#pragma once

#include "basis/core/vector.h"

namespace basis {

// A right-handed orthonormal frame; local z is the normal.
struct Frame {
  Vec3 tangent{1, 0, 0};
  Vec3 bitangent{0, 1, 0};
  Vec3 normal{0, 0, 1};

  // Builds the frame of a unit normal; n = +Z gives the identity frame.
  static Frame from_normal(const Vec3& n);

  Vec3 to_local(const Vec3& world) const;
  Vec3 to_world(const Vec3& local) const;
};

}  // namespace basis
