#include "basis/brdf/brdf_table.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "basis/brdf/tilt_derivative.h"
#include "basis/core/hemisphere.h"
#include "basis/core/parabolic.h"
#include "basis/core/projection.h"

namespace basis {

Vec3 table_outgoing(int i, int j, int wo_resolution) {
  const double step = 2.0 / (wo_resolution - 1);
  Vec2 st(-1 + step * i, -1 + step * j);
  const double r_max = std::tan(kTableMaxOutgoingDegrees * std::numbers::pi / 180 / 2);
  const double r = st.norm();
  if (r > r_max) st *= r_max / r;
  return parabolic_to_hemisphere(st);
}

namespace {

// Lobes peak near the mirror direction: at resolution n, the texels around it are sampled
// densely from the start, so that no lobe narrower than the first samples' spacing slips
// between them.
auto near_mirror(const Vec3& wo, int n) {
  const Vec2 mirror = cosine_hemisphere_to_square(Vec3(-wo.x(), -wo.y(), wo.z()));
  const int mx = std::min(n - 1, int(mirror.x() * n)), my = std::min(n - 1, int(mirror.y() * n));
  return [mx, my](int x, int y) { return std::abs(x - mx) <= 1 && std::abs(y - my) <= 1; };
}

}  // namespace

Grid tabulate_entry(const Brdf& brdf, const Vec3& wo, const BrdfTableOptions& options) {
  const int channels = channel_count(brdf);
  Grid grid(options.wi_resolution, channels, 1);
  average_over_texels(
      grid,
      [&](double u, double v, double* out, bool) {
        const Color f = evaluate(brdf, square_to_cosine_hemisphere({u, v}), wo);
        for (int c = 0; c < channels; ++c)
          out[c] = f[c];
      },
      options.supersampling, near_mirror(wo, options.wi_resolution));
  return grid;
}

Grid tabulate_tilt(const Brdf& brdf, const Vec3& wo, const BrdfTableOptions& options) {
  const int channels = channel_count(brdf);
  const int n = std::min(options.tilt_resolution, options.wi_resolution);
  Grid grid(n, channels, 2);
  SupersampleOptions sampling = options.supersampling;
  sampling.max_depth = std::min(sampling.max_depth, options.tilt_max_depth);
  average_over_texels(
      grid,
      [&](double u, double v, double* out, bool all_groups) {
        const Vec3 w = square_to_cosine_hemisphere({u, v});
        for (int axis = 0; axis < (all_groups ? 2 : 1); ++axis) {
          const Color d = tilt_derivative(brdf, w, wo, axis, options.derivative_step);
          for (int c = 0; c < channels; ++c)
            out[axis * channels + c] = d[c];
        }
      },
      sampling, near_mirror(wo, n));
  return grid;
}

BrdfTable tabulate_brdf(const Brdf& brdf, const BrdfTableOptions& options,
                        const TaskControl& control) {
  const int m = options.wo_resolution;
  if (m < 2 || m > 256) throw std::invalid_argument("wo resolution must be 2..256");
  if (!is_valid_resolution(options.wi_resolution))
    throw std::invalid_argument("wi resolution must be a power of two from 2 to 512");
  const std::size_t count = std::size_t(m) * m;
  std::vector<PackedTree> entries(count), tilts(options.tilt_derivatives ? count : 0);
  std::vector<char> needed(count, options.only_for.empty());
  for (const Vec3& wo : options.only_for)
    for (const TableTap& tap : table_taps(m, wo))
      needed[std::size_t(tap.j) * m + tap.i] = 1;
  std::atomic<std::size_t> done{0}, bytes{0};
  std::atomic<bool> stop{false}, too_large{false};
  control.report(0, count);
  tbb::parallel_for(std::size_t(0), count, [&](std::size_t k) {
    if (stop.load(std::memory_order_relaxed) || too_large.load(std::memory_order_relaxed)) return;
    if (control.cancel && control.cancel->load()) {
      stop = true;
      return;
    }
    if (!needed[k]) {  // a partial table: zero trees of the full table's shape
      const int channels = channel_count(brdf);
      entries[k] = pack(project(Grid(options.wi_resolution, channels, 1), options.projection),
                        options.bounds);
      if (options.tilt_derivatives)
        tilts[k] = pack(
            project(Grid(std::min(options.tilt_resolution, options.wi_resolution), channels, 2),
                    {.tolerance = 0, .mode = ProjectionOptions::Mode::absolute}),
            options.bounds);
      control.report(++done, count);
      return;
    }
    const Vec3 wo = table_outgoing(int(k % m), int(k / m), m);
    const Grid base = tabulate_entry(brdf, wo, options);
    entries[k] = pack(project(base, options.projection), options.bounds);
    if (options.tilt_derivatives) {
      // Absolute tolerance for both derivative groups: the scaled tolerance of f, taken from
      // the brightest channel's mean.
      double scale = 0;
      for (int c = 0; c < base.channels; ++c)
        scale = std::max(scale, std::abs(base.mean(0, c)));
      ProjectionOptions tilt_projection = options.projection;
      tilt_projection.mode = ProjectionOptions::Mode::absolute;
      tilt_projection.tolerance = options.tilt_tolerance_scale *
                                  (options.projection.mode == ProjectionOptions::Mode::relative
                                       ? options.projection.tolerance * scale
                                       : options.projection.tolerance);
      tilt_projection.max_depth = 0;
      tilt_projection.cut_on_all_groups = true;
      tilt_projection.group_tolerance_scale = 1;
      tilts[k] = pack(project(tabulate_tilt(brdf, wo, options), tilt_projection), options.bounds);
    }
    bytes += (entries[k].words.size() + (tilts.empty() ? 0 : tilts[k].words.size())) *
                 sizeof(std::uint32_t) +
             sizeof(TreeExtent) * (tilts.empty() ? 1 : 2);
    if (bytes > options.max_bytes) too_large = true;
    control.report(++done, count);
  });
  if (stop) throw Cancelled();
  if (too_large)
    throw std::length_error("the table grows beyond " + std::to_string(options.max_bytes >> 20) +
                            " MiB (the limit of one .qt file): lower the resolutions or raise "
                            "the tolerance");

  BrdfTable table;
  table.wo_resolution = m;
  table.model = model_name(brdf);
  table.trees = TreeSet(entries.front().shape);
  for (const PackedTree& e : entries)
    table.trees.append(e.view());
  if (!tilts.empty()) {
    table.tilt = TreeSet(tilts.front().shape);
    for (const PackedTree& t : tilts)
      table.tilt.append(t.view());
  }
  return table;
}

std::array<TableTap, 4> table_taps(int m, const Vec3& wo) {
  if (!(wo.z() >= 0) || !std::isfinite(wo.norm()))
    throw std::invalid_argument("outgoing direction below the horizon or not finite");
  const Vec2 st = hemisphere_to_parabolic(wo.normalized());
  auto axis = [m](double s, int& index, double& frac) {
    const double g = std::clamp((s + 1) / 2 * (m - 1), 0.0, double(m - 1));
    index = std::min(int(g), m - 2);
    frac = g - index;
  };
  int i0, j0;
  double fx, fy;
  axis(st.x(), i0, fx);
  axis(st.y(), j0, fy);
  return {TableTap{i0, j0, (1 - fx) * (1 - fy)}, TableTap{i0 + 1, j0, fx * (1 - fy)},
          TableTap{i0, j0 + 1, (1 - fx) * fy}, TableTap{i0 + 1, j0 + 1, fx * fy}};
}

}  // namespace basis
