#include "basis/study/reference.h"

#include <vector>

#include "basis/lighting/ray_scene.h"

namespace basis {

Color reference_reflection(const Environment& environment, const RayScene* scene,
                           const Vec3& position, const Frame& frame, const Brdf& brdf,
                           const Vec3& wo, int s, double ray_offset) {
  const Vec3 origin = ray_origin_above(position, frame.normal, ray_offset);
  Color sum{0, 0, 0};
  std::vector<Ray> rays;
  std::vector<RayHit> hits;
  std::vector<Color> contributions;
  for (int y = 0; y < environment.height(); ++y) {
    rays.clear();
    contributions.clear();
    environment.for_each_subpixel(y, 0, environment.width(), s, [&](int, const Vec3& w, double dw) {
      const Vec3 local = frame.to_local(w);
      if (local.z() <= 0) return;
      const Color f = evaluate(brdf, local, wo);
      const Color l = environment.radiance(w);
      contributions.push_back({f[0] * l[0] * local.z() * dw, f[1] * l[1] * local.z() * dw,
                               f[2] * l[2] * local.z() * dw});
      rays.push_back({origin, w});
    });
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
