#include "basis/render/direct_lighting.h"

#include <vector>

#include "basis/brdf/brdf_sampling.h"
#include "basis/core/random.h"
#include "basis/lighting/ray_scene.h"

namespace basis {

Color direct_lighting_sum(const RenderScene& scene, const ShadingPoint& point, std::uint64_t stream,
                          std::uint64_t first, int count) {
  const Frame frame = point.frame();
  const Vec3 wo = point.local_wo();
  const Brdf& brdf = scene.materials[point.material].brdf;
  const Vec3 origin = ray_origin_above(point.position, point.geometric_normal, scene.ray_offset);
  std::vector<Ray> rays;
  std::vector<Color> weights;  // f L cos / pdf x MIS weight, before visibility
  rays.reserve(2 * std::size_t(count));
  weights.reserve(2 * std::size_t(count));
  auto consider = [&](const Vec3& w, double pdf, double other_pdf) {
    if (!(pdf > 0) || !(w.dot(point.geometric_normal) > 0)) return;
    const Vec3 wi = frame.to_local(w);
    if (!(wi.z() > 0)) return;
    const Color f = evaluate(brdf, wi, wo);
    const Color l = scene.environment->radiance(w);
    const double mis = pdf * pdf / (pdf * pdf + other_pdf * other_pdf);
    const double scale = wi.z() / pdf * mis;
    const Color c{f[0] * l[0] * scale, f[1] * l[1] * scale, f[2] * l[2] * scale};
    if (c[0] <= 0 && c[1] <= 0 && c[2] <= 0) return;
    rays.push_back({origin, w});
    weights.push_back(c);
  };
  for (int k = 0; k < count; ++k) {
    const std::uint64_t id = splitmix64(stream + first + std::uint64_t(k)) * 8;
    // From the environment.
    const EnvironmentSampler::Sample light = scene.environment_sampler->sample(
        unit_random(id), unit_random(id + 1), unit_random(id + 2), unit_random(id + 3));
    consider(light.w, light.pdf, brdf_pdf(brdf, frame.to_local(light.w), wo));
    // From the BRDF.
    const BrdfSample b =
        sample_brdf(brdf, wo, unit_random(id + 4), unit_random(id + 5), unit_random(id + 6));
    const Vec3 w = frame.to_world(b.wi).normalized();
    consider(w, b.pdf, scene.environment_sampler->pdf(w));
  }
  std::vector<RayHit> hits(rays.size());
  if (!rays.empty()) scene.rays->trace(rays, hits);
  Color sum{0, 0, 0};
  for (std::size_t i = 0; i < rays.size(); ++i) {
    if (hits[i].hit) continue;
    for (int c = 0; c < 3; ++c)
      sum[c] += weights[i][c];
  }
  return sum;
}

}  // namespace basis
