#include "basis/lighting/capture.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "basis/core/file_error.h"
#include "basis/core/hemisphere.h"

namespace basis {

namespace {

// SplitMix64: a counter-based generator, so jitter depends only on (seed, point, sample).
std::uint64_t mix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

double unit(std::uint64_t x) {
  return double(mix(x) >> 11) * 0x1.0p-53;
}

}  // namespace

Grid capture(const Environment& environment, const RayScene* scene, const Vec3& position,
             const Frame& frame, const CaptureOptions& options, std::uint64_t index,
             CaptureStats* stats, std::vector<DirectionalLight>* lights) {
  const int n = options.resolution, k = options.strata;
  if (!is_valid_resolution(n))
    throw std::invalid_argument("capture resolution must be a power of two from 2 to 512");
  if (k < 1 || k > 64) throw std::invalid_argument("strata per axis must be 1..64");
  Grid grid(n, 3);
  const Vec3 origin = position + frame.normal * options.ray_offset;
  const double texel_area = 1.0 / (double(n) * n);
  const std::uint64_t stream = mix(options.seed ^ mix(index));

  // Strata: one ray each, traced in batches of a row of texels. A ray that escapes takes the
  // smooth part of the environment averaged over its stratum, from m_u x m_v jittered points
  // with about one per map pixel the stratum spans along each side (1 to 8).
  const double stratum = 1.0 / (double(n) * k);
  const double pixel_angle = environment.pixel_angle();
  std::vector<Ray> rays(std::size_t(n) * k * k);
  std::vector<RayHit> hits(rays.size());
  CaptureStats counts;
  auto stratum_corner = [&](int x, int y, int s) {
    return Vec2((x + double(s % k) / k) / n, (y + double(s / k) / k) / n);
  };
  for (int y = 0; y < n; ++y) {
    std::size_t r = 0;
    for (int x = 0; x < n; ++x)
      for (int s = 0; s < k * k; ++s, ++r) {
        const std::uint64_t id = stream + (std::uint64_t(y) * n + x) * k * k + s;
        const Vec2 corner = stratum_corner(x, y, s);
        const Vec2 uv = corner + Vec2(unit(2 * id), unit(2 * id + 1)) * stratum;
        rays[r] = {origin, frame.to_world(square_to_cosine_hemisphere(uv)).normalized()};
      }
    if (scene) {
      scene->trace(rays, hits);
    } else {
      std::fill(hits.begin(), hits.end(), RayHit{});
    }
    r = 0;
    for (int x = 0; x < n; ++x) {
      // Sub-samples per stratum side, from the angular size of the texel's middle stratum.
      int mu = 1, mv = 1;
      if (pixel_angle > 0) {
        const Vec2 centre((x + 0.5) / n, (y + 0.5) / n);
        const Vec3 c = square_to_cosine_hemisphere(centre);
        const Vec3 du = square_to_cosine_hemisphere(centre + Vec2(stratum, 0));
        const Vec3 dv = square_to_cosine_hemisphere(centre + Vec2(0, stratum));
        mu = std::clamp(int(std::ceil(angle_between(c, du) / pixel_angle)), 1, 8);
        mv = std::clamp(int(std::ceil(angle_between(c, dv) / pixel_angle)), 1, 8);
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
            const std::uint64_t sub = mix(id) + std::uint64_t(b * mu + a);
            const Vec2 uv =
                corner + Vec2((a + unit(2 * sub)) / mu, (b + unit(2 * sub + 1)) / mv) * stratum;
            const Color l =
                environment.smooth_radiance(frame.to_world(square_to_cosine_hemisphere(uv)));
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

  // Bright pixels: one shadow ray each (through the pixel's centre), their energy split into
  // pieces that land exactly in the texel each falls in, or (for compact lights kept apart)
  // that add to the light's energy and direction.
  const int s = std::max(1, options.bright_subsamples);
  std::vector<Ray> shadow;
  struct Deposit {
    std::size_t ray, texel;
    int light;     // compact light kept apart, or -1 for a texel
    Color energy;  // texels: radiance x weight; lights: radiance x solid angle
    Vec3 local;
  };
  std::vector<Deposit> deposits;
  for (const Environment::BrightPixel& b : environment.bright_pixels()) {
    const Vec3 centre = environment.direction(b.column + 0.5, b.row + 0.5);
    const int light = lights ? b.light : -1;
    bool any = false;
    for (int sy = 0; sy < s; ++sy) {
      const double y0 = b.row + double(sy) / s, y1 = b.row + double(sy + 1) / s;
      const double omega = environment.band_solid_angle(y0, y1, 1.0 / s);
      for (int sx = 0; sx < s; ++sx) {
        const Vec3 l =
            frame.to_local(environment.direction(b.column + (sx + 0.5) / s, (y0 + y1) / 2));
        if (l.z() <= 0) continue;
        const auto [tx, ty] = cosine_hemisphere_texel(l, n);
        const double weight = light >= 0 ? omega : omega * l.z() / std::numbers::pi / texel_area;
        deposits.push_back({shadow.size(),
                            std::size_t(ty) * n + tx,
                            light,
                            {b.excess[0] * weight, b.excess[1] * weight, b.excess[2] * weight},
                            l});
        any = true;
      }
    }
    if (any) shadow.push_back({origin, centre});
  }
  std::vector<RayHit> shadow_hits(shadow.size());
  if (scene && !shadow.empty()) scene->trace(shadow, shadow_hits);
  counts.rays += std::int64_t(shadow.size());
  struct Seen {
    Color energy{0, 0, 0};
    Vec3 direction = Vec3::Zero();
  };
  std::vector<Seen> seen(lights ? environment.lights().size() : 0);
  for (const Deposit& d : deposits) {
    if (shadow_hits[d.ray].hit) continue;
    if (d.light >= 0) {
      Seen& light = seen[std::size_t(d.light)];
      for (int c = 0; c < 3; ++c)
        light.energy[c] += d.energy[c];
      light.direction += luminance(d.energy) * d.local;
      continue;
    }
    for (int c = 0; c < 3; ++c)
      grid.at(0, c, int(d.texel % n), int(d.texel / n)) += float(d.energy[c]);
  }
  if (lights) {
    lights->clear();
    for (const Seen& light : seen) {
      if (!(light.direction.norm() > 0)) continue;
      const Vec3 w = light.direction.normalized();
      lights->push_back({w, light.energy});
    }
  }
  if (stats) {
    stats->rays += counts.rays;
    stats->escaped += counts.escaped;
  }
  return grid;
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
  std::vector<Quadtree> trees(count);
  std::vector<Frame> frames(count);
  std::vector<std::vector<DirectionalLight>> lights(count);
  std::atomic<std::size_t> done{0}, bytes{0};
  std::atomic<bool> stop{false}, too_large{false};
  std::atomic<long long> capture_ns{0}, projection_ns{0}, rays{0}, escaped{0};
  control.report(0, count);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 1), [&](const auto& range) {
    QuadtreeProjector projector;
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      if (stop.load(std::memory_order_relaxed) || too_large.load(std::memory_order_relaxed)) return;
      if (control.cancel && control.cancel->load()) {
        stop = true;
        return;
      }
      const Vec3 n = points[i].normal.normalized();
      frames[i] = Frame::from_normal(n);
      const auto t0 = std::chrono::steady_clock::now();
      CaptureStats stats;
      const Grid grid = capture(environment, scene, points[i].position, frames[i], options.capture,
                                i, &stats, options.separate_lights ? &lights[i] : nullptr);
      const auto t1 = std::chrono::steady_clock::now();
      // A relative tolerance counts the lights kept apart in the capture's mean, as it would
      // count them splatted into their texels.
      ProjectionOptions projection = options.projection;
      for (const DirectionalLight& light : lights[i])
        for (int c = 0; c < 3; ++c)
          projection.extra_mean[c] += light.energy[c] * light.direction.z() / std::numbers::pi;
      projector.project(grid, projection, trees[i]);
      const auto t2 = std::chrono::steady_clock::now();
      if (options.on_grid) options.on_grid(i, grid, lights[i]);
      capture_ns += std::chrono::duration_cast<std::chrono::nanoseconds>(t1 - t0).count();
      projection_ns += std::chrono::duration_cast<std::chrono::nanoseconds>(t2 - t1).count();
      rays += stats.rays;
      escaped += stats.escaped;
      bytes += (trees[i].nodes.size() + trees[i].errors.size()) * sizeof(Quad);
      if (bytes > options.max_bytes) too_large = true;
      control.report(++done, count);
    }
  });
  if (stop) throw Cancelled();
  if (too_large)
    throw std::length_error("the captures grow beyond " + std::to_string(options.max_bytes >> 20) +
                            " MiB (the limit of one .qt file): capture fewer points per file, "
                            "lower --res or raise the tolerance");
  CaptureSet set;
  set.trees = TreeSet(trees.front().shape);
  for (std::size_t i = 0; i < count; ++i) {
    set.trees.append(trees[i].view());
    set.positions.push_back(points[i].position);
    set.normals.push_back(frames[i].normal);
    set.tangents.push_back(frames[i].tangent);
    if (options.separate_lights) {
      set.light_offsets.push_back(std::uint32_t(set.lights.size()));
      set.lights.insert(set.lights.end(), lights[i].begin(), lights[i].end());
    }
  }
  if (options.separate_lights) set.light_offsets.push_back(std::uint32_t(set.lights.size()));
  if (timings) {
    timings->capture_seconds += capture_ns * 1e-9;
    timings->projection_seconds += projection_ns * 1e-9;
    timings->stats.rays += rays;
    timings->stats.escaped += escaped;
  }
  return set;
}

}  // namespace basis
