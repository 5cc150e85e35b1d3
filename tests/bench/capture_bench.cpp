// Capture kernels: Embree occlusion rays on a mesh of about 70k triangles, whole captures
// (tracing, environment filtering, projection) at 32 x 32 texels, and shading a capture whose
// sun is splatted or kept apart.
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <numbers>

#include "basis/brdf/brdf_table.h"
#include "basis/core/projection.h"
#include "basis/lighting/capture.h"
#include "basis/lighting/embree_scene.h"
#include "basis/lighting/shading.h"

namespace basis::bench {
namespace {

// A rolling terrain of 186 x 186 quads (69,192 triangles) over [-10, 10]^2.
const TriangleMesh& terrain() {
  static const TriangleMesh mesh = [] {
    TriangleMesh m;
    const int q = 186;
    for (int j = 0; j <= q; ++j)
      for (int i = 0; i <= q; ++i) {
        const float x = -10 + 20.0f * i / q, y = -10 + 20.0f * j / q;
        m.vertices.push_back({x, y, 0.8f * std::sin(0.9f * x) * std::cos(0.7f * y)});
      }
    for (int j = 0; j < q; ++j)
      for (int i = 0; i < q; ++i) {
        const std::uint32_t a = j * (q + 1) + i, b = a + 1, c = a + q + 1, d = c + 1;
        m.triangles.push_back({a, b, d});
        m.triangles.push_back({a, d, c});
      }
    m.emission.assign(m.triangles.size(), {0, 0, 0});
    return m;
  }();
  return mesh;
}

const EmbreeScene& scene() {
  static const EmbreeScene s(terrain());
  return s;
}

// A 512 x 256 sky with a sun, made here (no image library in benchmarks).
const Environment& sky() {
  static const Environment env = [] {
    Image image(512, 256, 3);
    for (int y = 0; y < 256; ++y)
      for (int x = 0; x < 512; ++x)
        for (int c = 0; c < 3; ++c)
          image.at(x, y, c) = y < 128 ? 0.3f + 0.2f * c + 0.5f * float(y) / 128 : 0.1f;
    for (int c = 0; c < 3; ++c)
      image.at(100, 60, c) = 5e4f;
    return Environment(image);
  }();
  return env;
}

void BM_Occlusion(benchmark::State& state) {
  // Rays from points on the terrain into the upper hemisphere, in batches of 1024.
  const std::size_t n = 1024;
  std::vector<Ray> rays(n);
  std::vector<RayHit> hits(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double x = -8 + 16.0 * ((i * 37) % n) / n, y = -8 + 16.0 * ((i * 91) % n) / n;
    const double phi = 2 * std::numbers::pi * ((i * 13) % 64) / 64,
                 z = 0.1 + 0.8 * ((i * 7) % 16) / 16;
    const double s = std::sqrt(1 - z * z);
    rays[i] = {Vec3(x, y, 0.8 * std::sin(0.9 * x) * std::cos(0.7 * y) + 1e-3),
               Vec3(s * std::cos(phi), s * std::sin(phi), z)};
  }
  scene();
  for (auto _ : state) {
    scene().trace(rays, hits);
    benchmark::DoNotOptimize(hits.data());
  }
  state.SetItemsProcessed(std::int64_t(n) * state.iterations());
  state.counters["triangles"] = double(terrain().triangles.size());
}
BENCHMARK(BM_Occlusion)->Name("trace/occlusion/70k_triangles");

void BM_Capture(benchmark::State& state) {
  const int res = int(state.range(0));
  const Frame frame = Frame::from_normal(Vec3(0.1, 0.2, 1).normalized());
  scene();
  sky();
  std::uint64_t index = 0;
  for (auto _ : state) {
    const Grid g =
        capture(sky(), &scene(), Vec3(0.5, 0.5, 0.8 * std::sin(0.45) * std::cos(0.35) + 1e-3),
                frame, {.resolution = res, .strata = 2}, index++)
            .texels;
    benchmark::DoNotOptimize(g.texels.data());
  }
  state.SetItemsProcessed(state.iterations());  // captures per second
  state.counters["rays_per_capture"] = double(res * res * 4);
}
BENCHMARK(BM_Capture)
    ->Name("capture/trace_and_filter")
    ->Arg(32)
    ->Arg(64)
    ->Unit(benchmark::kMicrosecond);

void BM_CaptureProjection(benchmark::State& state) {
  const int res = int(state.range(0));
  const Grid g =
      capture(sky(), &scene(), Vec3(0.5, 0.5, 0.8 * std::sin(0.45) * std::cos(0.35) + 1e-3),
              Frame::from_normal(Vec3(0.1, 0.2, 1).normalized()), {.resolution = res, .strata = 2})
          .texels;
  QuadtreeProjector projector;
  Quadtree tree;
  for (auto _ : state) {
    projector.project(g, {.tolerance = 0.05}, tree);
    benchmark::DoNotOptimize(tree.nodes.data());
  }
  state.counters["nodes"] = tree.node_count();
}
BENCHMARK(BM_CaptureProjection)
    ->Name("capture/project")
    ->Arg(32)
    ->Arg(64)
    ->Unit(benchmark::kMicrosecond);

// Shading one capture of the sky at 32 x 32 with a Phong 100 table (9 x 9 entries): the sun
// splatted into its texel, or kept apart and shaded with the BRDF or the table's texels.
void BM_ShadeSun(benchmark::State& state) {
  static const Brdf phong = Phong{{0.5, 0.5, 0.5}, {0.4, 0.4, 0.4}, 100};
  static const BrdfTable table = [] {
    BrdfTableOptions o;
    o.wo_resolution = 9;
    o.wi_resolution = 32;
    o.tilt_derivatives = false;
    return tabulate_brdf(phong, o);
  }();
  const SurfacePoint point{Vec3::Zero(), Vec3(0.1, 0.2, 1).normalized()};
  CaptureSetOptions capture_options;
  capture_options.capture.resolution = 32;
  capture_options.capture.compact_lights = state.range(0) > 0
                                               ? CaptureOptions::CompactLights::apart
                                               : CaptureOptions::CompactLights::splatted;
  const CaptureSet set = capture_set(sky(), nullptr, {&point, 1}, capture_options);
  ShadingOptions options;
  options.wo = Vec3(0.3, -0.2, 0.93).normalized();
  if (state.range(0) == 1) options.light_brdf = &phong;
  for (auto _ : state)
    benchmark::DoNotOptimize(shade(table.view(), set.view(), 0, options));
  state.counters["lights"] = double(set.lights.size());
  state.counters["capture_nodes"] = set.trees.view().tree(0).node_count();
}
BENCHMARK(BM_ShadeSun)
    ->Name("shade/phong100/32")
    ->ArgName("sun_splatted0_brdf1_table2")
    ->Arg(0)
    ->Arg(1)
    ->Arg(2);

}  // namespace
}  // namespace basis::bench
