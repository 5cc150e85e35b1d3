// Hemisphere captures: incident radiance L(w) V(x, w) at a point, as texel
// averages over the cosine-weighted concentric map of the point's frame, ready for projection.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "basis/core/frame.h"
#include "basis/core/grid.h"
#include "basis/core/projection.h"
#include "basis/core/task.h"
#include "basis/io/points_file.h"
#include "basis/lighting/capture_set.h"
#include "basis/lighting/environment.h"
#include "basis/lighting/ray_scene.h"

namespace basis {

struct CaptureOptions {
  int resolution = 128;       // N, texels per side (power of two, 2..512)
  int strata = 2;             // rays per texel = strata^2, jittered within a strata x strata grid
  int bright_subsamples = 4;  // pieces per axis of each bright environment pixel
  // Bright pixels outside compact lights that fall into one texel share the shadow ray of the
  // first of them, instead of one ray each (compact lights keep one ray per pixel).
  bool shared_bright_rays = false;
  // At most this many environment samples per axis average an escaping ray's stratum (about
  // one per map pixel the stratum spans, 1 to this).
  int stratum_subsamples = 8;
  // Take the subsamples from the environment's box-filtered pyramid at the scale each stands
  // for (Environment::smooth_radiance(w, pixels)), so that few of them average many pixels.
  bool prefiltered = false;
  std::uint64_t seed = 1;  // jitter; results depend on it and the point index only
  // Origins move along the normal by the larger of this (world units) and 2^-19 of the
  // position's largest coordinate (ray_origin_above). Callers scale it to their scene: the
  // tools and Python take TriangleMesh::ray_offset, 1e-4 of the scene's extent.
  double ray_offset = 1e-4;
  // Where the environment's compact lights (a sun) go: into the texels they fall in, like any
  // bright pixel, or apart, as one DirectionalLight per light seen.
  enum class CompactLights { splatted, apart };
  CompactLights compact_lights = CompactLights::splatted;
  // Also measure how far the occluders are (Capture::occluder_distance), tracing the strata's
  // rays to their nearest hit instead of testing occlusion alone.
  bool occluder_distances = false;
};

// Counts of what a capture did, for reports and benchmarks.
struct CaptureStats {
  long long rays = 0;
  long long escaped = 0;
  // With CaptureOptions::occluder_distances: the sum over the strata's rays that hit of
  // 1 / distance, and their count.
  double inverse_distance_sum = 0;
  long long occluded = 0;
};

// One capture: texel averages of L(w) V(x, w) over the cosine-weighted concentric map of the
// point's frame, and the compact lights kept apart (empty unless CompactLights::apart).
struct Capture {
  Grid texels;
  std::vector<DirectionalLight> lights;
  CaptureStats stats;
  // The harmonic mean distance to the occluders the strata's rays hit (infinity when none
  // does, or without CaptureOptions::occluder_distances): the scale over which the capture
  // changes as its point moves (a radiance cache's validity radius).
  double occluder_distance() const {
    return stats.occluded > 0 ? double(stats.occluded) / stats.inverse_distance_sum
                              : std::numeric_limits<double>::infinity();
  }
};

// Compact lights wider than this (their radius, Environment::CompactLight) are kept apart as
// the four quarters of their extent around their centre, each with its own energy and
// direction, so that a sharp lobe sees the light's spread rather than a point at its centre.
inline constexpr double kSplitLightRadiusDegrees = 1;

// The capture at `position` with local frame `frame`, in three phases:
//   strata: for every stratum, a ray through its jittered point; an escaping ray contributes
//           the environment's smooth part averaged over the stratum's footprint, a hit its
//           surface's emission;
//   bright pixels: each bright environment pixel is split into bright_subsamples^2 pieces, one
//           shadow ray towards the pixel's centre;
//   deposits: if that ray escapes, each piece above the horizon adds its energy exactly to the
//           texel it falls in, or, for a compact light kept apart, to that light's (or its
//           quarter's) energy and energy-weighted direction.
// With no scene nothing occludes. `index` decorrelates jitter between points. Deterministic.
// Throws std::overflow_error when the radiance overflows the float texels.
Capture capture(const Environment& environment, const RayScene* scene, const Vec3& position,
                const Frame& frame, const CaptureOptions& options, std::uint64_t index = 0);

// Adds each light's energy to the texel its direction falls in (where its pieces go with
// CompactLights::splatted): the grid of texel averages such a capture stands for.
void splat_lights(std::span<const DirectionalLight> lights, Grid& grid);

struct CaptureSetOptions {
  CaptureOptions capture;  // compact_lights apart gives every capture a list of lights
  ProjectionOptions projection;
  BoundKind bounds = BoundKind::l2;  // what the packed trees' bounds bound (packed_tree.h)
  // Called with each capture's texel grid before projection and the lights kept apart (from
  // worker threads), e.g. to write it out; may be empty.
  std::function<void(std::size_t index, const Grid& grid, std::span<const DirectionalLight> lights)>
      on_grid;
  // Capturing stops with std::length_error once what the set's file would hold (every point's
  // tree, position, frame and lights) passes this size (a .qt file holds at most 2 GiB), before
  // memory runs out and before the file is written.
  std::size_t max_bytes = std::size_t(2000) << 20;
  // The index of the first point in the whole run (a shard's first point): capture i's jitter
  // depends on the seed and first_index + i, and on_grid is called with that index, so that the
  // shards of a run capture exactly what one process would.
  std::uint64_t first_index = 0;
};

// Time spent, summed over threads: tracing and filtering (capture) and building trees.
struct CaptureTimings {
  double capture_seconds = 0;
  double projection_seconds = 0;
  CaptureStats stats;
};

// Captures every point in parallel and projects each capture into a tree. Deterministic for a
// seed and first index whatever the thread count; reports progress per point and stops (Cancelled)
// when asked. Radiance that overflows float texels is a std::overflow_error naming the
// environment (its file, or the constant).
CaptureSet capture_set(const Environment& environment, const RayScene* scene,
                       std::span<const SurfacePoint> points, const CaptureSetOptions& options,
                       const TaskControl& control = {}, CaptureTimings* timings = nullptr);

}  // namespace basis
