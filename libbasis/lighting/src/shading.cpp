#include "basis/lighting/shading.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <vector>

#include "basis/core/dense.h"
#include "basis/core/gradual_underflow.h"
#include "basis/core/hemisphere.h"

namespace basis {

Tilt capture_tilt(const CaptureSetView& captures, std::size_t k, const Vec3& normal) {
  const Vec3 local = captures.frame(k).to_local(normal.normalized());
  if (local.z() <= -1 + 1e-12)
    throw std::invalid_argument("the shading normal is opposite the capture's normal");
  return tilt_to(local);
}

double largest_tilt_degrees(const CaptureSetView& captures, const Vec3& normal) {
  const Vec3 unit = normal.normalized();
  double smallest_cosine = 1;
  for (const Vec3& n : captures.normals)
    smallest_cosine = std::min(smallest_cosine, n.normalized().dot(unit));
  return std::acos(std::clamp(smallest_cosine, -1.0, 1.0)) * 180 / std::numbers::pi;
}

Vec3 light_outgoing(const Vec3& wo) {
  return wo.z() > 0 ? wo : Vec3(wo.x(), wo.y(), 1e-9).normalized();
}

namespace {

// Adds f(wi, wo) E wi.z for each light, turned from the record's frame into the shading frame
// when both are given; lights below the shading horizon drop out. f is light_brdf at wi when
// given, else what table_f(wi, f, error) adds up (with its error bound). light_brdf is taken at
// light_outgoing(wo): at the horizon itself, where f is 0, it lost the lights that a wo a hair
// above it kept.
template <typename TableF>
void add_lights(std::span<const DirectionalLight> lights, const std::optional<Frame>& record,
                const std::optional<Frame>& shading, const Vec3& wo, const Brdf* light_brdf,
                Convolution& result, const TableF& table_f) {
  if (lights.empty()) return;
  // Summed in double and rounded once, so that a sum beyond the floats is an error
  // (certified_float) rather than an infinite value, and the bound covers the rounding.
  std::array<double, 3> value{}, bound{};
  for (int c = 0; c < 3; ++c) {
    value[c] = result.value[c];
    bound[c] = result.bound[c];
  }
  const Vec3 wo_f = light_outgoing(wo);
  for (const DirectionalLight& light : lights) {
    Vec3 wi = light.direction;
    if (shading) wi = shading->to_local(record->to_world(wi));
    if (!(wi.z() > 0)) continue;
    Color f{0, 0, 0}, error{0, 0, 0};
    if (light_brdf)
      f = evaluate(*light_brdf, wi, wo_f);
    else
      table_f(wi, f, error);
    for (int c = 0; c < 3; ++c) {
      value[c] += f[c] * light.energy[c] * wi.z();
      bound[c] += error[c] * light.energy[c] * wi.z();
    }
  }
  result = certified_convolution(value, bound);
}

// Adds capture k's directional lights to a lookup's result (see shade) towards the unit wo: f
// from light_brdf, else from the table's entries `taps` around wo, read texel by texel from
// `texels` when given (the same sums, see TexelsAtWo) or walked from their roots.
void add_capture_lights(const BrdfTableView& table, const std::array<TableTap, 4>& taps,
                        const TexelsAtWo* texels, const CaptureSetView& captures, std::size_t k,
                        const std::optional<Frame>& record, const std::optional<Frame>& shading,
                        const Vec3& wo, const Brdf* light_brdf, Convolution& result) {
  const int table_channels = table.trees.shape().channels;
  add_lights(captures.lights_of(k), record, shading, wo, light_brdf, result,
             [&](const Vec3& wi, Color& f, Color& error) {
               if (texels) {
                 const auto [x, y] = cosine_hemisphere_texel(wi, texels->resolution);
                 const std::array<double, 6>& texel = texels->at(x, y);
                 for (int c = 0; c < 3; ++c) {
                   f[c] += texel[c];
                   error[c] += texel[3 + c];
                 }
                 return;
               }
               const Vec2 uv = cosine_hemisphere_to_square(wi);
               for (const TableTap& tap : taps) {
                 if (!tap.reads_anything()) continue;
                 const PackedTreeView entry = table.entry(tap.i, tap.j);
                 const LeafQuadrant leaf = find_leaf(entry, uv.x(), uv.y());
                 for (int g = 0; g < (tap.reads_derivatives() ? 3 : 1); ++g)
                   for (int c = 0; c < 3; ++c) {
                     const int channel = std::min(c, table_channels - 1);
                     f[c] += tap.weights[g] * entry.value(leaf.node, g, channel, leaf.quadrant);
                     error[c] += std::abs(tap.weights[g]) *
                                 entry.largest_deviation_bound(leaf.node, g, channel, leaf.quadrant,
                                                               leaf.level);
                   }
               }
             });
}

}  // namespace

Rgb reflect_lights(std::span<const DirectionalLight> lights, const Frame& record,
                   const Frame& shading, const Vec3& wo, const Brdf& brdf) {
  Convolution result;
  add_lights(lights, record, shading, wo, &brdf, result, [](const Vec3&, Color&, Color&) {});
  return result.value;
}

Convolution shade(const BrdfTableView& table, const CaptureSetView& captures, std::size_t k,
                  const ShadingOptions& options) {
  const GradualUnderflow gradual_underflow;  // the bound assumes it (gradual_underflow.h)
  const Vec3 wo = outgoing_direction(options.wo);
  if (!options.normal)
    return shade(
        table,
        EntriesAtWo{lookup_taps(table, wo, options.interpolation), std::nullopt, std::nullopt},
        captures, k, options);
  const Tilt tilt = capture_tilt(captures, k, *options.normal);
  Convolution result = reflect_tilted(table, captures.trees.tree(k), wo, tilt, options.tilt_mode,
                                      {options.convolution, options.interpolation});
  if (captures.lights_of(k).empty()) return result;
  std::optional<Frame> record, shading;
  if (options.tilt_mode != TiltCompensation::none) {
    record = captures.frame(k);
    shading = tilted_frame(*record, tilt);
  }
  // The entries around wo, read only when the lights take f from the table.
  const auto taps = options.light_brdf ? std::array<TableTap, 4>{}
                                       : lookup_taps(table, wo, options.interpolation);
  add_capture_lights(table, taps, nullptr, captures, k, record, shading, wo, options.light_brdf,
                     result);
  return result;
}

Convolution shade(const BrdfTableView& table, const EntriesAtWo& entries,
                  const CaptureSetView& captures, std::size_t k, const ShadingOptions& options) {
  const GradualUnderflow gradual_underflow;  // the bound assumes it (gradual_underflow.h)
  if (options.normal)
    throw std::invalid_argument("shading with the entries already found takes untilted lookups");
  const Vec3 wo = outgoing_direction(options.wo);
  Convolution result = reflect(table, entries, captures.trees.tree(k), options.convolution);
  if (captures.lights_of(k).empty()) return result;
  add_capture_lights(table, entries.taps, entries.texels ? &*entries.texels : nullptr, captures, k,
                     std::nullopt, std::nullopt, wo, options.light_brdf, result);
  return result;
}

DenseLookup dense_lookup(const BrdfTableView& table, const Vec3& wo,
                         WoInterpolation interpolation) {
  DenseLookup lookup;
  lookup.wo = outgoing_direction(wo);
  bool first = true;
  for (const TableTap& tap : lookup_taps(table, lookup.wo, interpolation)) {
    if (!tap.reads_anything()) continue;
    Grid entry = combine_groups(reconstruct(table.entry(tap.i, tap.j)), tap.weights);
    if (first)
      lookup.grid = std::move(entry);
    else
      for (std::size_t t = 0; t < entry.texels.size(); ++t)
        lookup.grid.texels[t] += entry.texels[t];
    first = false;
  }
  return lookup;
}

Convolution shade_dense(const DenseLookup& table, const Grid& radiance,
                        std::span<const DirectionalLight> lights, const Brdf* light_brdf) {
  Convolution result;
  const Rgb d = dense_convolve_simd(table.grid, radiance);
  for (int c = 0; c < 3; ++c)
    result.value[c] = float(std::numbers::pi * d[c]);
  add_lights(lights, std::nullopt, std::nullopt, table.wo, light_brdf, result,
             [&](const Vec3& wi, Color& f, Color&) {
               const auto [x, y] = cosine_hemisphere_texel(wi, table.grid.resolution);
               for (int c = 0; c < 3; ++c)
                 f[c] += table.grid.at(0, std::min(c, table.grid.channels - 1), x, y);
             });
  return result;
}

Convolution capture_product(const CaptureSetView& a, const CaptureSetView& b, std::size_t k,
                            const ConvolutionOptions& options) {
  const GradualUnderflow gradual_underflow;  // the bound assumes it (gradual_underflow.h)
  // A set of one capture stands for every point.
  const std::size_t ka = a.trees.size() == 1 ? 0 : k, kb = b.trees.size() == 1 ? 0 : k;
  const PackedTreeView ta = a.trees.tree(ka), tb = b.trees.tree(kb);
  const Convolution product = convolve(ta, tb, options);
  // Summed in double and rounded once at the end (certified_float): a product beyond the floats
  // is an error, not an infinite value.
  std::array<double, 3> value{}, bound{};
  for (int c = 0; c < 3; ++c) {
    value[c] = double(product.value[c]) * std::numbers::pi;
    bound[c] = double(product.bound[c]) * std::numbers::pi;
  }
  const auto la = a.lights_of(ka), lb = b.lights_of(kb);
  if (la.empty() && lb.empty()) return certified_convolution(value, bound);
  // A light stands for energy * cos / (pi * texel area) over the texel it falls in at its own
  // capture's resolution (as splat_lights splats it); the captures' resolutions may differ.
  struct Splat {
    int x, y, resolution;
    Color weight;  // energy * cos
  };
  auto splats = [&](std::span<const DirectionalLight> lights, int n) {
    std::vector<Splat> out;
    for (const DirectionalLight& l : lights) {
      const auto [x, y] = cosine_hemisphere_texel(l.direction, n);
      out.push_back({x,
                     y,
                     n,
                     {l.energy[0] * l.direction.z(), l.energy[1] * l.direction.z(),
                      l.energy[2] * l.direction.z()}});
    }
    return out;
  };
  const std::vector<Splat> sa = splats(la, ta.shape().resolution),
                           sb = splats(lb, tb.shape().resolution);
  auto against_tree = [&](const std::vector<Splat>& lights, const PackedTreeView& tree) {
    for (const Splat& s : lights) {
      // The other tree's quadrant over the light's texel, or its leaf holding that texel: its
      // mean over the texel is the quadrant's value, within the quadrant's largest deviation.
      const LeafQuadrant leaf =
          find_leaf(tree, (s.x + 0.5) / s.resolution, (s.y + 0.5) / s.resolution,
                    std::countr_zero(unsigned(s.resolution)));
      for (int c = 0; c < 3; ++c) {
        const int channel = std::min(c, tree.shape().channels - 1);
        value[c] += s.weight[c] * tree.value(leaf.node, 0, channel, leaf.quadrant);
        bound[c] += s.weight[c] *
                    tree.largest_deviation_bound(leaf.node, channel, leaf.quadrant, leaf.level);
      }
    }
  };
  against_tree(sa, tb);
  against_tree(sb, ta);
  // Two lights meet where the finer one's texel lies in the coarser one's: their product over
  // it is weight * weight / (pi * the coarser texel's area).
  for (const Splat& p : sa)
    for (const Splat& q : sb) {
      const int coarse = std::min(p.resolution, q.resolution);
      const int px = p.x / (p.resolution / coarse), py = p.y / (p.resolution / coarse);
      const int qx = q.x / (q.resolution / coarse), qy = q.y / (q.resolution / coarse);
      if (px == qx && py == qy)
        for (int c = 0; c < 3; ++c)
          value[c] += p.weight[c] * q.weight[c] * double(coarse) * coarse / std::numbers::pi;
    }
  return certified_convolution(value, bound);
}

}  // namespace basis
