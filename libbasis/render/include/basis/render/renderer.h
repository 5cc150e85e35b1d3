// Rendering direct lighting from the environment, f Li V cos integrated over the hemisphere of
// every visible point (no interreflection), by Monte Carlo or through a radiance cache.
#pragma once

#include <cstdint>
#include <vector>

#include "basis/core/task.h"
#include "basis/io/image.h"
#include "basis/render/radiance_cache.h"
#include "basis/render/render_scene.h"

namespace basis {

enum class RenderMethod {
  monte_carlo,  // direct_lighting_sum at every pixel
  cache,        // radiance cache, records as quadtrees
  cache_dense,  // radiance cache, records as dense grids (the regular-texture baseline)
};

struct RenderOptions {
  RenderMethod method = RenderMethod::cache;
  int spp = 16;            // Monte Carlo: samples per pixel (each an environment and a BRDF draw)
  double time_budget = 0;  // Monte Carlo, when > 0: as many whole samples per pixel as fit
  std::uint64_t seed = 1;
  CacheOptions cache;
  // Records are placed in passes over pixel grids of spacing coarsest_spacing, half that, ...,
  // 1: a pass adds a record at each of its pixels where no earlier record is valid.
  int coarsest_spacing = 32;
};

// Wall time of each phase in seconds; phases that share a parallel loop split its wall time in
// proportion to their summed thread times.
struct RenderTimings {
  double total = 0;
  double primary = 0;         // camera rays, and the shadow rays of the pixels' light masks
  double record_tracing = 0;  // the records' captures
  double projection = 0;      // records into trees (or dense grids)
  double lookup = 0;          // the records' tilted table lookups (convolution)
  double interpolation = 0;   // finding valid records (k-d tree, weights), placement tests
  double shading = 0;         // Monte Carlo sampling and shadow rays
};

struct RenderResult {
  Image image;                        // linear RGB; pixels that miss show the environment
  std::vector<std::uint8_t> covered;  // per pixel (row-major): 1 where the camera ray hit
  RenderTimings timings;
  std::size_t records = 0;       // radiance cache records
  std::size_t record_bytes = 0;  // their trees or grids
  int spp = 0;                   // Monte Carlo samples per pixel rendered
};

// Renders the scene's camera view. The image is the same for any thread count; Monte Carlo
// with a time budget renders passes of whole samples per pixel until the next would not fit.
// Reports progress and stops (Cancelled) through `control`. Radiance that overflows the
// records' floats or the pixels' is a FileError naming the scene file and its light; options
// out of range are std::invalid_argument, and a render holding NaN pixels std::runtime_error.
RenderResult render(const RenderScene& scene, const RenderOptions& options,
                    const TaskControl& control = {});

}  // namespace basis
