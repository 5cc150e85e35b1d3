#include "basis/brdf_table.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "basis/hemisphere.h"
#include "basis/parabolic.h"

namespace basis {

Vec3 table_outgoing(int i, int j, int wo_resolution) {
  const double step = 2.0 / (wo_resolution - 1);
  Vec2 st(-1 + step * i, -1 + step * j);
  const double r_max = std::tan(kTableMaxOutgoingDegrees * std::numbers::pi / 180 / 2);
  const double r = st.norm();
  if (r > r_max) st *= r_max / r;
  return parabolic_to_hemisphere(st);
}

Grid tabulate_entry(const Brdf& brdf, const Vec3& wo, const BrdfTableOptions& options) {
  const int channels = channel_count(brdf);
  const int groups = options.tilt_derivatives ? 3 : 1;
  Grid grid(options.wi_resolution, channels, groups);
  const double h = options.derivative_step;
  // Lobes peak near the mirror direction: the texels around it are sampled densely from the
  // start, so that no lobe narrower than the first samples' spacing slips between them.
  const Vec2 mirror = cosine_hemisphere_to_square(Vec3(-wo.x(), -wo.y(), wo.z()));
  const int n = options.wi_resolution;
  const int mx = std::min(n - 1, int(mirror.x() * n)), my = std::min(n - 1, int(mirror.y() * n));
  average_over_texels(
      grid,
      [&](double u, double v, double* out, bool all_groups) {
        const Vec3 w = square_to_cosine_hemisphere({u, v});
        const Color f = evaluate(brdf, w, wo);
        for (int c = 0; c < channels; ++c) out[c] = f[c];
        if (groups == 1 || !all_groups) return;
        for (int axis = 0; axis < 2; ++axis) {
          const Color d = tilt_derivative(brdf, w, wo, axis, h);
          for (int c = 0; c < channels; ++c) out[(1 + axis) * channels + c] = d[c];
        }
      },
      options.supersampling,
      [&](int x, int y) { return std::abs(x - mx) <= 1 && std::abs(y - my) <= 1; });
  return grid;
}

BrdfTable tabulate_brdf(const Brdf& brdf, const BrdfTableOptions& options,
                        const TaskControl& control) {
  const int m = options.wo_resolution;
  if (m < 2 || m > 256) throw std::invalid_argument("wo resolution must be 2..256");
  if (!is_valid_resolution(options.wi_resolution))
    throw std::invalid_argument("wi resolution must be a power of two from 2 to 512");
  const std::size_t count = std::size_t(m) * m;
  std::vector<Quadtree> entries(count), tilts(options.tilt_derivatives ? count : 0);
  std::atomic<std::size_t> done{0};
  std::atomic<bool> stop{false};
  control.report(0, count);
  tbb::parallel_for(std::size_t(0), count, [&](std::size_t k) {
    if (stop.load(std::memory_order_relaxed)) return;
    if (control.cancel && control.cancel->load()) {
      stop = true;
      return;
    }
    const Vec3 wo = table_outgoing(int(k % m), int(k / m), m);
    const Grid grid = tabulate_entry(brdf, wo, options);
    Grid base(grid.resolution, grid.channels, 1);
    std::copy(grid.texels.begin(), grid.texels.begin() + std::ptrdiff_t(base.texels.size()),
              base.texels.begin());
    entries[k] = project(base, options.projection);
    if (!options.tilt_derivatives) return;
    Grid tilt(grid.resolution, grid.channels, 2);
    std::copy(grid.texels.begin() + std::ptrdiff_t(base.texels.size()), grid.texels.end(),
              tilt.texels.begin());
    // Absolute tolerance for both derivative groups: the scaled tolerance of f, taken from the
    // brightest channel's mean.
    double scale = 0;
    for (int c = 0; c < base.channels; ++c)
      scale = std::max(scale, std::abs(base.mean(0, c)));
    ProjectionOptions tilt_projection = options.projection;
    tilt_projection.mode = ProjectionOptions::Mode::absolute;
    tilt_projection.tolerance =
        options.tilt_tolerance_scale * (options.projection.mode == ProjectionOptions::Mode::relative
                                            ? options.projection.tolerance * scale
                                            : options.projection.tolerance);
    tilt_projection.cut_on_all_groups = true;
    tilt_projection.group_tolerance_scale = 1;
    tilts[k] = project(tilt, tilt_projection);
    control.report(++done, count);
  });
  if (stop) throw Cancelled();

  BrdfTable table;
  table.wo_resolution = m;
  table.model = model_name(brdf);
  table.trees = TreeSet(entries.front().shape);
  for (const Quadtree& e : entries) table.trees.append(e.view());
  if (!tilts.empty()) {
    table.tilt = TreeSet(tilts.front().shape);
    for (const Quadtree& t : tilts) table.tilt.append(t.view());
  }
  return table;
}

namespace {

// Parabolic grid cell around wo and bilinear weights of its four entries.
struct Bilinear {
  int i0, j0;
  double fx, fy;
};

Bilinear locate(const Vec3& wo, int m) {
  if (!(wo.z() >= 0) || !std::isfinite(wo.norm()))
    throw std::invalid_argument("outgoing direction below the horizon or not finite");
  const Vec2 st = hemisphere_to_parabolic(wo.normalized());
  auto axis = [m](double s, int& index, double& frac) {
    const double g = std::clamp((s + 1) / 2 * (m - 1), 0.0, double(m - 1));
    index = std::min(int(g), m - 2);
    frac = g - index;
  };
  Bilinear b{};
  axis(st.x(), b.i0, b.fx);
  axis(st.y(), b.j0, b.fy);
  return b;
}

template <typename Entry>
Convolution interpolate(const BrdfTableView& table, const Vec3& wo, Entry entry) {
  // entry(i, j) gives the convolution of entry (i, j).
  const Bilinear b = locate(wo, table.wo_resolution);
  Convolution result;
  for (int dj = 0; dj < 2; ++dj)
    for (int di = 0; di < 2; ++di) {
      const double weight = (di ? b.fx : 1 - b.fx) * (dj ? b.fy : 1 - b.fy);
      if (weight == 0) continue;
      const Convolution c = entry(b.i0 + di, b.j0 + dj);
      for (int ch = 0; ch < 3; ++ch) {
        result.value[ch] += float(weight * std::numbers::pi * c.value[ch]);
        result.bound[ch] += float(weight * std::numbers::pi * c.bound[ch]);
      }
    }
  return result;
}

}  // namespace

Convolution reflect(const BrdfTableView& table, const QuadtreeView& radiance, const Vec3& wo) {
  return interpolate(table, wo,
                     [&](int i, int j) { return convolve(table.entry(i, j), radiance); });
}

Convolution reflect_tilted(const BrdfTableView& table, const QuadtreeView& radiance,
                           const Vec3& wo_shading, const Tilt& tilt, TiltCompensation mode) {
  if (mode == TiltCompensation::none) return reflect(table, radiance, wo_shading);
  // Re-parametrised: the entry whose lobe sits where the tilted surface's lobe sits.
  Vec3 wo = tilt_rotation(tilt).transpose() * wo_shading;
  wo.z() = std::max(0.0, wo.z());
  if (mode == TiltCompensation::reparametrised) return reflect(table, radiance, wo);
  if (!table.has_tilt())
    throw std::invalid_argument("the BRDF table holds no tilt derivatives to compensate with");
  return interpolate(table, wo, [&](int i, int j) {
    Convolution c = convolve(table.entry(i, j), radiance);
    const GroupConvolution d = convolve_groups(table.tilt_entry(i, j), radiance);
    for (int ch = 0; ch < 3; ++ch)
      c.value[ch] += float(tilt.x * d.value[0][ch] + tilt.y * d.value[1][ch]);
    return c;
  });
}

}  // namespace basis
