// Hemisphere functions shared by the benchmarks: the Lambert + normalised Phong test BRDF of
// the paper (kd 0.5, ks 0.4, outgoing direction 30 degrees from the normal) and an RGB sky with
// a small sun and an occluding wall, both as texel averages in the cosine-weighted map.
#pragma once

#include <cmath>
#include <numbers>
#include <string>

#include "basis/brdf/brdf.h"
#include "basis/core/hemisphere.h"
#include "basis/core/supersample.h"

namespace basis::bench {

// "lambert" or "phongN" for N in 10, 100, 1000.
inline Brdf paper_brdf(const std::string& name) {
  if (name == "lambert") return Lambert{{0.5, 0.5, 0.5}};
  const double exponent = std::stod(name.substr(5));
  return Phong{{0.5, 0.5, 0.5}, {0.4, 0.4, 0.4}, exponent};
}

inline Vec3 paper_outgoing() {
  const double t = 30 * std::numbers::pi / 180;
  return {std::sin(t), 0, std::cos(t)};
}

inline Grid brdf_grid(const Brdf& brdf, const Vec3& wo, int n) {
  Grid g(n, channel_count(brdf));
  SupersampleOptions options;
  options.absolute_floor = 0.01;
  average_over_texels(
      g,
      [&](double u, double v, double* out, bool) {
        const Color f = evaluate(brdf, square_to_cosine_hemisphere({u, v}), wo);
        for (int c = 0; c < g.channels; ++c)
          out[c] = f[c];
      },
      options);
  return g;
}

// Sky radiance brightening towards the horizon, a wall (radiance 0.02) over a quarter of the
// azimuths below 35 degrees elevation, and a sun of angular radius 0.27 degrees, radiance 1e5,
// at 40 degrees elevation and the given azimuth (radians): its energy is added to the texel
// holding its centre.
inline Grid sky_grid(int n, double sun_azimuth = 1.0) {
  Grid g(n, 3);
  const double sin_wall = std::sin(35 * std::numbers::pi / 180);
  auto radiance = [&](const Vec3& w, int c) {
    const double azimuth = std::atan2(w.y(), w.x());
    if (w.z() < sin_wall && azimuth > 2.0 && azimuth < 2.0 + std::numbers::pi / 2) return 0.02;
    const double sky[3] = {0.35, 0.5, 0.9};
    return sky[c] * (0.5 + 0.8 * (1 - w.z()) * (1 - w.z()));
  };
  average_over_texels(
      g,
      [&](double u, double v, double* out, bool) {
        const Vec3 w = square_to_cosine_hemisphere({u, v});
        for (int c = 0; c < 3; ++c)
          out[c] = radiance(w, c);
      },
      SupersampleOptions{.relative_tolerance = 1e-3, .absolute_floor = 0.1, .max_depth = 3});
  const double elevation = 40 * std::numbers::pi / 180, azimuth = sun_azimuth;
  const Vec3 sun(std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                 std::sin(elevation));
  const double radius = 0.27 * std::numbers::pi / 180;
  const double solid_angle = 2 * std::numbers::pi * (1 - std::cos(radius));
  const Vec2 uv = cosine_hemisphere_to_square(sun);
  const int x = std::min(n - 1, int(uv.x() * n)), y = std::min(n - 1, int(uv.y() * n));
  const double texel_area = 1.0 / (double(n) * n);
  const double sun_colour[3] = {1.0, 0.95, 0.85};
  for (int c = 0; c < 3; ++c)
    g.at(0, c, x, y) +=
        float(1e5 * sun_colour[c] * solid_angle * sun.z() / std::numbers::pi / texel_area);
  return g;
}

}  // namespace basis::bench
