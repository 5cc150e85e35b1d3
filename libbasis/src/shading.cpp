#include "basis/shading.h"

#include <stdexcept>

namespace basis {

namespace {

Vec3 vec(const Point3& p) {
  return {p[0], p[1], p[2]};
}

}  // namespace

Frame capture_frame(const CaptureSetView& captures, std::size_t k) {
  Frame f;
  f.normal = vec(captures.normals[k]);
  f.tangent = vec(captures.tangents[k]);
  f.bitangent = f.normal.cross(f.tangent);
  return f;
}

Tilt capture_tilt(const CaptureSetView& captures, std::size_t k, const Vec3& normal) {
  const Vec3 local = capture_frame(captures, k).to_local(normal.normalized());
  if (local.z() <= -1 + 1e-12)
    throw std::invalid_argument("the shading normal is opposite the capture's normal");
  return tilt_to(local);
}

Convolution shade(const BrdfTableView& table, const CaptureSetView& captures, std::size_t k,
                  const ShadingOptions& options) {
  if (!(options.wo.z() >= 0)) throw std::invalid_argument("outgoing direction below the horizon");
  const QuadtreeView radiance = captures.trees.tree(k);
  if (!options.normal) return reflect(table, radiance, options.wo.normalized());
  const Tilt tilt = capture_tilt(captures, k, *options.normal);
  return reflect_tilted(table, radiance, options.wo.normalized(), tilt, options.tilt_mode);
}

}  // namespace basis
