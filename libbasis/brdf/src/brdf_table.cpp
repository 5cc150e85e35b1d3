#include "basis/brdf/brdf_table.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>

#include "basis/brdf/tilt_derivative.h"
#include "basis/core/grid.h"
#include "basis/core/hemisphere.h"
#include "basis/core/parabolic.h"
#include "basis/core/projection.h"
#include "basis/core/square_symmetry.h"

namespace basis {

Vec3 table_outgoing(const Vec2& grid_point) {
  Vec2 st = grid_point;
  const double r_max = std::tan(kTableMaxOutgoingDegrees * std::numbers::pi / 180 / 2);
  const double r = st.norm();
  if (r > r_max) st *= r_max / r;
  return parabolic_to_hemisphere(st);
}

Vec3 table_outgoing(int i, int j, int wo_resolution) {
  const double step = 2.0 / (wo_resolution - 1);
  return table_outgoing(Vec2(-1 + step * i, -1 + step * j));
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

double lobe_width(const Brdf& brdf) {
  constexpr int kSteps = 1700;  // 0.05 degrees
  const double top = 85 * std::numbers::pi / 180;
  std::vector<double> profile(kSteps + 1);
  for (int k = 0; k <= kSteps; ++k) {
    const double theta = top * k / kSteps;
    profile[k] =
        luminance(evaluate(brdf, Vec3(std::sin(theta), 0, std::cos(theta)), Vec3::UnitZ()));
  }
  const double floor = *std::min_element(profile.begin(), profile.end());
  const double peak = profile[0] - floor;
  if (!(peak > 1e-6 * std::abs(profile[0]))) return INFINITY;
  for (int k = 1; k <= kSteps; ++k)
    if (profile[k] - floor <= peak / 2) {
      // Between samples k - 1 and k, linearly.
      const double a = profile[k - 1] - floor, b = profile[k] - floor;
      const double theta = top * (k - 1 + (a - peak / 2) / (a - b)) / kSteps;
      return theta / 1.1774;
    }
  return INFINITY;
}

namespace {

// default_wo_resolution for a lobe of this width (radians).
int wo_resolution_for_width(double width) {
  // Steps of 4 / (M - 1) radians at the normal, at most 0.73 widths: M - 1 >= 5.5 / width.
  const double steps = std::isfinite(width) ? 5.5 / width : 0;
  const int rounded = int(std::ceil(steps / 8)) * 8;
  return std::clamp(rounded, 32, 128) + 1;
}

}  // namespace

int default_wo_resolution(const Brdf& brdf) {
  return wo_resolution_for_width(lobe_width(brdf));
}

std::vector<std::string> table_resolution_warnings(const Brdf& brdf,
                                                   const BrdfTableOptions& options) {
  std::vector<std::string> warnings;
  // Options tabulate_brdf refuses get its error instead.
  if (!is_valid_resolution(options.wi_resolution) || options.wo_resolution < 2) return warnings;
  const double width = lobe_width(brdf);
  if (!std::isfinite(width)) return warnings;
  char text[320];
  // The grid steps default_wo_resolution allows (at most 0.73 widths at the normal), without its
  // floor of 33, which broad lobes do not need.
  const int needed = std::min(wo_resolution_for_width(width), int(std::ceil(5.5 / width)) + 1);
  if (options.wo_resolution < needed) {
    std::snprintf(text, sizeof text,
                  "%d x %d outgoing directions are coarser than this lobe (%.2f degrees wide) "
                  "needs, %d x %d: lookups between entries may err by more than 1 %%",
                  options.wo_resolution, options.wo_resolution, width * 180 / std::numbers::pi,
                  needed, needed);
    warnings.push_back(text);
  }
  // The quadrature's finest step at the normal, in radians, at n texels per side.
  const auto finest_step = [&](int n) {
    return std::ldexp(2.0 / n, -options.supersampling.max_depth);
  };
  const double step = finest_step(options.wi_resolution);
  if (step > width / 2) {
    int enough = options.wi_resolution;
    while (enough < 512 && finest_step(enough) > width / 2)
      enough *= 2;
    const bool suffices = finest_step(enough) <= width / 2;
    std::snprintf(
        text, sizeof text,
        "the lobe (%.3f degrees wide) is narrower than twice the quadrature's finest "
        "step at %d x %d texels (%.3f degrees): texel averages may miss it; %s",
        width * 180 / std::numbers::pi, options.wi_resolution, options.wi_resolution,
        step * 180 / std::numbers::pi,
        suffices
            ? ("use at least " + std::to_string(enough) + " x " + std::to_string(enough)).c_str()
            : "even 512 x 512 may");
    warnings.push_back(text);
  }
  return warnings;
}

Grid tabulate_table_entry(const Brdf& brdf, int i, int j, const BrdfTableOptions& options) {
  const int m = options.wo_resolution;
  const double step = 2.0 / (m - 1), d = options.wo_derivative_step;
  const Vec2 st(-1 + step * i, -1 + step * j);
  const Vec3 wo = table_outgoing(st);
  if (!options.wo_derivatives) return tabulate_entry(brdf, wo, options);
  // The directions of the central differences, through the same pull inside the disk as the
  // entries (so that the derivatives are those of what the grid stands for).
  const Vec3 around[4] = {
      table_outgoing(Vec2(st.x() + d, st.y())), table_outgoing(Vec2(st.x() - d, st.y())),
      table_outgoing(Vec2(st.x(), st.y() + d)), table_outgoing(Vec2(st.x(), st.y() - d))};
  const double per_step = step / (2 * d);
  const int channels = channel_count(brdf);
  Grid grid(options.wi_resolution, channels, 3);
  // The derivatives are sharper than f: they decide convergence too.
  SupersampleOptions sampling = options.supersampling;
  sampling.checked_groups = 3;
  average_over_texels(
      grid,
      [&](double u, double v, double* out, bool all_groups) {
        const Vec3 wi = square_to_cosine_hemisphere({u, v});
        const Color f = evaluate(brdf, wi, wo);
        for (int c = 0; c < channels; ++c)
          out[c] = f[c];
        if (!all_groups) return;
        Color e[4];
        for (int k = 0; k < 4; ++k)
          e[k] = evaluate(brdf, wi, around[k]);
        for (int c = 0; c < channels; ++c) {
          out[channels + c] = (e[0][c] - e[1][c]) * per_step;
          out[2 * channels + c] = (e[2][c] - e[3][c]) * per_step;
        }
      },
      sampling, near_mirror(wo, options.wi_resolution));
  return grid;
}

ProjectionOptions entry_projection(const BrdfTableOptions& options) {
  ProjectionOptions p = options.projection;
  if (options.wo_derivatives) {
    p.cut_on_all_groups = true;
    p.group_tolerance_scale = options.wo_derivative_tolerance_scale;
  }
  return p;
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

std::vector<SquareSymmetry> brdf_symmetries(const Brdf& brdf) {
  // Random pairs of directions above the horizon, the same every time.
  std::mt19937_64 rng(20261202);
  std::uniform_real_distribution<double> unit(0, 1);
  auto direction = [&] {
    const double z = 0.02 + 0.98 * unit(rng), phi = 2 * std::numbers::pi * unit(rng);
    const double r = std::sqrt(1 - z * z);
    return Vec3(r * std::cos(phi), r * std::sin(phi), z);
  };
  std::vector<std::pair<Vec3, Vec3>> pairs(256);
  for (auto& [wi, wo] : pairs) {
    wi = direction();
    wo = direction();
  }
  const auto all = SquareSymmetry::all();
  auto holds = [&](const SquareSymmetry& g) {
    for (const auto& [wi, wo] : pairs) {
      const Color a = evaluate(brdf, wi, wo), b = evaluate(brdf, g.apply(wi), g.apply(wo));
      for (int c = 0; c < 3; ++c)
        if (!(std::abs(a[c] - b[c]) <= 1e-9 * (std::abs(a[c]) + std::abs(b[c])) + 1e-300))
          return false;
    }
    return true;
  };
  // Whole groups only: all eight, the four rotations, the half turn, or none.
  bool ok[8];
  for (int k = 0; k < 8; ++k)
    ok[k] = k == 0 || holds(all[k]);
  const int size = ok[1] && ok[2] && ok[3] ? (ok[4] && ok[5] && ok[6] && ok[7] ? 8 : 4)
                   : ok[2]                 ? 2
                                           : 1;
  if (size == 2) return {all[0], all[2]};
  return std::vector<SquareSymmetry>(all.begin(), all.begin() + size);
}

void check_table_options(const BrdfTableOptions& options) {
  if (options.wo_resolution < 2 || options.wo_resolution > 256)
    throw std::invalid_argument("wo resolution must be 2..256");
  if (!is_valid_resolution(options.wi_resolution))
    throw std::invalid_argument("wi resolution must be a power of two from 2 to 512");
  check_projection_options(options.projection);
}

BrdfTable tabulate_brdf(const Brdf& brdf, const BrdfTableOptions& options,
                        const TaskControl& control) {
  check_table_options(options);
  const int m = options.wo_resolution;
  const std::size_t count = std::size_t(m) * m;
  std::vector<PackedTree> entries(count), tilts(options.tilt_derivatives ? count : 0);
  std::vector<char> needed(count, options.only_for.empty());
  const int entry_groups = options.wo_derivatives ? 3 : 1;
  const ProjectionOptions projection = entry_projection(options);
  for (const Vec3& wo : options.only_for)
    for (const TableTap& tap : table_taps(m, wo))
      needed[std::size_t(tap.j) * m + tap.i] = 1;

  // Entries related by a symmetry of the BRDF hold the same grid moved: each orbit's first
  // entry (its representative) is tabulated, and every needed entry of the orbit is made from
  // it. The grid's parabolic points are symmetric about the normal, as the square is.
  const std::vector<SquareSymmetry> symmetries =
      options.use_symmetries ? brdf_symmetries(brdf) : std::vector<SquareSymmetry>{{}};
  std::vector<std::size_t> representative(count);
  std::vector<SquareSymmetry> from_representative(count);
  for (std::size_t k = 0; k < count; ++k) {
    representative[k] = k;
    for (const SquareSymmetry& g : symmetries) {
      const auto [i, j] = g.inverse().apply(int(k % m), int(k / m), m);
      const std::size_t r = std::size_t(j) * m + i;
      if (r < representative[k]) {
        representative[k] = r;
        from_representative[k] = g;
      }
    }
  }
  std::vector<std::vector<std::size_t>> orbits(count);
  for (std::size_t k = 0; k < count; ++k)
    orbits[representative[k]].push_back(k);
  std::vector<std::size_t> work;  // representatives of orbits with a needed entry
  for (std::size_t r = 0; r < count; ++r)
    if (std::any_of(orbits[r].begin(), orbits[r].end(), [&](std::size_t k) { return needed[k]; }))
      work.push_back(r);

  std::atomic<std::size_t> done{0}, bytes{0};
  std::atomic<bool> stop{false}, too_large{false};
  control.report(0, count);
  const int channels = channel_count(brdf);
  // Zero trees of the full table's shape for the entries a partial table leaves out.
  for (std::size_t k = 0; k < count; ++k) {
    if (needed[k]) continue;
    entries[k] = pack(project(Grid(options.wi_resolution, channels, entry_groups), projection),
                      options.bounds, entry_groups);
    if (options.tilt_derivatives)
      tilts[k] =
          pack(project(Grid(std::min(options.tilt_resolution, options.wi_resolution), channels, 2),
                       {.tolerance = 0, .mode = ProjectionOptions::Mode::absolute}),
               options.bounds);
    control.report(++done, count);
  }
  tbb::parallel_for(std::size_t(0), work.size(), [&](std::size_t w) {
    if (stop.load(std::memory_order_relaxed) || too_large.load(std::memory_order_relaxed)) return;
    if (control.cancel && control.cancel->load()) {
      stop = true;
      return;
    }
    const std::size_t r = work[w];
    const Vec3 wo = table_outgoing(int(r % m), int(r / m), m);
    const Grid base = tabulate_table_entry(brdf, int(r % m), int(r / m), options);
    Grid tilt_base;
    ProjectionOptions tilt_projection = options.projection;
    if (options.tilt_derivatives) {
      tilt_base = tabulate_tilt(brdf, wo, options);
      // Absolute tolerance for both derivative groups: the scaled tolerance of f, taken from
      // the brightest channel's mean.
      double scale = 0;
      for (int c = 0; c < base.channels; ++c)
        scale = std::max(scale, std::abs(base.mean(0, c)));
      tilt_projection.mode = ProjectionOptions::Mode::absolute;
      tilt_projection.tolerance = options.tilt_tolerance_scale *
                                  (options.projection.mode == ProjectionOptions::Mode::relative
                                       ? options.projection.tolerance * scale
                                       : options.projection.tolerance);
      tilt_projection.max_depth = 0;
      tilt_projection.cut_on_all_groups = true;
      tilt_projection.group_tolerance_scale = 1;
    }
    if (!all_finite(base.texels) || !all_finite(tilt_base.texels)) {
      char where[96];
      std::snprintf(where, sizeof where, "(%.4g, %.4g, %.4g)", wo.x(), wo.y(), wo.z());
      throw std::overflow_error(std::string("the BRDF's values at wo = ") + where +
                                ", or their derivatives, are not finite or overflow float "
                                "(largest 3.4e38)");
    }
    QuadtreeProjector projector;
    const GridVector derivatives = options.wo_derivatives ? GridVector{1, false} : GridVector{};
    for (const std::size_t k : orbits[r]) {
      if (!needed[k]) continue;
      const SquareSymmetry& g = from_representative[k];
      // The derivatives over (s, t) turn with the grid of entries; the tilt derivatives are
      // about the tangent axes, an axial vector.
      entries[k] =
          pack(projector.project(g.is_identity() ? base : transform_grid(base, g, derivatives),
                                 projection),
               options.bounds, entry_groups);
      if (options.tilt_derivatives)
        tilts[k] = pack(
            projector.project(g.is_identity() ? tilt_base : transform_grid(tilt_base, g, {0, true}),
                              tilt_projection),
            options.bounds);
      bytes += (entries[k].words.size() + (tilts.empty() ? 0 : tilts[k].words.size())) *
                   sizeof(std::uint32_t) +
               sizeof(TreeExtent) * (tilts.empty() ? 1 : 2);
      if (bytes > options.max_bytes) too_large = true;
      control.report(++done, count);
    }
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

Vec3 outgoing_direction(const Vec3& wo) {
  const Vec3 unit = unit_direction(wo);
  if (unit == Vec3::Zero() || !(unit.z() >= 0))
    throw std::invalid_argument("outgoing direction below the horizon, zero or not finite");
  return unit;
}

std::array<TableTap, 4> table_taps(int m, const Vec3& wo, WoInterpolation interpolation) {
  const Vec2 st = hemisphere_to_parabolic(outgoing_direction(wo));
  auto axis = [m](double s, int& index, double& frac) {
    const double g = std::clamp((s + 1) / 2 * (m - 1), 0.0, double(m - 1));
    index = std::min(int(g), m - 2);
    frac = g - index;
  };
  int i0, j0;
  double fx, fy;
  axis(st.x(), i0, fx);
  axis(st.y(), j0, fy);
  std::array<TableTap, 4> taps;
  if (interpolation == WoInterpolation::bilinear) {
    const double wx[2] = {1 - fx, fx}, wy[2] = {1 - fy, fy};
    for (int b = 0; b < 2; ++b)
      for (int a = 0; a < 2; ++a)
        taps[2 * b + a] = {i0 + a, j0 + b, {wx[a] * wy[b], 0, 0}};
    return taps;
  }
  // Cubic Hermite bases on [0, 1]: value at corner 0 and 1 (h), derivative per step (g).
  auto bases = [](double x, double h[2], double g[2]) {
    h[0] = (2 * x - 3) * x * x + 1;
    h[1] = (3 - 2 * x) * x * x;
    g[0] = ((x - 2) * x + 1) * x;
    g[1] = (x - 1) * x * x;
  };
  double hx[2], gx[2], hy[2], gy[2];
  bases(fx, hx, gx);
  bases(fy, hy, gy);
  // Bicubic Hermite: sum over the corners of value h_a h_b, s-derivative g_a h_b, t-derivative
  // h_a g_b and cross derivative g_a g_b, the cross derivative at every corner estimated as
  // ((S(a, 1) - S(a, 0)) + (T(1, b) - T(0, b))) / 2 from the corners' derivatives S and T:
  // its terms fold into the weights of S and T.
  for (int b = 0; b < 2; ++b)
    for (int a = 0; a < 2; ++a) {
      const double along_t = 0.5 * (2 * b - 1) * gx[a] * (gy[0] + gy[1]);
      const double along_s = 0.5 * (2 * a - 1) * gy[b] * (gx[0] + gx[1]);
      taps[2 * b + a] = {
          i0 + a, j0 + b, {hx[a] * hy[b], gx[a] * hy[b] + along_t, hx[a] * gy[b] + along_s}};
    }
  return taps;
}

}  // namespace basis
