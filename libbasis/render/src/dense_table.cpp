#include "basis/render/dense_table.h"

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <numbers>

namespace basis {

DenseTable::DenseTable(const BrdfTableView& table, int resolution)
    : table_(table),
      resolution_(resolution),
      entries_(std::make_unique<Slot[]>(table.trees.size())),
      tilt_entries_(std::make_unique<Slot[]>(table.tilt.size())) {}

int DenseTable::tilt_resolution() const {
  return table_.has_tilt() ? table_.tilt.shape().resolution : 0;
}

const Grid& DenseTable::entry(int i, int j) const {
  Slot& slot = entries_[std::size_t(j) * table_.wo_resolution + i];
  std::call_once(slot.once, [&] {
    Grid grid = reconstruct(table_.entry(i, j));
    slot.grid = grid.resolution > resolution_ ? downsample(grid, resolution_) : std::move(grid);
  });
  return slot.grid;
}

const Grid& DenseTable::tilt_entry(int i, int j) const {
  Slot& slot = tilt_entries_[std::size_t(j) * table_.wo_resolution + i];
  std::call_once(slot.once, [&] { slot.grid = reconstruct(table_.tilt_entry(i, j)); });
  return slot.grid;
}

namespace {

// The integral over [0,1]^2 of group g of a against group 0 of b, per channel (a vectorised
// dot product of the planes over the texel area).
Rgb group_product(const Grid& a, int g, const Grid& b) {
  Rgb out{};
  const double texel_area = 1.0 / double(a.plane_size());
  for (int c = 0; c < 3; ++c) {
    const auto pa = a.plane(g, std::min(c, a.channels - 1));
    const auto pb = b.plane(0, std::min(c, b.channels - 1));
    const Eigen::Map<const Eigen::VectorXf> va(pa.data(), Eigen::Index(pa.size()));
    const Eigen::Map<const Eigen::VectorXf> vb(pb.data(), Eigen::Index(pb.size()));
    out[c] = float(double(va.dot(vb)) * texel_area);
  }
  return out;
}

}  // namespace

Convolution reflect_tilted_dense(const DenseTable& table, const Grid& radiance,
                                 const Grid& radiance_at_tilt_resolution, const Vec3& wo_shading,
                                 const Tilt& tilt, TiltCompensation mode,
                                 WoInterpolation interpolation) {
  Vec3 wo = wo_shading;
  if (mode != TiltCompensation::none) {
    wo = tilt_rotation(tilt).transpose() * wo_shading;
    wo.z() = std::max(0.0, wo.z());
  }
  // Summed in double and rounded once, as the trees' lookups are: beyond floats is an error.
  std::array<double, 3> value{};
  for (const TableTap& tap : lookup_taps(table.table(), wo, interpolation)) {
    if (!tap.reads_anything()) continue;
    const Grid& entry = table.entry(tap.i, tap.j);
    for (int g = 0; g < 3 && g < entry.groups; ++g) {
      if (tap.weights[g] == 0) continue;
      const Rgb d = group_product(entry, g, radiance);
      for (int c = 0; c < 3; ++c)
        value[c] += std::numbers::pi * tap.weights[g] * d[c];
    }
  }
  if (mode == TiltCompensation::compensated && tilt.angle() >= kUncompensatedTilt)
    for (const TableTap& tap : table_taps(table.table().wo_resolution, wo)) {
      if (tap.weights[0] == 0) continue;
      const Grid& d = table.tilt_entry(tap.i, tap.j);
      const Rgb dx = group_product(d, 0, radiance_at_tilt_resolution);
      const Rgb dy = group_product(d, 1, radiance_at_tilt_resolution);
      for (int c = 0; c < 3; ++c)
        value[c] += std::numbers::pi * tap.weights[0] * (tilt.x * dx[c] + tilt.y * dy[c]);
    }
  Convolution result;  // the dense product certifies nothing: no bound
  for (int c = 0; c < 3; ++c)
    result.value[c] = certified_float(value[c], 0).value;
  return result;
}

}  // namespace basis
