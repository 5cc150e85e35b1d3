// Hemisphere captures (DESIGN section 6): incident radiance L(w) V(x, w) at a point, as texel
// averages over the cosine-weighted concentric map of the point's frame, ready for projection.
#pragma once

#include <cstdint>
#include <span>

#include "basis/environment.h"
#include "basis/frame.h"
#include "basis/grid.h"

namespace basis {

struct Ray {
  Vec3 origin;
  Vec3 direction;  // unit
};

// What a ray meets: nothing (it escapes to the environment) or a surface, whose emitted
// radiance is `emission` (black for surfaces that only occlude).
struct RayHit {
  bool hit = false;
  Color emission{0, 0, 0};
};

// Geometry that rays are traced against (trace.h implements it with Embree). Implementations
// must be callable from several threads at once.
class RayScene {
 public:
  virtual ~RayScene() = default;
  virtual void trace(std::span<const Ray> rays, std::span<RayHit> hits) const = 0;
};

struct CaptureOptions {
  int resolution = 64;        // N, texels per side (power of two, 2..512)
  int strata = 2;             // rays per texel = strata^2, jittered within a strata x strata grid
  int bright_subsamples = 4;  // per axis within each bright environment pixel
  std::uint64_t seed = 1;     // jitter; results depend on it and the point index only
  double ray_offset = 1e-4;   // origins move this far along the normal (scaled by the scene)
};

// Counts of what a capture did, for reports and benchmarks.
struct CaptureStats {
  long long rays = 0;
  long long escaped = 0;
};

// The capture at `position` with local frame `frame`: for every stratum, a ray through its
// jittered point; an escaping ray contributes the environment's smooth part averaged over the
// stratum's solid angle, a hit its surface's emission. Each bright environment pixel is split
// into bright_subsamples^2 pieces whose energy goes exactly into the texel it falls in, if a
// shadow ray towards it escapes. With no scene nothing occludes. `index` decorrelates jitter
// between points. Deterministic.
Grid capture(const Environment& environment, const RayScene* scene, const Vec3& position,
             const Frame& frame, const CaptureOptions& options, std::uint64_t index = 0,
             CaptureStats* stats = nullptr);

}  // namespace basis
