#include "basis/render/renderer.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include "basis/core/file_error.h"
#include "basis/core/random.h"
#include "basis/render/direct_lighting.h"

namespace basis {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Runs body(y) for every row in parallel, checking for cancellation.
template <typename Body>
void for_each_row(int height, const TaskControl& control, Body&& body) {
  std::atomic<bool> stop{false};
  tbb::parallel_for(0, height, [&](int y) {
    if (stop || (control.cancel && control.cancel->load())) {
      stop = true;
      return;
    }
    body(y);
  });
  if (stop) throw Cancelled();
}

// Splits `wall` seconds over parts in proportion to their thread times.
void apportion(double wall, std::initializer_list<std::pair<double*, double>> parts) {
  double total = 0;
  for (const auto& [out, t] : parts)
    total += t;
  for (const auto& [out, t] : parts)
    *out += total > 0 ? wall * t / total : 0;
}

struct Primary {
  std::vector<RadianceCache::Site> sites;  // per pixel
};

Primary primary_pass(const RenderScene& scene, bool masks, RenderResult& result,
                     const TaskControl& control) {
  const Camera& camera = scene.file.camera;
  const int w = camera.width, h = camera.height;
  Primary primary;
  primary.sites.resize(std::size_t(w) * h);
  result.image = Image(w, h, 3);
  result.covered.assign(std::size_t(w) * h, 0);
  for_each_row(h, control, [&](int y) {
    std::vector<Ray> rays(w);
    std::vector<RayIntersection> hits(w);
    for (int x = 0; x < w; ++x)
      rays[x] = camera.ray(x + 0.5, y + 0.5);
    scene.rays->intersect(rays, hits);
    for (int x = 0; x < w; ++x) {
      RadianceCache::Site& site = primary.sites[std::size_t(y) * w + x];
      site.point = shading_point(scene, rays[x], hits[x], camera.pixel_angle());
      if (!site.point.hit) {
        const Color l = scene.environment->radiance(rays[x].direction);
        for (int c = 0; c < 3; ++c)
          result.image.at(x, y, c) = float(l[c]);
        continue;
      }
      result.covered[std::size_t(y) * w + x] = 1;
      if (masks)
        site.lights =
            light_mask(scene, site.point.position, site.point.normal, site.point.geometric_normal);
    }
  });
  return primary;
}

void render_monte_carlo(const RenderScene& scene, const RenderOptions& options,
                        const Primary& primary, Clock::time_point start, RenderResult& result,
                        const TaskControl& control) {
  const int w = scene.file.camera.width, h = scene.file.camera.height;
  std::vector<double> sums(std::size_t(w) * h * 3, 0);
  const auto t0 = Clock::now();
  int done = 0;
  const bool budgeted = options.time_budget > 0;
  // Passes of at most kPassSamples samples, so that interruption is prompt whatever --spp says.
  constexpr int kPassSamples = 16;
  int pass = budgeted ? 1 : std::min(options.spp, kPassSamples);
  while (pass > 0) {
    const auto pass_start = Clock::now();
    for_each_row(h, control, [&](int y) {
      for (int x = 0; x < w; ++x) {
        const std::size_t p = std::size_t(y) * w + x;
        const RadianceCache::Site& site = primary.sites[p];
        if (!site.point.hit) continue;
        const std::uint64_t stream = splitmix64(options.seed ^ splitmix64(p)) << 20;
        const Color s = direct_lighting_sum(scene, site.point, stream, std::uint64_t(done), pass);
        for (int c = 0; c < 3; ++c)
          sums[3 * p + c] += s[c];
      }
    });
    done += pass;
    control.report(std::size_t(done), std::size_t(budgeted ? done + 1 : options.spp));
    if (!budgeted) {
      pass = std::min(options.spp - done, kPassSamples);
      continue;
    }
    const double per_sample = since(pass_start) / pass;
    const double left = options.time_budget - since(start);
    pass = per_sample > 0 ? int(std::min({left / per_sample, double(std::max(1, 2 * done)),
                                          double(kPassSamples)}))
                          : 0;
  }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::size_t p = std::size_t(y) * w + x;
      if (!primary.sites[p].point.hit) continue;
      for (int c = 0; c < 3; ++c)
        result.image.at(x, y, c) = float(sums[3 * p + c] / done);
    }
  result.spp = done;
  result.timings.shading = since(t0);
}

void render_cache(const RenderScene& scene, const RenderOptions& options, const Primary& primary,
                  RenderResult& result, const TaskControl& control) {
  const int w = scene.file.camera.width, h = scene.file.camera.height;
  CacheOptions cache_options = options.cache;
  cache_options.dense = options.method == RenderMethod::cache_dense;
  cache_options.seed = options.seed;
  RadianceCache cache(scene, cache_options);
  const std::size_t total = std::size_t(w) * h;

  // Placement: passes over finer and finer pixel grids.
  const auto placement_start = Clock::now();
  for (int spacing = std::max(1, options.coarsest_spacing); spacing >= 1; spacing /= 2) {
    const int columns = (w + spacing - 1) / spacing, rows = (h + spacing - 1) / spacing;
    std::vector<std::uint8_t> needs(std::size_t(columns) * rows, 0);
    for_each_row(rows, control, [&](int r) {
      std::array<RadianceCache::Neighbour, 16> found;
      for (int c = 0; c < columns; ++c) {
        const RadianceCache::Site& site =
            primary.sites[std::size_t(r) * spacing * w + std::size_t(c) * spacing];
        if (site.point.hit && cache.find(site, found) == 0) needs[std::size_t(r) * columns + c] = 1;
      }
    });
    std::vector<RadianceCache::Site> sites;
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < columns; ++c)
        if (needs[std::size_t(r) * columns + c])
          sites.push_back(primary.sites[std::size_t(r) * spacing * w + std::size_t(c) * spacing]);
    cache.add_records(sites, control);
    control.report(total / 2 / std::size_t(spacing), total);
  }
  const double placement_wall = since(placement_start);
  const CacheTimings placed = cache.timings();

  // The full pass.
  const auto shading_start = Clock::now();
  std::atomic<std::size_t> rows_done{0};
  for_each_row(h, control, [&](int y) {
    std::array<RadianceCache::Neighbour, 16> found;
    for (int x = 0; x < w; ++x) {
      const RadianceCache::Site& site = primary.sites[std::size_t(y) * w + x];
      if (!site.point.hit) continue;
      const int n = cache.find(site, found);
      const Rgb l = cache.interpolate(std::span(found.data(), std::size_t(n)), site.point);
      for (int c = 0; c < 3; ++c)
        result.image.at(x, y, c) = l[c];
    }
    control.report(total / 2 + ++rows_done * std::size_t(w) / 2, total);
  });
  const double shading_wall = since(shading_start);
  const CacheTimings all = cache.timings();

  RenderTimings& t = result.timings;
  apportion(placement_wall, {{&t.record_tracing, placed.tracing},
                             {&t.projection, placed.projection},
                             {&t.interpolation, placed.search}});
  const double lookup = all.lookup - placed.lookup, search = all.search - placed.search;
  // The full pass's own overhead (its loop, writing pixels) is shared out with the two.
  apportion(shading_wall, {{&t.lookup, lookup}, {&t.interpolation, search}});
  result.records = cache.size();
  result.record_bytes = cache.bytes();
}

}  // namespace

RenderResult render(const RenderScene& scene, const RenderOptions& options,
                    const TaskControl& control) {
  if (options.method == RenderMethod::monte_carlo && options.spp < 1 && !(options.time_budget > 0))
    throw std::invalid_argument("Monte Carlo needs at least one sample per pixel");
  const auto start = Clock::now();
  RenderResult result;
  const bool cached = options.method != RenderMethod::monte_carlo;
  // Radiance near the largest float overflows in the records or the pixels: one error that
  // names the scene and its light, never an image with infinities.
  const auto too_bright = [&](const char* what) {
    return FileError(scene.file.path + ": " + scene.environment->name() +
                     ": radiance too large to render: " + what);
  };
  try {
    const Primary primary = primary_pass(scene, cached, result, control);
    result.timings.primary = since(start);
    if (cached)
      render_cache(scene, options, primary, result, control);
    else
      render_monte_carlo(scene, options, primary, start, result, control);
  } catch (const std::overflow_error& e) {
    throw too_bright(e.what());
  }
  if (std::ranges::any_of(result.image.pixels, [](float v) { return std::isinf(v); }))
    throw too_bright("pixels overflow float (largest 3.4e38)");
  if (std::ranges::any_of(result.image.pixels, [](float v) { return std::isnan(v); }))
    throw std::runtime_error(scene.file.path + ": the render holds NaN pixels");
  result.timings.total = since(start);
  return result;
}

}  // namespace basis
