#include "basis/brdf/table_lookup.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "basis/core/gradual_underflow.h"

namespace basis {

std::array<TableTap, 4> lookup_taps(const BrdfTableView& table, const Vec3& wo,
                                    WoInterpolation interpolation) {
  return table_taps(table.wo_resolution, wo,
                    table.has_wo_derivatives() ? interpolation : WoInterpolation::bilinear);
}

namespace {

// One entry's part of a lookup: its groups weighted in one descent (only group 0 when the
// derivatives' weights are zero).
Convolution convolve_tap(const BrdfTableView& table, const TableTap& tap,
                         const PackedTreeView& radiance, const ConvolutionOptions& options) {
  const PackedTreeView entry = table.entry(tap.i, tap.j);
  if (!tap.reads_derivatives() && tap.weights[0] == 1) return convolve(entry, radiance, options);
  const std::array<float, 3> weights = {float(tap.weights[0]), float(tap.weights[1]),
                                        float(tap.weights[2])};
  return convolve_weighted(entry, std::span(weights.data(), std::size_t(tap.groups_read())),
                           radiance, options);
}

// Sums entry(tap) over the taps that read anything, pi included.
// In double, then to floats whose bound still holds (certified_float).
template <typename Entry>
Convolution interpolate(const std::array<TableTap, 4>& taps, Entry entry) {
  std::array<double, 3> value{}, bound{};
  for (const TableTap& tap : taps) {
    if (!tap.reads_anything()) continue;
    const Convolution c = entry(tap);
    for (int ch = 0; ch < 3; ++ch) {
      value[ch] += std::numbers::pi * c.value[ch];
      bound[ch] += std::numbers::pi * c.bound[ch];
    }
  }
  return certified_convolution(value, bound);
}

}  // namespace

Convolution reflect(const BrdfTableView& table, const PackedTreeView& radiance, const Vec3& wo,
                    const LookupOptions& options) {
  const GradualUnderflow gradual_underflow;  // the bound assumes it (gradual_underflow.h)
  const std::array<TableTap, 4> taps = lookup_taps(table, wo, options.interpolation);
  return interpolate(taps, [&](const TableTap& tap) {
    return convolve_tap(table, tap, radiance, options.convolution);
  });
}

namespace {

// Adds to every texel of the square (x0, y0) .. + size the terms of the leaves of node n's
// quadrants below it (quadrants of level `level`), group by group, as a light's walk adds them.
void add_leaf_terms(const PackedTreeView& entry, const TableTap& tap, int n, int x0, int y0,
                    int size, int level, TexelsAtWo& out) {
  const int half = size / 2;
  const int groups = tap.reads_derivatives() ? 3 : 1;
  const int channels = entry.shape().channels;
  for (int q = 0; q < 4; ++q) {
    const int x = x0 + (q & 1) * half, y = y0 + (q >> 1) * half;
    if (const int child = entry.child(n, q)) {
      add_leaf_terms(entry, tap, child, x, y, half, level + 1, out);
      continue;
    }
    std::array<std::array<double, 6>, 3> terms;
    for (int g = 0; g < groups; ++g)
      for (int c = 0; c < 3; ++c) {
        const int channel = std::min(c, channels - 1);
        terms[g][c] = tap.weights[g] * entry.value(n, g, channel, q);
        terms[g][3 + c] =
            std::abs(tap.weights[g]) * entry.largest_deviation_bound(n, g, channel, q, level);
      }
    for (int ty = y; ty < y + half; ++ty)
      for (int tx = x; tx < x + half; ++tx) {
        std::array<double, 6>& texel =
            out.texels[std::size_t(ty) * std::size_t(out.resolution) + std::size_t(tx)];
        for (int g = 0; g < groups; ++g)
          for (int i = 0; i < 6; ++i)
            texel[i] += terms[g][i];
      }
  }
}

}  // namespace

TexelsAtWo texels_at(const BrdfTableView& table, const std::array<TableTap, 4>& taps) {
  TexelsAtWo out;
  out.resolution = table.trees.shape().resolution;
  out.texels.assign(std::size_t(out.resolution) * std::size_t(out.resolution), {});
  for (const TableTap& tap : taps)
    if (tap.reads_anything())
      add_leaf_terms(table.entry(tap.i, tap.j), tap, 0, 0, 0, out.resolution, 1, out);
  return out;
}

EntriesAtWo entries_at(const BrdfTableView& table, const Vec3& wo, WoInterpolation interpolation,
                       bool with_texels) {
  EntriesAtWo entries{lookup_taps(table, wo, interpolation), std::nullopt, std::nullopt};
  std::vector<WeightedTerm> terms;
  bool derivatives = false;
  for (const TableTap& tap : entries.taps) {
    if (!tap.reads_anything()) continue;
    terms.push_back({table.entry(tap.i, tap.j),
                     {float(tap.weights[0]), float(tap.weights[1]), float(tap.weights[2])},
                     tap.groups_read()});
    derivatives = derivatives || tap.reads_derivatives();
  }
  const bool foldable = folding_available() && table.trees.shape().bounds == BoundKind::l2;
  if (foldable && (terms.size() > 1 || derivatives)) entries.folded = fold(terms);
  if (with_texels) entries.texels = texels_at(table, entries.taps);
  return entries;
}

Convolution reflect(const BrdfTableView& table, const EntriesAtWo& entries,
                    const PackedTreeView& radiance, const ConvolutionOptions& options) {
  const GradualUnderflow gradual_underflow;  // the bound assumes it (gradual_underflow.h)
  if (!entries.folded)
    return interpolate(entries.taps, [&](const TableTap& tap) {
      return convolve_tap(table, tap, radiance, options);
    });
  const Convolution c = convolve(*entries.folded, radiance, options);
  Convolution result;
  for (int ch = 0; ch < 3; ++ch) {
    const CertifiedFloat f =
        certified_float(std::numbers::pi * c.value[ch], std::numbers::pi * c.bound[ch]);
    result.value[ch] = f.value;
    result.bound[ch] = f.bound;
  }
  return result;
}

Convolution reflect_tilted(const BrdfTableView& table, const PackedTreeView& radiance,
                           const Vec3& wo_shading, const Tilt& tilt, TiltCompensation mode,
                           const LookupOptions& options) {
  const GradualUnderflow gradual_underflow;  // the bound assumes it (gradual_underflow.h)
  outgoing_direction(wo_shading);            // refuses wo below the horizon, zero or not finite
  if (!std::isfinite(tilt.x) || !std::isfinite(tilt.y))
    throw std::invalid_argument("tilt is not finite");
  if (tilt.angle() > kLargestTilt * (1 + 1e-9))
    throw std::invalid_argument("tilt of " + std::to_string(tilt.angle() * 180 / std::numbers::pi) +
                                " degrees: a surface tilted past 90 degrees faces away from the "
                                "hemisphere the radiance was recorded over");
  if (mode == TiltCompensation::none) return reflect(table, radiance, wo_shading, options);
  // Re-parametrised: the entry whose lobe sits where the tilted surface's lobe sits.
  Vec3 wo = tilt_rotation(tilt).transpose() * wo_shading;
  wo.z() = std::max(0.0, wo.z());
  Convolution result = reflect(table, radiance, wo, options);
  if (mode == TiltCompensation::reparametrised || tilt.angle() < kUncompensatedTilt) return result;
  if (!table.has_tilt())
    throw std::invalid_argument("the BRDF table holds no tilt derivatives to compensate with");
  // The first-order correction, from the tilt trees of the entries around wo, bilinearly,
  // summed in double and rounded once: a sum beyond floats is an error, not infinity.
  std::array<double, 3> corrected{result.value[0], result.value[1], result.value[2]};
  for (const TableTap& tap : table_taps(table.wo_resolution, wo)) {
    if (tap.weights[0] == 0) continue;
    const GroupConvolution d = convolve_groups(table.tilt_entry(tap.i, tap.j), radiance);
    for (int ch = 0; ch < 3; ++ch)
      corrected[ch] += std::numbers::pi * tap.weights[0] *
                       (tilt.x * double(d.value[0][ch]) + tilt.y * double(d.value[1][ch]));
  }
  for (int ch = 0; ch < 3; ++ch)
    result.value[ch] = certified_float(corrected[ch], result.bound[ch]).value;
  return result;
}

}  // namespace basis
