// Reference reflected radiance for tests and studies: the integral of f L cos computed
// directly over an environment map's pixels, independent of captures and tables.
#pragma once

#include "basis/brdf.h"
#include "basis/environment.h"
#include "basis/frame.h"

namespace basis::testing {

// Integral over the sphere of f(F^T w, wo) L(w) max(0, w . n) dw, each map pixel split
// s x s: the radiance reflected towards wo (local to F) by the surface with frame F.
inline double exact_reflection(const Environment& env, const Brdf& brdf, const Frame& f,
                               const Vec3& wo, int channel, int s = 3) {
  double sum = 0;
  for (int y = 0; y < env.height(); ++y)
    for (int sy = 0; sy < s; ++sy) {
      const double y0 = y + double(sy) / s, y1 = y0 + 1.0 / s;
      const double dw = env.band_solid_angle(y0, y1, 1.0 / s);
      for (int x = 0; x < env.width(); ++x)
        for (int sx = 0; sx < s; ++sx) {
          const Vec3 w = env.direction(x + (sx + 0.5) / s, (y0 + y1) / 2);
          const Vec3 local = f.to_local(w);
          if (local.z() <= 0) continue;
          sum += evaluate(brdf, local, wo)[channel] * env.radiance(w)[channel] * local.z() * dw;
        }
    }
  return sum;
}

// The same for the three channels at once.
inline Color exact_reflection_rgb(const Environment& env, const Brdf& brdf, const Frame& f,
                                  const Vec3& wo, int s = 3) {
  Color sum{0, 0, 0};
  for (int y = 0; y < env.height(); ++y)
    for (int sy = 0; sy < s; ++sy) {
      const double y0 = y + double(sy) / s, y1 = y0 + 1.0 / s;
      const double dw = env.band_solid_angle(y0, y1, 1.0 / s);
      for (int x = 0; x < env.width(); ++x)
        for (int sx = 0; sx < s; ++sx) {
          const Vec3 w = env.direction(x + (sx + 0.5) / s, (y0 + y1) / 2);
          const Vec3 local = f.to_local(w);
          if (local.z() <= 0) continue;
          const Color b = evaluate(brdf, local, wo), l = env.radiance(w);
          for (int c = 0; c < 3; ++c) sum[c] += b[c] * l[c] * local.z() * dw;
        }
    }
  return sum;
}

// Mean relative errors of the three ways of shading a tilted surface.
struct TiltErrors {
  double none = 0, reparametrised = 0, compensated = 0;
};

}  // namespace basis::testing
