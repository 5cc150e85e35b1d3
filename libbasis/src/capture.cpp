#include "basis/capture.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "basis/hemisphere.h"

namespace basis {

namespace {

// SplitMix64: a counter-based generator, so jitter depends only on (seed, point, sample).
std::uint64_t mix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

double unit(std::uint64_t x) { return double(mix(x) >> 11) * 0x1.0p-53; }

}  // namespace

Grid capture(const Environment& environment, const RayScene* scene, const Vec3& position,
             const Frame& frame, const CaptureOptions& options, std::uint64_t index,
             CaptureStats* stats) {
  const int n = options.resolution, k = options.strata;
  if (!is_valid_resolution(n))
    throw std::invalid_argument("capture resolution must be a power of two from 2 to 512");
  if (k < 1 || k > 64) throw std::invalid_argument("strata per axis must be 1..64");
  Grid grid(n, 3);
  const Vec3 origin = position + frame.normal * options.ray_offset;
  const double texel_area = 1.0 / (double(n) * n);
  const double stratum_area = texel_area / (k * k);
  const std::uint64_t stream = mix(options.seed ^ mix(index));

  // Strata: one ray each, traced in batches of a row of texels.
  std::vector<Ray> rays(std::size_t(n) * k * k);
  std::vector<RayHit> hits(rays.size());
  std::vector<Vec3> local(rays.size());
  CaptureStats counts;
  for (int y = 0; y < n; ++y) {
    std::size_t r = 0;
    for (int x = 0; x < n; ++x)
      for (int j = 0; j < k; ++j)
        for (int i = 0; i < k; ++i, ++r) {
          const std::uint64_t id = stream + ((std::uint64_t(y) * n + x) * k + j) * k + i;
          const double u = (x + (i + unit(2 * id)) / k) / n;
          const double v = (y + (j + unit(2 * id + 1)) / k) / n;
          local[r] = square_to_cosine_hemisphere({u, v});
          rays[r] = {origin, frame.to_world(local[r]).normalized()};
        }
    if (scene) {
      scene->trace(rays, hits);
    } else {
      std::fill(hits.begin(), hits.end(), RayHit{});
    }
    r = 0;
    for (int x = 0; x < n; ++x) {
      Color sum{0, 0, 0};
      for (int s = 0; s < k * k; ++s, ++r) {
        Color l;
        if (hits[r].hit) {
          l = hits[r].emission;
        } else {
          ++counts.escaped;
          // Solid angle of the stratum: d(omega) = pi du dv / cos(theta).
          const double omega = std::min(2 * std::numbers::pi,
                                        std::numbers::pi * stratum_area / std::max(local[r].z(), 1e-3));
          l = environment.smooth_average(rays[r].direction, omega);
        }
        for (int c = 0; c < 3; ++c) sum[c] += l[c];
      }
      for (int c = 0; c < 3; ++c) grid.at(0, c, x, y) = float(sum[c] / (k * k));
    }
    counts.rays += std::int64_t(n) * k * k;
  }

  // Bright pixels, split into pieces whose energy lands exactly in their texel.
  const int s = std::max(1, options.bright_subsamples);
  std::vector<Ray> shadow;
  std::vector<std::pair<std::size_t, Color>> deposits;  // texel, radiance x weight
  for (const Environment::BrightPixel& b : environment.bright_pixels())
    for (int sy = 0; sy < s; ++sy) {
      const double y0 = b.row + double(sy) / s, y1 = b.row + double(sy + 1) / s;
      const double omega = environment.band_solid_angle(y0, y1, 1.0 / s);
      for (int sx = 0; sx < s; ++sx) {
        const Vec3 d = environment.direction(b.column + (sx + 0.5) / s, (y0 + y1) / 2);
        const Vec3 l = frame.to_local(d);
        if (l.z() <= 0) continue;
        const Vec2 uv = cosine_hemisphere_to_square(l);
        const int tx = std::min(n - 1, int(uv.x() * n)), ty = std::min(n - 1, int(uv.y() * n));
        const double weight = omega * l.z() / std::numbers::pi / texel_area;
        shadow.push_back({origin, d});
        deposits.push_back({std::size_t(ty) * n + tx,
                            {b.excess[0] * weight, b.excess[1] * weight, b.excess[2] * weight}});
      }
    }
  std::vector<RayHit> shadow_hits(shadow.size());
  if (scene && !shadow.empty()) scene->trace(shadow, shadow_hits);
  counts.rays += std::int64_t(shadow.size());
  for (std::size_t i = 0; i < deposits.size(); ++i) {
    if (shadow_hits[i].hit) continue;
    const std::size_t t = deposits[i].first;
    for (int c = 0; c < 3; ++c)
      grid.at(0, c, int(t % n), int(t / n)) += float(deposits[i].second[c]);
  }
  if (stats) {
    stats->rays += counts.rays;
    stats->escaped += counts.escaped;
  }
  return grid;
}

}  // namespace basis
