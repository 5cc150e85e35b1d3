#include "basis/study/reference.h"

#include <vector>

namespace basis {

Color reference_reflection(const Environment& environment, const RayScene* scene,
                           const Vec3& position, const Frame& frame, const Brdf& brdf,
                           const Vec3& wo, int s, double ray_offset) {
  const Vec3 origin = position + frame.normal * ray_offset;
  Color sum{0, 0, 0};
  std::vector<Ray> rays;
  std::vector<RayHit> hits;
  std::vector<Color> contributions;
  for (int y = 0; y < environment.height(); ++y) {
    rays.clear();
    contributions.clear();
    for (int sy = 0; sy < s; ++sy) {
      const double y0 = y + double(sy) / s, y1 = y0 + 1.0 / s;
      const double dw = environment.band_solid_angle(y0, y1, 1.0 / s);
      for (int x = 0; x < environment.width(); ++x)
        for (int sx = 0; sx < s; ++sx) {
          const Vec3 w = environment.direction(x + (sx + 0.5) / s, (y0 + y1) / 2);
          const Vec3 local = frame.to_local(w);
          if (local.z() <= 0) continue;
          const Color f = evaluate(brdf, local, wo), l = environment.radiance(w);
          contributions.push_back({f[0] * l[0] * local.z() * dw, f[1] * l[1] * local.z() * dw,
                                   f[2] * l[2] * local.z() * dw});
          rays.push_back({origin, w});
        }
    }
    hits.assign(rays.size(), RayHit{});
    if (scene && !rays.empty()) scene->trace(rays, hits);
    for (std::size_t i = 0; i < rays.size(); ++i) {
      if (hits[i].hit) continue;
      for (int c = 0; c < 3; ++c)
        sum[c] += contributions[i][c];
    }
  }
  return sum;
}

}  // namespace basis
