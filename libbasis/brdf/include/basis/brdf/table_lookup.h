// Lookups in BRDF tables: the reflected radiance of a radiance tree towards any outgoing
// direction, from the table entries around it, optionally for a surface tilted against the
// frame the radiance was recorded in (rotation compensation).
#pragma once

#include <array>
#include <optional>
#include <vector>

#include "basis/brdf/brdf_table.h"
#include "basis/core/convolution.h"
#include "basis/core/folded_tree.h"
#include "basis/core/tilt.h"

namespace basis {

struct LookupOptions {
  // Options of every convolution (an accuracy target, or the values alone).
  ConvolutionOptions convolution;
  // Between entries: Hermite when the table holds derivatives over wo (bilinear otherwise), or
  // bilinear whatever the table holds.
  WoInterpolation interpolation = WoInterpolation::hermite;
};

// The entries a lookup at wo reads in this table and their weights: Hermite's when asked for
// and the table holds derivatives over wo, else bilinear ones.
std::array<TableTap, 4> lookup_taps(const BrdfTableView& table, const Vec3& wo,
                                    WoInterpolation interpolation);

// Reflected radiance Lo(wo) = integral of f(wi, wo) L(wi) cos(theta_i) dwi (pi included) for
// wo (a direction, any length) with wo.z >= 0 in the table's frame: the entries around wo in the
// parabolic grid convolved with the radiance tree, each in one descent with its groups weighted as
// the interpolation says (lookup_taps). The bound sums the entries' weighted bounds: it covers the
// trees against their texels, not the BRDF's variation between entries.
// Throws std::invalid_argument for wo below the horizon, zero or not finite.
Convolution reflect(const BrdfTableView& table, const PackedTreeView& radiance, const Vec3& wo,
                    const LookupOptions& options = {});

// The entries a batch of lookups at one wo reads (lookup_taps), found once, and folded with
// their weights into one tree (folded_tree.h): each lookup then descends once, over the union
// of the entries' nodes, instead of once per entry. Folded when more than one entry is read,
// or one with its derivatives, from a table with RMS (l2) bounds, in a build that convolves
// folded trees; whatever the batch's size, so that a batch split in parts gives the same
// results. Folding costs 0.03-1.1 ms for the main job's tables (up to about 4 ms the first time
// in a process, as its memory is first touched).
//
// The entries around wo read texel by texel, for directional lights that take f from the table:
// in texel (x, y) of the table's resolution, f, the entries' leaf values there weighted and summed
// (RGB, a grey table's channel repeated), and its bound, the leaves' largest-deviation bounds
// weighted by |w|. A light then reads one texel where it would walk every entry from the root;
// the sums are made in the order of that walk, so both give the same bits. 48 bytes a texel
// (0.75 MiB at 128^2), built in about a millisecond.
struct TexelsAtWo {
  int resolution = 0;
  std::vector<std::array<double, 6>> texels;  // row y, column x: f RGB, then its bound RGB
  const std::array<double, 6>& at(int x, int y) const {
    return texels[std::size_t(y) * std::size_t(resolution) + std::size_t(x)];
  }
};
TexelsAtWo texels_at(const BrdfTableView& table, const std::array<TableTap, 4>& taps);

struct EntriesAtWo {
  std::array<TableTap, 4> taps;
  std::optional<FoldedTree> folded;
  std::optional<TexelsAtWo> texels;  // when asked for (with_texels)
};
EntriesAtWo entries_at(const BrdfTableView& table, const Vec3& wo, WoInterpolation interpolation,
                       bool with_texels = false);

// reflect() with the entries around wo already found (entries_at): many radiance trees looked
// up at one wo find and fold them once. Folded, the value is the entries' up to the folded
// sum's rounding to halves, and the bound theirs but for that rounding and the folded bound
// codes' rounding up (FoldedTree); the accuracy target applies to the folded sum as a whole.
Convolution reflect(const BrdfTableView& table, const EntriesAtWo& entries,
                    const PackedTreeView& radiance, const ConvolutionOptions& options = {});

// How reflect_tilted accounts for a tilt of the surface against the record's frame.
enum class TiltCompensation {
  none,            // the table at wo, as if the surface were not tilted
  reparametrised,  // the table at R^-1 wo: the lobe follows the tilt (section 2.4)
  compensated,     // reparametrised plus tilt.x * conv(tilt group 0) + tilt.y * conv(tilt
                   // group 1), the first-order tilt derivatives (tilt_derivative.h)
};

// Tilts below this angle (radians) are not compensated: their first-order term is below float
// rounding of the result.
inline constexpr double kUncompensatedTilt = 1e-7;

// The largest tilt reflect_tilted takes (radians): 90 degrees. The compensation holds to about
// 1 % up to 5 degrees and 2 % at 10 (README); beyond that it is an extrapolation.
inline constexpr double kLargestTilt = 1.5707963267948966;

// Reflected radiance at a surface tilted by `tilt` against the frame `radiance` was recorded
// in; wo_shading is in the tilted (shading) frame. The bound is that of the re-parametrised
// term; the compensation itself is a first-order estimate, interpolated bilinearly between
// entries. Compensation needs a table with tilt derivatives; std::invalid_argument otherwise,
// and for wo_shading below the horizon, zero or not finite, or a tilt not finite or beyond
// kLargestTilt. A value beyond the largest float, the compensation's included, is
// std::overflow_error.
Convolution reflect_tilted(const BrdfTableView& table, const PackedTreeView& radiance,
                           const Vec3& wo_shading, const Tilt& tilt, TiltCompensation mode,
                           const LookupOptions& options = {});

}  // namespace basis
