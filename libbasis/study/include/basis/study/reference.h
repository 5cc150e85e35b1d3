// Ground truth for studies: reflected radiance integrated directly over an environment map's
// pixels with the exact BRDF, optionally occluded by a scene, independent of any basis.
#pragma once

#include "basis/brdf/brdf.h"
#include "basis/core/frame.h"
#include "basis/lighting/capture.h"
#include "basis/lighting/environment.h"

namespace basis {

// Integral over the sphere of f(F^T w, wo) L(w) V(p, w) max(0, w . n) dw with each map pixel
// split subsamples^2 ways (one visibility ray each when a scene is given): the radiance
// reflected towards wo (local to frame F) at point p.
Color reference_reflection(const Environment& environment, const RayScene* scene,
                           const Vec3& position, const Frame& frame, const Brdf& brdf,
                           const Vec3& wo, int subsamples = 2, double ray_offset = 1e-4);

}  // namespace basis
