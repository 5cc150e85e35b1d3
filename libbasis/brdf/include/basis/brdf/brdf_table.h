// BRDF tables: an M x M parabolic grid over the outgoing direction, each
// entry a quadtree over the incoming direction in the cosine-weighted concentric map.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "basis/brdf/brdf.h"
#include "basis/core/projection.h"
#include "basis/core/supersample.h"
#include "basis/core/task.h"
#include "basis/core/tree_set.h"

namespace basis {

// Entry (i, j) sits at parabolic coordinates s_i = -1 + 2 i / (M - 1), t_j = -1 + 2 j / (M - 1)
// and is tree j * M + i of `trees`, which hold f(wi, wo). When present, tree j * M + i of `tilt`
// holds the entry's two tilt derivatives (tilt_derivative.h) as channel groups 0 and 1, cut on its
// own so that lookups without compensation do not pay for it.
struct BrdfTableView {
  int wo_resolution = 0;
  TreeSetView trees;
  TreeSetView tilt;  // empty when the table has no tilt derivatives

  PackedTreeView entry(int i, int j) const {
    return trees.tree(std::size_t(j) * wo_resolution + i);
  }
  PackedTreeView tilt_entry(int i, int j) const {
    return tilt.tree(std::size_t(j) * wo_resolution + i);
  }
  bool has_tilt() const { return tilt.size() > 0; }
};

// An owning BRDF table with the description of what it tabulates.
struct BrdfTable {
  int wo_resolution = 0;
  TreeSet trees;
  TreeSet tilt;
  std::string model;  // model name (lambert, phong, ..., merl)
  std::string spec;   // the JSON spec it was tabulated from

  BrdfTableView view() const { return {wo_resolution, trees.view(), tilt.view()}; }
};

// The outgoing direction of entry (i, j): the parabolic grid point, pulled inside the disk to
// at most kTableMaxOutgoingDegrees from the normal (grid points beyond the rim stand for the
// horizon, where BRDFs are zero or singular).
inline constexpr double kTableMaxOutgoingDegrees = 89.0;
Vec3 table_outgoing(int i, int j, int wo_resolution);

struct BrdfTableOptions {
  int wo_resolution = 33;   // M, entries per side of the parabolic grid (2..256)
  int wi_resolution = 128;  // N, texels per side of each entry (power of two, 2..512)
  ProjectionOptions projection;
  // What the packed entries' bounds bound (packed_tree.h): the RMS deviation (l2, tighter, the
  // default) or the largest deviation (linf, every texel).
  BoundKind bounds = BoundKind::l2;
  bool tilt_derivatives = true;   // also tabulate the tilt derivatives (rotation compensation)
  double derivative_step = 1e-3;  // radians, central differences of tilt_derivative
  // The tilt trees are refined where their bound exceeds this multiple of the entry's own
  // tolerance: their contribution is scaled by the tilt (0.1 rad is 5.7 degrees).
  double tilt_tolerance_scale = 10;
  // Texels per side of the tilt trees (at most wi_resolution): the first-order correction
  // needs less resolution than f itself.
  int tilt_resolution = 32;
  int tilt_max_depth = 2;  // quadrature levels for the derivatives (they are costly to sample)
  // Tabulation stops with std::length_error once the trees pass this size (a .qt file holds
  // at most 2 GiB), before memory runs out.
  std::size_t max_bytes = std::size_t(2000) << 20;
  // When not empty, only the entries that untilted lookups at these outgoing directions read
  // (table_taps) are tabulated, and every other entry holds zero: a partial table, for tests
  // and previews that need a few directions of a large table.
  std::vector<Vec3> only_for;
  SupersampleOptions supersampling{.relative_tolerance = 2e-3,
                                   .absolute_floor = 1e-6,
                                   .floor_fraction_of_mean = 1,
                                   .max_depth = 6,
                                   .max_group_depth = 6,
                                   .forced_depth = 3};
};

// Texel averages over wi of one entry: f(wi, wo) per channel, at wi_resolution.
Grid tabulate_entry(const Brdf& brdf, const Vec3& wo, const BrdfTableOptions& options);

// Texel averages of the entry's tilt derivatives (rotation.h) about the tangent (group 0) and
// the bitangent (group 1), at tilt_resolution.
Grid tabulate_tilt(const Brdf& brdf, const Vec3& wo, const BrdfTableOptions& options);

// Tabulates every entry in parallel (deterministic whatever the thread count) and projects it.
// Reports progress per entry; throws Cancelled when the control asks.
BrdfTable tabulate_brdf(const Brdf& brdf, const BrdfTableOptions& options,
                        const TaskControl& control = {});

// One of the four entries a lookup at wo combines, with its bilinear weight.
struct TableTap {
  int i, j;
  double weight;
};
// The four entries around wo (unit, wo.z >= 0) in a parabolic grid of M x M entries.
// Throws std::invalid_argument for wo below the horizon.
std::array<TableTap, 4> table_taps(int wo_resolution, const Vec3& wo);

}  // namespace basis
