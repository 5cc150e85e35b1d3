#include "basis/render/shading_point.h"

#include <algorithm>

namespace basis {

Vec3 above_horizon(Vec3 w) {
  if (w.z() < 1e-3) {
    w.z() = 1e-3;
    w.normalize();
  }
  return w;
}

Vec3 ShadingPoint::local_wo() const {
  return above_horizon(frame().to_local(wo));
}

ShadingPoint shading_point(const RenderScene& scene, const Ray& ray, const RayIntersection& hit,
                           double pixel_angle) {
  ShadingPoint p;
  if (!hit.hit) return p;
  p.hit = true;
  p.position = scene.mesh.point(hit.triangle, hit.u, hit.v);
  p.wo = -ray.direction;
  p.geometric_normal = scene.mesh.normal(hit.triangle);
  Vec3 n = scene.mesh.shading_normal(hit.triangle, hit.u, hit.v);
  if (p.geometric_normal.dot(p.wo) < 0) p.geometric_normal = -p.geometric_normal;
  if (n.dot(p.geometric_normal) < 0) n = -n;
  p.normal = n;
  p.material = scene.material_of[hit.triangle];
  p.footprint = std::max(1e-12, double(hit.distance) * pixel_angle);
  return p;
}

}  // namespace basis
