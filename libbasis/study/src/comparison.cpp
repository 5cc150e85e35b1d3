#include "basis/study/comparison.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "basis/core/convolution.h"
#include "basis/core/dense.h"
#include "basis/core/projection.h"
#include "basis/core/tree_set.h"
#include "basis/study/haar.h"
#include "basis/study/sh.h"
#include "basis/study/timing.h"

namespace basis {

namespace {

double relative_error(const Color& value, const Color& truth) {
  const double t = luminance({truth[0], truth[1], truth[2]});
  return std::abs(luminance(value) - t) / t;
}

Color times_pi(const Rgb& v) {
  return {std::numbers::pi * v[0], std::numbers::pi * v[1], std::numbers::pi * v[2]};
}

// Keeps a value observable so that timing loops are not optimised away.
void keep(double v) {
  static_cast<void>(v);
  asm volatile("" : : "g"(&v) : "memory");
}

std::string format(const char* pattern, double a, double b = 0) {
  char text[64];
  std::snprintf(text, sizeof text, pattern, a, b);
  return text;
}

}  // namespace

std::vector<ComparisonRow> compare_methods(const ComparisonCase& c, const ComparisonOptions& o) {
  std::vector<ComparisonRow> rows;
  const double t = o.seconds_per_timing;
  auto row = [&](std::string method, std::string param) {
    ComparisonRow r;
    r.method = std::move(method);
    r.param = std::move(param);
    r.brdf = c.brdf;
    r.light = c.light;
    return r;
  };
  const int finest = c.light_grid.resolution;

  // Quadtrees at several resolutions and tolerances.
  for (int n : o.quadtree_resolutions) {
    if (n > finest) continue;
    const Grid brdf = downsample(c.brdf_grid, n), light = downsample(c.light_grid, n);
    for (double tolerance : o.quadtree_tolerances) {
      // Packed trees, as tables and capture sets hold them; projection timed with packing.
      const ProjectionOptions p{.tolerance = tolerance};
      const PackedTree a = pack(project(brdf, p)), b = pack(project(light, p));
      QuadtreeProjector projector;
      Quadtree scratch;
      const double project_ns = median_time_ns(
          [&] {
            projector.project(light, p, scratch);
            keep(double(pack(scratch).words.size()));
          },
          t);
      // Full descents, then accuracy-targeted ones.
      std::vector<double> accuracies = {0};
      if (tolerance == o.quadtree_targeted_tolerance)
        accuracies.insert(accuracies.end(), o.quadtree_accuracies.begin(),
                          o.quadtree_accuracies.end());
      for (const double accuracy : accuracies) {
        ComparisonRow r =
            accuracy == 0
                ? row("quadtree", format("%g@%g", n, tolerance))
                : row("quadtree_targeted", format("%g@%g", n, tolerance) + format("~%g", accuracy));
        r.bytes = double(b.words.size() * sizeof(std::uint32_t) + sizeof(TreeExtent));
        r.project_ns = project_ns;
        const ConvolutionOptions options{.accuracy = accuracy};
        r.convolve_ns =
            median_time_ns([&] { keep(convolve(a.view(), b.view(), options).value[0]); }, t);
        r.rel_error =
            relative_error(times_pi(convolve(a.view(), b.view(), options).value), c.truth);
        rows.push_back(r);
      }
    }
  }
  // Dense grids: the box-filtered texels, a plain loop and a vectorised dot product.
  for (int n : o.dense_resolutions) {
    if (n > finest) continue;
    const Grid brdf = downsample(c.brdf_grid, n), light = downsample(c.light_grid, n);
    const double error = relative_error(times_pi(dense_convolve_naive(brdf, light)), c.truth);
    const double project = median_time_ns([&] { keep(downsample(c.light_grid, n).texels[0]); }, t);
    for (const std::string method : {"dense_naive", "dense_simd"}) {
      ComparisonRow r = row(method, format("%g", n));
      r.bytes = double(light.texels.size() * sizeof(float));
      r.project_ns = project;
      r.convolve_ns = method == "dense_naive"
                          ? median_time_ns([&] { keep(dense_convolve_naive(brdf, light)[0]); }, t)
                          : median_time_ns([&] { keep(dense_convolve_simd(brdf, light)[0]); }, t);
      r.rel_error = error;
      rows.push_back(r);
    }
  }
  // Spherical harmonics: the BRDF times the cosine as a transfer, the light as radiance.
  for (int order : o.sh_orders) {
    const std::vector<double> transfer = sh_project(c.brdf_grid, order, true);
    const std::vector<double> radiance = sh_project(c.light_grid, order, false);
    ComparisonRow r = row("sh", format("%g", order));
    r.bytes = double(radiance.size() * sizeof(float));
    r.project_ns = median_time_ns([&] { keep(sh_project(c.light_grid, order, false)[0]); }, t);
    r.convolve_ns = median_time_ns(
        [&] { keep(sh_dot(transfer, c.brdf_grid.channels, radiance, 3, order)[0]); }, t);
    r.rel_error =
        relative_error(sh_dot(transfer, c.brdf_grid.channels, radiance, 3, order), c.truth);
    rows.push_back(r);
  }
  // Haar wavelets, non-linear approximation at the finest texels.
  for (std::size_t kept : o.haar_kept) {
    const HaarApproximation a = haar_project(c.brdf_grid, kept);
    const HaarApproximation b = haar_project(c.light_grid, kept);
    ComparisonRow r = row("haar", format("%g", double(kept)));
    r.bytes = double(b.bytes());
    r.project_ns =
        median_time_ns([&] { keep(double(haar_project(c.light_grid, kept).bytes())); }, t);
    r.convolve_ns = median_time_ns([&] { keep(haar_dot(a, b)[0]); }, t);
    const auto v = haar_dot(a, b);
    r.rel_error = relative_error(
        {std::numbers::pi * v[0], std::numbers::pi * v[1], std::numbers::pi * v[2]}, c.truth);
    rows.push_back(r);
  }
  return rows;
}

}  // namespace basis
