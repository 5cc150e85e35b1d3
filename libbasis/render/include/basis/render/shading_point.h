// What a camera ray sees: the surface point it meets and how it is shaded.
#pragma once

#include <cstdint>

#include "basis/core/frame.h"
#include "basis/render/camera.h"
#include "basis/render/render_scene.h"

namespace basis {

struct ShadingPoint {
  bool hit = false;
  Vec3 position = Vec3::Zero();
  Vec3 geometric_normal{0, 0, 1};  // the triangle's, turned towards the eye
  Vec3 normal{0, 0, 1};            // shading normal (vertex normals), on the same side
  Vec3 wo{0, 0, 1};                // world, unit, towards the eye
  std::uint32_t material = 0;
  double footprint = 0;  // world length a pixel covers there: distance x pixel angle

  // The shading frame and wo in it (pulled just above its horizon when the shading normal
  // turns the eye below it).
  Frame frame() const { return Frame::from_normal(normal); }
  Vec3 local_wo() const;
};

// w (unit, local) pulled just above the horizon (z >= 1e-3) when it lies at or below it.
Vec3 above_horizon(Vec3 w);

// The shading point of an intersection of `ray` (unit direction) with the scene's mesh.
ShadingPoint shading_point(const RenderScene& scene, const Ray& ray, const RayIntersection& hit,
                           double pixel_angle);

}  // namespace basis
