#include "basis/brdf/table_lookup.h"

#include <algorithm>
#include <numbers>
#include <stdexcept>

namespace basis {

namespace {

template <typename Entry>
Convolution interpolate(const BrdfTableView& table, const Vec3& wo, Entry entry) {
  // entry(i, j) gives the convolution of entry (i, j).
  Convolution result;
  for (const TableTap& tap : table_taps(table.wo_resolution, wo)) {
    if (tap.weight == 0) continue;
    const Convolution c = entry(tap.i, tap.j);
    for (int ch = 0; ch < 3; ++ch) {
      result.value[ch] += float(tap.weight * std::numbers::pi * c.value[ch]);
      result.bound[ch] += float(tap.weight * std::numbers::pi * c.bound[ch]);
    }
  }
  return result;
}

}  // namespace

Convolution reflect(const BrdfTableView& table, const PackedTreeView& radiance, const Vec3& wo,
                    const ConvolutionOptions& options) {
  return interpolate(table, wo,
                     [&](int i, int j) { return convolve(table.entry(i, j), radiance, options); });
}

Convolution reflect_tilted(const BrdfTableView& table, const PackedTreeView& radiance,
                           const Vec3& wo_shading, const Tilt& tilt, TiltCompensation mode,
                           const ConvolutionOptions& options) {
  if (mode == TiltCompensation::none) return reflect(table, radiance, wo_shading, options);
  // Re-parametrised: the entry whose lobe sits where the tilted surface's lobe sits.
  Vec3 wo = tilt_rotation(tilt).transpose() * wo_shading;
  wo.z() = std::max(0.0, wo.z());
  if (mode == TiltCompensation::reparametrised) return reflect(table, radiance, wo, options);
  if (!table.has_tilt())
    throw std::invalid_argument("the BRDF table holds no tilt derivatives to compensate with");
  return interpolate(table, wo, [&](int i, int j) {
    Convolution c = convolve(table.entry(i, j), radiance, options);
    const GroupConvolution d = convolve_groups(table.tilt_entry(i, j), radiance);
    for (int ch = 0; ch < 3; ++ch)
      c.value[ch] += float(tilt.x * d.value[0][ch] + tilt.y * d.value[1][ch]);
    return c;
  });
}

}  // namespace basis
