// Rays and the geometry they are traced against: the interface captures and references use,
// implemented with Embree by EmbreeScene (embree_scene.h).
#pragma once

#include <cstdint>
#include <limits>
#include <span>

#include "basis/core/color.h"
#include "basis/core/vector.h"

namespace basis {

// The origin of rays leaving a surface at `position`: moved along `normal` (unit) by `offset`
// (world units), and by at least 2^-19 of the position's largest coordinate (16 steps of a
// float there), so that a scene far from the origin does not meet its own surface through the
// single-precision coordinates it is traced in.
Vec3 ray_origin_above(const Vec3& position, const Vec3& normal, double offset);

struct Ray {
  Vec3 origin;
  Vec3 direction;  // unit
};

// What a ray meets: nothing (it escapes to the environment) or a surface, whose emitted
// radiance is `emission` (black for surfaces that only occlude), at `distance` along the ray
// (filled by trace_nearest, and by trace in scenes with emitters, where it traces the nearest
// hit; otherwise infinity).
struct RayHit {
  bool hit = false;
  Color emission{0, 0, 0};
  float distance = std::numeric_limits<float>::infinity();
};

// The nearest surface a ray meets: its distance, its triangle and the barycentric coordinates
// (u, v) of the hit on it, the weights of the triangle's second and third vertices.
struct RayIntersection {
  bool hit = false;
  float distance = std::numeric_limits<float>::infinity();
  std::uint32_t triangle = 0;
  float u = 0, v = 0;
};

// Geometry that rays are traced against. Implementations must be callable from several
// threads at once. Each call fills hits[i] for rays[i]; `hits` holds at least as many entries.
class RayScene {
 public:
  virtual ~RayScene() = default;
  // Whether each ray meets a surface, and the emission of what it meets.
  virtual void trace(std::span<const Ray> rays, std::span<RayHit> hits) const = 0;
  // The same, with the distance to the nearest surface met.
  virtual void trace_nearest(std::span<const Ray> rays, std::span<RayHit> hits) const = 0;
  // The nearest surface each ray meets (camera rays).
  virtual void intersect(std::span<const Ray> rays, std::span<RayIntersection> hits) const = 0;
};

}  // namespace basis
