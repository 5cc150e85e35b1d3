// BRDF tables: an M x M parabolic grid over the outgoing direction, each
// entry a quadtree over the incoming direction in the cosine-weighted concentric map.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "basis/brdf/brdf.h"
#include "basis/core/projection.h"
#include "basis/core/square_symmetry.h"
#include "basis/core/supersample.h"
#include "basis/core/task.h"
#include "basis/core/tree_set.h"

namespace basis {

// Entry (i, j) sits at parabolic coordinates s_i = -1 + 2 i / (M - 1), t_j = -1 + 2 j / (M - 1)
// and is tree j * M + i of `trees`, which hold f(wi, wo) in group 0 and, when the table has wo
// derivatives, h df/ds and h df/dt in groups 1 and 2 (h = 2 / (M - 1), the grid step: the
// derivatives over the outgoing direction's parabolic coordinates, per step, that Hermite
// interpolation between entries reads). When present, tree j * M + i of `tilt` holds the entry's
// two tilt derivatives (tilt_derivative.h) as channel groups 0 and 1, cut on its own so that
// lookups without compensation do not pay for it.
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
  bool has_wo_derivatives() const {
    return trees.shape().groups == 3 && trees.shape().bounded_groups == 3;
  }
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
// The same for any parabolic coordinates (s, t): the direction the table's grid stands for there.
Vec3 table_outgoing(const Vec2& st);

struct BrdfTableOptions {
  int wo_resolution = 33;   // M, entries per side of the parabolic grid (2..256); tools take
                            // default_wo_resolution(brdf)
  int wi_resolution = 128;  // N, texels per side of each entry (power of two, 2..512)
  // Entries are cut relative to their own values (down to a fifth of the mean): a lobe's dim
  // tails stay as accurate, relative to themselves, as its core, which is what a light bright
  // in the tails sees (measured: README, lookups between table entries).
  ProjectionOptions projection{.tolerance = 0.05, .local_floor = 0.2};
  // What the packed entries' bounds bound (packed_tree.h): the RMS deviation (l2, tighter, the
  // default) or the largest deviation (linf, every texel).
  BoundKind bounds = BoundKind::l2;
  // Also tabulate each entry's derivatives over wo (groups 1 and 2), for Hermite interpolation
  // between entries: lookups between entries then follow a lobe as it moves with wo instead of
  // blending the four neighbours' lobes. They are central differences of step
  // wo_derivative_step in (s, t), texel-averaged like f.
  bool wo_derivatives = true;
  double wo_derivative_step = 1e-4;
  // The derivative groups are refined where their bound exceeds this multiple of f's tolerance
  // (a Hermite lookup weighs them by at most 0.15).
  double wo_derivative_tolerance_scale = 4;
  bool tilt_derivatives = true;  // also tabulate the tilt derivatives (rotation compensation)
  // Tabulate one entry per orbit of the BRDF's symmetries (brdf_symmetries) and move its grid
  // to the other entries of the orbit: up to 8 times fewer entries to integrate.
  bool use_symmetries = true;
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
  // Graded at the horizon: measured BRDFs (RGL) keep f cos finite there, so f grows as 1/cos.
  SupersampleOptions supersampling{.relative_tolerance = 2e-3,
                                   .absolute_floor = 1e-6,
                                   .floor_fraction_of_mean = 1,
                                   .max_depth = 6,
                                   .max_group_depth = 6,
                                   .forced_depth = 3,
                                   .graded_boundary = true};
};

// The angular width of the BRDF's lobe at normal incidence, in radians: the half width at half
// maximum of f(wi, normal) above its floor, over theta_i from 0 to 85 degrees (luminance), over
// 1.1774 (the ratio of a Gaussian's half width to its standard deviation). A lookup's result
// varies with wo over about this angle. Infinity for a BRDF without a lobe (Lambert).
double lobe_width(const Brdf& brdf);

// The outgoing-direction resolution M a table of this BRDF needs for Hermite lookups between
// entries to hold 1 % under high-contrast light (README): grid steps at the normal of at most
// 0.73 lobe widths (the parabolic step 2 / (M - 1) is 4 / (M - 1) radians there), M - 1 a
// multiple of 8, from 33 (the lobes of Phong 30 and wider) to 129 (Phong 500 and sharper).
int default_wo_resolution(const Brdf& brdf);

// What a table of these options may get wrong for this BRDF, one sentence each (empty when
// nothing): an outgoing grid coarser than default_wo_resolution asks for, without its floor of
// 33 (lookups between entries may err by more than the 1 % it holds: 8 % for Phong 1 at
// M = 4); a lobe narrower than twice the finest quadrature step at the normal,
// 2 / (wi_resolution 2^max_depth) radians, which texel averages can miss (Phong 10^4 at
// wi_resolution 2 gives 0 where the answer is 1).
std::vector<std::string> table_resolution_warnings(const Brdf& brdf,
                                                   const BrdfTableOptions& options);

// Texel averages over wi of f(wi, wo) per channel, at wi_resolution: a slice of the BRDF.
Grid tabulate_entry(const Brdf& brdf, const Vec3& wo, const BrdfTableOptions& options);

// Texel averages of table entry (i, j) of an options.wo_resolution^2 table: f at the entry's
// outgoing direction in group 0 and, with options.wo_derivatives, its derivatives over (s, t)
// per grid step in groups 1 and 2.
Grid tabulate_table_entry(const Brdf& brdf, int i, int j, const BrdfTableOptions& options);

// How the projection of a table entry is cut: options.projection, also on the derivative
// groups when there are some.
ProjectionOptions entry_projection(const BrdfTableOptions& options);

// Texel averages of the entry's tilt derivatives (tilt_derivative.h) about the tangent (group 0)
// and the bitangent (group 1), at tilt_resolution.
Grid tabulate_tilt(const Brdf& brdf, const Vec3& wo, const BrdfTableOptions& options);

// The symmetries of the square (square_symmetry.h) that the BRDF has to rounding,
// f(g wi, g wo) = f(wi, wo) at 256 random pairs of directions, as a whole group: all eight for
// isotropic BRDFs with bilateral symmetry (every analytic model), the four rotations for
// isotropic ones without it, the half turn, or the identity alone.
std::vector<SquareSymmetry> brdf_symmetries(const Brdf& brdf);

// Throws std::invalid_argument for options tabulate_brdf refuses: resolutions out of range (wo
// 2..256, wi a power of two 2..512) and projection tolerances that are not finite numbers >= 0.
void check_table_options(const BrdfTableOptions& options);

// Tabulates every entry in parallel (deterministic whatever the thread count) and projects it.
// Reports progress per entry; throws Cancelled when the control asks, std::overflow_error
// naming wo when the BRDF's values (or their derivatives) there are not finite floats, and
// std::invalid_argument for resolutions out of range (wo 2..256, wi a power of two 2..512).
BrdfTable tabulate_brdf(const Brdf& brdf, const BrdfTableOptions& options,
                        const TaskControl& control = {});

// How a lookup between entries combines the four around wo:
//   bilinear: their results, bilinearly (section 2.4 of the paper);
//   hermite: bicubic Hermite interpolation from their values and their derivatives over (s, t)
//            (groups 1 and 2), with the cross derivative estimated from the derivatives'
//            differences along the cell's edges. Exact for cubics along s and t.
enum class WoInterpolation { bilinear, hermite };

// One of the four entries a lookup at wo combines: the weights of its value (group 0) and of
// its derivatives over s and t (groups 1 and 2, zero for bilinear lookups).
struct TableTap {
  int i, j;
  std::array<double, 3> weights;
  bool reads_derivatives() const { return weights[1] != 0 || weights[2] != 0; }
  bool reads_anything() const { return weights[0] != 0 || reads_derivatives(); }
  // The groups a lookup combines: up to the last one with a non-zero weight (1 to 3).
  int groups_read() const { return weights[2] != 0 ? 3 : weights[1] != 0 ? 2 : 1; }
};
// The unit direction of an outgoing wo of any length; std::invalid_argument when wo is below the
// horizon (z < 0), zero or not finite.
Vec3 outgoing_direction(const Vec3& wo);
// The four entries around the direction of wo (any length, wo.z >= 0) in a parabolic grid of
// M x M entries, with their weights. Throws std::invalid_argument for wo below the horizon,
// zero or not finite.
std::array<TableTap, 4> table_taps(int wo_resolution, const Vec3& wo,
                                   WoInterpolation interpolation = WoInterpolation::bilinear);

}  // namespace basis
