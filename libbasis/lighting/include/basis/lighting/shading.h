// Shading capture points with a BRDF table: reflected radiance at
// every capture of a set for an outgoing direction, optionally for a tilted surface normal.
#pragma once

#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "basis/brdf/table_lookup.h"
#include "basis/core/frame.h"
#include "basis/lighting/capture_set.h"

namespace basis {

struct ShadingOptions {
  // Outgoing direction in the shading frame (the capture's frame unless `normal` is given), of
  // any non-zero length; must have wo.z >= 0.
  Vec3 wo{0, 0, 1};
  // Shade as if the surface normal were this unit vector (world coordinates) instead of the
  // capture's: the shading frame is the capture's frame rotated by the smallest rotation taking
  // its normal to this one, and the tilt is compensated as `tilt_mode` says.
  std::optional<Vec3> normal;
  TiltCompensation tilt_mode = TiltCompensation::compensated;
  // f for the captures' directional lights: this BRDF (the one the table tabulates) at the
  // light's exact direction when given, else the table's entries at the texel it falls in.
  const Brdf* light_brdf = nullptr;
  // Options of every convolution (an accuracy target, or the values alone: the bound is then
  // +infinity).
  ConvolutionOptions convolution;
  // How lookups between table entries interpolate (table_lookup.h).
  WoInterpolation interpolation = WoInterpolation::hermite;
};

// The outgoing direction the lights' f is taken at for a unit wo (z >= 0): wo itself above the
// horizon; on it, where BRDFs are 0, their limit from above (wo raised by 1e-9), so that a wo
// exactly on the horizon keeps the lights a wo a hair above it keeps.
Vec3 light_outgoing(const Vec3& wo);

// The radiance the directional lights of a record (directions in frame `record`) reflect towards
// wo (in frame `shading`): the sum of f(wi, light_outgoing(wo)) E wi.z with wi each light turned
// into the shading frame; lights below its horizon drop out.
Rgb reflect_lights(std::span<const DirectionalLight> lights, const Frame& record,
                   const Frame& shading, const Vec3& wo, const Brdf& brdf);

// The tilt of a surface of normal `normal` (world) against capture k's frame;
// std::invalid_argument when `normal` is 90 degrees or more from the capture's normal.
Tilt capture_tilt(const CaptureSetView& captures, std::size_t k, const Vec3& normal);

// The tilt up to which lookups at another normal are supported: compensated, within about 2 %
// at 10 degrees (README). Beyond it they still run, but the tilt's error grows fast and no
// bound covers it (the bound is the lookup's, table against capture).
inline constexpr double kSupportedTiltDegrees = 10;
// The largest angle, in degrees, between `normal` (world) and the captures' normals.
double largest_tilt_degrees(const CaptureSetView& captures, const Vec3& normal);

// Reflected radiance (pi included) at capture k, with the certified bound of the lookup: the
// table convolved with the capture's tree, plus f(wi, wo) E wi.z for each of its directional
// lights. With options.normal the lights turn with the surface exactly (no compensation
// needed; lights below the tilted horizon drop out), except in TiltCompensation::none. A
// light's bound is 0 with light_brdf, else the entries' leaves' largest-deviation bounds at its
// texel. Throws std::invalid_argument for a wo below the horizon, zero or not finite, a normal
// tilted 90 degrees or more from the capture's, or a tilt on a table without tilt derivatives;
// std::overflow_error for a result beyond the floats (certified_float).
Convolution shade(const BrdfTableView& table, const CaptureSetView& captures, std::size_t k,
                  const ShadingOptions& options);
// The same, untilted (std::invalid_argument with options.normal), with the entries around wo
// found beforehand by entries_at: many captures shaded at one wo find and fold them once. Lights
// that take f from the table read it from the entries' texels when entries_at made them
// (with_texels), else walk the entries themselves; both give the same bits.
Convolution shade(const BrdfTableView& table, const EntriesAtWo& entries,
                  const CaptureSetView& captures, std::size_t k, const ShadingOptions& options);

// The dense counterpart of an untilted lookup at wo, for comparisons: the table at wo at full
// resolution, the entries the lookup reads reconstructed with their groups weighted as the
// lookup weighs them and summed into one grid (as a batch of tree lookups folds them).
struct DenseLookup {
  Vec3 wo{0, 0, 1};
  Grid grid;
};
DenseLookup dense_lookup(const BrdfTableView& table, const Vec3& wo,
                         WoInterpolation interpolation = WoInterpolation::hermite);

// What shade() returns for an untilted lookup, computed with the vectorised dense product of the
// table's grid at wo and the capture's full-resolution grid (the trees' reconstructions give
// the same value up to rounding); the bound is 0.
Convolution shade_dense(const DenseLookup& table, const Grid& radiance,
                        std::span<const DirectionalLight> lights, const Brdf* light_brdf);

// The integral of L_a L_b cos over the hemisphere (pi times the product's integral over the
// cosine-weighted map) at capture k, each capture's directional lights standing in the texel
// they fall in at its own resolution (as splat_lights would put them; the sets' resolutions may
// differ); the bound adds, for each light, its weight times the largest-deviation bound of the
// other tree's quadrant over that texel (or of its leaf holding it). A set of one capture stands
// for every point. The trees' descent takes `options` (an accuracy target, or the values alone
// with a bound of +infinity).
Convolution capture_product(const CaptureSetView& a, const CaptureSetView& b, std::size_t k,
                            const ConvolutionOptions& options = {});

}  // namespace basis
