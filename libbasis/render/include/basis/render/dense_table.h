// A BRDF table's entries as dense grids, reconstructed on first use: the regular-texture
// baseline of the radiance cache (the paper's Figure 7), looked up with the same interpolation
// and rotation compensation as the quadtree table.
#pragma once

#include <memory>
#include <mutex>
#include <vector>

#include "basis/brdf/table_lookup.h"
#include "basis/core/grid.h"

namespace basis {

class DenseTable {
 public:
  // Entries at `resolution` texels a side (at most the table's), tilt entries at theirs.
  DenseTable(const BrdfTableView& table, int resolution);

  const BrdfTableView& table() const { return table_; }
  int resolution() const { return resolution_; }
  int tilt_resolution() const;
  // Entry (i, j), every group, at resolution(); thread-safe.
  const Grid& entry(int i, int j) const;
  // Tilt entry (i, j), both groups, at tilt_resolution(); thread-safe.
  const Grid& tilt_entry(int i, int j) const;

 private:
  struct Slot {
    std::once_flag once;
    Grid grid;
  };
  BrdfTableView table_;
  int resolution_;
  std::unique_ptr<Slot[]> entries_, tilt_entries_;
};

// What reflect_tilted returns (its value; the bound is 0), from dense products of the entries
// with `radiance` (at the table's resolution()) and of the tilt entries with
// `radiance_at_tilt_resolution` (the same radiance averaged down to tilt_resolution()).
Convolution reflect_tilted_dense(const DenseTable& table, const Grid& radiance,
                                 const Grid& radiance_at_tilt_resolution, const Vec3& wo_shading,
                                 const Tilt& tilt, TiltCompensation mode,
                                 WoInterpolation interpolation = WoInterpolation::hermite);

}  // namespace basis
