// Reference reflected radiance for tests and studies: the integral of f L cos computed
// directly over an environment map's pixels, independent of captures and tables.
#pragma once

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstddef>
#include <vector>

#include "basis/brdf/brdf.h"
#include "basis/core/frame.h"
#include "basis/lighting/environment.h"

namespace basis::testing {

// The sphere as an environment map's pixels, each split s x s: the centre direction of each
// sub-pixel and its radiance times its solid angle (the radiance is constant over a pixel, so
// s only resolves f and the cosine; s = 1 suffices for lobes many pixels wide).
struct MapSamples {
  std::vector<Vec3> directions;
  std::vector<Color> weighted_radiance;
};

inline MapSamples map_samples(const Environment& env, int s = 3) {
  MapSamples m;
  for (int y = 0; y < env.height(); ++y)
    for (int sy = 0; sy < s; ++sy) {
      const double y0 = y + double(sy) / s, y1 = y0 + 1.0 / s;
      const double dw = env.band_solid_angle(y0, y1, 1.0 / s);
      for (int x = 0; x < env.width(); ++x)
        for (int sx = 0; sx < s; ++sx) {
          const Vec3 w = env.direction(x + (sx + 0.5) / s, (y0 + y1) / 2);
          const Color l = env.radiance(w);
          m.directions.push_back(w);
          m.weighted_radiance.push_back({l[0] * dw, l[1] * dw, l[2] * dw});
        }
    }
  return m;
}

// Sum over the samples of f(F^T w, wo) L(w) max(0, w . n) dw for the three channels: the
// radiance reflected towards wo (local to F) by the surface with frame F. Fixed blocks are
// summed in parallel and then in order, so the result does not depend on the thread count.
inline Color exact_reflection_rgb(const MapSamples& m, const Brdf& brdf, const Frame& f,
                                  const Vec3& wo) {
  constexpr std::size_t block = 4096;
  const std::size_t count = m.directions.size(), blocks = (count + block - 1) / block;
  std::vector<Color> sums(blocks, Color{0, 0, 0});
  tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
    Color& sum = sums[b];
    for (std::size_t i = b * block; i < std::min(count, (b + 1) * block); ++i) {
      const Vec3 local = f.to_local(m.directions[i]);
      if (local.z() <= 0) continue;
      const Color v = evaluate(brdf, local, wo);
      for (int c = 0; c < 3; ++c)
        sum[c] += v[c] * m.weighted_radiance[i][c] * local.z();
    }
  });
  Color sum{0, 0, 0};
  for (const Color& s : sums)
    for (int c = 0; c < 3; ++c)
      sum[c] += s[c];
  return sum;
}

// The same straight from the map, each pixel split s x s.
inline Color exact_reflection_rgb(const Environment& env, const Brdf& brdf, const Frame& f,
                                  const Vec3& wo, int s = 3) {
  return exact_reflection_rgb(map_samples(env, s), brdf, f, wo);
}

// One channel.
inline double exact_reflection(const Environment& env, const Brdf& brdf, const Frame& f,
                               const Vec3& wo, int channel, int s = 3) {
  return exact_reflection_rgb(env, brdf, f, wo, s)[channel];
}

// Mean relative errors of the three ways of shading a tilted surface.
struct TiltErrors {
  double none = 0, reparametrised = 0, compensated = 0;
};

}  // namespace basis::testing
