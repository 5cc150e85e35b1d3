// Monte Carlo estimates of direct lighting from the environment: the integral of
// f(wi, wo) L(wi) V(x, wi) cos(theta_i) over the hemisphere, in solid angle.
#pragma once

#include <cstdint>

#include "basis/core/color.h"
#include "basis/render/render_scene.h"
#include "basis/render/shading_point.h"

namespace basis {

// The sum over samples [first, first + count) of one estimate each: a direction drawn from the
// environment (EnvironmentSampler) and one from the BRDF (sample_brdf), each behind a shadow
// ray, combined by multiple importance sampling with the power heuristic. Sample s of a point
// depends on `stream` and s only, so sums over several calls equal one call's. Divide by the
// number of samples for the estimate.
Color direct_lighting_sum(const RenderScene& scene, const ShadingPoint& point, std::uint64_t stream,
                          std::uint64_t first, int count);

}  // namespace basis
