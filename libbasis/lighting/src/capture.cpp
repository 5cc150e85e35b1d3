#include "basis/lighting/capture.h"
#include "basis/core/random.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <unordered_map>
#include <vector>

#include "basis/core/file_error.h"
#include "basis/core/hemisphere.h"
#include "basis/core/projection.h"

namespace basis {

namespace {

// Phase 1: texel averages from the strata's rays. A ray that escapes takes the smooth part of
// the environment averaged over its stratum, from m_u x m_v jittered points with about one per
// map pixel the stratum spans along each side (1 to options.stratum_subsamples); a ray that
// hits takes the emission.
// Rays are traced in batches of a row of texels.
void trace_strata(const Environment& environment, const RayScene* scene, const Vec3& origin,
                  const Frame& frame, const CaptureOptions& options, std::uint64_t stream,
                  Grid& grid, CaptureStats& counts) {
  const int n = options.resolution, k = options.strata;
  const double stratum = 1.0 / (double(n) * k);
  const double pixel_angle = environment.pixel_angle();
  std::vector<Ray> rays(std::size_t(n) * k * k);
  std::vector<RayHit> hits(rays.size());
  auto stratum_corner = [&](int x, int y, int s) {
    return Vec2((x + double(s % k) / k) / n, (y + double(s / k) / k) / n);
  };
  for (int y = 0; y < n; ++y) {
    std::size_t r = 0;
    for (int x = 0; x < n; ++x)
      for (int s = 0; s < k * k; ++s, ++r) {
        const std::uint64_t id = stream + (std::uint64_t(y) * n + x) * k * k + s;
        const Vec2 corner = stratum_corner(x, y, s);
        const Vec2 uv = corner + Vec2(unit_random(2 * id), unit_random(2 * id + 1)) * stratum;
        rays[r] = {origin, frame.to_world(square_to_cosine_hemisphere(uv)).normalized()};
      }
    if (scene && options.occluder_distances) {
      scene->trace_nearest(rays, hits);
      for (const RayHit& h : hits)
        if (h.hit && h.distance > 0) {
          counts.inverse_distance_sum += 1.0 / h.distance;
          ++counts.occluded;
        }
    } else if (scene) {
      scene->trace(rays, hits);
    } else {
      std::fill(hits.begin(), hits.end(), RayHit{});
    }
    r = 0;
    for (int x = 0; x < n; ++x) {
      // Sub-samples per stratum side, from the angular size of the texel's middle stratum.
      int mu = 1, mv = 1;
      double footprint = 1;  // map pixels a subsample stands for, along each side
      if (pixel_angle > 0) {
        const Vec2 centre((x + 0.5) / n, (y + 0.5) / n);
        const Vec3 c = square_to_cosine_hemisphere(centre);
        const Vec3 du = square_to_cosine_hemisphere(centre + Vec2(stratum, 0));
        const Vec3 dv = square_to_cosine_hemisphere(centre + Vec2(0, stratum));
        const int most = std::max(1, options.stratum_subsamples);
        const double pu = angle_between(c, du) / pixel_angle;
        const double pv = angle_between(c, dv) / pixel_angle;
        mu = std::clamp(int(std::ceil(pu)), 1, most);
        mv = std::clamp(int(std::ceil(pv)), 1, most);
        if (options.prefiltered) footprint = std::min(pu / mu, pv / mv);
      }
      Color sum{0, 0, 0};
      for (int s = 0; s < k * k; ++s, ++r) {
        if (hits[r].hit) {
          for (int c = 0; c < 3; ++c)
            sum[c] += hits[r].emission[c];
          continue;
        }
        ++counts.escaped;
        const Vec2 corner = stratum_corner(x, y, s);
        const std::uint64_t id = stream + (std::uint64_t(y) * n + x) * k * k + s;
        Color average{0, 0, 0};
        for (int b = 0; b < mv; ++b)
          for (int a = 0; a < mu; ++a) {
            const std::uint64_t sub = splitmix64(id) + std::uint64_t(b * mu + a);
            const Vec2 uv = corner + Vec2((a + unit_random(2 * sub)) / mu,
                                          (b + unit_random(2 * sub + 1)) / mv) *
                                         stratum;
            const Vec3 w = frame.to_world(square_to_cosine_hemisphere(uv));
            const Color l = options.prefiltered ? environment.smooth_radiance(w, footprint)
                                                : environment.smooth_radiance(w);
            for (int c = 0; c < 3; ++c)
              average[c] += l[c];
          }
        for (int c = 0; c < 3; ++c)
          sum[c] += average[c] / (mu * mv);
      }
      for (int c = 0; c < 3; ++c)
        grid.at(0, c, x, y) = float(sum[c] / (k * k));
    }
    counts.rays += std::int64_t(n) * k * k;
  }
}

// Phase 2: the pieces of the bright pixels above the horizon, each behind the shadow ray of its
// pixel. A piece of a compact light kept apart carries radiance x solid angle; any other piece
// its share of the texel it falls in (radiance x solid angle x cos / pi / texel area).
struct BrightPieces {
  struct Piece {
    std::size_t ray;    // its pixel's shadow ray
    std::size_t texel;  // y * N + x
    int light;          // 4 x the compact light kept apart + its part, or -1 for a texel
    Color energy;
    Vec3 local;  // direction in the capture's frame
  };
  std::vector<Ray> shadow_rays;
  std::vector<Piece> pieces;
};

BrightPieces gather_bright_pieces(const Environment& environment, const Vec3& origin,
                                  const Frame& frame, const CaptureOptions& options) {
  const int n = options.resolution;
  const double texel_area = 1.0 / (double(n) * n);
  const bool lights_apart = options.compact_lights == CaptureOptions::CompactLights::apart;
  const int s = std::max(1, options.bright_subsamples);
  BrightPieces out;
  const auto compact = environment.lights();
  // With shared_bright_rays: the shadow ray of each texel's first bright pixel outside lights.
  std::unordered_map<std::size_t, std::size_t> texel_ray;
  for (const Environment::BrightPixel& b : environment.bright_pixels()) {
    const int light = lights_apart ? b.light : -1;
    // A light wider than kSplitLightRadiusDegrees is kept as the four quarters of its extent
    // around its centre (part 4 light + q), so that shading sees how it spreads.
    const bool split = light >= 0 && compact[std::size_t(light)].radius >
                                         kSplitLightRadiusDegrees * std::numbers::pi / 180;
    const Frame around =
        split ? Frame::from_normal(compact[std::size_t(light)].direction) : Frame{};
    const Vec3& centre = b.centre;
    std::size_t ray = out.shadow_rays.size();
    bool shared = false;
    std::size_t key = 0;
    if (options.shared_bright_rays && b.light < 0 && frame.to_local(centre).z() > 0) {
      const auto [cx, cy] = cosine_hemisphere_texel(frame.to_local(centre), n);
      key = std::size_t(cy) * n + cx + 1;
      const auto [at, inserted] = texel_ray.try_emplace(key, ray);
      ray = at->second;
      shared = !inserted;
    }
    bool any = false;
    auto piece = [&](int, const Vec3& w, double solid_angle) {
      const Vec3 l = frame.to_local(w);
      if (l.z() <= 0) return;
      const auto [tx, ty] = cosine_hemisphere_texel(l, n);
      const double weight =
          light >= 0 ? solid_angle : solid_angle * l.z() / std::numbers::pi / texel_area;
      const Vec3 offset = around.to_local(w);
      const int part = light < 0 ? -1
                       : !split  ? 4 * light
                                 : 4 * light + (offset.x() >= 0) + 2 * (offset.y() >= 0);
      out.pieces.push_back({ray,
                            std::size_t(ty) * n + tx,
                            part,
                            {b.excess[0] * weight, b.excess[1] * weight, b.excess[2] * weight},
                            l});
      any = true;
    };
    if (s == 1)
      piece(b.column, b.centre, b.solid_angle);
    else
      environment.for_each_subpixel(b.row, b.column, b.column + 1, s, piece);
    if (any && !shared) out.shadow_rays.push_back({origin, centre});
    // A texel's first pixel that left no piece (all below the horizon) gives it no ray.
    if (!any && !shared && key != 0) texel_ray.erase(key);
  }
  return out;
}

// Phase 3: the visible pieces into their texels, or into their lights' energy and direction.
void deposit_bright_pieces(const BrightPieces& bright, std::span<const RayHit> shadow_hits,
                           std::size_t environment_lights, Grid& grid,
                           std::vector<DirectionalLight>& lights) {
  struct Seen {
    Color energy{0, 0, 0};
    Vec3 direction = Vec3::Zero();
  };
  std::vector<Seen> seen(4 * environment_lights);
  const int n = grid.resolution;
  for (const BrightPieces::Piece& piece : bright.pieces) {
    if (shadow_hits[piece.ray].hit) continue;
    if (piece.light >= 0) {
      Seen& light = seen[std::size_t(piece.light)];
      for (int c = 0; c < 3; ++c)
        light.energy[c] += piece.energy[c];
      light.direction += luminance(piece.energy) * piece.local;
      continue;
    }
    for (int c = 0; c < 3; ++c)
      grid.at(0, c, int(piece.texel % n), int(piece.texel / n)) += float(piece.energy[c]);
  }
  for (const Seen& light : seen) {
    if (!(light.direction.norm() > 0)) continue;
    lights.push_back({light.direction.normalized(), light.energy});
  }
}

}  // namespace

Capture capture(const Environment& environment, const RayScene* scene, const Vec3& position,
                const Frame& frame, const CaptureOptions& options, std::uint64_t index) {
  const int n = options.resolution, k = options.strata;
  if (!is_valid_resolution(n))
    throw std::invalid_argument("capture resolution must be a power of two from 2 to 512");
  if (k < 1 || k > 64) throw std::invalid_argument("strata per axis must be 1..64");
  Capture out{Grid(n, 3), {}, {}};
  const Vec3 origin = ray_origin_above(position, frame.normal, options.ray_offset);
  trace_strata(environment, scene, origin, frame, options,
               splitmix64(options.seed ^ splitmix64(index)), out.texels, out.stats);

  const BrightPieces bright = gather_bright_pieces(environment, origin, frame, options);
  std::vector<RayHit> shadow_hits(bright.shadow_rays.size());
  if (scene && !bright.shadow_rays.empty()) scene->trace(bright.shadow_rays, shadow_hits);
  out.stats.rays += std::int64_t(bright.shadow_rays.size());
  deposit_bright_pieces(bright, shadow_hits, environment.lights().size(), out.texels, out.lights);

  if (!all_finite(out.texels.texels))
    throw std::overflow_error("texels overflow float (largest 3.4e38)");
  return out;
}

void splat_lights(std::span<const DirectionalLight> lights, Grid& grid) {
  const int n = grid.resolution;
  for (const DirectionalLight& light : lights) {
    const Vec3& w = light.direction;
    if (!(w.z() > 0)) continue;
    const auto [tx, ty] = cosine_hemisphere_texel(w, n);
    const double weight = w.z() / std::numbers::pi * double(n) * n;
    for (int c = 0; c < std::min(3, grid.channels); ++c)
      grid.at(0, c, tx, ty) += float(light.energy[c] * weight);
  }
}

CaptureSet capture_set(const Environment& environment, const RayScene* scene,
                       std::span<const SurfacePoint> points, const CaptureSetOptions& options,
                       const TaskControl& control, CaptureTimings* timings) {
  const std::size_t count = points.size();
  if (count == 0) throw std::invalid_argument("no points to capture");
  for (std::size_t k = 0; k < count; ++k)
    if (!points[k].position.allFinite())
      throw std::invalid_argument("point " + std::to_string(k) + "'s position is NaN or infinite");
  std::vector<PackedTree> trees(count);
  std::vector<Frame> frames(count);
  std::vector<std::vector<DirectionalLight>> lights(count);
  std::atomic<std::size_t> done{0}, bytes{0};
  std::atomic<bool> stop{false}, too_large{false};
  std::atomic<long long> capture_ns{0}, projection_ns{0}, rays{0}, escaped{0};
  control.report(0, count);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 1), [&](const auto& range) {
    QuadtreeProjector projector;
    Quadtree tree;
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      if (stop.load(std::memory_order_relaxed) || too_large.load(std::memory_order_relaxed)) return;
      if (control.cancel && control.cancel->load()) {
        stop = true;
        return;
      }
      const Vec3 n = points[i].normal.normalized();
      frames[i] = Frame::from_normal(n);
      const auto t0 = std::chrono::steady_clock::now();
      Capture c;
      try {
        c = capture(environment, scene, points[i].position, frames[i], options.capture,
                    options.first_index + i);
      } catch (const std::overflow_error& e) {
        throw std::overflow_error(environment.name() +
                                  ": radiance too large for captures: " + e.what());
      }
      lights[i] = std::move(c.lights);
      const auto t1 = std::chrono::steady_clock::now();
      // A relative tolerance counts the lights kept apart in the capture's mean, as it would
      // count them splatted into their texels.
      ProjectionOptions projection = options.projection;
      const Color lights_mean = mean_of_lights(lights[i]);
      for (std::size_t c = 0; c < 3; ++c)
        projection.extra_mean[c] += lights_mean[c];
      try {
        projector.project(c.texels, projection, tree);
        trees[i] = pack_exact_texels(tree, options.bounds);
      } catch (const std::overflow_error& e) {
        throw std::overflow_error(environment.name() +
                                  ": radiance too large for captures: " + e.what());
      }
      const auto t2 = std::chrono::steady_clock::now();
      if (options.on_grid) options.on_grid(options.first_index + i, c.texels, lights[i]);
      capture_ns += std::chrono::duration_cast<std::chrono::nanoseconds>(t1 - t0).count();
      projection_ns += std::chrono::duration_cast<std::chrono::nanoseconds>(t2 - t1).count();
      rays += c.stats.rays;
      escaped += c.stats.escaped;
      // What the point adds to its file: its tree's words and extent, and its position, normal
      // and tangent, its lights and their offset, in doubles as files keep them.
      constexpr std::size_t kVectorBytes = 3 * sizeof(double);
      bytes += trees[i].words.size() * sizeof(std::uint32_t) + sizeof(TreeExtent) +
               3 * kVectorBytes + sizeof(std::uint32_t) + lights[i].size() * 2 * kVectorBytes;
      if (bytes > options.max_bytes) too_large = true;
      control.report(++done, count);
    }
  });
  if (stop) throw Cancelled();
  if (too_large)
    throw std::length_error("the captures grow beyond " + std::to_string(options.max_bytes >> 20) +
                            " MiB (the limit of one .qt file): capture fewer points per file, at a "
                            "lower resolution, or raise the tolerance");
  const bool lights_apart = options.capture.compact_lights == CaptureOptions::CompactLights::apart;
  CaptureSet set;
  set.trees = TreeSet(trees.front().shape);
  for (std::size_t i = 0; i < count; ++i) {
    set.trees.append(trees[i].view());
    set.positions.push_back(points[i].position);
    set.normals.push_back(frames[i].normal);
    set.tangents.push_back(frames[i].tangent);
    if (lights_apart) {
      set.light_offsets.push_back(std::uint32_t(set.lights.size()));
      set.lights.insert(set.lights.end(), lights[i].begin(), lights[i].end());
    }
  }
  if (lights_apart) set.light_offsets.push_back(std::uint32_t(set.lights.size()));
  if (timings) {
    timings->capture_seconds += capture_ns * 1e-9;
    timings->projection_seconds += projection_ns * 1e-9;
    timings->stats.rays += rays;
    timings->stats.escaped += escaped;
  }
  return set;
}

}  // namespace basis
