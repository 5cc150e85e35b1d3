#include "basis/brdf/table_lookup.h"

#include <algorithm>
#include <numbers>
#include <stdexcept>
#include <vector>

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
template <typename Entry>
Convolution interpolate(const std::array<TableTap, 4>& taps, Entry entry) {
  Convolution result;
  for (const TableTap& tap : taps) {
    if (!tap.reads_anything()) continue;
    const Convolution c = entry(tap);
    for (int ch = 0; ch < 3; ++ch) {
      result.value[ch] += float(std::numbers::pi * c.value[ch]);
      result.bound[ch] += float(std::numbers::pi * c.bound[ch]);
    }
  }
  return result;
}

}  // namespace

Convolution reflect(const BrdfTableView& table, const PackedTreeView& radiance, const Vec3& wo,
                    const LookupOptions& options) {
  const std::array<TableTap, 4> taps = lookup_taps(table, wo, options.interpolation);
  return interpolate(taps, [&](const TableTap& tap) {
    return convolve_tap(table, tap, radiance, options.convolution);
  });
}

EntriesAtWo entries_at(const BrdfTableView& table, const Vec3& wo, WoInterpolation interpolation) {
  EntriesAtWo entries{lookup_taps(table, wo, interpolation), std::nullopt};
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
  return entries;
}

Convolution reflect(const BrdfTableView& table, const EntriesAtWo& entries,
                    const PackedTreeView& radiance, const ConvolutionOptions& options) {
  if (!entries.folded)
    return interpolate(entries.taps, [&](const TableTap& tap) {
      return convolve_tap(table, tap, radiance, options);
    });
  const Convolution c = convolve(*entries.folded, radiance, options);
  Convolution result;
  for (int ch = 0; ch < 3; ++ch) {
    result.value[ch] = float(std::numbers::pi * c.value[ch]);
    result.bound[ch] = float(std::numbers::pi * c.bound[ch]);
  }
  return result;
}

Convolution reflect_tilted(const BrdfTableView& table, const PackedTreeView& radiance,
                           const Vec3& wo_shading, const Tilt& tilt, TiltCompensation mode,
                           const LookupOptions& options) {
  if (mode == TiltCompensation::none) return reflect(table, radiance, wo_shading, options);
  // Re-parametrised: the entry whose lobe sits where the tilted surface's lobe sits.
  Vec3 wo = tilt_rotation(tilt).transpose() * wo_shading;
  wo.z() = std::max(0.0, wo.z());
  Convolution result = reflect(table, radiance, wo, options);
  if (mode == TiltCompensation::reparametrised || tilt.angle() < kUncompensatedTilt) return result;
  if (!table.has_tilt())
    throw std::invalid_argument("the BRDF table holds no tilt derivatives to compensate with");
  // The first-order correction, from the tilt trees of the entries around wo, bilinearly.
  for (const TableTap& tap : table_taps(table.wo_resolution, wo)) {
    if (tap.weights[0] == 0) continue;
    const GroupConvolution d = convolve_groups(table.tilt_entry(tap.i, tap.j), radiance);
    for (int ch = 0; ch < 3; ++ch)
      result.value[ch] += float(std::numbers::pi * tap.weights[0] *
                                (tilt.x * d.value[0][ch] + tilt.y * d.value[1][ch]));
  }
  return result;
}

}  // namespace basis
