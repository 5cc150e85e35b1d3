// Rays and the geometry they are traced against: the interface captures and references use,
// implemented with Embree by EmbreeScene (embree_scene.h).
#pragma once

#include <span>

#include "basis/core/color.h"
#include "basis/core/vector.h"

namespace basis {

struct Ray {
  Vec3 origin;
  Vec3 direction;  // unit
};

// What a ray meets: nothing (it escapes to the environment) or a surface, whose emitted
// radiance is `emission` (black for surfaces that only occlude).
struct RayHit {
  bool hit = false;
  Color emission{0, 0, 0};
};

// Geometry that rays are traced against. Implementations must be callable from several
// threads at once.
class RayScene {
 public:
  virtual ~RayScene() = default;
  virtual void trace(std::span<const Ray> rays, std::span<RayHit> hits) const = 0;
};

}  // namespace basis
