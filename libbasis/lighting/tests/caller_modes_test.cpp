// Lookups and shading in a caller that runs with flush-to-zero and denormals-are-zero set (as
// renderers often do): radiance below the normal floats, a constant sky and a sun kept apart,
// reflects to the same values and bounds, bit for bit, as in the default modes (and a constant
// light to within its bound of the exact radiance), and the caller has its modes back after every
// call (gradual_underflow.h). Without the lookups' or shading's own scopes the values read as 0.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "basis/brdf/table_lookup.h"
#include "basis/lighting/capture.h"
#include "basis/lighting/shading.h"

#if defined(__SSE2__)
#include <immintrin.h>

namespace basis {
namespace {

constexpr unsigned kFlushModes = _MM_FLUSH_ZERO_MASK | _MM_DENORMALS_ZERO_MASK;

// Runs `call` with both modes set, then gives the test its own modes back (also if it throws);
// returns what the modes were when the call returned.
unsigned in_flushing_modes(const std::function<void()>& call) {
  struct Scope {
    unsigned saved = _mm_getcsr();
    Scope() { _mm_setcsr(saved | kFlushModes); }
    ~Scope() { _mm_setcsr(saved); }
  } scope;
  call();
  return _mm_getcsr() & kFlushModes;
}

struct Case {
  std::string name;
  std::function<Convolution()> run;
};

// The same call in the default modes and in flushing ones: the same bits, and the modes back.
void expect_independent_of_the_modes(const Case& c) {
  ASSERT_EQ(_mm_getcsr() & kFlushModes, 0u) << "the test runs in the default modes";
  const Convolution expected = c.run();
  Convolution flushed;
  EXPECT_EQ(in_flushing_modes([&] { flushed = c.run(); }), kFlushModes) << c.name;
  for (int ch = 0; ch < 3; ++ch) {
    EXPECT_EQ(flushed.value[ch], expected.value[ch]) << c.name << ", channel " << ch;
    EXPECT_EQ(flushed.bound[ch], expected.bound[ch]) << c.name << ", channel " << ch;
  }
}

TEST(CallerModes, FlushToZeroChangesNoLookupAndNoShading) {
  BrdfTableOptions table_options;
  table_options.wo_resolution = 5;
  table_options.wi_resolution = 8;
  const BrdfTable table = tabulate_brdf(Lambert{{1, 1, 1}}, table_options);

  // Constant light below the normal floats (the smallest normal float is about 1.18e-38): a
  // white Lambert surface reflects exactly that radiance, whatever the direction.
  const Color tiny{3e-39, 6e-39, 1e-39};
  const std::vector<SurfacePoint> points = {{Vec3::Zero(), Vec3::UnitZ()},
                                            {Vec3(1, 0, 0), Vec3(0.3, -0.4, 0.866).normalized()}};
  CaptureSetOptions capture_options;
  capture_options.capture.resolution = 16;
  const CaptureSet tiny_set =
      capture_set(Environment::constant(tiny), nullptr, points, capture_options);
  const CaptureSet unit_set =
      capture_set(Environment::constant({1, 1, 1}), nullptr, points, capture_options);

  // A sky below the normal floats with a sun kept apart as a compact light, also tiny.
  Image sky(256, 128, 3);
  for (float& p : sky.pixels)
    p = 1e-42f;
  for (int c = 0; c < 3; ++c)
    sky.pixels[(std::size_t(30) * 256 + 80) * 3 + std::size_t(c)] = 1e-36f;
  capture_options.capture.compact_lights = CaptureOptions::CompactLights::apart;
  const CaptureSet sun_set = capture_set(Environment(sky), nullptr, points, capture_options);
  ASSERT_FALSE(sun_set.view().lights_of(0).empty()) << "the sun is kept apart";

  const Vec3 wo_on_row(0.5, 0, 0.866), wo_off_rows = Vec3(0.3, 0.2, 0.93).normalized();
  const Tilt tilt = tilt_to(Vec3(0.1, 0.05, 1).normalized());
  std::vector<Case> cases;
  for (const CaptureSet* set : {&tiny_set, &sun_set})
    for (const Vec3& wo : {wo_on_row, wo_off_rows})
      for (std::size_t k = 0; k < points.size(); ++k) {
        const std::string at = (set == &tiny_set ? "constant" : "sun") + std::string(", point ") +
                               std::to_string(k) + (wo == wo_on_row ? ", on a row" : ", off rows");
        const CaptureSetView view = set->view();
        const PackedTreeView tree = view.trees.tree(k);
        cases.push_back(
            {"reflect, " + at, [&table, tree, wo] { return reflect(table.view(), tree, wo); }});
        cases.push_back({"reflect with the entries folded, " + at, [&table, tree, wo] {
                           return reflect(
                               table.view(),
                               entries_at(table.view(), wo, WoInterpolation::hermite, false), tree);
                         }});
        cases.push_back({"reflect_tilted, " + at, [&table, tree, wo, tilt] {
                           return reflect_tilted(table.view(), tree, wo, tilt,
                                                 TiltCompensation::compensated);
                         }});
        cases.push_back({"shade, " + at, [&table, view, k, wo] {
                           ShadingOptions options;
                           options.wo = wo;
                           return shade(table.view(), view, k, options);
                         }});
        cases.push_back({"shade at a normal, " + at, [&table, view, k, wo] {
                           ShadingOptions options;
                           options.wo = wo;
                           options.normal = Vec3(0.05, 0.1, 1).normalized();
                           return shade(table.view(), view, k, options);
                         }});
        cases.push_back({"shade with the entries found, " + at, [&table, view, k, wo] {
                           ShadingOptions options;
                           options.wo = wo;
                           return shade(
                               table.view(),
                               entries_at(table.view(), wo, WoInterpolation::hermite, true), view,
                               k, options);
                         }});
        cases.push_back({"shade with the BRDF for the lights, " + at, [&table, view, k, wo] {
                           static const Brdf white = Lambert{{1, 1, 1}};
                           ShadingOptions options;
                           options.wo = wo;
                           options.light_brdf = &white;
                           return shade(table.view(), view, k, options);
                         }});
        cases.push_back({"capture_product, " + at, [view, &unit_set, k] {
                           return capture_product(view, unit_set.view(), k);
                         }});
      }
  for (const Case& c : cases)
    expect_independent_of_the_modes(c);

  // And in the default modes, the untilted lookups of the constant light hold their bound of it.
  for (std::size_t k = 0; k < points.size(); ++k)
    for (const Vec3& wo : {wo_on_row, wo_off_rows}) {
      ShadingOptions options;
      options.wo = wo;
      const Convolution lo = shade(table.view(), tiny_set.view(), k, options);
      for (int ch = 0; ch < 3; ++ch) {
        EXPECT_GT(lo.value[ch], 0) << k << ", channel " << ch;
        EXPECT_LE(std::abs(double(lo.value[ch]) - tiny[ch]), double(lo.bound[ch]))
            << k << ", channel " << ch << ": " << lo.value[ch] << " for " << tiny[ch];
      }
    }
}

}  // namespace
}  // namespace basis
#endif
